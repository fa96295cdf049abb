"""Hand-derived forces, batches against single fish, refused parameters, the config, doctests."""

import doctest
import math
from pathlib import Path

import numpy as np
import pytest

import fishtail_plant.errors
import fishtail_plant.fish.figures
import fishtail_plant.fish.fish
import fishtail_plant.fish.integrator
import fishtail_plant.fish.model
import fishtail_plant.fish.spheroid
import fishtail_plant.fish.tail_drive
from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.errors import (
    BeatAlignmentError,
    FishParameterError,
    SwimInputError,
    SwimParameterError,
)
from fishtail_plant.fish.figures import beat_means
from fishtail_plant.fish.fish import FISH_PARAMETERS, FishParameters
from fishtail_plant.fish.integrator import simulate
from fishtail_plant.fish.model import SwimModel
from fishtail_plant.fish.tail_drive import (
    EngineTailDrive,
    SinusoidalTailDrive,
    constant_carrier_speed,
)
from fishtail_plant.values import FishConfigError, load_fish_parameters, read_fish_values

CONFIG = Path(__file__).resolve().parents[3] / "fishtail_bringup" / "config" / "fish.yaml"
#: Lighthill's trailing-edge force alone: the fish without the fin plate's recoil and drag.
LIGHTHILL_FISH = FishParameters(fin_chord_m=0.0, fin_normal_drag_coefficient=0.0)


def test_sinusoidal_fin_force_at_rest_by_hand():
    # Fish at rest, fin of length l at theta = alpha0 = 0.2 turning at theta_dot = alpha_a omega.
    # The tip moves along the fin's normal: v_T = (-Tx_dot, Ty_dot) = l theta_dot (sin, cos) = w n
    # with w = l theta_dot and u_t = 0, so F_T = ½ m w² t = ½ m w² (cos 0.2, -sin 0.2).
    length, theta, rate = 0.3, 0.2, 0.3 * 2.0 * math.pi
    fish = LIGHTHILL_FISH
    m = math.pi / 4.0 * 1000.0 * 0.1**2
    push = 0.5 * m * (length * rate) ** 2
    force_x, force_y = push * math.cos(theta), -push * math.sin(theta)
    tip_x, tip_y = -0.05 - length * math.cos(theta), length * math.sin(theta)
    moment = tip_x * force_y - tip_y * force_x
    assert (round(force_x, 6), round(force_y, 6), round(moment, 6)) == (
        1.230723, -0.24948, 0.012474,
    )
    model = SwimModel(fish, SinusoidalTailDrive(length, theta, 0.3, 2.0 * math.pi))
    flow, body, _ = model.forces(0.0, np.zeros((1, 6)))
    np.testing.assert_allclose([flow.force.x[0], flow.force.y[0], flow.force.z[0]],
                               [force_x, force_y, moment], rtol=1e-14)  # fmt: skip
    assert (body.x[0], body.y[0], body.z[0]) == (0.0, 0.0, 0.0)
    rates = model.derivatives(0.0, np.zeros((1, 6)))[0]
    np.testing.assert_allclose(
        rates[3:],
        [force_x / fish.surge_mass_kg, force_y / fish.sway_mass_kg,
         moment / fish.yaw_inertia_kg_m2],  # fmt: skip
        rtol=1e-14,
    )


def test_deflected_still_fin_is_a_rudder_that_turns_the_fish_left():
    # A fin held at theta > 0 on a fish moving forward: the force has a drag part and points to
    # the right behind C, so the moment about C is positive (left turn).
    model = SwimModel(FishParameters(), SinusoidalTailDrive(0.3, 0.2, 0.0, 1.0))
    state = np.array([[0.0, 0.0, 0.0, 0.3, 0.0, 0.0]])
    flow, _, _ = model.forces(0.0, state)
    assert flow.force.x[0] < 0.0 and flow.force.y[0] < 0.0 and flow.force.z[0] > 0.0


def test_straight_still_fin_makes_no_force():
    model = SwimModel(FishParameters(), SinusoidalTailDrive(0.3, 0.0, 0.0, 1.0))
    flow, _, _ = model.forces(0.0, np.array([[0.0, 0.0, 0.0, 0.4, 0.0, 0.0]]))
    assert (flow.force.x[0], flow.force.y[0], flow.force.z[0]) == (0.0, 0.0, 0.0)


