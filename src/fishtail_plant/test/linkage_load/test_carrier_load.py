"""The carrier's torque: energy balance, Lagrange's equation, invariants and hand-derived cases.

The kinetic energy the checks use is built from the drawn joints by differences (conftest.py),
not from the module's reduced inertia; loads on the tail are checked through the engine's tip
and fin rates, which test_mechanisms.py checks against differences of the pose.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fishtail_kinematics.engine.blocks import BLOCK_SAMPLES
from fishtail_kinematics.engine.errors import InvalidInputError
from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail, UndulatoryTail
from fishtail_plant.errors import InvalidInertiaError
from fishtail_plant.linkage_load.carrier_load import (
    CarrierLoadModel,
    carrier_load,
)
from fishtail_plant.linkage_load.link_inertia import LinkInertia

TWO_PI = 2.0 * math.pi
PHASE_RAD = 0.4
TAILS = [
    OscillatoryTail(OscillatoryGeometry(phase_rad=PHASE_RAD)),
    UndulatoryTail(UndulatoryGeometry(phase_rad=PHASE_RAD)),
    OscillatoryTail(OscillatoryGeometry(phase_rad=PHASE_RAD)).with_pivot_shift(0.04),
    UndulatoryTail(UndulatoryGeometry(phase_rad=PHASE_RAD)).with_pivot_shift(-0.03),
]
IDS = ["oscillatory", "undulatory", "oscillatory-shifted", "undulatory-shifted"]
#: One revolution, evenly (the periodic trapezoid rule: means are exact for trigonometric
#: polynomials of degree below the sample count).
REVOLUTION = np.arange(720) * (TWO_PI / 720)
# A carrier that speeds up and slows down: phi(t) = 0.3 + 5 t + 3 sin 2t, in [0, 2] s.
# Time step of the differences: T(t) holds harmonics up to some 6 x 11 rad/s, so the five-point
# stencil's truncation, ~ (66 h)^4 / 30, is 1e-11 at 1e-4 s, while its rounding, ~ 1e-16 / h
# relative, is 1e-12.
TIME_STEP_S = 1e-4
TIMES = np.linspace(0.05, 1.95, 96)


def trajectory(t):
    """phi, phi_dot, phi_ddot."""
    return (
        0.3 + 5.0 * t + 3.0 * np.sin(2.0 * t),
        5.0 + 6.0 * np.cos(2.0 * t),
        -12.0 * np.sin(2.0 * t),
    )


def time_derivative(function, t, step=TIME_STEP_S):
    """Five-point central difference in time: truncation ~ step^4 f^(5)."""
    return (
        function(t - 2 * step) - 8 * function(t - step)
        + 8 * function(t + step) - function(t + 2 * step)
    ) / (12 * step)  # fmt: skip


def only(**values):
    """A LinkInertia with these values and every other one zero."""
    return dataclasses.replace(LinkInertia.massless(), **values)


@pytest.fixture(scope="module", params=TAILS, ids=IDS)
def tail(request):
    return request.param


def test_reduced_inertia_is_the_kinetic_energy_of_the_joints(tail, from_points):
    model = CarrierLoadModel(tail, LinkInertia())
    expected = from_points.reduced_inertia(tail, LinkInertia(), REVOLUTION)
    got = model.reduced_inertia(REVOLUTION).inertia_kg_m2
    np.testing.assert_allclose(got, expected, rtol=1e-10)
    np.testing.assert_allclose(
        model.kinetic_energy(REVOLUTION, 7.0), 0.5 * expected * 49.0, rtol=1e-10
    )


def test_power_balance_along_an_accelerating_carrier(tail):
    """Power: tau phi_dot + F . v_T + M omega_fin = dT/dt, dT/dt by differences in time."""
    model = CarrierLoadModel(tail, LinkInertia())
    phi, phi_dot, phi_ddot = trajectory(TIMES)
    force_x, force_y, moment = 0.7 * np.cos(3 * TIMES), -0.4 + 0.1 * TIMES, 0.05 * np.sin(TIMES)
    load = model.load(phi, phi_dot, phi_ddot, force_x, force_y, moment)
    state = tail.solve(phi, phi_dot)
    fin_rate = getattr(state, f"{tail.fin_angle_field()}_dot")
    load_power = force_x * state.tip_x_dot + force_y * state.tip_y_dot + moment * fin_rate

    def energy(t):
        angle, speed, _ = trajectory(t)
        return model.kinetic_energy(angle, speed)

    energy_rate = time_derivative(energy, TIMES)
    np.testing.assert_allclose(load.power_w, load.torque_n_m * phi_dot, rtol=1e-15)
    scale = np.abs(energy_rate).max() + np.abs(load_power).max()
    np.testing.assert_allclose(load.power_w + load_power, energy_rate, rtol=0, atol=1e-10 * scale)
    # The split adds up, and the inertial part alone balances dT/dt.
    np.testing.assert_allclose(
        load.inertial_torque_n_m + load.external_torque_n_m, load.torque_n_m, rtol=1e-15
    )
    np.testing.assert_allclose(
        load.inertial_torque_n_m * phi_dot, energy_rate, rtol=0, atol=1e-10 * scale
    )


def test_lagrange_equation_from_the_joints(tail, from_points):
    """Lagrange: tau = d/dt(dL/dphi_dot) - dL/dphi - Q_load, L = T(phi, phi_dot) of the joints."""
    inertia = LinkInertia()
    model = CarrierLoadModel(tail, inertia)
    times = TIMES[::6]
    phi, phi_dot, phi_ddot = trajectory(times)
    step = 1e-3

    def lagrangian(angle, speed):
        return from_points.kinetic_energy(tail, inertia, angle, speed)

    def momentum(t):  # dL/dphi_dot; L is quadratic in phi_dot, so the difference is exact
        angle, speed, _ = trajectory(t)
        return (lagrangian(angle, speed + 0.5) - lagrangian(angle, speed - 0.5)) / 1.0

    def slope(angle, speed):
        return (
            lagrangian(angle - 2 * step, speed) - 8 * lagrangian(angle - step, speed)
            + 8 * lagrangian(angle + step, speed) - lagrangian(angle + 2 * step, speed)
        ) / (12 * step)  # fmt: skip

    force_x, force_y = 0.3, -0.2
    state = tail.solve(phi, 1.0)
    generalised_load = force_x * state.tip_x_dot + force_y * state.tip_y_dot
    # T from the joints is itself a difference (~1e-13 relative): a longer step in time keeps
    # its noise, divided by the step, below the stencil's truncation.
    rate = time_derivative(momentum, times, step=2e-4)
    expected = rate - slope(phi, phi_dot) - generalised_load
    got = model.load(phi, phi_dot, phi_ddot, force_x, force_y).torque_n_m
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-7 * np.abs(expected).max())


@pytest.mark.parametrize("speed", [0.0, 1.0, 4.0, -16.0, 100.0])
def test_a_massless_tail_without_load_needs_no_torque(tail, speed):
    load = carrier_load(tail, LinkInertia.massless(), REVOLUTION, speed)
    for part in (load.torque_n_m, load.inertial_torque_n_m, load.external_torque_n_m):
        np.testing.assert_array_equal(part, 0.0)
    np.testing.assert_array_equal(load.reduced_inertia_kg_m2, 0.0)


def test_the_planet_and_the_carrier_by_hand(tail):
    """Rigid rotors: J = I + m d^2 whatever the angle, and tau = J phi_ddot."""
    radius = tail.geometry.ring_radius_m
    inertia = only(
        planet_mass_kg=0.07, planet_inertia_kg_m2=8e-5, carrier_mass_kg=0.003,
        carrier_inertia_kg_m2=6e-7,
    )  # fmt: skip
    expected = 8e-5 + 0.07 * (radius / 2) ** 2 + 6e-7 + 0.003 * (radius / 4) ** 2
    load = carrier_load(tail, inertia, REVOLUTION, 9.0, -2.5)
    np.testing.assert_allclose(load.reduced_inertia_kg_m2, expected, rtol=1e-14)
    np.testing.assert_allclose(load.torque_n_m, -2.5 * expected, rtol=1e-12)


def test_at_the_ends_of_the_stroke_the_tail_is_at_rest(tail):
    """OP = +-R: the Cardan point turns round, every link of the tail stops, J' = 0."""
    ends = np.array([-PHASE_RAD, math.pi - PHASE_RAD])
    rotors = only(planet_mass_kg=0.07)
    rotor_inertia = 0.07 * (tail.geometry.ring_radius_m / 2) ** 2
    load = carrier_load(tail, dataclasses.replace(LinkInertia(), planet_mass_kg=0.07), ends, 6.0)
    bare = carrier_load(tail, rotors, ends, 6.0)
    reduced = CarrierLoadModel(tail, LinkInertia()).reduced_inertia(ends)
    np.testing.assert_allclose(reduced.slope_kg_m2_per_rad, 0.0, atol=1e-15)
    np.testing.assert_allclose(load.torque_n_m, 0.0, atol=1e-15)
    np.testing.assert_allclose(bare.reduced_inertia_kg_m2, rotor_inertia, rtol=1e-14)


