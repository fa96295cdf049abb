"""Fossen's damping terms: their forms, the energy they take, what they do to the scaling laws."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.fish.figures import steady_surge_speed
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.integrator import rk4_step
from fishtail_plant.fish.model import (
    SURGE,
    SWAY,
    YAW_RATE,
    SwimModel,
    body_force,
    fin_drag,
    fin_recoil,
)
from fishtail_plant.fish.tail_drive import (
    EngineTailDrive,
    SinusoidalTailDrive,
    constant_carrier_speed,
)

BARE = FishParameters(drag_coefficient=0.0, lift_coefficient_per_rad=0.0, yaw_damping_kg_m2=0.0)
#: The fish as it was before the damping terms and the fin plate: the default without the plate.
LIGHTHILL_FISH = FishParameters(fin_chord_m=0.0, fin_normal_drag_coefficient=0.0)


def test_each_damping_term_by_hand():
    fish = dataclasses.replace(
        BARE, surge_linear_damping_kg_s=2.0, sway_linear_damping_kg_s=3.0,
        sway_quadratic_damping_kg_m=5.0, yaw_linear_damping_kg_m2_s=0.7, yaw_damping_kg_m2=0.2,
    )  # fmt: skip
    u, v, r = np.array([0.3]), np.array([-0.1]), np.array([-2.0])
    force = body_force(fish, u, v, r)
    np.testing.assert_allclose(force.x, -2.0 * 0.3, rtol=1e-15)
    np.testing.assert_allclose(force.y, -3.0 * -0.1 - 5.0 * 0.1 * -0.1, rtol=1e-15)
    np.testing.assert_allclose(force.z, -0.7 * -2.0 - 0.2 * 2.0 * -2.0, rtol=1e-15)


def test_zero_new_terms_give_todays_figures():
    """The balance and the hull force as they were before the new terms.

    The cycle-average balance of the report's tails at 4 rad/s without the fin plate as
    docs/swimming-dynamics.md states it (check 5, c = 0), and the hull force by its old formula,
    to the last bit.
    """
    documented_speeds = ((OscillatoryGeometry(), 0.173892), (UndulatoryGeometry(), 0.378148))
    for geometry, documented in documented_speeds:
        drive = EngineTailDrive(make_tail(geometry), constant_carrier_speed(4.0))
        speed = steady_surge_speed(drive, LIGHTHILL_FISH, 2 * math.pi / 4.0)[0]
        assert round(float(speed), 6) == documented
    fish = FishParameters()
    u, v, r = np.array([0.3, -0.2]), np.array([0.05, 0.1]), np.array([0.4, -1.0])
    speed = np.hypot(u, v)
    drag, lift = fish.drag_factor_kg_m * speed, fish.lift_factor_kg_m * np.arctan2(v, u) * speed
    lift = lift * (u > 0)
    force = body_force(fish, u, v, r)
    np.testing.assert_array_equal(force.x, -drag * u + lift * v)
    np.testing.assert_array_equal(force.y, -drag * v - lift * u)
    np.testing.assert_array_equal(force.z, -fish.yaw_damping_kg_m2 * r * np.abs(r))


def _energy_balance(model, period, steps_per_beat, beats):
    """Kinetic energy of the body against the work of every force on it (coupling does none)."""
    fish = model.fish

    def with_work(time_s, state):
        body = state[:, :6]
        rates = model.derivatives(time_s, body)
        flow, hull, tail = model.forces(time_s, body)
        u, v, r = body[:, SURGE], body[:, SWAY], body[:, YAW_RATE]
        total = [f + h for f, h in zip(flow.force, hull, strict=True)]
        if model.has_fin_drag:
            total = [t + p for t, p in zip(total, fin_drag(fish, tail, u, v, r).force, strict=True)]
        if model.has_recoil:
            recoil = fin_recoil(fish, tail, model.drive.acceleration(time_s), u, v, r)
            along = sum(g * a for g, a in zip(recoil.direction, rates[:, 3:6].T, strict=True))
            inertial = [-recoil.added_mass_kg * along * g for g in recoil.direction]
            total = [t + a + b for t, a, b in zip(total, recoil.rest, inertial, strict=True)]
        power = total[0] * u + total[1] * v + total[2] * r
        return np.column_stack([rates, power])

    state = np.zeros((1, 7))
    step = period / steps_per_beat
    for index in range(steps_per_beat * beats):
        state = rk4_step(with_work, index * step, state, step)
    u, v, r = state[0, SURGE], state[0, SWAY], state[0, YAW_RATE]
    energy = 0.5 * (fish.surge_mass_kg * u**2 + fish.sway_mass_kg * v**2
                    + fish.yaw_inertia_kg_m2 * r**2)  # fmt: skip
    return state[0, 6], energy


@pytest.mark.parametrize("chord", [0.0, 0.06])
def test_energy_closes_with_every_dissipative_term(chord):
    fish = FishParameters(
        surge_linear_damping_kg_s=1.5, sway_linear_damping_kg_s=2.0,
        sway_quadratic_damping_kg_m=3.0, yaw_linear_damping_kg_m2_s=0.05,
        fin_chord_m=chord, fin_normal_drag_coefficient=1.2 if chord else 0.0,
    )  # fmt: skip
    model = SwimModel(fish, SinusoidalTailDrive(0.35, 0.15, 0.3, 2.0 * np.pi))
    residuals = []
    for steps_per_beat in (24, 48):
        work, energy = _energy_balance(model, 1.0, steps_per_beat, 3)
        residuals.append(abs(work - energy) / abs(energy))
    assert residuals[1] < 2e-5
    assert residuals[0] / residuals[1] > 10.0  # fourth order


def test_the_damping_dissipates():
    """Each term's power on the body is -X_u u² and the like: never positive."""
    fish = dataclasses.replace(
        BARE, surge_linear_damping_kg_s=1.0, sway_linear_damping_kg_s=1.0,
        sway_quadratic_damping_kg_m=1.0, yaw_linear_damping_kg_m2_s=1.0,
    )  # fmt: skip
    rng = np.random.default_rng(3)
    u, v, r = (rng.uniform(-1, 1, 500) for _ in range(3))
    force = body_force(fish, u, v, r)
    assert np.all(force.x * u + force.y * v + force.z * r <= 0.0)


def test_with_linear_damping_speed_is_no_longer_proportional_to_frequency():
    """Check 1's time scaling holds with the linear terms at 0 and fails with them."""
    tail = make_tail(OscillatoryGeometry())
    speeds = np.array([4.0, 8.0])
    periods = 2 * math.pi / speeds
    ratios = {}
    for linear in (0.0, 2.0):
        fish = FishParameters(surge_linear_damping_kg_s=linear)
        drive = EngineTailDrive(tail, constant_carrier_speed(speeds))
        ratios[linear] = steady_surge_speed(drive, fish, periods) * periods
    assert abs(ratios[0.0][1] / ratios[0.0][0] - 1.0) < 1e-12
    assert ratios[2.0][1] / ratios[2.0][0] > 1.05  # faster beats outrun the linear drag
