"""Tail-beat segmentation and per-beat swing statistics (used by the monitor and offline analysis).

Whether the tail swings symmetrically, beat by beat: :class:`BeatTracker` cuts a stream of theta3
into beats (upward zero crossings, with hysteresis) and :func:`judge` gives each a verdict against
:class:`SymmetryTolerances`, or :attr:`Verdict.NOT_JUDGED` where a verdict would be on missing
data; :func:`beats_of` runs the same code over a recording. Integrals are over the carrier angle
when it is given, so that a rippling motor speed does not look like a skewed linkage. The method
and the tolerances: docs/kinematics.md ("The symmetry monitor").

>>> import math
>>> tracker = BeatTracker()
>>> def theta3(t):
...     return 0.4 * math.sin(2 * math.pi * (t - 0.05))
>>> beats = [tracker.add(k * 0.01, theta3(k * 0.01)) for k in range(400)]
>>> [round(b.period_s, 6) for b in beats if b is not None]
[1.0, 1.0, 1.0]
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from fishtail_common.parameters import ParameterSpec
from fishtail_common.stream_timing import StreamTiming

#: Default Schmitt-trigger width of the beat segmentation [rad].
DEFAULT_HYSTERESIS_RAD = 0.01
#: Default interval without samples after which the beat in progress is forgotten [s].
DEFAULT_GAP_RESET_S = 0.5
#: How a gap inside a beat bounds the beat's figures (judge_with_gaps; docs/kinematics.md, "Beats
#: with a gap"): theta3 over a beat is a smooth swing whose curvature per rad^2 of the beat's phase
#: (2 pi a beat) is at most this times the amplitude (a sine's is 1; the report's linkage 0.91) ...
CURVATURE_FACTOR = 2.0
#: ... whose slope where it crosses zero is at least this times the amplitude per rad (a sine's 1,
#: the report's linkage 1.08) ...
CROSSING_SLOPE_FACTOR = 0.5
#: ... and a gap longer than this share of the beat may hide more than that model allows.
MAX_GAP_SHARE = 0.125


class Verdict(enum.IntEnum):
    """Per-beat verdict; values as in fishtail_msgs/SymmetryReport and DiagnosticStatus."""

    OK = 0
    WARN = 1
    ERROR = 2
    NOT_JUDGED = 3


@dataclasses.dataclass(frozen=True)
class SymmetryTolerances:
    """Limits of a beat's asymmetry; WARN above the first of each pair, ERROR above the second.

    Raises:
        ValueError: a limit that is negative or not finite, or a WARN limit above its ERROR one.
    """

    time_share_warn: float = 0.005
    time_share_error: float = 0.02
    mean_angle_warn_rad: float = 0.01
    mean_angle_error_rad: float = 0.035
    peak_asymmetry_warn_rad: float = 0.01
    peak_asymmetry_error_rad: float = 0.035

    def __post_init__(self) -> None:
        """Refuse negative, non-finite or inverted limits."""
        pairs = (
            ("time_share", self.time_share_warn, self.time_share_error),
            ("mean_angle", self.mean_angle_warn_rad, self.mean_angle_error_rad),
            ("peak_asymmetry", self.peak_asymmetry_warn_rad, self.peak_asymmetry_error_rad),
        )
        for name, warn, error in pairs:
            if not (math.isfinite(warn) and math.isfinite(error) and 0.0 <= warn <= error):
                raise ValueError(f"{name} tolerances need 0 <= warn <= error, got {warn}, {error}")


def _tolerance_parameter(field: dataclasses.Field[float]) -> ParameterSpec:
    unit = "rad" if field.name.endswith("_rad") else "share of the beat, |share - 0.5|"
    level = "WARN" if "warn" in field.name else "ERROR"
    assert isinstance(field.default, float)
    return ParameterSpec(field.name, field.default, f"{level} above this", unit, 0.0, 1.0)


#: The monitor's parameters of beat segmentation and judgement (defaults: the dataclass's and
#: the constants above), also read from a parameter file by the offline analysis.
HYSTERESIS = ParameterSpec(
    "hysteresis_rad",
    DEFAULT_HYSTERESIS_RAD,
    "theta3 must go below -hysteresis before an upward zero crossing counts as a new beat",
    "rad",
    0.0,
    0.5,
)
GAP_RESET = ParameterSpec(
    "gap_reset_sec",
    DEFAULT_GAP_RESET_S,
    "a gap in tail/state longer than this restarts the beat",
    "s",
    0.01,
    60.0,
)
TOLERANCE_PARAMETERS: tuple[ParameterSpec, ...] = tuple(
    _tolerance_parameter(field) for field in dataclasses.fields(SymmetryTolerances)
)
SYMMETRY_PARAMETERS: tuple[ParameterSpec, ...] = (*TOLERANCE_PARAMETERS, HYSTERESIS, GAP_RESET)


@dataclasses.dataclass(frozen=True)
class BeatStatistics:
    """One tail beat: peaks, amplitude, time-mean of theta3, time on each side, period."""

    index: int
    start_s: float
    end_s: float
    positive_peak_rad: float
    negative_peak_rad: float
    mean_angle_rad: float
    positive_time_share: float
    negative_time_share: float
    #: Longest interval between samples inside the beat that the caller marked as a gap; 0 if
    #: none.
    gap_s: float = 0.0
    #: All the beat's intervals the caller marked as gaps, summed [s]; 0 if none.
    gap_total_s: float = 0.0
    #: How many of those gaps theta3 changed sign across (a zero crossing inside them).
    gap_crossings: int = 0

    @property
    def period_s(self) -> float:
        """Duration of the beat."""
        return self.end_s - self.start_s

    @property
    def frequency_hz(self) -> float:
        """Tail-beat frequency."""
        return 1.0 / self.period_s

    @property
    def amplitude_rad(self) -> float:
        """Half the peak-to-peak swing."""
        return 0.5 * (self.positive_peak_rad - self.negative_peak_rad)

    @property
    def peak_asymmetry_rad(self) -> float:
        """Positive peak + negative peak: zero when the swing is centred on theta3 = 0."""
        return self.positive_peak_rad + self.negative_peak_rad

    @property
    def time_share_imbalance(self) -> float:
        """Positive minus negative time share, halved: zero for a symmetric swing."""
        return 0.5 * (self.positive_time_share - self.negative_time_share)


@dataclasses.dataclass(frozen=True)
class GapBounds:
    """How far a beat's gaps may have moved its figures (linear interpolation across them)."""

    #: Each peak, and so the peak asymmetry [rad].
    peak_rad: float
    #: The mean angle [rad].
    mean_angle_rad: float
    #: The time-share imbalance.
    time_share: float