def test_batch_equals_single_fish_runs():
    spans = np.array([0.08, 0.1, 0.12])
    drags = np.array([0.2, 0.3, 0.4])
    amplitudes = np.array([0.2, 0.3, 0.4])
    chords = np.array([0.0, 0.03, 0.05])

    def run(span, drag, amplitude, chord):
        fish = FishParameters(fin_span_m=span, drag_coefficient=drag, fin_chord_m=chord)
        drive = SinusoidalTailDrive(0.35, 0.1, amplitude, 2.0 * np.pi)
        count = np.size(span)
        return simulate(SwimModel(fish, drive), count, 1.0 / 24, 24 * 3).state

    batch = run(spans, drags, amplitudes, chords)
    for k in range(3):
        single = run(spans[k], drags[k], amplitudes[k], chords[k])
        np.testing.assert_allclose(batch[:, k], single[:, 0], rtol=1e-13, atol=1e-15)


def test_engine_batch_over_carrier_speeds_equals_single_runs():
    speeds = np.array([4.0, 8.0])
    tail = make_tail(UndulatoryGeometry())
    fish = FishParameters(fin_chord_m=0.04)

    def run(speed):
        drive = EngineTailDrive(tail, constant_carrier_speed(speed))
        return simulate(SwimModel(fish, drive), np.size(speed), 0.02, 60).state

    batch = run(speeds)
    for k, speed in enumerate(speeds):
        np.testing.assert_allclose(batch[:, k], run(np.array([speed]))[:, 0], rtol=1e-12,
                                   atol=1e-15)  # fmt: skip


def test_engine_tail_accelerations_match_differences_of_its_velocities():
    drive = EngineTailDrive(make_tail(OscillatoryGeometry()), constant_carrier_speed(6.0))
    times = np.linspace(0.05, 1.0, 7)
    step = 1e-5
    ahead, behind = drive.sample(times + step), drive.sample(times - step)
    acceleration = drive.acceleration(times)
    for field, rate in (("tip_x_ddot", "tip_x_dot"), ("tip_y_ddot", "tip_y_dot"),
                        ("fin_acceleration", "fin_rate")):  # fmt: skip
        difference = (getattr(ahead, rate) - getattr(behind, rate)) / (2 * step)
        np.testing.assert_allclose(getattr(acceleration, field), difference, atol=1e-5)


def test_recoil_is_minus_the_rate_of_the_fins_added_momentum():
    # Integrate a fish with a chord, then differentiate the world-frame momentum m c w_c n of the
    # fin's added mass along the trajectory: its negative rate must be the recoil the model used.
    chord = 0.06
    # The recoil alone: the plate's drag would be one more force in the balance below.
    fish = FishParameters(fin_chord_m=chord, fin_normal_drag_coefficient=0.0)
    model = SwimModel(fish, SinusoidalTailDrive(0.3, 0.1, 0.3, 2.0 * np.pi))
    step = 1e-3
    trajectory = simulate(model, 1, step, 400)
    state, time_s = trajectory.state[:, 0], trajectory.time_s
    tail = model.drive.sample(time_s)
    u, v, r, psi = state[:, 3], state[:, 4], state[:, 5], state[:, 2]
    sin_f, cos_f = np.sin(tail.fin_angle), np.cos(tail.fin_angle)
    mid_x = -0.05 - tail.tip_x + 0.5 * chord * cos_f
    mid_y = tail.tip_y - 0.5 * chord * sin_f
    velocity_x = u - r * mid_y - tail.tip_x_dot - 0.5 * chord * sin_f * tail.fin_rate
    velocity_y = v + r * mid_x + tail.tip_y_dot - 0.5 * chord * cos_f * tail.fin_rate
    normal = velocity_x * sin_f + velocity_y * cos_f
    mass = fish.fin_added_mass_per_length_kg_m * chord
    # n in the world frame: the body's (sin, cos) turned by psi.
    momentum_x = mass * normal * (sin_f * np.cos(psi) - cos_f * np.sin(psi))
    momentum_y = mass * normal * (sin_f * np.sin(psi) + cos_f * np.cos(psi))
    k = slice(100, 300)
    rate_x = np.gradient(momentum_x, step)[k]
    rate_y = np.gradient(momentum_y, step)[k]
    # The model's recoil: its accelerations times the masses minus every other force.
    rates = model.derivatives(time_s[k], state[k])
    flow, body, _ = model.forces(time_s[k], state[k])
    m1, m2 = fish.surge_mass_kg, fish.sway_mass_kg
    recoil_x = m1 * rates[:, 3] - m2 * v[k] * r[k] - flow.force.x - body.x
    recoil_y = m2 * rates[:, 4] + m1 * u[k] * r[k] - flow.force.y - body.y
    world_x = recoil_x * np.cos(psi[k]) - recoil_y * np.sin(psi[k])
    world_y = recoil_x * np.sin(psi[k]) + recoil_y * np.cos(psi[k])
    scale = np.abs(rate_x).max()
    np.testing.assert_allclose(world_x, -rate_x, atol=1e-4 * scale)
    np.testing.assert_allclose(world_y, -rate_y, atol=1e-4 * scale)


