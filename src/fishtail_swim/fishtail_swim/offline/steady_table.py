"""The cycle-average steady swimming table over carrier speeds, and its time-stepped check.

Balance (fast, every speed at once): the body held at u = U, v = r = 0, U from
:func:`~fishtail_plant.fish.figures.steady_surge_speed`, the figures from the trailing-edge force
over one beat. Check (slow): the same fish free in sway and yaw, stepped from rest
(:mod:`.time_run`). Columns and definitions: docs/swimming-dynamics.md (``steady``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from fishtail_plant.fish.figures import steady_surge_speed, tail_power
from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.fish.model import trailing_edge_force
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed
from fishtail_swim.offline.inputs import Swimmer
from fishtail_swim.offline.progress import Progress
from fishtail_swim.offline.time_run import run_figures, run_from_rest

#: Samples per beat of the held-body means and the tip's excursion (the means converge
#: spectrally; the excursion's sampling error is ~(pi/samples)² of A).
BEAT_SAMPLES = 1024
#: The check's run: steps per beat and beats from rest (the start-up transient falls about
#: 100-fold every 20 beats; the figures are over the last two).
CHECK_STEPS_PER_BEAT = 32
CHECK_BEATS = 50
# Carrier speeds per batch: bounds the (BEAT_SAMPLES, speeds) arrays to a few MB each.
_SPEEDS_PER_BATCH = 1000


class SteadyRows(NamedTuple):
    """The balance's figures, one element per carrier speed."""

    carrier_speed_rad_s: FloatArray
    beat_frequency_hz: FloatArray
    speed_m_s: FloatArray
    body_lengths_per_s: FloatArray
    strouhal_number: FloatArray
    mean_thrust_n: FloatArray
    tail_power_w: FloatArray
    froude_efficiency: FloatArray


class CheckRows(NamedTuple):
    """The free body's figures for the checked speeds."""

    carrier_speed_rad_s: FloatArray
    balance_speed_m_s: FloatArray
    speed_m_s: FloatArray
    strouhal_number: FloatArray
    froude_efficiency: FloatArray
    mean_sway_m_s: FloatArray
    turning_radius_m: FloatArray


def steady_rows(swimmer: Swimmer, carrier_speed_rad_s: FloatArray) -> SteadyRows:
    """The balance at every carrier speed, in batches of up to a thousand speeds."""
    speeds = np.atleast_1d(np.asarray(carrier_speed_rad_s, dtype=float))
    progress = Progress("steady", speeds.size)
    batches = []
    for start in range(0, speeds.size, _SPEEDS_PER_BATCH):
        batches.append(_steady_batch(swimmer, speeds[start : start + _SPEEDS_PER_BATCH]))
        progress.update(start + _SPEEDS_PER_BATCH)
    progress.finish()
    return SteadyRows(*(np.concatenate(column) for column in zip(*batches, strict=True)))


def _steady_batch(swimmer: Swimmer, speeds: FloatArray) -> SteadyRows:
    fish = swimmer.fish
    drive = EngineTailDrive(swimmer.tail, constant_carrier_speed(speeds))
    period = 2.0 * np.pi / speeds
    speed = steady_surge_speed(drive, fish, period)
    tail = drive.sample(np.arange(BEAT_SAMPLES)[:, None] / BEAT_SAMPLES * period)
    surge = np.broadcast_to(speed, tail.tip_x.shape)
    held = np.zeros_like(surge)
    force = trailing_edge_force(fish, tail, surge, held, held).force
    thrust = force.x.mean(axis=0)
    power = tail_power(force, tail).mean(axis=0)
    frequency = 1.0 / period
    excursion = np.ptp(tail.tip_y, axis=0)
    return SteadyRows(
        speeds, frequency, speed, speed / fish.body_length_m, frequency * excursion / speed,
        thrust, power, thrust * speed / power,
    )  # fmt: skip


def checked_indices(count: int) -> list[int]:
    """The rows the check steps: the first, the middle and the last (fewer if fewer rows)."""
    return sorted({0, count // 2, count - 1})


def check_rows(swimmer: Swimmer, rows: SteadyRows, indices: Sequence[int]) -> CheckRows:
    """Step the free body at the carrier speeds of ``rows[indices]``, one run each."""
    speeds = rows.carrier_speed_rad_s[list(indices)]
    progress = Progress("check", CHECK_STEPS_PER_BEAT * CHECK_BEATS * speeds.size)
    figures = []
    for number, speed in enumerate(speeds):
        step = 2.0 * np.pi / speed / CHECK_STEPS_PER_BEAT
        offset = number * CHECK_STEPS_PER_BEAT * CHECK_BEATS
        # Progress over every run together: the runs' own counts are shifted by the ones done.
        shifted = _ShiftedProgress(progress, offset)
        run = run_from_rest(
            swimmer, np.array([speed]), step, CHECK_STEPS_PER_BEAT * CHECK_BEATS, shifted
        )
        figures.append(run_figures(run))
    progress.finish()
    return CheckRows(
        speeds,
        rows.speed_m_s[list(indices)],
        np.concatenate([f.means.mean_speed_m_s for f in figures]),
        np.concatenate([f.tail.strouhal_number for f in figures]),
        np.concatenate([f.tail.froude_efficiency for f in figures]),
        np.concatenate([f.means.mean_sway_m_s for f in figures]),
        np.concatenate([f.means.turning_radius_m for f in figures]),
    )


class _ShiftedProgress(Progress):
    def __init__(self, whole: Progress, offset: float) -> None:
        self.whole = whole
        self.offset = offset

    def update(self, done: float) -> None:
        self.whole.update(self.offset + done)

    def finish(self) -> None:
        """The whole task's line ends when every run is done."""