def gap_bounds(beat: BeatStatistics) -> GapBounds | None:
    """Bounds on the error the beat's gaps can cause, or None if they are too long to bound.

    Across a gap the tracker joins the samples on either side by a straight line. With theta3's
    curvature at most K = CURVATURE_FACTOR x amplitude per rad^2 of phase and a gap of phase width
    d = 2 pi gap / period, the line is off by at most K d^2 / 8 inside the gap: a peak that fell
    in it is at most that much higher than the samples show. The integral over the gap is off by
    at most K d^3 / 12, so the mean (the integral over 2 pi) by K d_max^2 D / (24 pi) for gaps
    of total phase width D. A zero crossing in a gap moves by at most (K d^2 / 8) / the slope
    there (>= CROSSING_SLOPE_FACTOR x amplitude), and each crossing inside a gap moves the share
    by that over 2 pi. The peaks' bound does not use where the gap is. Beats without a gap: all
    0. None: a gap over MAX_GAP_SHARE of the beat, or figures that are not finite.
    """
    if not beat.gap_s > 0.0:
        return GapBounds(0.0, 0.0, 0.0)
    period = beat.period_s
    amplitude = beat.amplitude_rad
    if not (math.isfinite(period) and period > 0.0 and math.isfinite(amplitude)):
        return None
    if not beat.gap_s <= MAX_GAP_SHARE * period:
        return None
    width = 2.0 * math.pi * beat.gap_s / period
    total = 2.0 * math.pi * max(beat.gap_total_s, beat.gap_s) / period
    curvature = CURVATURE_FACTOR * amplitude
    line_error = curvature * width * width / 8.0
    crossing_shift = line_error / (CROSSING_SLOPE_FACTOR * amplitude) if amplitude > 0.0 else 0.0
    return GapBounds(
        peak_rad=line_error,
        mean_angle_rad=curvature * width * width * total / (24.0 * math.pi),
        time_share=min(beat.gap_crossings, 2) * crossing_shift / (2.0 * math.pi),
    )