def test_a_tail_link_alone_by_hand():
    """Mechanism 1 with only ST's moment of inertia: J = I theta3'^2, tau = I theta3' theta3''."""
    tail = TAILS[0]
    moment = 2e-4
    phi = REVOLUTION
    rate = tail.solve(phi, 1.0).theta3_dot
    load = carrier_load(tail, only(tail_link_inertia_kg_m2=moment), phi, 1.0)
    np.testing.assert_allclose(load.reduced_inertia_kg_m2, moment * rate**2, rtol=1e-13)
    step = 1e-4  # theta3'' by a central difference of the engine's exact rate
    curvature = (
        tail.solve(phi + step, 1.0).theta3_dot - tail.solve(phi - step, 1.0).theta3_dot
    ) / (2 * step)
    np.testing.assert_allclose(
        load.torque_n_m, moment * rate * curvature, rtol=0, atol=1e-8 * moment
    )


def test_constant_speed_inertial_torque_is_conservative_and_scales_with_speed_squared(tail):
    model = CarrierLoadModel(tail, LinkInertia())
    slow = model.load(REVOLUTION, 4.0).inertial_torque_n_m
    fast = model.load(REVOLUTION, 12.0).inertial_torque_n_m
    peak = np.abs(slow).max()
    assert peak > 0.0
    # Conservative: no work over a revolution (the mean of a periodic derivative).
    assert abs(slow.mean()) < 1e-14 * peak
    np.testing.assert_allclose(fast, 9.0 * slow, rtol=1e-12, atol=1e-15 * peak)
    np.testing.assert_allclose(model.load(REVOLUTION, -4.0).inertial_torque_n_m, slow, rtol=1e-12)


