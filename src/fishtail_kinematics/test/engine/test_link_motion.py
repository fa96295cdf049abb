"""Second-order kinematics of the linkages against differences of the drawn joints.

The velocity ratios and their derivatives of every body (``Tail.link_motion``) agree with
fourth-order central differences of the joints' positions and directions (``Tail.link_points``,
see conftest.py), for both mechanisms and geometries other than the report's.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.link_motion import PlaneMotion
from fishtail_kinematics.engine.mechanisms import OscillatoryTail, UndulatoryTail
from fishtail_plant.linkage_load.link_inertia import LINKS

CYCLE = np.linspace(0.0, 2.0 * math.pi, 361)
OTHER_OSCILLATORY = OscillatoryGeometry(
    ring_radius_m=0.08, crank_link_m=0.12, rocker_link_m=0.25, tail_link_m=0.2,
    pivot_offset_m=0.22, phase_rad=0.7,
)  # fmt: skip
TAILS = [
    OscillatoryTail(OscillatoryGeometry()),
    OscillatoryTail(OTHER_OSCILLATORY),
    # theta2 not monotone over the stroke: a stationary point inside it.
    OscillatoryTail(
        OscillatoryGeometry(
            ring_radius_m=0.1, crank_link_m=0.15, rocker_link_m=0.1, pivot_offset_m=0.2
        )
    ),
    UndulatoryTail(UndulatoryGeometry()),
    UndulatoryTail(UndulatoryGeometry(pin_offset_m=0.05, phase_rad=-1.1, fin_link_m=0.25)),
    # S shifted: the tail link keeps its mounting, so its angle is not theta3.
    OscillatoryTail(OTHER_OSCILLATORY).with_pivot_shift(0.03),
    UndulatoryTail(UndulatoryGeometry(phase_rad=0.3)).with_pivot_shift(-0.035),
]
IDS = ["report-1", "other-1", "non-monotone-1", "report-2", "other-2", "shifted-1", "shifted-2"]
# Differences of positions: first derivatives to ~1e-13 m/rad, second ones to ~1e-10 m/rad^2.
VELOCITY_TOLERANCE = 1e-11
ACCELERATION_TOLERANCE = 1e-8


@pytest.fixture(scope="module", params=TAILS, ids=IDS)
def tail(request):
    return request.param


def test_the_bodies_are_the_tails_links(tail):
    bodies = tail.link_motion(tail.solve(CYCLE, 1.0))
    assert tuple(body.link for body in bodies) == tail.links
    assert set(tail.links) <= set(LINKS)


def test_velocities_and_accelerations_match_differences_of_the_joints(tail, from_points):
    bodies = tail.link_motion(tail.solve(CYCLE, 1.0))
    expected = from_points.ratios(tail, CYCLE)
    for body in bodies:
        ratios = expected[body.link]
        scale = max(1.0, float(np.abs(ratios.acceleration).max()))
        pairs = [
            (body.angular_velocity, ratios.rate, VELOCITY_TOLERANCE),
            (body.angular_acceleration, ratios.rate_derivative, ACCELERATION_TOLERANCE * scale),
        ]
        if isinstance(body, PlaneMotion):
            pairs += [
                (body.velocity_x, ratios.velocity[:, 0], VELOCITY_TOLERANCE),
                (body.velocity_y, ratios.velocity[:, 1], VELOCITY_TOLERANCE),
                (body.acceleration_x, ratios.acceleration[:, 0], ACCELERATION_TOLERANCE * scale),
                (body.acceleration_y, ratios.acceleration[:, 1], ACCELERATION_TOLERANCE * scale),
            ]
        else:
            # The centre of mass circles a point at rest at the body's own angular speed.
            speed = np.hypot(*ratios.velocity.T)
            power = np.sum(ratios.velocity * ratios.acceleration, axis=-1)
            radius = body.radius_m
            pairs += [
                (radius * np.abs(body.angular_velocity), speed, VELOCITY_TOLERANCE),
                (
                    radius**2 * body.angular_velocity * body.angular_acceleration,
                    power,
                    ACCELERATION_TOLERANCE * scale,
                ),
            ]
        for got, want, tolerance in pairs:
            np.testing.assert_allclose(
                np.broadcast_to(got, CYCLE.shape), want, rtol=0, atol=tolerance, err_msg=body.link
            )


def test_reduced_inertia_terms_are_the_kinetic_energy_and_its_change(tail, from_points):
    """Each body's m |v|^2 + I w^2 and 2 (m v.a + I w alpha), from differences of the joints."""
    bodies = tail.link_motion(tail.solve(CYCLE, 1.0))
    expected = from_points.ratios(tail, CYCLE)
    mass, moment = 0.3, 2e-3
    for body in bodies:
        ratios = expected[body.link]
        energy, change = body.reduced_inertia_terms(mass, moment)
        np.testing.assert_allclose(
            energy,
            mass * np.sum(ratios.velocity**2, axis=-1) + moment * ratios.rate**2,
            rtol=0, atol=1e-12, err_msg=body.link,
        )  # fmt: skip
        np.testing.assert_allclose(
            change,
            2 * mass * np.sum(ratios.velocity * ratios.acceleration, axis=-1)
            + 2 * moment * ratios.rate * ratios.rate_derivative,
            rtol=0, atol=1e-9, err_msg=body.link,
        )  # fmt: skip


def test_speed_scales_velocities_and_squares_into_accelerations(tail):
    unit = tail.link_motion(tail.solve(CYCLE, 1.0))
    fast = tail.link_motion(tail.solve(CYCLE, -3.0))
    for slow_body, fast_body in zip(unit, fast, strict=True):
        assert type(fast_body) is type(slow_body)
        for field in ("velocity_x", "velocity_y", "angular_velocity"):
            if hasattr(slow_body, field):
                np.testing.assert_allclose(
                    getattr(fast_body, field), -3.0 * np.asarray(getattr(slow_body, field)),
                    rtol=1e-12, atol=1e-15,
                )  # fmt: skip
        for field in ("acceleration_x", "acceleration_y", "angular_acceleration"):
            if hasattr(slow_body, field):
                np.testing.assert_allclose(
                    getattr(fast_body, field), 9.0 * np.asarray(getattr(slow_body, field)),
                    rtol=1e-12, atol=1e-14,
                )  # fmt: skip


def test_the_cardan_couple_by_hand():
    """Carrier middle at R/4 and planet centre at R/2 from O, turning at +-phi_dot."""
    tail = OscillatoryTail(OscillatoryGeometry(phase_rad=0.4))
    radius = tail.geometry.ring_radius_m
    carrier, planet, *_ = tail.link_motion(tail.solve(CYCLE, 2.0))
    for body, distance, spin in ((carrier, radius / 4, 2.0), (planet, radius / 2, -2.0)):
        assert body.radius_m == distance
        np.testing.assert_array_equal(body.angular_velocity, spin)
        np.testing.assert_array_equal(body.angular_acceleration, 0.0)


def test_floats_take_the_scalar_path():
    tail = UndulatoryTail(UndulatoryGeometry())
    bodies = tail.link_motion(tail.solve(0.4, 1.0))
    arrays = tail.link_motion(tail.solve(np.array([0.4]), 1.0))
    for body, array_body in zip(bodies, arrays, strict=True):
        for value, array_value in zip(body[1:], array_body[1:], strict=True):
            assert np.ndim(value) == 0
            assert float(value) == pytest.approx(float(np.ravel(array_value)[0]), abs=1e-13)
