"""Beat segmentation and per-beat statistics against closed-form cases and the engine."""

from __future__ import annotations

import dataclasses
import math
import random

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail
from fishtail_kinematics.engine.symmetry import (
    CROSSING_SLOPE_FACTOR,
    CURVATURE_FACTOR,
    MAX_GAP_SHARE,
    BeatStatistics,
    BeatTracker,
    GapBounds,
    SymmetryTolerances,
    Verdict,
    beats_of,
    gap_bounds,
    judge,
)


def biased_sine(amplitude: float, bias: float, frequency_hz: float, rate_hz: float, seconds: float):
    time_s = np.arange(0.0, seconds, 1.0 / rate_hz)
    return time_s, amplitude * np.sin(2 * math.pi * frequency_hz * time_s) + bias


@pytest.mark.parametrize("bias", [0.0, 0.05, -0.12])
def test_biased_sine_statistics_match_closed_form(bias):
    amplitude, frequency = 0.4, 1.3
    time_s, theta3 = biased_sine(amplitude, bias, frequency, 2000.0, 6.0)
    beats = beats_of(time_s, theta3)
    assert len(beats) >= 6
    # Fraction of a period with A sin + b > 0 is 1/2 + asin(b/A)/pi.
    positive_share = 0.5 + math.asin(bias / amplitude) / math.pi
    for beat in beats:
        assert beat.period_s == pytest.approx(1 / frequency, abs=1e-6)
        assert beat.frequency_hz == pytest.approx(frequency, rel=1e-5)
        assert beat.positive_peak_rad == pytest.approx(amplitude + bias, abs=1e-5)
        assert beat.negative_peak_rad == pytest.approx(bias - amplitude, abs=1e-5)
        assert beat.amplitude_rad == pytest.approx(amplitude, abs=1e-5)
        assert beat.mean_angle_rad == pytest.approx(bias, abs=1e-6)
        assert beat.positive_time_share == pytest.approx(positive_share, abs=1e-5)
        assert beat.positive_time_share + beat.negative_time_share == pytest.approx(1.0)


def test_statistics_barely_depend_on_sample_rate():
    coarse = beats_of(*biased_sine(0.4, 0.03, 0.64, 100.0, 8.0))
    fine = beats_of(*biased_sine(0.4, 0.03, 0.64, 5000.0, 8.0))
    assert coarse[1].positive_time_share == pytest.approx(fine[1].positive_time_share, abs=2e-4)
    assert coarse[1].mean_angle_rad == pytest.approx(fine[1].mean_angle_rad, abs=2e-4)
    assert coarse[1].period_s == pytest.approx(fine[1].period_s, abs=1e-4)


def test_noise_around_zero_does_not_split_beats():
    time_s, theta3 = biased_sine(0.4, 0.0, 1.0, 1000.0, 5.3)
    jitter = random.Random(4)
    noisy = [value + jitter.uniform(-0.004, 0.004) for value in theta3]
    # The first beat starts at the first upward crossing after a dip, t = 1 s: 4 whole beats.
    assert len(beats_of(time_s, noisy, hysteresis_rad=0.01)) == 4
    # Without hysteresis the same noise makes spurious beats: the hysteresis is what helps.
    assert len(beats_of(time_s, noisy, hysteresis_rad=0.0)) > 4


def test_bad_samples_are_counted_and_ignored():
    tracker = BeatTracker()
    time_s, theta3 = biased_sine(0.4, 0.0, 1.0, 200.0, 4.2)
    beats = []
    for k, (t, value) in enumerate(zip(time_s, theta3, strict=True)):
        if k % 50 == 7:
            assert tracker.add(float(t), float("nan")) is None
            assert tracker.add(float(t) - 0.5, 0.0) is None
        beat = tracker.add(float(t), float(value))
        if beat is not None:
            beats.append(beat)
    assert tracker.rejected_samples == 2 * len(range(7, len(time_s), 50))
    assert [round(b.period_s, 6) for b in beats] == [1.0, 1.0, 1.0]


def test_reset_forgets_the_beat_in_progress():
    tracker = BeatTracker()
    time_s, theta3 = biased_sine(0.4, 0.0, 1.0, 200.0, 1.6)
    for t, value in zip(time_s, theta3, strict=True):
        tracker.add(float(t), float(value))
    tracker.reset()
    later_t, later_theta = biased_sine(0.4, 0.0, 1.0, 200.0, 2.6)
    samples = zip(later_t + 10.0, later_theta, strict=True)
    completed = [b for b in (tracker.add(float(t), float(v)) for t, v in samples) if b is not None]
    # The first beat after the gap starts at the first crossing after it, not before the gap.
    assert completed and all(b.start_s > 10.0 for b in completed)


