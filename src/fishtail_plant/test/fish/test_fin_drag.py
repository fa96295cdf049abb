"""The fin plate's resistive force: its integrals, sign, power, and its place in the balance."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.fish import formulas
from fishtail_plant.fish.figures import (
    cycle_mean_tail_force,
    fin_drag_tail_power,
    held_fish,
    steady_surge_speed,
)
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.model import fin_drag
from fishtail_plant.fish.tail_drive import (
    EngineTailDrive,
    SinusoidalTailDrive,
    TailSample,
    constant_carrier_speed,
)

PLATE = FishParameters(fin_chord_m=0.06, fin_normal_drag_coefficient=1.2)
RNG = np.random.default_rng(7)


def random_states(count):
    """Tails and body velocities spread so that w changes sign along many of the plates."""
    sample = TailSample(
        RNG.uniform(0.1, 0.3, count), RNG.uniform(-0.1, 0.1, count),
        RNG.uniform(-0.5, 0.5, count), RNG.uniform(-0.5, 0.5, count),
        RNG.uniform(-1.0, 1.0, count), RNG.uniform(-8.0, 8.0, count),
    )  # fmt: skip
    u, v = RNG.uniform(-0.3, 0.5, count), RNG.uniform(-0.2, 0.2, count)
    return sample, u, v, RNG.uniform(-2.0, 2.0, count)


def plate_by_quadrature(fish, sample, u, v, r, points=20_001):
    """Force, moment about T and dissipation from w(s) sampled along the plate (midpoint rule)."""
    chord = fish.fin_chord_m
    s = (np.arange(points) + 0.5) / points * chord
    angle = sample.fin_angle[:, None]
    x = -fish.tail_origin_offset_m - sample.tip_x[:, None] + s * np.cos(angle)
    y = sample.tip_y[:, None] - s * np.sin(angle)
    # The plate point's velocity through the water, straight from its motion in the body.
    x_dot = -sample.tip_x_dot[:, None] - s * np.sin(angle) * sample.fin_rate[:, None]
    y_dot = sample.tip_y_dot[:, None] - s * np.cos(angle) * sample.fin_rate[:, None]
    velocity_x = u[:, None] - r[:, None] * y + x_dot
    velocity_y = v[:, None] + r[:, None] * x + y_dot
    w = velocity_x * np.sin(angle) + velocity_y * np.cos(angle)
    k = fish.fin_drag_factor_kg_m2
    density = -k * np.abs(w) * w * chord / points
    normal = density.sum(axis=1)
    return normal, (s * density).sum(axis=1), (k * np.abs(w) ** 3 * chord / points).sum(axis=1)


def test_the_closed_form_integrals_match_quadrature_along_the_plate():
    sample, u, v, r = random_states(200)
    plate = fin_drag(PLATE, sample, u, v, r)
    normal, about_tip, _ = plate_by_quadrature(PLATE, sample, u, v, r)
    n = np.sin(sample.fin_angle), np.cos(sample.fin_angle)
    np.testing.assert_allclose(plate.force.x, normal * n[0], rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(plate.force.y, normal * n[1], rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(plate.moment_about_tip, about_tip, rtol=1e-6, atol=1e-12)
    # The moment about C is the resultant's at T plus the moment about T.
    tip_x = -PLATE.tail_origin_offset_m - sample.tip_x
    expected = tip_x * plate.force.y - sample.tip_y * plate.force.x + plate.moment_about_tip
    np.testing.assert_allclose(plate.force.z, expected, rtol=1e-12, atol=1e-15)


def test_the_force_opposes_the_plates_motion_and_its_power_is_the_dissipation():
    sample, u, v, r = random_states(200)
    plate = fin_drag(PLATE, sample, u, v, r)
    _, _, dissipation = plate_by_quadrature(PLATE, sample, u, v, r)
    # Power on the plate moving through the water: F . v_T + M_T (r - theta_dot).
    flow = formulas.tip_force(
        1.0, PLATE.tail_origin_offset_m, sample.tip_x, sample.tip_y, sample.tip_x_dot,
        sample.tip_y_dot, np.cos(sample.fin_angle), np.sin(sample.fin_angle), u, v, r,
    )  # fmt: skip
    tangential, normal = flow[3], flow[4]
    angle = sample.fin_angle
    tip_velocity = (
        tangential * np.cos(angle) + normal * np.sin(angle),
        -tangential * np.sin(angle) + normal * np.cos(angle),
    )
    power = (
        plate.force.x * tip_velocity[0]
        + plate.force.y * tip_velocity[1]
        + plate.moment_about_tip * (r - sample.fin_rate)
    )
    assert np.all(power <= 1e-15)
    np.testing.assert_allclose(-power, dissipation, rtol=1e-6, atol=1e-12)
    # Where w keeps its sign over the plate, the force is against it.
    end = normal + (r - sample.fin_rate) * PLATE.fin_chord_m
    one_sign = normal * end > 0.0
    assert one_sign.sum() > 20
    along_n = plate.force.x * np.sin(angle) + plate.force.y * np.cos(angle)
    assert np.all(np.sign(along_n[one_sign]) == -np.sign(normal[one_sign]))


@pytest.mark.parametrize(
    "fish",
    [FishParameters(fin_chord_m=0.0, fin_normal_drag_coefficient=1.2),
     FishParameters(fin_chord_m=0.06, fin_normal_drag_coefficient=0.0)],
    ids=["no chord", "no C_n"],
)  # fmt: skip
def test_no_chord_or_no_coefficient_gives_exact_zeros(fish):
    sample, u, v, r = random_states(50)
    plate = fin_drag(fish, sample, u, v, r)
    for part in (*plate.force, plate.moment_about_tip):
        assert np.all(part == 0.0)
    assert not fish.has_fin_drag


def test_held_at_rest_the_oscillating_tail_needs_exactly_the_plates_dissipation():
    """Mechanism 1 held at rest: Lighthill's force runs through the pivot, the plate's does not."""
    tail = make_tail(OscillatoryGeometry())
    speed = 4.0
    period = 2.0 * math.pi / speed
    drive = EngineTailDrive(tail, constant_carrier_speed(speed))
    without = held_fish(drive, dataclasses.replace(PLATE, fin_normal_drag_coefficient=0.0), period)
    assert abs(float(without.tail_power_w[0])) < 1e-15
    held = held_fish(drive, PLATE, period, samples=512)
    times = np.arange(512)[:, None] / 512 * period
    sample = drive.sample(times)
    zero = np.zeros_like(sample.tip_x)
    _, _, dissipation = plate_by_quadrature(
        PLATE, TailSample(*(np.ravel(part) for part in sample)), *(zero.ravel(),) * 3
    )
    assert float(held.tail_power_w[0]) > 0.0
    np.testing.assert_allclose(held.tail_power_w, held.fin_drag_power_w, rtol=1e-12)
    np.testing.assert_allclose(held.fin_drag_power_w[0], dissipation.mean(), rtol=1e-6)


@pytest.mark.parametrize("drive_kind", ["oscillatory", "undulatory", "sinusoid"])
def test_the_balance_with_a_plate_closes_and_meets_the_plate_free_balance_as_c_n_vanishes(
    drive_kind,
):
    if drive_kind == "sinusoid":
        drive, period = SinusoidalTailDrive(0.2, 0.0, 0.35, 2 * math.pi), 1.0
    else:
        geometry = OscillatoryGeometry() if drive_kind == "oscillatory" else UndulatoryGeometry()
        drive = EngineTailDrive(make_tail(geometry), constant_carrier_speed(4.0))
        period = 2.0 * math.pi / 4.0
    fish = dataclasses.replace(PLATE, surge_linear_damping_kg_s=0.5)
    speed = steady_surge_speed(drive, fish, period)
    thrust = cycle_mean_tail_force(drive, fish, speed, period)
    drag = fish.drag_factor_kg_m * speed**2 + fish.surge_linear_damping_kg_s * speed
    np.testing.assert_allclose(thrust, drag, rtol=1e-10)
    free = dataclasses.replace(fish, fin_normal_drag_coefficient=0.0)
    tiny = dataclasses.replace(fish, fin_normal_drag_coefficient=1e-12)
    np.testing.assert_allclose(
        steady_surge_speed(drive, tiny, period), steady_surge_speed(drive, free, period), rtol=1e-9
    )
    # The plate's drag costs speed.
    assert speed[0] < steady_surge_speed(drive, free, period)[0]


def test_the_tail_works_against_the_plate_held_at_rest_by_the_power_formula():
    """fin_drag_tail_power with the body at rest is the plate's whole dissipation."""
    sample, _, _, _ = random_states(100)
    zero = np.zeros(100)
    plate = fin_drag(PLATE, sample, zero, zero, zero)
    _, _, dissipation = plate_by_quadrature(PLATE, sample, zero, zero, zero)
    np.testing.assert_allclose(fin_drag_tail_power(plate, sample), dissipation, rtol=1e-6)
