"""The cycle-average steady swimming table over a tail's beats, and its time-stepped check.

Balance (fast, every row at once): the body held at u = U, v = r = 0, U from
:func:`~fishtail_plant.fish.figures.steady_surge_speed`, the figures from the trailing-edge force
over one beat (with a fin plate, its drag too), and the fish held still (a bollard test). Check
(slow): the same fish free in sway and yaw, stepped from rest (:mod:`.time_run`). Columns and
definitions: docs/swimming-dynamics.md (``steady``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from fishtail_plant.fish.figures import held_fish, held_tail, steady_surge_speed
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_swim.offline.inputs import Swimmer
from fishtail_swim.offline.progress import Progress
from fishtail_swim.offline.tables import Column
from fishtail_swim.offline.tail_beats import CardanBeats, TailBeats
from fishtail_swim.offline.time_run import run_beats_from_rest, run_figures

#: Samples per beat of the held-body means and the tip's excursion (the means converge
#: spectrally; the excursion's sampling error is ~(pi/samples)² of A).
BEAT_SAMPLES = 1024
#: The check's run: steps per beat and beats from rest (the start-up transient falls about
#: 100-fold every 20 beats; the figures are over the last two).
CHECK_STEPS_PER_BEAT = 32
CHECK_BEATS = 50
# Rows per batch: bounds the (BEAT_SAMPLES, rows) arrays to a few MB each.
_ROWS_PER_BATCH = 1000


class BalanceRows(NamedTuple):
    """The balance's figures, one element per row (per beat of the tail)."""

    beat_frequency_hz: FloatArray
    speed_m_s: FloatArray
    body_lengths_per_s: FloatArray
    strouhal_number: FloatArray
    mean_thrust_n: FloatArray
    tail_power_w: FloatArray
    froude_efficiency: FloatArray
    held_thrust_n: FloatArray
    held_tail_power_w: FloatArray


class SteadyRows(NamedTuple):
    """The balance's figures of the Cardan tail, one element per carrier speed."""

    carrier_speed_rad_s: FloatArray
    beat_frequency_hz: FloatArray
    speed_m_s: FloatArray
    body_lengths_per_s: FloatArray
    strouhal_number: FloatArray
    mean_thrust_n: FloatArray
    tail_power_w: FloatArray
    froude_efficiency: FloatArray
    held_thrust_n: FloatArray
    held_tail_power_w: FloatArray


class CheckRows(NamedTuple):
    """The free body's figures for the checked rows."""

    balance_speed_m_s: FloatArray
    speed_m_s: FloatArray
    strouhal_number: FloatArray
    froude_efficiency: FloatArray
    mean_sway_m_s: FloatArray
    turning_radius_m: FloatArray


def steady_rows(swimmer: Swimmer, carrier_speed_rad_s: FloatArray) -> SteadyRows:
    """The balance of the Cardan tail at every carrier speed (:func:`balance_rows`)."""
    speeds = np.atleast_1d(np.asarray(carrier_speed_rad_s, dtype=float))
    return SteadyRows(speeds, *balance_rows(swimmer.fish, CardanBeats(swimmer.tail, speeds)))


def balance_rows(fish: FishParameters, beats: TailBeats) -> BalanceRows:
    """The balance at every beat of ``beats``, in batches of up to a thousand rows."""
    count = beats.beat_period_s.size
    progress = Progress("steady", count)
    batches = []
    for start in range(0, count, _ROWS_PER_BATCH):
        batches.append(_balance_batch(fish, beats.subset(slice(start, start + _ROWS_PER_BATCH))))
        progress.update(start + _ROWS_PER_BATCH)
    progress.finish()
    return BalanceRows(*(np.concatenate(column) for column in zip(*batches, strict=True)))


def _balance_batch(fish: FishParameters, beats: TailBeats) -> BalanceRows:
    drive = beats.drive
    period = beats.beat_period_s
    speed = steady_surge_speed(drive, fish, period)
    times = np.arange(BEAT_SAMPLES)[:, None] / BEAT_SAMPLES * period
    towed = held_tail(drive, fish, times, speed)
    thrust, power = towed.push_n.mean(axis=0), towed.power_w.mean(axis=0)
    tail = towed.tail
    still = held_fish(drive, fish, period, BEAT_SAMPLES)
    frequency = 1.0 / period
    excursion = np.ptp(tail.tip_y, axis=0)
    return BalanceRows(
        frequency, speed, speed / fish.body_length_m, frequency * excursion / speed,
        thrust, power, thrust * speed / power,
        np.broadcast_to(still.thrust_n, speed.shape),
        np.broadcast_to(np.round(still.tail_power_w, 12) + 0.0, speed.shape),
    )  # fmt: skip