def not_judged_reason(beat: BeatStatistics) -> str | None:
    """Why ``beat`` cannot be judged at all, or None if it may be (see :func:`judge` for gaps)."""
    reasons = []
    if not (math.isfinite(beat.mean_angle_rad) and math.isfinite(beat.positive_time_share)):
        reasons.append(
            "the carrier angle did not advance over the beat, so its mean and shares are "
            "undefined (reported as 0)"
        )
    if beat.gap_s > 0.0 and gap_bounds(beat) is None:
        reasons.append(
            f"the input has a gap of {beat.gap_s * 1e3:.0f} ms inside the beat (samples lost "
            f"or late; over {MAX_GAP_SHARE:g} of the beat), peaks "
            f"{math.degrees(beat.positive_peak_rad):+.3f}/"
            f"{math.degrees(beat.negative_peak_rad):+.3f} deg are from what arrived"
        )
    return "not judged: " + "; ".join(reasons) if reasons else None


def _level(value: float, warn: float, error: float) -> Verdict:
    # Written as "not <=" so that a NaN figure is an error, never a pass.
    if not abs(value) <= error:
        return Verdict.ERROR
    if not abs(value) <= warn:
        return Verdict.WARN
    return Verdict.OK


def judge(beat: BeatStatistics, tolerances: SymmetryTolerances) -> tuple[Verdict, str]:
    """Verdict and a one-line reason that quotes the measured bias (NOT_JUDGED: why not)."""
    reason = not_judged_reason(beat)
    if reason is not None:
        return Verdict.NOT_JUDGED, reason
    bounds = gap_bounds(beat)
    assert bounds is not None  # not_judged_reason() refuses the gaps that cannot be bounded
    degrees = math.degrees
    measures: tuple[tuple[str, float, float, float, str, Callable[[float], str]], ...] = (
        ("time share", beat.time_share_imbalance, tolerances.time_share_warn,
         tolerances.time_share_error, f"{beat.positive_time_share:.4f} of the beat on +side",
         lambda limit: f"0.5 +/- {limit:g}"),
        ("mean angle", beat.mean_angle_rad, tolerances.mean_angle_warn_rad,
         tolerances.mean_angle_error_rad, f"mean theta3 {degrees(beat.mean_angle_rad):+.3f} deg",
         lambda limit: f"+/- {degrees(limit):.3f} deg"),
        ("peak asymmetry", beat.peak_asymmetry_rad, tolerances.peak_asymmetry_warn_rad,
         tolerances.peak_asymmetry_error_rad,
         f"peaks {degrees(beat.positive_peak_rad):+.3f}/{degrees(beat.negative_peak_rad):+.3f} deg",
         lambda limit: f"sum within +/- {degrees(limit):.3f} deg"),
    )  # fmt: skip
    margins = (bounds.time_share, bounds.mean_angle_rad, bounds.peak_rad)
    # A gap that could move a figure across a limit leaves the verdict open: not judged.
    open_measures = [
        f"{name} {text} +/- {degrees(margin) if name != 'time share' else margin:.3g}"
        f"{' deg' if name != 'time share' else ''} could cross its limit"
        for (name, value, warn, error, text, _), margin in zip(measures, margins, strict=True)
        if margin > 0.0
        and _level(max(abs(value) - margin, 0.0), warn, error)
        != _level(abs(value) + margin, warn, error)
    ]
    if open_measures:
        return Verdict.NOT_JUDGED, (
            f"not judged: the input has a gap of {beat.gap_s * 1e3:.0f} ms inside the beat "
            f"(samples lost or late) that could change the verdict: " + "; ".join(open_measures)
        )
    verdict = Verdict.OK
    failures = []
    for name, value, warn, error, text, limit_text in measures:
        level = _level(value, warn, error)
        verdict = max(verdict, level)
        if level != Verdict.OK:
            limit = error if level == Verdict.ERROR else warn
            failures.append(f"{name} off: {text}, limit {limit_text(limit)}")
    bridged = ""
    if beat.gap_s > 0.0:
        bridged = f" (a gap of {beat.gap_s * 1e3:.0f} ms bridged, too short to change the verdict)"
    if not failures:
        return verdict, (
            f"symmetric: {beat.positive_time_share:.4f} of the beat on +side, "
            f"mean theta3 {math.degrees(beat.mean_angle_rad):+.3f} deg{bridged}"
        )
    return verdict, "asymmetric swing: " + "; ".join(failures) + bridged