def test_inertial_torque_period_and_symmetry(tail):
    """Period 2 pi, odd about the stroke end phi = -psi, and not of period pi.

    The pose depends on phi only through OP = R cos(phi + psi): phi -> -2 psi - phi is the
    same pose with every rate reversed, so J is even and J' odd about phi = -psi. phi + pi
    mirrors OP, which the linkage (drive on one side of the axis) does not mirror.
    """
    model = CarrierLoadModel(tail, LinkInertia())
    torque = model.load(REVOLUTION, 4.0).inertial_torque_n_m
    peak = np.abs(torque).max()
    np.testing.assert_allclose(
        model.load(REVOLUTION + TWO_PI, 4.0).inertial_torque_n_m, torque, atol=1e-13 * peak
    )
    mirrored = model.load(-2 * PHASE_RAD - REVOLUTION, 4.0).inertial_torque_n_m
    np.testing.assert_allclose(mirrored, -torque, atol=1e-13 * peak)
    half_turn = model.load(REVOLUTION + math.pi, 4.0).inertial_torque_n_m
    assert np.abs(half_turn - torque).max() > 0.05 * peak


def test_loads_on_the_tail_through_the_tip_and_fin_ratios(tail):
    """External torque = -(F . dT/dphi + M dtheta_fin/dphi), independent of speed and masses."""
    phi = REVOLUTION
    state = tail.solve(phi, 1.0)
    fin_rate = getattr(state, f"{tail.fin_angle_field()}_dot")
    load = carrier_load(tail, LinkInertia(), phi, 3.0, 0.0, 2.0, -1.0, 0.5)
    np.testing.assert_allclose(
        load.external_torque_n_m,
        -(2.0 * state.tip_x_dot - 1.0 * state.tip_y_dot + 0.5 * fin_rate),
        rtol=1e-13, atol=1e-16,
    )  # fmt: skip
    # A force along the tail link ST through the pivot does no work: mechanism 1's tip moves
    # perpendicular to ST.
    if tail.fin_joint is None:
        along = np.stack([np.cos(state.fin_angle), np.sin(state.fin_angle)])
        load = carrier_load(tail, LinkInertia.massless(), phi, 3.0, 0.0, *along)
        np.testing.assert_allclose(load.torque_n_m, 0.0, atol=1e-15)


