"""The steady segments of a run: beats, stretches of steady carrier speed, settled fish.

Pure numpy on a run's samples (:class:`RecordedSamples`: the fish's pose and the carrier's
angle, each at its own stamps): the run is cut into beats (one carrier turn each), the beats into
stretches where the carrier speed holds, and each stretch is trimmed at its start until the
fish's speed has settled; what remains of at least ``min_beats`` beats is a steady segment with
the mean carrier speed, the fish's mean speed and its mean yaw rate over its whole beats. The
criterion and its tolerances: docs/recording.md ("Steady segments for fit").

>>> criterion = SteadyCriterion()
>>> criterion.min_beats, criterion.carrier_tolerance, criterion.speed_tolerance
(10, 0.02, 0.01)
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from fishtail_common.bag_reading import BagError
from fishtail_plant.fish.fish import FloatArray

__all__ = [
    "NoSteadySegmentError",
    "RecordedSamples",
    "SteadyCriterion",
    "SteadySegment",
    "steady_segments",
]

TWO_PI = 2.0 * math.pi


class NoSteadySegmentError(BagError):
    """The bag holds no steady segment; the message is one line saying why."""


@dataclasses.dataclass(frozen=True)
class SteadyCriterion:
    """When a stretch of a run is steady.

    ``min_beats``: whole beats a segment needs. ``carrier_tolerance``: each beat's mean carrier
    speed within this fraction of the running mean of its stretch. ``speed_tolerance``: the fish's
    speed over each beat of the segment, and its means over the earlier and the later half of
    them, within this fraction of its mean over the segment. ``gap_s``: successive samples of a
    topic further apart than this are a gap, which no segment spans.
    """

    min_beats: int = 10
    carrier_tolerance: float = 0.02
    speed_tolerance: float = 0.01
    gap_s: float = 0.1

    def __post_init__(self) -> None:
        """Check the values.

        Raises:
            ValueError: ``min_beats`` below 2, or a tolerance or gap that is not positive.
        """
        if self.min_beats < 2:
            raise ValueError(f"a segment needs at least 2 beats, got min_beats={self.min_beats}")
        for name in ("carrier_tolerance", "speed_tolerance", "gap_s"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be a positive number, got {value!r}")

    def describe(self) -> str:
        """The criterion in one line, for the measurements file's comments."""
        return (
            f"at least {self.min_beats} whole beats, each beat's carrier speed within "
            f"{100 * self.carrier_tolerance:g} % of its stretch's mean, the fish's speed over "
            f"each beat and over each half within {100 * self.speed_tolerance:g} % of its "
            f"mean, no gap over {self.gap_s:g} s"
        )


@dataclasses.dataclass(frozen=True)
class SteadySegment:
    """One steady segment: its window (s since the first fish/odom stamp) and its means."""

    start_s: float
    end_s: float
    beats: int
    #: From where the carrier speed last changed (or the recording resumed) to start_s.
    settle_s: float
    carrier_speed_rad_s: float
    speed_m_s: float
    yaw_rate_rad_s: float


@dataclasses.dataclass(frozen=True)
class RecordedSamples:
    """The samples the segments come from, sorted by stamp, t in s since ``origin_ns``."""

    odom_time_s: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    psi_rad: FloatArray
    carrier_time_s: FloatArray
    carrier_angle_rad: FloatArray
    origin_ns: int = 0


def _pieces(time_s: FloatArray, gap_s: float) -> list[tuple[float, float]]:
    """The stretches of ``time_s`` without a gap, as (first, last) times."""
    if time_s.size == 0:
        return []
    breaks = np.flatnonzero(np.diff(time_s) > gap_s)
    starts = np.concatenate([[0], breaks + 1])
    ends = np.concatenate([breaks, [time_s.size - 1]])
    return [(float(time_s[a]), float(time_s[b])) for a, b in zip(starts, ends, strict=True)]


def _overlaps(
    first: list[tuple[float, float]], second: list[tuple[float, float]]
) -> list[tuple[float, float]]:
    """Where two sorted lists of intervals overlap."""
    common, i, j = [], 0, 0
    while i < len(first) and j < len(second):
        start, end = max(first[i][0], second[j][0]), min(first[i][1], second[j][1])
        if start < end:
            common.append((start, end))
        if first[i][1] < second[j][1]:
            i += 1
        else:
            j += 1
    return common


