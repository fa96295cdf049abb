"""Swimming figures: a hand-computed Lighthill case, Strouhal numbers, validation, report tail."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail, UndulatoryTail
from fishtail_kinematics.engine.swimming import (
    SPEED_SOURCE_PARAMETER,
    SPEED_SOURCE_SIMULATED,
    SwimmingParameters,
    TipSampleBuffer,
    choose_forward_speed,
    lighthill_mean_thrust,
    strouhal_number,
    swimming_figures,
    tip_kinematics,
)
from fishtail_kinematics.engine.symmetry import BeatTracker, beats_of

REPORT_SPEED_RAD_S = 4.0


def report_cycle(tail, revolutions: float = 3.25, per_revolution: int = 720):
    """The tail solved at k 2pi/N over a few revolutions at 4 rad/s, with its time axis."""
    angles = np.arange(int(revolutions * per_revolution)) * (2.0 * math.pi / per_revolution)
    return angles / REPORT_SPEED_RAD_S, tail.solve(angles, REPORT_SPEED_RAD_S)


def test_hand_computed_sinusoid():
    # h(t) = a sin(w t) at the tip, slope dh/dx = b sin(w t + p) there.
    a, b, p = 0.04, 0.35, 0.7
    frequency = 1.5
    w = 2.0 * math.pi * frequency
    u, span, rho = 0.5, 0.12, 1025.0
    t = np.arange(0.0, 4.3, 1e-4)
    figures = swimming_figures(
        t, a * np.sin(w * t), a * w * np.cos(w * t), np.arctan(b * np.sin(w * t + p)),
        SwimmingParameters(forward_speed_m_s=u, fin_span_m=span, water_density_kg_m3=rho),
    )  # fmt: skip
    # By hand: mean(cos^2) = mean(sin^2) = 1/2 over whole periods, so
    # mean((dh/dt)^2) = a^2 w^2 / 2 and mean((dh/dx)^2) = b^2 / 2, whatever the phase p;
    # m = (pi/4) rho s^2 and T = (m/2) (a^2 w^2 / 2 - U^2 b^2 / 2).
    m = math.pi / 4.0 * rho * span**2
    expected_thrust = m / 2.0 * (a**2 * w**2 / 2.0 - u**2 * b**2 / 2.0)
    assert m == pytest.approx(11.5925, abs=1e-4)
    # = 5.79626 kg/m x (0.0710612 - 0.0153125) m^2/s^2
    assert expected_thrust == pytest.approx(0.323132, abs=1e-6)
    # Beats start where w t + p crosses 2 pi k upwards: (2 pi - 0.7)/w = 0.592 s; the last whole
    # beat ends before 4.3 s, so 5 whole beats.
    assert figures.beats == 5
    assert figures.beat_frequency_hz == pytest.approx(frequency, rel=1e-9)
    assert figures.tip_excursion_m == pytest.approx(2 * a, rel=1e-6)
    assert figures.added_mass_per_length_kg_m == pytest.approx(m, rel=1e-15)
    assert figures.mean_square_lateral_velocity_m2_s2 == pytest.approx(a**2 * w**2 / 2, rel=1e-7)
    assert figures.mean_square_slope == pytest.approx(b**2 / 2, rel=1e-7)
    assert figures.mean_thrust_n == pytest.approx(expected_thrust, rel=1e-6)
    assert figures.strouhal_number == pytest.approx(frequency * 2 * a / u, rel=1e-6)  # 0.24


def test_thrust_is_negative_when_the_slope_term_wins():
    parameters = SwimmingParameters(forward_speed_m_s=2.0, fin_span_m=0.1)
    m = math.pi / 4 * 1000.0 * 0.01
    assert lighthill_mean_thrust(0.1, 0.05, parameters) == pytest.approx(m / 2 * (0.1 - 4 * 0.05))
    assert lighthill_mean_thrust(0.1, 0.05, parameters) < 0.0


@pytest.mark.parametrize(
    ("frequency", "excursion", "speed", "expected"),
    [(2.0, 0.05, 0.4, 0.25), (0.6366, 0.1342, 0.3, 0.28478), (1.0, 0.0, 1.0, 0.0)],
)
def test_strouhal_number(frequency, excursion, speed, expected):
    assert strouhal_number(frequency, excursion, speed) == pytest.approx(expected, abs=1e-5)


@pytest.mark.parametrize(
    "values",
    [
        {"forward_speed_m_s": 0.0, "fin_span_m": 0.1},
        {"forward_speed_m_s": -0.3, "fin_span_m": 0.1},
        {"forward_speed_m_s": math.nan, "fin_span_m": 0.1},
        {"forward_speed_m_s": math.inf, "fin_span_m": 0.1},
        {"forward_speed_m_s": 0.3, "fin_span_m": 0.0},
        {"forward_speed_m_s": 0.3, "fin_span_m": 0.1, "water_density_kg_m3": -1000.0},
        {"forward_speed_m_s": 0.3, "fin_span_m": 0.1, "water_density_kg_m3": 0.0},
        {"forward_speed_m_s": True, "fin_span_m": 0.1},
        {"forward_speed_m_s": "0.3", "fin_span_m": 0.1},
    ],
)
def test_parameters_are_validated(values):
    with pytest.raises(ValueError, match="forward_speed_m_s|fin_span_m|water_density_kg_m3"):
        SwimmingParameters(**values)


def test_parameters_default_to_fresh_water():
    parameters = SwimmingParameters(forward_speed_m_s=1, fin_span_m=0.2)
    assert parameters.water_density_kg_m3 == 1000.0
    assert isinstance(parameters.forward_speed_m_s, float)
    assert parameters.added_mass_per_length_kg_m == pytest.approx(math.pi / 4 * 1000 * 0.04)
    with pytest.raises(ValueError, match="forward speed"):
        strouhal_number(1.0, 0.1, 0.0)


def test_bad_samples_are_refused():
    parameters = SwimmingParameters(forward_speed_m_s=0.3, fin_span_m=0.1)
    t = np.linspace(0.0, 3.0, 3001)
    angle = 0.3 * np.sin(2 * math.pi * t)
    with pytest.raises(ValueError, match="equally long"):
        swimming_figures(t, angle[:-1], angle, angle, parameters)
    with pytest.raises(ValueError, match="increasing"):
        swimming_figures(t[::-1], angle, angle, angle, parameters)
    with pytest.raises(ValueError, match="finite"):
        swimming_figures(t, np.where(t > 1, np.nan, angle), angle, angle, parameters)
    with pytest.raises(ValueError, match="no complete tail beat"):
        swimming_figures(t[:1500], angle[:1500], angle[:1500], angle[:1500], parameters)


def test_report_geometry_mechanism_1_at_4_rad_s():
    g = OscillatoryGeometry()
    t, s = report_cycle(OscillatoryTail(g))
    parameters = SwimmingParameters(forward_speed_m_s=0.3, fin_span_m=0.1)
    figures = swimming_figures(t, s.tip_y, s.tip_y_dot, s.theta3, parameters)
    assert figures.beats == 2  # 3.25 revolutions hold two whole beats between upward crossings
    assert figures.beat_frequency_hz == pytest.approx(4.0 / (2.0 * math.pi), rel=1e-10)
    # The tail swings +-atan(R/OS) = +-26.565 deg: A = 2 ST sin(26.565 deg).
    excursion = 2.0 * g.tail_link_m * math.sin(math.radians(26.565051177077994))
    assert excursion == pytest.approx(0.134164, abs=1e-6)
    assert figures.tip_excursion_m == pytest.approx(excursion, abs=1e-12)
    assert figures.strouhal_number == pytest.approx(4.0 / (2 * math.pi) * excursion / 0.3)
    # The means are those of one uniformly sampled revolution (whole periods).
    one_turn = slice(0, 720)
    mean_velocity_sq = float(np.mean(s.tip_y_dot[one_turn] ** 2))
    mean_slope_sq = float(np.mean(np.tan(s.theta3[one_turn]) ** 2))
    m = math.pi / 4 * 1000.0 * 0.1**2
    assert figures.mean_thrust_n == pytest.approx(
        m / 2 * (mean_velocity_sq - 0.3**2 * mean_slope_sq), rel=1e-6
    )
    assert figures.mean_thrust_n > 0.0


def test_mechanism_2_uses_theta5_and_any_whole_beats_give_the_same_figures():
    t, s = report_cycle(UndulatoryTail(UndulatoryGeometry()))
    parameters = SwimmingParameters(forward_speed_m_s=0.3, fin_span_m=0.1)
    on_theta5 = swimming_figures(t, s.tip_y, s.tip_y_dot, s.theta5, parameters)
    on_theta3 = swimming_figures(
        t, s.tip_y, s.tip_y_dot, s.theta5, parameters, beats=beats_of(t, s.theta3)
    )
    assert on_theta5.beat_frequency_hz == pytest.approx(4.0 / (2.0 * math.pi), rel=1e-9)
    for name in ("beat_frequency_hz", "tip_excursion_m", "mean_thrust_n", "strouhal_number"):
        assert getattr(on_theta3, name) == pytest.approx(getattr(on_theta5, name), rel=1e-5), name
    assert on_theta5.tip_excursion_m == pytest.approx(np.ptp(s.tip_y), rel=1e-6)


def test_live_buffer_matches_the_batch_figures_beat_by_beat():
    t, s = report_cycle(UndulatoryTail(UndulatoryGeometry()), revolutions=5.1)
    tracker, buffer = BeatTracker(), TipSampleBuffer()
    live, batch, sizes = [], [], []
    for k in range(t.size):
        buffer.add(float(t[k]), float(s.tip_y[k]), float(s.tip_y_dot[k]), float(s.theta5[k]))
        beat = tracker.add(float(t[k]), float(s.theta3[k]))
        if beat is not None:
            live.append(buffer.complete(beat))
            batch.append(tip_kinematics(t, s.tip_y, s.tip_y_dot, s.theta5, beats=[beat]))
            sizes.append(len(buffer))
    assert len(live) == 4
    for got, expected in zip(live, batch, strict=True):
        assert got == expected
    assert max(sizes) <= 2  # only the samples after the beat's end are kept


@pytest.mark.parametrize(("max_samples", "computed"), [(600, [False, False]), (1200, [True, True])])
def test_live_buffer_drops_a_beat_that_overflows(max_samples, computed):
    t = np.linspace(0.0, 2.5, 2501)  # 1000 samples a beat; beats 0.1-1.1 s and 1.1-2.1 s
    angle = 0.3 * np.sin(2 * math.pi * (t - 0.1))
    tracker, buffer = BeatTracker(), TipSampleBuffer(max_samples=max_samples)
    results = []
    for k in range(t.size):
        buffer.add(float(t[k]), float(angle[k]), 0.0, float(angle[k]))
        beat = tracker.add(float(t[k]), float(angle[k]))
        if beat is not None:
            results.append(buffer.complete(beat))
        assert len(buffer) <= max_samples
    assert [result is not None for result in results] == computed


def test_a_fresh_simulated_speed_is_used():
    assert choose_forward_speed(0.3, 0.52, 0.0, 2.0) == (0.52, SPEED_SOURCE_SIMULATED)
    assert choose_forward_speed(0.3, 0.52, 2.0, 2.0) == (0.52, SPEED_SOURCE_SIMULATED)
    assert choose_forward_speed(0.3, 25.0, 1.0, 2.0) == (25.0, SPEED_SOURCE_SIMULATED)


@pytest.mark.parametrize(
    ("simulated_m_s", "age_s"),
    [
        (0.52, 2.001),  # stale
        (0.52, math.inf),  # never received
        (math.nan, math.inf),  # never received
        (0.52, math.nan),
        (math.nan, 0.1),
        (math.inf, 0.1),
        (-math.inf, 0.1),
        (0.0, 0.1),  # at rest: St = f A / U is undefined
        (-0.2, 0.1),
    ],
)
def test_a_stale_missing_or_unusable_simulated_speed_falls_back_to_the_parameter(
    simulated_m_s, age_s
):
    assert choose_forward_speed(0.3, simulated_m_s, age_s, 2.0) == (0.3, SPEED_SOURCE_PARAMETER)