def engine_beats(pivot_offset_m: float, rate_hz: float = 200.0) -> list:
    tail = OscillatoryTail(OscillatoryGeometry(pivot_offset_m=pivot_offset_m))
    time_s = np.arange(0.0, 8.0, 1.0 / rate_hz)
    return beats_of(time_s, tail.solve(4.0 * time_s, 4.0).theta3)


def test_report_geometry_is_judged_symmetric():
    tolerances = SymmetryTolerances()
    beats = engine_beats(0.2)
    assert len(beats) == 4
    for beat in beats:
        verdict, message = judge(beat, tolerances)
        assert verdict == Verdict.OK, message
        assert beat.positive_time_share == pytest.approx(0.5, abs=1e-3)
        assert beat.period_s == pytest.approx(2 * math.pi / 4.0, abs=1e-3)
        assert beat.amplitude_rad == pytest.approx(math.atan(0.5), abs=1e-4)


@pytest.mark.parametrize(
    ("pivot_offset_m", "expected", "fragment"),
    [(0.19, Verdict.WARN, "0.507"), (0.17, Verdict.ERROR, "0.526")],
)
def test_skewed_pivot_offset_is_flagged_with_the_measured_bias(pivot_offset_m, expected, fragment):
    # OS changed, RS left at the value that is symmetric for OS = 0.2.
    verdict, message = judge(engine_beats(pivot_offset_m)[-1], SymmetryTolerances())
    assert verdict == expected
    assert "time share off" in message and fragment in message


@pytest.mark.parametrize(
    "kwargs",
    [{"time_share_warn": -0.1}, {"mean_angle_warn_rad": 0.1, "mean_angle_error_rad": 0.05},
     {"peak_asymmetry_error_rad": math.nan}],
)  # fmt: skip
def test_tolerances_refuse_nonsense(kwargs):
    with pytest.raises(ValueError, match="warn <= error"):
        SymmetryTolerances(**kwargs)


def test_hysteresis_must_be_non_negative():
    with pytest.raises(ValueError, match="hysteresis_rad"):
        BeatTracker(-0.1)


def test_carrier_weighting_keeps_speed_ripple_out_of_the_verdict():
    # The symmetric linkage driven at a speed that ripples once per revolution (a PID or a load
    # that is not constant): in time the tail lingers on one side, over the carrier it does not.
    tail = OscillatoryTail(OscillatoryGeometry())
    time_s = np.arange(0.0, 10.0, 0.005)
    carrier = 4.0 * time_s + 0.15 * np.sin(4.0 * time_s)
    theta3 = tail.solve(carrier, 4.0).theta3
    tolerances = SymmetryTolerances()
    by_time = beats_of(time_s, theta3)
    by_carrier = beats_of(time_s, theta3, carrier_rad=carrier)
    assert len(by_time) == len(by_carrier) >= 5
    assert all(judge(beat, tolerances)[0] != Verdict.OK for beat in by_time)
    for beat in by_carrier:
        assert judge(beat, tolerances)[0] == Verdict.OK
        assert beat.positive_time_share == pytest.approx(0.5, abs=1e-4)
        # Period and frequency still come from time.
        assert beat.period_s == pytest.approx(2 * math.pi / 4.0, rel=0.02)


def test_a_carrier_that_does_not_advance_is_not_judged_not_a_pass():
    tracker = BeatTracker()
    time_s, theta3 = biased_sine(0.4, 0.0, 1.0, 200.0, 3.5)
    beats = [tracker.add(float(t), float(v), 0.0) for t, v in zip(time_s, theta3, strict=True)]
    completed = [b for b in beats if b is not None]
    assert completed
    for beat in completed:
        verdict, message = judge(beat, SymmetryTolerances())
        # Not a verdict on the linkage: the figures it would rest on are undefined.
        assert verdict == Verdict.NOT_JUDGED
        assert message.startswith("not judged: the carrier angle did not advance"), message


def report_geometry_at_200_hz(hole_s: tuple[float, float] | None):
    """theta3 of the report geometry at 4 rad/s at 200 Hz, without the samples inside hole_s."""
    tail = OscillatoryTail(OscillatoryGeometry())
    time_s = np.arange(0.0, 8.0, 0.005)
    if hole_s is not None:
        time_s = time_s[(time_s <= hole_s[0]) | (time_s >= hole_s[1])]
    carrier = 4.0 * time_s
    return time_s, tail.solve(carrier, 4.0).theta3, carrier