def _beat_ends(time_s: FloatArray, angle_rad: FloatArray) -> FloatArray:
    """When the carrier passes each multiple of 2 pi (a beat's end), linear between samples.

    The angle is unwrapped and taken as its running maximum: a carrier standing or turning back
    starts no beat.
    """
    if time_s.size < 2:
        return np.empty(0)
    reach = np.maximum.accumulate(np.unwrap(angle_rad))
    turn = np.floor(reach / TWO_PI).astype(np.int64)
    after = np.flatnonzero(np.diff(turn) > 0) + 1
    counts = turn[after] - turn[after - 1]
    index = np.repeat(after, counts)
    first = np.repeat(turn[after - 1] + 1, counts)
    offsets = np.arange(index.size) - np.repeat(np.cumsum(counts) - counts, counts)
    level = (first + offsets) * TWO_PI
    before = reach[index - 1]
    fraction = (level - before) / (reach[index] - before)
    ends: FloatArray = time_s[index - 1] + fraction * (time_s[index] - time_s[index - 1])
    return ends


@dataclasses.dataclass(frozen=True)
class _Beats:
    """A gap-free stretch's beats: B + 1 ends, the fish's pose there, each beat's speeds."""

    ends_s: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    psi_rad: FloatArray

    @property
    def count(self) -> int:
        return max(self.ends_s.size - 1, 0)

    @property
    def carrier_speed(self) -> FloatArray:
        return np.asarray(TWO_PI / np.diff(self.ends_s), dtype=float)

    @property
    def chords(self) -> FloatArray:
        return np.asarray(np.hypot(np.diff(self.x_m), np.diff(self.y_m)), dtype=float)

    def segment(self, first: int, stop: int, settle_s: float) -> SteadySegment:
        """Beats ``first`` to ``stop`` - 1 as a segment: means over them, beat ends as limits."""
        duration = float(self.ends_s[stop] - self.ends_s[first])
        return SteadySegment(
            start_s=float(self.ends_s[first]),
            end_s=float(self.ends_s[stop]),
            beats=stop - first,
            settle_s=settle_s,
            carrier_speed_rad_s=TWO_PI * (stop - first) / duration,
            speed_m_s=float(self.chords[first:stop].sum()) / duration,
            yaw_rate_rad_s=float(self.psi_rad[stop] - self.psi_rad[first]) / duration,
        )


def _beats_in(samples: RecordedSamples, start_s: float, end_s: float) -> _Beats:
    """The whole beats between ``start_s`` and ``end_s`` and the fish's pose at their ends."""
    t = samples.carrier_time_s
    a, b = np.searchsorted(t, start_s, side="left"), np.searchsorted(t, end_s, side="right")
    ends = _beat_ends(t[a:b], samples.carrier_angle_rad[a:b])
    ends = ends[(ends >= start_s) & (ends <= end_s)]
    o = samples.odom_time_s
    c, d = np.searchsorted(o, start_s, side="left"), np.searchsorted(o, end_s, side="right")
    time = o[c:d]
    psi = np.unwrap(samples.psi_rad[c:d])
    return _Beats(
        ends,
        np.interp(ends, time, samples.x_m[c:d]),
        np.interp(ends, time, samples.y_m[c:d]),
        np.interp(ends, time, psi),
    )


def _carrier_stretches(speed: FloatArray, tolerance: float) -> list[tuple[int, int]]:
    """Runs of beats (first, stop) each within ``tolerance`` of its run's running mean speed."""
    runs: list[tuple[int, int]] = []
    first, total = 0, 0.0
    for index, value in enumerate(speed.tolist()):
        if index > first:
            mean = total / (index - first)
            if abs(value - mean) > tolerance * mean:
                runs.append((first, index))
                first, total = index, 0.0
        total += value
    if speed.size:
        runs.append((first, speed.size))
    return runs


@dataclasses.dataclass
class _Verdicts:
    """Why stretches were not steady, for the refusal's line and the notes."""

    whole_beats: int = 0
    longest: tuple[int, float] = (0, math.nan)  # beats, carrier speed
    # The stretch that came nearest to steady: departure, drift (see _departures), carrier speed.
    best_spread: tuple[float, float, float] = (math.inf, math.inf, math.nan)
    gaps: int = 0

    def refusal(self, source: str, criterion: SteadyCriterion, recorded_s: float) -> str:
        """The one-line reason there is no steady segment."""
        head = f"{source}: no steady segment:"
        if self.whole_beats == 0:
            return (
                f"{head} too short: the carrier turned no whole beat where fish/odom and the "
                f"carrier were both recorded without a gap ({recorded_s:.2f} s in {self.gaps + 1}"
                f" piece(s), gaps over {criterion.gap_s:g} s)"
            )
        if math.isinf(self.best_spread[0]):
            beats, speed = self.longest
            return (
                f"{head} too short: the carrier speed held within "
                f"{100 * criterion.carrier_tolerance:g} % for at most {beats} whole beats (at "
                f"{speed:.4g} rad/s), {criterion.min_beats} needed"
            )
        departure, drift, speed = self.best_spread
        return (
            f"{head} the fish's speed never steady: over the last {criterion.min_beats} beats "
            f"of the steady carrier at {speed:.4g} rad/s a beat's speed departs from their mean "
            f"by up to {100 * departure:.3g} % and the halves' means differ by "
            f"{100 * drift:.3g} %, {100 * criterion.speed_tolerance:g} % allowed"
        )