def balance_columns(beats: TailBeats, rows: BalanceRows) -> list[Column]:
    """The steady table: the tail's own columns (what sets each beat), then the balance's."""
    return [
        *beats.table_columns(),
        Column("U [m/s]", rows.speed_m_s, ".4f", "speed_m_s"),
        Column("U [L/s]", rows.body_lengths_per_s, ".3f", "body_lengths_per_s"),
        Column("St", rows.strouhal_number, ".3f", "strouhal_number"),
        Column("thrust [N]", rows.mean_thrust_n, ".4g", "mean_thrust_n"),
        Column("power [W]", rows.tail_power_w, ".4g", "tail_power_w"),
        Column("efficiency", rows.froude_efficiency, ".3f", "froude_efficiency"),
        Column("held thrust [N]", rows.held_thrust_n, ".4g", "held_thrust_n"),
        Column("held power [W]", rows.held_tail_power_w, ".4g", "held_tail_power_w"),
    ]


def checked_indices(count: int) -> list[int]:
    """The rows the check steps: the first, the middle and the last (fewer if fewer rows)."""
    return sorted({0, count // 2, count - 1})


def check_rows(
    fish: FishParameters, beats: TailBeats, rows: BalanceRows, indices: Sequence[int]
) -> CheckRows:
    """Step the free body at the beats of ``rows[indices]``, one run each."""
    checked = beats.subset(indices)
    count = len(indices)
    progress = Progress("check", CHECK_STEPS_PER_BEAT * CHECK_BEATS * count)
    figures = []
    for number in range(count):
        one = checked.subset([number])
        step = float(one.beat_period_s[0]) / CHECK_STEPS_PER_BEAT
        offset = number * CHECK_STEPS_PER_BEAT * CHECK_BEATS
        # Progress over every run together: the runs' own counts are shifted by the ones done.
        shifted = _ShiftedProgress(progress, offset)
        run = run_beats_from_rest(fish, one, step, CHECK_STEPS_PER_BEAT * CHECK_BEATS, shifted)
        figures.append(run_figures(run))
    progress.finish()
    return CheckRows(
        rows.speed_m_s[list(indices)],
        np.concatenate([f.means.mean_speed_m_s for f in figures]),
        np.concatenate([f.tail.strouhal_number for f in figures]),
        np.concatenate([f.tail.froude_efficiency for f in figures]),
        np.concatenate([f.means.mean_sway_m_s for f in figures]),
        np.concatenate([f.means.turning_radius_m for f in figures]),
    )


def check_columns(checked_beats: TailBeats, checked: CheckRows) -> list[Column]:
    """The check's table: the checked rows' keys, then the held and the free body's figures."""
    change = checked.speed_m_s / checked.balance_speed_m_s - 1.0
    return [
        *checked_beats.key_columns(),
        Column("U held [m/s]", checked.balance_speed_m_s, ".4f", "held_speed_m_s"),
        Column("U free [m/s]", checked.speed_m_s, ".4f", "free_speed_m_s"),
        Column("change [%]", 100.0 * change, "+.2f", "change_percent"),
        Column("St free", checked.strouhal_number, ".3f", "free_strouhal_number"),
        Column("efficiency free", checked.froude_efficiency, ".3f", "free_froude_efficiency"),
        Column("<v> [m/s]", checked.mean_sway_m_s, ".2e", "mean_sway_m_s"),
        Column("turning radius [m]", checked.turning_radius_m, ".4g", "turning_radius_m"),
    ]


class _ShiftedProgress(Progress):
    def __init__(self, whole: Progress, offset: float) -> None:
        self.whole = whole
        self.offset = offset

    def update(self, done: float) -> None:
        self.whole.update(self.offset + done)

    def finish(self) -> None:
        """The whole task's line ends when every run is done."""