class BeatTracker:
    """Streaming beat segmentation: feed samples with :meth:`add`, get a beat when one completes.

    Per sample it does a handful of float operations and allocates nothing unless a beat ends.
    Samples must come in increasing time; an older or equal time, or a non-finite value, is
    ignored and counted in :attr:`rejected_samples` (the caller reports it). The caller marks a
    sample that follows a gap in the input (``after_gap``); the beats the gap falls in carry its
    length in :attr:`BeatStatistics.gap_s` and are not judged.
    """

    def __init__(self, hysteresis_rad: float = DEFAULT_HYSTERESIS_RAD) -> None:
        """Create a tracker that needs theta3 below -hysteresis_rad before a crossing counts.

        Raises:
            ValueError: a hysteresis that is negative or not finite.
        """
        if not (math.isfinite(hysteresis_rad) and hysteresis_rad >= 0.0):
            raise ValueError(f"hysteresis_rad must be finite and >= 0, got {hysteresis_rad!r}")
        self.hysteresis_rad = hysteresis_rad
        self.beats_completed = 0
        self.rejected_samples = 0
        self._last_time: float | None = None
        self._last_value = 0.0
        self._armed = False
        self._in_beat = False
        self._last_coordinate = 0.0
        self._reset_beat(0.0, 0.0)

    def _reset_beat(self, start_s: float, start_coordinate: float) -> None:
        self._start = start_s
        self._start_coordinate = start_coordinate
        self._maximum = -math.inf
        self._minimum = math.inf
        self._integral = 0.0
        self._positive_time = 0.0
        self._gap = 0.0
        self._gap_total = 0.0
        self._gap_crossings = 0

    def reset(self) -> None:
        """Forget the beat in progress (e.g. after a gap in the data)."""
        self._last_time = None
        self._armed = False
        self._in_beat = False

    def add(
        self,
        time_s: float,
        theta3: float,
        carrier_rad: float | None = None,
        after_gap: bool = False,
    ) -> BeatStatistics | None:
        """Add one sample; return the beat it completes, if any.

        ``carrier_rad`` (the unwrapped carrier angle of the sample) makes the shares and the mean
        carrier-angle weighted; give it with every sample or with none. ``after_gap``: the
        interval since the previous sample is a gap in the input.
        """
        coordinate = time_s if carrier_rad is None else carrier_rad
        if not (math.isfinite(time_s) and math.isfinite(theta3) and math.isfinite(coordinate)):
            self.rejected_samples += 1
            return None
        previous_time = self._last_time
        if previous_time is None:
            self._last_time, self._last_value = time_s, theta3
            self._last_coordinate = coordinate
            self._armed = theta3 < -self.hysteresis_rad
            return None
        if time_s <= previous_time:
            self.rejected_samples += 1
            return None
        previous = self._last_value
        previous_coordinate = self._last_coordinate
        self._last_time, self._last_value = time_s, theta3
        self._last_coordinate = coordinate
        completed = None
        gap = time_s - previous_time if after_gap else 0.0
        crossed = 1 if gap > 0.0 and (previous < 0.0) != (theta3 < 0.0) else 0
        self._gap_total += gap
        self._gap_crossings += crossed
        if gap > self._gap:
            # Before a crossing in this interval: the beat it ends and the one it starts both
            # contain part of the gap.
            self._gap = gap
        if self._armed and previous < 0.0 <= theta3:
            fraction = -previous / (theta3 - previous)
            crossing = previous_time + (time_s - previous_time) * fraction
            step = coordinate - previous_coordinate
            crossing_coordinate = previous_coordinate + step * fraction
            if self._in_beat:
                self._accumulate(previous_coordinate, previous, crossing_coordinate, 0.0)
                completed = self._finish(crossing, crossing_coordinate)
            self._in_beat = True
            self._armed = False
            self._reset_beat(crossing, crossing_coordinate)
            self._gap = gap
            self._gap_total = gap
            self._gap_crossings = crossed
            self._accumulate(crossing_coordinate, 0.0, coordinate, theta3)
        elif self._in_beat:
            self._accumulate(previous_coordinate, previous, coordinate, theta3)
        if theta3 < -self.hysteresis_rad:
            self._armed = True
        return completed

    def _accumulate(self, t0: float, v0: float, t1: float, v1: float) -> None:
        dt = t1 - t0
        if v0 > self._maximum:
            self._maximum = v0
        if v1 > self._maximum:
            self._maximum = v1
        if v0 < self._minimum:
            self._minimum = v0
        if v1 < self._minimum:
            self._minimum = v1
        self._integral += 0.5 * (v0 + v1) * dt
        if v0 >= 0.0 and v1 >= 0.0:
            self._positive_time += dt
        elif (v0 >= 0.0) != (v1 >= 0.0):
            # The segment crosses zero: split it at the interpolated crossing.
            positive_end = v0 if v0 >= 0.0 else v1
            self._positive_time += dt * positive_end / (abs(v0) + abs(v1))

    def _finish(self, end_s: float, end_coordinate: float) -> BeatStatistics:
        period = end_s - self._start
        measure = end_coordinate - self._start_coordinate
        if not measure > 0.0:
            # A carrier angle that did not advance over a whole beat is not a usable weight.
            measure, self._integral, self._positive_time = period, math.nan, math.nan
        positive_share = self._positive_time / measure
        beat = BeatStatistics(
            index=self.beats_completed,
            start_s=self._start,
            end_s=end_s,
            positive_peak_rad=self._maximum,
            negative_peak_rad=self._minimum,
            mean_angle_rad=self._integral / measure,
            positive_time_share=positive_share,
            negative_time_share=1.0 - positive_share,
            gap_s=self._gap,
            gap_total_s=self._gap_total,
            gap_crossings=self._gap_crossings,
        )
        self.beats_completed += 1
        return beat