def _departures(speed: FloatArray, first: int, stop: int) -> tuple[FloatArray, FloatArray]:
    """Per start from ``first`` on, how far the fish's speed from there to ``stop`` is from steady.

    For each start: the largest departure of a beat's speed from the beats' mean, and the
    difference between the means over their earlier and later halves, both relative to the mean.
    """
    window = speed[first:stop]
    reverse = window[::-1]
    mean = (np.cumsum(reverse) / np.arange(1, window.size + 1))[::-1]
    highest = np.maximum.accumulate(reverse)[::-1]
    lowest = np.minimum.accumulate(reverse)[::-1]
    departure = np.maximum(highest - mean, mean - lowest) / mean
    total = np.concatenate([[0.0], np.cumsum(window)])
    start = np.arange(window.size)
    half = np.maximum((window.size - start) // 2, 1)
    earlier = (total[start + half] - total[start]) / half
    later = (total[-1] - total[window.size - half]) / half
    return departure, np.abs(later - earlier) / mean


def _settled(
    beats: _Beats, first: int, stop: int, criterion: SteadyCriterion, verdicts: _Verdicts
) -> SteadySegment | None:
    """The stretch's beats from the first one on which the fish's speed is steady, if any.

    Steady: every beat's speed within the speed tolerance of the mean over the beats from there
    to the stretch's end, and the means over their earlier and later halves within it too.
    """
    speed = beats.chords / np.diff(beats.ends_s)
    last = stop - criterion.min_beats
    departure, drift = _departures(speed, first, stop)
    steady = (departure[: last - first + 1] <= criterion.speed_tolerance) & (
        drift[: last - first + 1] <= criterion.speed_tolerance
    )
    if steady.any():
        start = first + int(np.argmax(steady))
        settle = float(beats.ends_s[start] - beats.ends_s[first])
        return beats.segment(start, stop, settle)
    worst = float(max(departure[last - first], drift[last - first]))
    if worst < verdicts.best_spread[0]:
        carrier = float(np.mean(beats.carrier_speed[first:stop]))
        verdicts.best_spread = (float(departure[last - first]), float(drift[last - first]), carrier)
    return None


def steady_segments(
    samples: RecordedSamples, criterion: SteadyCriterion, source: str = "recording"
) -> tuple[tuple[SteadySegment, ...], tuple[str, ...]]:
    """The steady segments of the samples, in time order, and notes on what was left out.

    Raises:
        NoSteadySegmentError: none (the line, beginning with ``source``, says why).
    """
    pieces = _overlaps(
        _pieces(samples.odom_time_s, criterion.gap_s),
        _pieces(samples.carrier_time_s, criterion.gap_s),
    )
    verdicts = _Verdicts(gaps=max(len(pieces) - 1, 0))
    segments: list[SteadySegment] = []
    for start_s, end_s in pieces:
        beats = _beats_in(samples, start_s, end_s)
        verdicts.whole_beats += beats.count
        for first, stop in _carrier_stretches(beats.carrier_speed, criterion.carrier_tolerance):
            if stop - first > verdicts.longest[0]:
                speed = float(np.mean(beats.carrier_speed[first:stop]))
                verdicts.longest = (stop - first, speed)
            if stop - first < criterion.min_beats:
                continue
            segment = _settled(beats, first, stop, criterion, verdicts)
            if segment is not None:
                segments.append(segment)
    if not segments:
        recorded = sum(end - start for start, end in pieces)
        raise NoSteadySegmentError(verdicts.refusal(source, criterion, recorded))
    notes = []
    if verdicts.gaps:
        notes.append(f"{verdicts.gaps} gap(s) over {criterion.gap_s:g} s split the recording")
    return tuple(segments), tuple(notes)