def test_broadcasting_over_angles_and_loads(tail):
    model = CarrierLoadModel(tail, LinkInertia())
    angles = REVOLUTION[::60, None]
    forces = np.array([0.0, 1.0, -2.0])
    load = model.load(angles, 5.0, 1.0, forces)
    assert load.torque_n_m.shape == (12, 3)
    for part in load:
        assert part.shape == (12, 3)
    for column, force in enumerate(forces):
        single = model.load(angles[:, 0], 5.0, 1.0, force)
        np.testing.assert_allclose(load.torque_n_m[:, column], single.torque_n_m, rtol=1e-15)
    scalar = model.load(0.7, 5.0)
    assert scalar.torque_n_m.shape == ()
    # Blocks of angles give the numbers of one angle at a time (the engine's float path, equal
    # to rounding), across block boundaries.
    many = np.linspace(0.0, 50.0, 2 * BLOCK_SAMPLES + 3)
    picked = [0, BLOCK_SAMPLES - 1, BLOCK_SAMPLES, many.size - 1]
    blocks = model.reduced_inertia(many)
    for index in picked:
        single = model.reduced_inertia(many[index])
        assert single.inertia_kg_m2.shape == ()
        for part, alone in zip(blocks, single, strict=True):
            assert float(alone) == pytest.approx(part[index], rel=1e-12, abs=1e-15)
    # Inputs shaped like the angles (one pass over blocks) and inputs broadcast along another
    # axis (J once per angle, then broadcast) give the same numbers.
    speeds = 3.0 + np.sin(many)
    forces = np.cos(3.0 * many)
    together = model.load(many, speeds, 0.5, forces, 0.2, -0.1)
    moments = np.array([-0.1, -0.1])
    apart = model.load(many[:, None], speeds[:, None], 0.5, forces[:, None], 0.2, moments)
    for part, other in zip(together, apart, strict=True):
        assert other.shape == (many.size, 2)
        np.testing.assert_array_equal(part, other[:, 0])
        np.testing.assert_array_equal(part, other[:, 1])


@pytest.mark.parametrize(
    ("argument", "name"),
    [("motor_angle", "carrier angle"), ("motor_velocity", "carrier speed"),
     ("motor_acceleration", "carrier acceleration"), ("tip_force_x", "tip force x"),
     ("tip_force_y", "tip force y"), ("fin_moment", "fin moment")],
)  # fmt: skip
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_input_is_refused_naming_it(tail, argument, name, bad):
    values = {"motor_angle": np.array([0.0, 1.0, 2.0]), "motor_velocity": 4.0}
    values[argument] = np.array([0.0, bad, 1.0])
    with pytest.raises(InvalidInputError, match=f"1 non-finite {name} value.*flat index 1"):
        carrier_load(tail, LinkInertia(), **values)


@pytest.mark.parametrize("name", ["tail_link_mass_kg", "planet_inertia_kg_m2", "slider_mass_kg"])
@pytest.mark.parametrize("bad", [-1e-3, math.nan, math.inf])
def test_bad_masses_are_refused_naming_them(name, bad):
    with pytest.raises(InvalidInertiaError, match=f"{name} must be finite and >= 0, got"):
        LinkInertia(**{name: bad})