def test_a_beat_with_a_gap_is_not_judged():
    # A hole of about 315 ms (at 4 rad/s, 1.26 rad of carrier) around the + peak of a beat of
    # the symmetric linkage. Interpolated across, the peak is 21.8 deg instead of 26.6: judged,
    # that beat would be a false "asymmetric swing" (ERROR).
    time_s, theta3, carrier = report_geometry_at_200_hz(None)
    beats = beats_of(time_s, theta3, carrier_rad=carrier)
    peak_time = beats[1].start_s + 0.25 * beats[1].period_s
    hole = (peak_time - 0.16, peak_time + 0.155)
    time_s, theta3, carrier = report_geometry_at_200_hz(hole)
    gap = float(np.max(np.diff(time_s)))
    assert gap == pytest.approx(0.315, abs=0.006)

    tolerances = SymmetryTolerances()
    tracker = BeatTracker()  # premise: without the gap mark, the verdict is a false alarm
    unmarked = [b for b in map(tracker.add, time_s, theta3, carrier) if b is not None]
    assert judge(unmarked[1], tolerances)[0] != Verdict.OK

    beats = beats_of(time_s, theta3, carrier_rad=carrier)
    assert len(beats) == len(unmarked)
    verdict, message = judge(beats[1], tolerances)
    assert verdict == Verdict.NOT_JUDGED
    assert beats[1].gap_s == pytest.approx(gap)
    assert message.startswith(f"not judged: the input has a gap of {gap * 1e3:.0f} ms"), message
    for beat in beats[:1] + beats[2:]:
        assert beat.gap_s == 0.0
        assert judge(beat, tolerances)[0] == Verdict.OK


def test_a_gap_across_a_crossing_belongs_to_both_beats():
    tracker = BeatTracker()
    time_s, theta3 = biased_sine(0.4, 0.0, 1.0, 200.0, 4.5)
    marked = []
    for k, (t, value) in enumerate(zip(time_s, theta3, strict=True)):
        if 390 < k < 410:  # the upward crossing at t = 2 s lies in the hole
            continue
        beat = tracker.add(float(t), float(value), after_gap=(k == 410))
        if beat is not None:
            marked.append(beat)
    # Beats [1, 2], [2, 3], [3, 4] s (the first upward crossing after a dip is at 1 s).
    assert [b.gap_s > 0.0 for b in marked] == [True, True, False]
    assert marked[0].gap_s == marked[1].gap_s == pytest.approx(0.1)
    assert marked[0].end_s == pytest.approx(2.0, abs=1e-3)


def test_jitter_is_not_a_gap():
    # Stamps up to 15 ms late on a 5 ms grid (under the 20 ms floor): every beat is judged.
    jitter = np.random.default_rng(5)
    time_s = np.arange(0.0, 6.0, 0.005)
    late = jitter.random(time_s.size) < 0.05
    time_s = np.where(late, time_s + jitter.uniform(0.0, 0.004, time_s.size), time_s)
    keep = np.concatenate(([True], np.diff(time_s) > 0.0))
    time_s = time_s[keep]
    drop = jitter.random(time_s.size) < 0.02  # and a few lost: 10-15 ms intervals
    time_s = time_s[~drop]
    theta3 = 0.4 * np.sin(2 * math.pi * time_s)
    beats = beats_of(time_s, theta3)
    assert len(beats) == 4  # [1, 2] ... [4, 5] s
    assert all(beat.gap_s == 0.0 for beat in beats)


def test_a_long_gap_restarts_the_beat():
    time_s, theta3 = biased_sine(0.4, 0.0, 1.0, 200.0, 6.0)
    keep = (time_s < 2.7) | (time_s > 3.3)
    beats = beats_of(time_s[keep], theta3[keep], gap_reset_s=0.5)
    # [2, 3] held the hole and is forgotten; after it theta3 must dip again before the crossing
    # at 4 s starts a beat.
    assert [(round(b.start_s, 6), round(b.end_s, 6)) for b in beats] == [(1.0, 2.0), (4.0, 5.0)]


# ---- beats with a hole in the input


def sine_with_hole(hole_s: float, hole_phase: float, *, peak_bias: float = 0.0, speed=4.0):
    """theta3 of the report's amplitude at 200 Hz, 4 beats of a 4 rad/s carrier, with holes.

    Samples are missing for ``hole_s`` around ``hole_phase`` (rad into each beat) of beats 1, 2.

    ``peak_bias`` raises the positive half-wave only: a peak asymmetry of that much.
    """
    amplitude, period = 0.4636, 2 * math.pi / speed
    time_s = np.arange(0.0, 4.2 * period, 0.005)
    phase = speed * time_s
    theta3 = amplitude * np.sin(phase)
    theta3 = np.where(theta3 > 0.0, theta3 * (1.0 + peak_bias / amplitude), theta3)
    keep = np.ones_like(time_s, bool)
    for beat in (1, 2):
        centre = (beat * 2 * math.pi + hole_phase) / speed
        keep &= ~((time_s > centre - hole_s / 2) & (time_s < centre + hole_s / 2))
    return time_s[keep], theta3[keep], phase[keep]


def verdicts(time_s, theta3, carrier, tolerances=None):
    tolerances = tolerances or SymmetryTolerances()
    return [judge(beat, tolerances) for beat in beats_of(time_s, theta3, carrier_rad=carrier)]


