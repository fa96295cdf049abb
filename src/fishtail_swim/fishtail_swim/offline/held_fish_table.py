"""The fish held still (a bollard test): its thrust and tail power at each beat frequency.

The first thing a builder measures in a tank, and for mechanism 1 the case where only the fin's
own drag asks the motor for power (Lighthill's force then runs through the pivot). The figures
are :func:`~fishtail_plant.fish.figures.held_fish`'s; what they mean: docs/motor-load.md
("The held fish").
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_plant.fish.figures import held_fish
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.tail_drive import EngineTailDrive, TailDrive, constant_carrier_speed
from fishtail_swim.offline.tables import Column


class HeldFishRows(NamedTuple):
    """One row per beat frequency."""

    beat_frequency_hz: FloatArray
    thrust_n: FloatArray
    tail_power_w: FloatArray
    fin_drag_power_w: FloatArray


def held_fish_rows(
    drive: TailDrive, fish: FishParameters, beat_frequency_hz: npt.ArrayLike
) -> HeldFishRows:
    """:func:`held_fish` of ``drive`` (one tail motion per frequency) for ``fish``."""
    frequency = np.asarray(beat_frequency_hz, dtype=float).ravel()
    held = held_fish(drive, fish, 1.0 / frequency)
    shape = frequency.shape
    return HeldFishRows(
        frequency,
        np.broadcast_to(held.thrust_n, shape),
        np.broadcast_to(held.tail_power_w, shape),
        np.broadcast_to(held.fin_drag_power_w, shape),
    )


def held_linkage_rows(
    tail: Tail, fish: FishParameters, carrier_speed_rad_s: npt.ArrayLike
) -> HeldFishRows:
    """:func:`held_fish_rows` of the Cardan tail at carrier speeds (one beat per revolution)."""
    speed = np.asarray(carrier_speed_rad_s, dtype=float).ravel()
    drive = EngineTailDrive(tail, constant_carrier_speed(speed))
    return held_fish_rows(drive, fish, speed / (2.0 * np.pi))


def held_fish_columns(rows: HeldFishRows) -> list[Column]:
    """The rows as table columns (powers rounded at 1e-12 W: Lighthill's exact 0 stays 0)."""
    tail_power = np.round(rows.tail_power_w, 12) + 0.0
    return [
        Column("f [Hz]", rows.beat_frequency_hz, ".2f", "beat_frequency_hz"),
        Column("held thrust [N]", rows.thrust_n, ".4f", "held_thrust_n"),
        Column("held tail power [W]", tail_power, ".4f", "held_tail_power_w"),
        Column("of which fin drag [W]", rows.fin_drag_power_w, ".4f", "held_fin_drag_power_w"),
    ]
