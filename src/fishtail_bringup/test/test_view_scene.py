"""The live view's pure part: messages -> primitives, and a bag's state -> the same pictures."""

from __future__ import annotations

import doctest
import math

import numpy as np
import pytest
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, PoseStamped, Quaternion
from nav_msgs.msg import Odometry
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

import fishtail_bringup.view_scene as scene
from fishtail_bringup.view_replay import FishFromOdometry, TailFromState
from fishtail_bringup.view_scene import (
    Clear,
    Lines,
    Points,
    Series,
    TailPlots,
    Text,
    goal_primitives,
    marker_primitives,
    spec_primitives,
    symmetry_primitives,
)
from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.markers import build_markers
from fishtail_kinematics.engine.mechanisms import OscillatoryTail, UndulatoryTail
from fishtail_kinematics.nodes.marker_publisher import marker_message
from fishtail_msgs.msg import SymmetryReport, TailState


def stamp(seconds: float) -> Time:
    return Time(sec=int(seconds), nanosec=round((seconds % 1.0) * 1e9))


def marker(kind: int, points, action: int = Marker.ADD, ns: str = "links", marker_id: int = 0):
    message = Marker(type=kind, action=action, ns=ns, id=marker_id)
    message.header.stamp = stamp(12.25)
    message.pose.orientation.w = 1.0
    message.scale.x = 0.004
    message.color = ColorRGBA(r=0.25, g=0.5, b=1.0, a=1.0)
    message.points = [Point(x=float(x), y=float(y)) for x, y in points]
    return message


def test_doctests():
    result = doctest.testmod(scene)
    assert result.attempted > 0 and result.failed == 0


def test_marker_constants_are_visualization_msgs():
    for name in ("ARROW", "CUBE", "SPHERE", "CYLINDER", "LINE_STRIP", "LINE_LIST", "CUBE_LIST",
                 "SPHERE_LIST", "POINTS", "ADD", "DELETE", "DELETEALL"):  # fmt: skip
        assert getattr(scene, name) == getattr(Marker, name), name


def test_line_strip_list_and_sphere_list():
    array = MarkerArray(markers=[
        marker(Marker.LINE_STRIP, [(0, 0), (1, 0), (1, 1)], ns="ring"),
        marker(Marker.LINE_LIST, [(0, 0), (1, 0), (2, 0), (2, 1), (9, 9)]),
        marker(Marker.SPHERE_LIST, [(0.5, 0.5), (1.5, 0.5)], ns="joints"),
    ])  # fmt: skip
    stamp_s, (ring, links, joints) = marker_primitives(array, "tail")
    assert stamp_s == pytest.approx(12.25)
    assert isinstance(ring, Lines) and ring.entity == "tail/ring" and len(ring.strips) == 1
    assert ring.strips[0].tolist() == [[0, 0], [1, 0], [1, 1]]
    assert ring.colour == (0.25, 0.5, 1.0, 1.0) and ring.width_m == pytest.approx(0.004)
    # Pairs, one segment each; an odd last point is not a segment.
    assert [s.tolist() for s in links.strips] == [[[0, 0], [1, 0]], [[2, 0], [2, 1]]]
    assert isinstance(joints, Points) and joints.positions.tolist() == [[0.5, 0.5], [1.5, 0.5]]


def test_deletes_clear_and_other_kinds_are_skipped():
    text = marker(Marker.TEXT_VIEW_FACING, [])
    sphere = marker(Marker.SPHERE, [], ns="pivot", marker_id=4)
    sphere.pose.position.x, sphere.pose.position.y = 0.3, -0.1
    array = MarkerArray(markers=[
        marker(0, [], action=Marker.DELETEALL), marker(0, [], action=Marker.DELETE, ns="trail"),
        text, sphere,
    ])  # fmt: skip
    _, primitives = marker_primitives(array, "fish")
    assert primitives[:2] == [Clear("fish"), Clear("fish/trail")]
    assert len(primitives) == 3 and primitives[2].entity == "fish/pivot/4"
    assert primitives[2].positions.tolist() == [[0.3, -0.1]]


def test_a_marker_pose_moves_and_turns_its_points():
    message = marker(Marker.LINE_STRIP, [(1, 0), (2, 0)])
    message.pose.position.x, message.pose.position.y = 1.0, 2.0
    message.pose.orientation = Quaternion(z=math.sin(math.pi / 4), w=math.cos(math.pi / 4))
    _, [line] = marker_primitives(MarkerArray(markers=[message]), "tail")
    assert np.allclose(line.strips[0], [[1.0, 3.0], [1.0, 4.0]])


@pytest.mark.parametrize(
    "tail", [OscillatoryTail(OscillatoryGeometry()), UndulatoryTail(UndulatoryGeometry())]
)
def test_the_kinematics_node_markers_and_the_engine_specs_draw_the_same(tail):
    """Live (tail/markers) and bag replay (engine specs) give identical primitives."""
    specs = build_markers(tail, tail.solve(0.7), [(0.3, 0.0), (0.31, 0.01), (0.32, 0.02)])
    array = MarkerArray(
        markers=[marker_message(spec, "tail_mechanism", stamp(1.0)) for spec in specs]
    )
    _, from_messages = marker_primitives(array, "tail")
    from_specs = spec_primitives(specs, "tail")
    assert [p.entity for p in from_messages] == [p.entity for p in from_specs]
    assert "tail/tip_trail" in [p.entity for p in from_specs]
    for a, b in zip(from_messages, from_specs, strict=True):
        assert type(a) is type(b) and a.colour == pytest.approx(b.colour)
        if isinstance(a, Lines):
            assert all(np.allclose(s, t) for s, t in zip(a.strips, b.strips, strict=True))
        else:
            assert np.allclose(a.positions, b.positions)


