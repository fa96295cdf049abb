"""Beat segmentation and per-beat statistics against closed-form cases and the engine."""

from __future__ import annotations

import math
import random

import numpy as np
import pytest

from fishtail_kinematics.mechanisms import OscillatoryGeometry, OscillatoryTail
from fishtail_kinematics.symmetry import (
    BeatTracker,
    SymmetryTolerances,
    Verdict,
    beats_of,
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


def test_a_carrier_that_does_not_advance_is_an_error_not_a_pass():
    tracker = BeatTracker()
    time_s, theta3 = biased_sine(0.4, 0.0, 1.0, 200.0, 3.5)
    beats = [tracker.add(float(t), float(v), 0.0) for t, v in zip(time_s, theta3, strict=True)]
    completed = [b for b in beats if b is not None]
    assert completed
    assert all(judge(beat, SymmetryTolerances())[0] == Verdict.ERROR for beat in completed)
