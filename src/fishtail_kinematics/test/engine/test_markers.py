"""RViz markers: what build_markers draws (pure; the node's topic is tested in nodes/)."""

from __future__ import annotations

import numpy as np

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.markers import (
    LINE_LIST,
    LINE_STRIP,
    SPHERE_LIST,
    STATIC_NAMESPACES,
    build_markers,
)
from fishtail_kinematics.engine.mechanisms import OscillatoryTail, UndulatoryTail

COMMON_NAMESPACES = ["ring", "guides", "planet", "carrier", "cardan_point", "links", "tail_link",
                     "joints", "pivots"]  # fmt: skip


def by_namespace(specs):
    return {spec.namespace: spec for spec in specs}


def segment_lengths(points):
    pairs = np.asarray(points).reshape(-1, 2, 2)
    return np.hypot(*(pairs[:, 1] - pairs[:, 0]).T)


def test_oscillatory_markers_draw_the_solved_linkage():
    g = OscillatoryGeometry()
    tail = OscillatoryTail(g)
    state = tail.solve(1.1, 4.0)
    specs = by_namespace(build_markers(tail, state, [(0.3, 0.0), (0.31, 0.01), (0.32, 0.02)]))
    assert list(specs) == [*COMMON_NAMESPACES, "tip_trail"]
    points = tail.link_points(state)
    ring = specs["ring"]
    assert ring.kind == LINE_STRIP
    np.testing.assert_allclose(np.hypot(*ring.points.T), g.ring_radius_m, atol=1e-15)
    np.testing.assert_allclose(ring.points[0], ring.points[-1], atol=1e-15)  # closed
    planet = specs["planet"]
    np.testing.assert_allclose(
        np.hypot(*(planet.points - points.planet_centre).T), 0.5 * g.ring_radius_m, atol=1e-15
    )
    np.testing.assert_allclose(specs["cardan_point"].points, [[0.0, state.slider_position]])
    links = specs["links"]
    assert links.kind == LINE_LIST
    np.testing.assert_allclose(
        segment_lengths(links.points), [g.crank_link_m, g.rocker_link_m], atol=1e-12
    )
    np.testing.assert_allclose(segment_lengths(specs["tail_link"].points), [g.tail_link_m])
    np.testing.assert_allclose(specs["tail_link"].points[-1], [state.tip_x, state.tip_y])
    assert specs["joints"].kind == SPHERE_LIST
    np.testing.assert_allclose(specs["pivots"].points, [[0.0, 0.0], [g.pivot_offset_m, 0.0]])
    np.testing.assert_array_equal(specs["tip_trail"].points[-1], [0.32, 0.02])
    for spec in specs.values():
        assert spec.size_m > 0.0
        assert all(0.0 <= channel <= 1.0 for channel in spec.colour)
        assert spec.points.ndim == 2 and spec.points.shape[1] == 2
        assert np.all(np.isfinite(spec.points))


def test_undulatory_markers_draw_every_link_and_joint():
    g = UndulatoryGeometry()
    tail = UndulatoryTail(g)
    specs = by_namespace(build_markers(tail, tail.solve(2.5, 4.0)))
    assert list(specs) == COMMON_NAMESPACES  # no trail yet
    np.testing.assert_allclose(
        segment_lengths(specs["links"].points),
        [g.crank_link_m, g.rocker_link_m, g.swing_arm_m, g.slotted_link_m],
        atol=1e-12,
    )
    np.testing.assert_allclose(segment_lengths(specs["tail_link"].points), [g.fin_link_m])
    assert len(specs["joints"].points) == 6  # R, U, A, V, W, T


def test_trail_needs_two_points_and_static_markers_do_not_depend_on_the_state():
    g = OscillatoryGeometry()
    tail = OscillatoryTail(g)
    assert "tip_trail" not in by_namespace(build_markers(tail, tail.solve(0.0), [(0.3, 0.0)]))
    first = by_namespace(build_markers(tail, tail.solve(0.0)))
    second = by_namespace(build_markers(tail, tail.solve(2.0)))
    for name in STATIC_NAMESPACES:
        np.testing.assert_array_equal(first[name].points, second[name].points)
    assert not np.allclose(first["links"].points, second["links"].points)


def test_a_shifted_pivot_is_drawn_where_it_is():
    g = UndulatoryGeometry()
    tail = UndulatoryTail(g).with_pivot_shift(0.025)
    state = tail.solve(0.8, 4.0)
    specs = by_namespace(build_markers(tail, state))
    np.testing.assert_allclose(
        specs["pivots"].points, [[0.0, 0.0], [g.pivot_offset_m + 0.025, 0.0]]
    )
    np.testing.assert_allclose(
        segment_lengths(specs["links"].points),
        [g.crank_link_m, g.rocker_link_m, g.swing_arm_m, g.slotted_link_m],
        atol=1e-12,
    )
    np.testing.assert_allclose(specs["tail_link"].points[-1], [state.tip_x, state.tip_y])