def tail_state(seconds: float, theta3: float, theta5: float, speed: float) -> TailState:
    fin_angle = theta3 if math.isnan(theta5) else theta5  # unshifted, as the kinematics node
    message = TailState(
        theta3=theta3, theta5=theta5, motor_velocity=speed, pivot_shift=0.0, swing_bias=0.0,
        fin_angle=fin_angle,
    )  # fmt: skip
    message.header.stamp = stamp(seconds)
    return message


def test_tail_plots_gather_degrees_and_skip_a_missing_theta5():
    plots = TailPlots()
    plots.add(tail_state(1.0, math.radians(10.0), math.nan, 4.0))
    plots.add(tail_state(1.005, math.radians(-5.0), math.nan, 4.1))
    assert len(plots) == 2
    (series,) = plots.flush()
    assert isinstance(series, Series) and series.entity == scene.TAIL_PLOT
    assert series.names == ("θ3 [deg]", "carrier speed [rad/s]")
    assert series.values == pytest.approx(np.array([[10.0, 4.0], [-5.0, 4.1]]))
    assert series.times_s == pytest.approx([1.0, 1.005])
    assert len(plots) == 0 and plots.flush() == []
    plots.add(tail_state(2.0, math.radians(20.0), math.radians(30.0), 4.0))
    (series,) = plots.flush()
    assert series.names == ("θ3 [deg]", "θ5 [deg]", "carrier speed [rad/s]")
    assert series.values == pytest.approx(np.array([[20.0, 30.0, 4.0]]))


def test_a_drawing_is_merged_into_one_entity_with_each_shape_s_colour_and_size():
    tail = OscillatoryTail(OscillatoryGeometry())
    specs = build_markers(tail, tail.solve(0.3), [(0.3, 0.0), (0.3, 0.01)])
    primitives = scene.spec_primitives(specs, scene.TAIL_ROOT)
    [drawing] = scene.merged(primitives, scene.TAIL_ROOT)
    assert isinstance(drawing, scene.Shapes) and drawing.entity == "tail/drawing"
    assert drawing.lines == tuple(p for p in primitives if isinstance(p, Lines))
    assert len(drawing.lines) + len(drawing.points) == len(primitives)
    # A DELETEALL clears the root first; deleting one marker waits for the next whole drawing.
    cleared = scene.merged([scene.Clear("tail"), scene.Clear("tail/ring"), *primitives], "tail")
    assert [type(p) for p in cleared] == [scene.Clear, scene.Shapes]


@pytest.mark.parametrize(
    ("verdict", "level"),
    [(SymmetryReport.OK, "INFO"), (SymmetryReport.WARN, "WARN"), (SymmetryReport.ERROR, "ERROR"),
     (SymmetryReport.NOT_JUDGED, "WARN")],
)  # fmt: skip
def test_verdicts_become_log_lines_with_levels(verdict, level):
    report = SymmetryReport(beat_index=7, verdict=verdict, message="symmetric: 0.5000")
    report.header.stamp = stamp(3.0)
    stamp_s, [line] = symmetry_primitives(report)
    assert stamp_s == 3.0 and isinstance(line, Text) and line.level == level
    assert line.text.startswith("beat 7 ") and line.text.endswith(": symmetric: 0.5000")


def test_a_goal_is_a_disc_and_a_heading():
    goal = PoseStamped()
    goal.header.stamp = stamp(5.0)
    goal.pose.position.x, goal.pose.position.y = 2.0, -1.0
    goal.pose.orientation = Quaternion(z=1.0, w=0.0)  # facing -x
    stamp_s, (disc, heading) = goal_primitives(goal)
    assert stamp_s == 5.0 and disc.positions.tolist() == [[2.0, -1.0]]
    assert np.allclose(heading.strips[0], [[2.0, -1.0], [2.0 - scene.GOAL_HEADING_M, -1.0]])


def test_a_bag_state_redraws_the_linkage_with_its_trail():
    tail = OscillatoryTail(OscillatoryGeometry())
    drawing = TailFromState(tail, trail_length=3)
    for angle in (0.0, 0.1, 0.2, 0.3):
        state = tail.solve(angle, 4.0)
        message = TailState(
            motor_angle=angle, motor_velocity=4.0, pivot_shift=0.0, swing_bias=0.0,
            fin_angle=state.fin_angle,
        )  # fmt: skip
        primitives = drawing.primitives(message)
    trail = next(p for p in primitives if p.entity == "tail/tip_trail")
    expected = [(s.tip_x, s.tip_y) for s in (tail.solve(a) for a in (0.1, 0.2, 0.3))]
    assert np.allclose(trail.strips[0], expected)
    assert {"tail/ring", "tail/planet", "tail/links", "tail/tail_link"} <= {
        p.entity for p in primitives
    }


def test_a_bag_odometry_redraws_hull_path_and_tail_in_world():
    fish = FishFromOdometry(0.5, 0.2, 0.05, path_length=2)
    for x in (0.0, 0.1, 0.2):
        odometry = Odometry()
        odometry.pose.pose.position.x, odometry.pose.pose.position.y = x, 1.0
        odometry.pose.pose.orientation = Quaternion(
            z=math.sin(math.pi / 4), w=math.cos(math.pi / 4)
        )
        body, path, tail = fish.primitives(odometry, tip=(0.3, 0.0))
    assert np.allclose(path.strips[0], [[0.1, 1.0], [0.2, 1.0]])
    # Heading +y: the nose is L/2 ahead of C, the tail tip l_O + 0.3 behind it.
    assert np.allclose(body.strips[0][0], [0.2, 1.25])
    assert np.allclose(tail.strips[0], [[0.2, 0.95], [0.2, 0.65]])
