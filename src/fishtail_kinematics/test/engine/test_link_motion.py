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
from fishtail_kinematics.engine.link_inertia import LINKS
from fishtail_kinematics.engine.mechanisms import OscillatoryTail, UndulatoryTail

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
]
IDS = ["report-1", "other-1", "non-monotone-1", "report-2", "other-2"]
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
        for got, want, tolerance in (
            (body.velocity_x, ratios.velocity[:, 0], VELOCITY_TOLERANCE),
            (body.velocity_y, ratios.velocity[:, 1], VELOCITY_TOLERANCE),
            (body.angular_velocity, ratios.rate, VELOCITY_TOLERANCE),
            (body.acceleration_x, ratios.acceleration[:, 0], ACCELERATION_TOLERANCE * scale),
            (body.acceleration_y, ratios.acceleration[:, 1], ACCELERATION_TOLERANCE * scale),
            (body.angular_acceleration, ratios.rate_derivative, ACCELERATION_TOLERANCE * scale),
        ):
            np.testing.assert_allclose(
                np.broadcast_to(got, CYCLE.shape), want, rtol=0, atol=tolerance, err_msg=body.link
            )


def test_speed_scales_velocities_and_squares_into_accelerations(tail):
    unit = tail.link_motion(tail.solve(CYCLE, 1.0))
    fast = tail.link_motion(tail.solve(CYCLE, -3.0))
    for slow_body, fast_body in zip(unit, fast, strict=True):
        for field in ("velocity_x", "velocity_y", "angular_velocity"):
            np.testing.assert_allclose(
                getattr(fast_body, field), -3.0 * np.asarray(getattr(slow_body, field)),
                rtol=1e-12, atol=1e-15,
            )  # fmt: skip
        for field in ("acceleration_x", "acceleration_y", "angular_acceleration"):
            np.testing.assert_allclose(
                getattr(fast_body, field), 9.0 * np.asarray(getattr(slow_body, field)),
                rtol=1e-12, atol=1e-14,
            )  # fmt: skip


def test_the_cardan_couple_by_hand():
    """Carrier middle at R/4 and planet centre at R/2 from O: uniform circular motion."""
    tail = OscillatoryTail(OscillatoryGeometry(phase_rad=0.4))
    radius = tail.geometry.ring_radius_m
    carrier, planet, *_ = tail.link_motion(tail.solve(CYCLE, 2.0))
    for body, distance, spin in ((carrier, radius / 4, 2.0), (planet, radius / 2, -2.0)):
        speed = np.hypot(body.velocity_x, body.velocity_y)
        np.testing.assert_allclose(speed, distance * 2.0, rtol=1e-14)
        np.testing.assert_allclose(
            np.hypot(body.acceleration_x, body.acceleration_y), distance * 4.0, rtol=1e-14
        )
        # The acceleration points at O: perpendicular to the velocity.
        np.testing.assert_allclose(
            body.velocity_x * body.acceleration_x + body.velocity_y * body.acceleration_y,
            0.0, atol=1e-16,
        )  # fmt: skip
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