def beats_of(
    time_s: npt.ArrayLike,
    theta3: npt.ArrayLike,
    hysteresis_rad: float = DEFAULT_HYSTERESIS_RAD,
    carrier_rad: npt.ArrayLike | None = None,
    gap_reset_s: float = math.inf,
) -> list[BeatStatistics]:
    """All complete beats of a recorded series (the same code path as the live monitor).

    As in the monitor, gaps are found by
    :class:`~fishtail_common.stream_timing.StreamTiming` on the stamps, and an interval
    longer than ``gap_reset_s`` forgets the beat in progress.

    Raises:
        ValueError: a hysteresis that is negative or not finite.
    """
    tracker = BeatTracker(hysteresis_rad)
    timing = StreamTiming()
    beats = []
    times: list[float] = np.asarray(time_s, float).ravel().tolist()
    values: list[float] = np.asarray(theta3, float).ravel().tolist()
    carriers: list[float] | list[None] = (
        [None] * len(times) if carrier_rad is None else np.asarray(carrier_rad, float).tolist()
    )
    previous = None
    for t, value, carrier in zip(times, values, carriers, strict=True):
        if previous is not None and t - previous > gap_reset_s:
            tracker.reset()
        previous = t
        gap = timing.observe(t)
        beat = tracker.add(t, value, carrier, gap)
        if beat is not None:
            beats.append(beat)
    return beats
