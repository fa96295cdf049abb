"""The fish's tf frames (fishtail_swim.frames): the yaw quaternion, the body and the tail frame."""

import math

import numpy as np
import pytest

from fishtail_common.interface import BODY_FRAME, ODOM_FRAME, TAIL_FRAME
from fishtail_swim.frames import (
    TAIL_IN_BODY_ROTATION,
    FrameTransform,
    body_in_odom,
    tail_in_body,
    yaw_quaternion,
)

TAIL_ORIGIN_OFFSET_M = 0.05
ANGLES = [0.0, 0.3, -1.2, math.pi / 2, math.pi, 2.5 * math.pi]


def rotation_matrix(q):
    """The rotation matrix of a unit quaternion (x, y, z, w): the textbook formula."""
    x, y, z, w = q
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


@pytest.mark.parametrize("psi", ANGLES)
def test_yaw_quaternion_is_a_turn_about_z(psi):
    q = yaw_quaternion(psi)
    assert q == pytest.approx((0.0, 0.0, math.sin(psi / 2), math.cos(psi / 2)), abs=1e-15)
    assert math.fsum(c * c for c in q) == pytest.approx(1.0)
    expected = [[math.cos(psi), -math.sin(psi), 0], [math.sin(psi), math.cos(psi), 0], [0, 0, 1]]
    np.testing.assert_allclose(rotation_matrix(q), expected, atol=1e-15)


@pytest.mark.parametrize("psi", ANGLES)
def test_body_in_odom_puts_the_centre_of_mass_and_heading(psi):
    transform = body_in_odom(1.5, -0.25, psi)
    assert (transform.parent, transform.child) == (ODOM_FRAME, BODY_FRAME)
    assert transform.translation == (1.5, -0.25, 0.0)
    assert transform.rotation == yaw_quaternion(psi)
    # The body's x axis (forward) points along the heading, its z stays up.
    nose = transform.apply((1.0, 0.0, 0.0))
    assert nose == pytest.approx((1.5 + math.cos(psi), -0.25 + math.sin(psi), 0.0), abs=1e-12)
    assert transform.apply((0.0, 0.0, 1.0)) == pytest.approx((1.5, -0.25, 1.0), abs=1e-12)


def test_tail_frame_is_the_body_turned_half_a_turn_about_y_at_o():
    transform = tail_in_body(TAIL_ORIGIN_OFFSET_M)
    assert (transform.parent, transform.child) == (BODY_FRAME, TAIL_FRAME)
    assert TAIL_IN_BODY_ROTATION == (0.0, 1.0, 0.0, 0.0)
    assert transform.rotation == TAIL_IN_BODY_ROTATION
    # O, the tail frame's origin, on the body axis behind the centre of mass.
    assert transform.translation == (-TAIL_ORIGIN_OFFSET_M, 0.0, 0.0)
    assert transform.apply((0.0, 0.0, 0.0)) == (-TAIL_ORIGIN_OFFSET_M, 0.0, 0.0)
    # Tail x back (body -x), y left (body y), z down (body -z).
    np.testing.assert_array_equal(rotation_matrix(TAIL_IN_BODY_ROTATION), np.diag([-1, 1, -1]))
    origin = np.array(transform.translation)
    axes = {(1, 0, 0): (-1, 0, 0), (0, 1, 0): (0, 1, 0), (0, 0, 1): (0, 0, -1)}
    for tail_axis, body_axis in axes.items():
        assert np.array(transform.apply(tail_axis)) - origin == pytest.approx(body_axis)


@pytest.mark.parametrize("point", [(0.1, 0.02), (0.35, -0.08), (-0.01, 0.0)])
def test_a_tail_point_lands_where_the_dynamics_put_it(point):
    """(x_t, y_t) in the tail frame is (-l_O - x_t, y_t) in the body (docs/swimming-dynamics.md)."""
    x_t, y_t = point
    assert tail_in_body(TAIL_ORIGIN_OFFSET_M).apply((x_t, y_t, 0.0)) == pytest.approx(
        (-TAIL_ORIGIN_OFFSET_M - x_t, y_t, 0.0), abs=1e-15
    )


@pytest.mark.parametrize(
    "rotation",
    [
        (0.0, 0.0, 0.0, 1.0),
        (0.0, 1.0, 0.0, 0.0),
        (0.0, 0.0, math.sin(0.4), math.cos(0.4)),
        tuple(np.array([0.1, -0.7, 0.3, 0.5]) / np.linalg.norm([0.1, -0.7, 0.3, 0.5])),
    ],
)
def test_apply_rotates_like_the_rotation_matrix_then_translates(rotation):
    transform = FrameTransform("a", "b", (0.5, -1.0, 2.0), rotation)
    point = np.array([0.3, -0.2, 0.9])
    expected = rotation_matrix(rotation) @ point + np.array(transform.translation)
    np.testing.assert_allclose(transform.apply(tuple(point)), expected, atol=1e-14)
