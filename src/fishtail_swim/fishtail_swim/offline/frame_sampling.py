"""A recording's samples brought to the frames of an animation: the frame times' brackets.

:class:`Brackets` keeps, for every frame, only the samples either side of it, so that memory is
bounded by the frame count, not the recording's length; :func:`frame_values` interpolates them
(NaN across a gap longer than ``gap_s``); :class:`DecimatedPath` keeps C's path at a bounded
number of points a frame interval. The rules: docs/swimming-dynamics.md (``animate --bag``).

>>> interpolate_samples(np.array([0.0, 1.0]), np.array([[0.0], [2.0]]), np.array([0.25]), 2.0)
array([[0.5]])
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from fishtail_plant.fish.fish import FloatArray

#: Consecutive fish/odom samples further apart than this are a gap (50 samples at the simulator's
#: 200 Hz, 5 frames at 20 fps).
DEFAULT_GAP_S = 0.25


class Brackets:
    """For each frame time, the last sample at or before it and the first after it.

    Samples are added in time order (:meth:`add`); one at or before the previous is dropped and
    counted in :attr:`dropped` (a repeated stamp, or one out of order). Arrays of NaN where a frame
    has no such sample.
    """

    def __init__(self, frame_time_s: FloatArray, width: int) -> None:
        """Brackets of samples of ``width`` values at ``frame_time_s`` (increasing)."""
        frames = frame_time_s.size
        self.frame_time_s = frame_time_s
        self.before_t = np.full(frames, np.nan)
        self.before = np.full((frames, width), np.nan)
        self.after_t = np.full(frames, np.nan)
        self.after = np.full((frames, width), np.nan)
        self.count = 0
        self.dropped = 0
        self.first_t = math.nan
        self.last_t = -math.inf
        self._last = np.full(width, np.nan)
        self._next = 0  # the first frame whose "after" is not set yet

    def add(self, time_s: float, values: Sequence[float]) -> None:
        """One sample: ``values`` at ``time_s``."""
        if not time_s > self.last_t:
            self.dropped += 1
            return
        k = self._next
        times = self.frame_time_s
        while k < times.size and times[k] < time_s:
            if self.count:
                self.before_t[k] = self.last_t
                self.before[k] = self._last
            self.after_t[k] = time_s
            self.after[k] = values
            k += 1
        self._next = k
        if not self.count:
            self.first_t = time_s
        self.count += 1
        self.last_t = time_s
        self._last = np.asarray(values, dtype=np.float64)

    def finish(self) -> None:
        """After the last sample: the frames at or after it have it as their "before"."""
        if self.count:
            rest = slice(self._next, None)
            self.before_t[rest] = self.last_t
            self.before[rest] = self._last
        self._next = self.frame_time_s.size


def frame_values(
    brackets: Brackets, gap_s: float, edge_s: float, angle_columns: Sequence[int] = ()
) -> FloatArray:
    """The value of every frame, ``(F, width)``: linear in time between its bracketing samples.

    NaN where the samples are more than ``gap_s`` apart, or where one is missing and the other is
    more than ``edge_s`` from the frame. ``angle_columns`` are interpolated the shorter way round.
    """
    t = brackets.frame_time_s
    before, after = brackets.before, brackets.after
    span = brackets.after_t - brackets.before_t
    with np.errstate(invalid="ignore", divide="ignore"):
        fraction = np.where(span > 0.0, (t - brackets.before_t) / span, 0.0)
    step = after - before
    for column in angle_columns:
        step[:, column] = np.angle(np.exp(1j * step[:, column]))
    values = before + fraction[:, None] * step
    values[~(span <= gap_s)] = np.nan
    # The ends of a topic: the sample itself, if it is close enough.
    only_before = np.isnan(brackets.after_t) & (t - brackets.before_t <= edge_s)
    only_after = np.isnan(brackets.before_t) & (brackets.after_t - t <= edge_s)
    values[only_before] = before[only_before]
    values[only_after] = after[only_after]
    return values


def interpolate_samples(
    sample_time_s: FloatArray,
    samples: FloatArray,
    frame_time_s: FloatArray,
    gap_s: float = DEFAULT_GAP_S,
    edge_s: float = 0.0,
    angle_columns: Sequence[int] = (),
) -> FloatArray:
    """:func:`frame_values` of samples given as arrays, ``(K,)`` times and ``(K, width)`` values."""
    brackets = Brackets(np.asarray(frame_time_s, dtype=np.float64), samples.shape[1])
    for time_s, values in zip(sample_time_s.tolist(), samples, strict=True):
        brackets.add(time_s, values)
    brackets.finish()
    return frame_values(brackets, gap_s, edge_s, angle_columns)


def frame_count(start_s: float, end_s: float, fps: float) -> int:
    """Frames at start + k / fps up to ``end_s`` (included when it falls on a frame)."""
    return math.floor((end_s - start_s) * fps * (1.0 + 1e-12) + 1e-9) + 1


class DecimatedPath:
    """C's path in the window, decimated in time, with a NaN row after the last sample of a gap."""

    def __init__(self, start_s: float, end_s: float, step_s: float, gap_s: float) -> None:
        """The path from ``start_s`` to ``end_s``, a point every ``step_s``, gaps over ``gap_s``."""
        self.start_s, self.end_s, self.step_s, self.gap_s = start_s, end_s, step_s, gap_s
        self.time_s: list[float] = []
        self.points: list[tuple[float, float]] = []
        self.gaps = 0
        self._last: tuple[float, float, float] | None = None  # the previous sample (t, x, y)

    def _keep(self, time_s: float, x: float, y: float) -> None:
        if not self.time_s or time_s > self.time_s[-1] or math.isnan(self.points[-1][0]):
            self.time_s.append(time_s)
            self.points.append((x, y))

    def add(self, time_s: float, x: float, y: float) -> None:
        """The next fish/odom sample (after the previous one)."""
        last = self._last
        self._last = (time_s, x, y)
        if time_s < self.start_s:
            return
        if time_s > self.end_s:
            if last is not None and self.start_s <= last[0] <= self.end_s:
                self._keep(*last)
            return
        if last is not None and time_s - last[0] > self.gap_s:
            if last[0] >= self.start_s:
                self._keep(*last)
                self.time_s.append(last[0])
                self.points.append((math.nan, math.nan))
            self.gaps += 1
            self._keep(time_s, x, y)
        elif not self.time_s or time_s - self.time_s[-1] >= self.step_s:
            self._keep(time_s, x, y)

    def finish(self) -> tuple[FloatArray, FloatArray]:
        """The kept times ``(K,)`` and points ``(K, 2)``, the window's last sample included."""
        if self._last is not None and self.start_s <= self._last[0] <= self.end_s:
            self._keep(*self._last)
        return np.asarray(self.time_s, dtype=np.float64), np.asarray(
            self.points, dtype=np.float64
        ).reshape(-1, 2)
