"""Joint positions of the drawn linkage.

Every link keeps its length over a cycle, pins stay on their links, the Cardan couple's points stay
on the ring's diameters, and the tip is the engine's tip.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.linkage_points import OscillatoryPoints, UndulatoryPoints
from fishtail_kinematics.engine.mechanisms import OscillatoryTail, UndulatoryTail

CYCLE = np.linspace(0.0, 2.0 * math.pi, 721)
TOLERANCE_M = 1e-12
OTHER_OSCILLATORY = OscillatoryGeometry(
    ring_radius_m=0.08, crank_link_m=0.12, rocker_link_m=0.25, tail_link_m=0.2,
    pivot_offset_m=0.22, phase_rad=0.7,
)  # fmt: skip
OTHER_UNDULATORY = UndulatoryGeometry(pin_offset_m=0.05, phase_rad=-1.1, fin_link_m=0.25)


def distance(a, b):
    return np.hypot(*(np.asarray(a) - np.asarray(b)).T)


def assert_length(a, b, length):
    np.testing.assert_allclose(distance(a, b), length, rtol=0, atol=TOLERANCE_M)


def assert_on_segment(point, start, end, length):
    """``point`` lies on the segment start-end (whose length is ``length``)."""
    np.testing.assert_allclose(
        distance(start, point) + distance(point, end), length, rtol=0, atol=TOLERANCE_M
    )


def assert_cardan_couple(points, g, phi):
    half = 0.5 * g.ring_radius_m
    assert_length(points.origin, points.planet_centre, half)  # carrier crank R/2
    assert_length(points.planet_centre, points.cardan, half)  # P on the planet's rim
    assert_length(points.planet_centre, points.planet_opposite, half)
    # P and D are the ends of a diameter of the planet, on the y and x axes of the ring.
    np.testing.assert_allclose(
        points.cardan + points.planet_opposite, 2 * points.planet_centre, atol=TOLERANCE_M
    )
    np.testing.assert_array_equal(points.cardan[..., 0], 0.0)
    np.testing.assert_array_equal(points.planet_opposite[..., 1], 0.0)
    np.testing.assert_allclose(
        points.cardan[..., 1], g.ring_radius_m * np.cos(phi + g.phase_rad), atol=TOLERANCE_M
    )
    # The carrier turns counter-clockwise with phi, a quarter turn ahead of phi + psi.
    carrier_angle = np.arctan2(points.planet_centre[..., 1], points.planet_centre[..., 0])
    np.testing.assert_allclose(
        np.remainder(carrier_angle - (phi + g.phase_rad) - 0.5 * math.pi + math.pi, 2 * math.pi)
        - math.pi,
        0.0,
        atol=1e-12,
    )


@pytest.mark.parametrize("g", [OscillatoryGeometry(), OTHER_OSCILLATORY])
def test_oscillatory_links_keep_their_lengths_over_a_cycle(g):
    tail = OscillatoryTail(g)
    state = tail.solve(CYCLE, 4.0)
    p = tail.link_points(state)
    assert isinstance(p, OscillatoryPoints)
    assert p.tip.shape == (CYCLE.size, 2)
    assert_cardan_couple(p, g, CYCLE)
    assert_length(p.cardan, p.joint_r, g.crank_link_m)
    assert_length(p.joint_r, p.pivot_s, g.rocker_link_m)
    assert_length(p.pivot_s, p.tip, g.tail_link_m)
    np.testing.assert_array_equal(p.pivot_s, np.broadcast_to([g.pivot_offset_m, 0.0], (721, 2)))
    np.testing.assert_array_equal(p.origin, 0.0)
    # The drawn joint R is where the engine's theta2 puts it, and the tail is at theta3.
    np.testing.assert_allclose(
        p.joint_r - p.pivot_s,
        g.rocker_link_m * np.stack((np.cos(state.theta2), np.sin(state.theta2)), axis=-1),
        atol=TOLERANCE_M,
    )
    np.testing.assert_allclose(
        np.arctan2(p.tip[:, 1] - p.pivot_s[:, 1], p.tip[:, 0] - p.pivot_s[:, 0]),
        state.theta3,
        atol=1e-12,
    )


@pytest.mark.parametrize("g", [UndulatoryGeometry(), OTHER_UNDULATORY])
def test_undulatory_links_keep_their_lengths_and_pins_stay_on_their_links(g):
    tail = UndulatoryTail(g)
    state = tail.solve(CYCLE, 4.0)
    p = tail.link_points(state)
    assert isinstance(p, UndulatoryPoints)
    assert_cardan_couple(p, g, CYCLE)
    assert_length(p.cardan, p.joint_r, g.crank_link_m)
    assert_length(p.joint_r, p.pivot_s, g.rocker_link_m)
    assert_length(p.pivot_s, p.joint_w, g.swing_arm_m)
    assert_length(p.pivot_s, p.pin_u, g.pin_offset_m)
    assert_on_segment(p.pin_u, p.pivot_s, p.joint_w, g.swing_arm_m)  # U on SW
    assert_length(p.slider_a, p.joint_v, g.slotted_link_m)
    assert_on_segment(p.pin_u, p.slider_a, p.joint_v, g.slotted_link_m)  # U in AV's slot
    assert_length(p.joint_v, p.joint_w, g.fin_joint_offset_m)
    assert_length(p.joint_w, p.tip, g.fin_link_m - g.fin_joint_offset_m)
    assert_on_segment(p.joint_w, p.joint_v, p.tip, g.fin_link_m)  # W on VT
    np.testing.assert_array_equal(p.slider_a[:, 1], 0.0)  # A slides on the body axis
    assert np.all(p.slider_a[:, 0] < g.pivot_offset_m)  # ... in front of S
    # The tail link VT points along theta5.
    np.testing.assert_allclose(
        np.arctan2(p.tip[:, 1] - p.joint_v[:, 1], p.tip[:, 0] - p.joint_v[:, 0]),
        state.theta5,
        atol=1e-12,
    )


@pytest.mark.parametrize(
    ("g", "tail_class"),
    [(OscillatoryGeometry(), OscillatoryTail), (UndulatoryGeometry(), UndulatoryTail)],
)
def test_scalar_states_give_single_points_equal_to_the_array_path(g, tail_class):
    tail = tail_class(g)
    batch = tail.link_points(tail.solve(CYCLE[:50], 4.0))
    for index in (0, 17, 49):
        single = tail.link_points(tail.solve(float(CYCLE[index]), 4.0))
        for name, point in single._asdict().items():
            assert point.shape == (2,), name
            np.testing.assert_allclose(point, getattr(batch, name)[index], atol=1e-12)


@pytest.mark.parametrize("shift", [-0.03, 0.045])
def test_a_shifted_pivot_moves_s_and_every_link_keeps_its_length(shift):
    """S is drawn at (OS + s, 0) and every link keeps its length.

    A stays on the body axis, SW lies at theta3 + bias and the tail link along the fin angle.
    """
    oscillatory = OscillatoryTail(OTHER_OSCILLATORY).with_pivot_shift(shift)
    undulatory = UndulatoryTail(OTHER_UNDULATORY).with_pivot_shift(shift)
    for tail in (oscillatory, undulatory):
        g = tail.geometry
        state = tail.solve(CYCLE, 4.0)
        p = tail.link_points(state)
        assert_cardan_couple(p, g, CYCLE)
        np.testing.assert_array_equal(
            p.pivot_s, np.broadcast_to([g.pivot_offset_m + shift, 0.0], (721, 2))
        )
        assert_length(p.cardan, p.joint_r, g.crank_link_m)
        assert_length(p.joint_r, p.pivot_s, g.rocker_link_m)
        np.testing.assert_allclose(p.tip, np.stack((state.tip_x, state.tip_y), axis=-1), atol=0)
    p = oscillatory.link_points(oscillatory.solve(CYCLE, 4.0))
    assert_length(p.pivot_s, p.tip, OTHER_OSCILLATORY.tail_link_m)
    state = undulatory.solve(CYCLE, 4.0)
    p = undulatory.link_points(state)
    g = OTHER_UNDULATORY
    assert_length(p.pivot_s, p.joint_w, g.swing_arm_m)
    assert_on_segment(p.pin_u, p.pivot_s, p.joint_w, g.swing_arm_m)
    assert_on_segment(p.pin_u, p.slider_a, p.joint_v, g.slotted_link_m)
    assert_length(p.joint_v, p.joint_w, g.fin_joint_offset_m)
    assert_on_segment(p.joint_w, p.joint_v, p.tip, g.fin_link_m)
    np.testing.assert_array_equal(p.slider_a[:, 1], 0.0)
    arm = p.joint_w - p.pivot_s
    np.testing.assert_allclose(
        np.arctan2(arm[:, 1], arm[:, 0]), state.theta3 + undulatory.swing_bias_rad, atol=1e-12
    )