@pytest.mark.parametrize("where", [0.0, math.pi / 2, math.pi, 3 * math.pi / 2])
def test_a_24_ms_hole_anywhere_in_a_symmetric_beat_is_bridged_and_judged(where):
    # At the zero crossings, the peaks and in between: too short to move any figure to a limit.
    time_s, theta3, carrier = sine_with_hole(0.024, where)
    beats = beats_of(time_s, theta3, carrier_rad=carrier)
    assert any(beat.gap_s > 0.02 for beat in beats)
    results = verdicts(time_s, theta3, carrier)
    assert [verdict for verdict, _ in results] == [Verdict.OK] * len(results), results
    # 24 ms missing on a 5 ms grid: a 30 ms interval.
    assert any("a gap of 30 ms bridged" in text for _, text in results), results


def test_a_small_hole_is_not_judged_only_where_it_could_cross_a_limit():
    # A 40 ms hole at 4 rad/s may hide up to 0.003 rad of a peak (the bound does not use where
    # the hole is): a figure that close to a limit is left open, one farther from it is judged.
    tolerances = SymmetryTolerances()
    time_s, theta3, carrier = sine_with_hole(0.04, math.pi / 2, peak_bias=0.0099)
    results = verdicts(time_s, theta3, carrier, tolerances)
    holed = [r for r in results if "gap" in r[1]]
    assert holed and all(v == Verdict.NOT_JUDGED for v, _ in holed), results
    assert all("peak asymmetry" in t and "could cross its limit" in t for _, t in holed), holed
    assert all(v == Verdict.OK for v, t in results if "gap" not in t), results
    time_s, theta3, carrier = sine_with_hole(0.04, math.pi / 2, peak_bias=0.005)
    assert all(v == Verdict.OK for v, _ in verdicts(time_s, theta3, carrier, tolerances))
    # A clear asymmetry stays an ERROR across the hole: the bound cannot bring it back.
    time_s, theta3, carrier = sine_with_hole(0.04, math.pi / 2, peak_bias=0.1)
    assert all(v == Verdict.ERROR for v, _ in verdicts(time_s, theta3, carrier, tolerances))


def test_a_hole_over_an_eighth_of_the_beat_is_not_judged():
    time_s, theta3, carrier = sine_with_hole(0.315, math.pi / 2)
    results = verdicts(time_s, theta3, carrier)
    holed = [text for verdict, text in results if verdict == Verdict.NOT_JUDGED]
    assert len(holed) == 2 and all("gap of 3" in t and "over 0.125" in t for t in holed), results


def test_gap_bounds_follow_the_curvature_rule():
    beat = BeatStatistics(
        index=0, start_s=0.0, end_s=1.0, positive_peak_rad=0.5, negative_peak_rad=-0.5,
        mean_angle_rad=0.0, positive_time_share=0.5, negative_time_share=0.5, gap_s=0.02,
        gap_total_s=0.04, gap_crossings=2,
    )  # fmt: skip
    bounds = gap_bounds(beat)
    width = 2 * math.pi * 0.02
    curvature = CURVATURE_FACTOR * 0.5
    assert bounds.peak_rad == pytest.approx(curvature * width**2 / 8)
    assert bounds.mean_angle_rad == pytest.approx(curvature * width**2 * 2 * width / (24 * math.pi))
    assert bounds.time_share == pytest.approx(
        2 * (curvature * width**2 / 8) / (CROSSING_SLOPE_FACTOR * 0.5) / (2 * math.pi)
    )
    # No gap: no bound; a NaN amplitude or a hole over MAX_GAP_SHARE: cannot be bounded.
    assert gap_bounds(dataclasses.replace(beat, gap_s=0.0)) == GapBounds(0.0, 0.0, 0.0)
    assert gap_bounds(dataclasses.replace(beat, positive_peak_rad=math.nan)) is None
    assert gap_bounds(dataclasses.replace(beat, gap_s=MAX_GAP_SHARE * 1.01)) is None
    # The bound holds for the linkage itself: the largest error of a straight line across a
    # hole of this width anywhere in the report's swing is below it.
    tail = OscillatoryTail(OscillatoryGeometry())
    phase = np.linspace(0.0, 2 * math.pi, 4001)
    theta3 = np.asarray(tail.solve(phase, 0.0 * phase).theta3)
    amplitude = 0.5 * (theta3.max() - theta3.min())
    step = int(round(width / (phase[1] - phase[0])))
    worst = 0.0
    for start in range(0, len(phase) - step, 7):
        chord = np.linspace(theta3[start], theta3[start + step], step + 1)
        worst = max(worst, float(np.abs(theta3[start : start + step + 1] - chord).max()))
    assert worst < CURVATURE_FACTOR * amplitude * width**2 / 8