@pytest.mark.parametrize(
    ("values", "name"),
    [
        ({"body_mass_kg": 0.0}, "body_mass_kg"),
        ({"body_length_m": float("nan")}, "body_length_m"),
        ({"added_mass_sway_kg": -1.0}, "added_mass_sway_kg"),
        ({"yaw_damping_kg_m2": float("inf")}, "yaw_damping_kg_m2"),
        ({"fin_span_m": np.array([0.1, -0.1])}, "fin_span_m"),
        ({"body_yaw_inertia_kg_m2": 0.0}, "body_yaw_inertia_kg_m2"),
    ],
)
def test_bad_fish_parameters_are_refused_by_name(values, name):
    with pytest.raises(SwimParameterError) as caught:
        FishParameters.from_values(values)
    assert caught.value.name == name
    assert name in str(caught.value) and "outside" in str(caught.value)


def test_array_error_names_the_fish_and_unknown_names_are_refused():
    with pytest.raises(SwimParameterError, match=r"fin_span_m = -0.1 .*\(fish 1\)"):
        FishParameters(fin_span_m=np.array([0.1, -0.1]))
    with pytest.raises(FishParameterError, match="unknown fish parameter 'mass'"):
        FishParameters.from_values({"mass": 1.0})
    with pytest.raises(FishParameterError, match="must be a number"):
        FishParameters.from_values({"body_mass_kg": "heavy"})
    with pytest.raises(FishParameterError, match="do not broadcast"):
        FishParameters(fin_span_m=np.full(2, 0.1), drag_coefficient=np.full(3, 0.3))


def test_bad_tail_and_run_inputs_are_refused():
    with pytest.raises(SwimParameterError, match="amplitude_rad = -0.1"):
        SinusoidalTailDrive(0.3, 0.0, -0.1, 1.0)
    with pytest.raises(SwimParameterError, match=r"fin_length_m = 0.0 .*\(fish 1\)"):
        SinusoidalTailDrive(np.array([0.3, 0.0]), 0.0, 0.1, 1.0)
    with pytest.raises(SwimParameterError, match="carrier_speed_rad_s"):
        constant_carrier_speed(np.array([4.0, np.nan]))
    model = SwimModel(FishParameters(), SinusoidalTailDrive(0.3, 0.0, 0.2, 2 * np.pi))
    with pytest.raises(SwimInputError, match="step_s"):
        simulate(model, 1, 0.0, 10)
    with pytest.raises(SwimInputError, match="initial_state"):
        simulate(model, 1, 0.1, 10, initial_state=np.zeros((2, 6)))
    trajectory = simulate(model, 1, 0.1, 25)
    with pytest.raises(BeatAlignmentError, match="does not divide"):
        beat_means(trajectory, 0.75, beats=1)
    with pytest.raises(BeatAlignmentError, match="3 whole beats asked"):
        beat_means(trajectory, 1.0, beats=3)


def test_config_file_holds_every_default_and_loads():
    values = read_fish_values(CONFIG)
    assert list(values) == [spec.name for spec in FISH_PARAMETERS]
    for spec in FISH_PARAMETERS:
        assert values[spec.name] == pytest.approx(spec.default, rel=1e-15), spec.name
    assert load_fish_parameters(CONFIG) == FishParameters()


def test_config_errors_are_one_line_and_named(tmp_path):
    bad = tmp_path / "fish.yaml"
    bad.write_text("/**:\n  ros__parameters:\n    drag_coefficient: -2.0\n")
    with pytest.raises(FishConfigError) as caught:
        load_fish_parameters(bad)
    assert "\n" not in str(caught.value)
    assert str(caught.value).endswith("drag_coefficient = -2.0 is outside [0.0, 100.0]")
    bad.write_text("/**:\n  ros__parameters:\n    tail_length: 0.2\n")
    with pytest.raises(FishConfigError, match="unknown fish parameter 'tail_length'"):
        load_fish_parameters(bad)
    bad.write_text("drag_coefficient: 0.3\n")
    with pytest.raises(FishConfigError, match="ros__parameters"):
        load_fish_parameters(bad)
    with pytest.raises(FishConfigError, match="cannot read"):
        load_fish_parameters(tmp_path / "missing.yaml")


@pytest.mark.parametrize(
    "module",
    [
        fishtail_plant.errors,
        fishtail_plant.fish.figures,
        fishtail_plant.fish.fish,
        fishtail_plant.fish.integrator,
        fishtail_plant.fish.model,
        fishtail_plant.fish.spheroid,
        fishtail_plant.fish.tail_drive,
    ],
)
def test_doctests(module):
    result = doctest.testmod(module)
    assert result.attempted > 0 and result.failed == 0
