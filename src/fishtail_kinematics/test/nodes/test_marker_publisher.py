"""The kinematics node's throttled tail/markers topic, and the RViz config that shows it.

The node tests run the node in this process (its own namespace, so nothing else on the ROS domain
interferes) and drive its callbacks directly; one test receives the published MarkerArray.
"""

from __future__ import annotations

import math
import os
import time
from pathlib import Path

import pytest
import yaml

from fishtail_common.interface import TAIL_MARKERS
from fishtail_kinematics.engine.geometry import OscillatoryGeometry
from fishtail_kinematics.nodes import marker_publisher

ROOT = Path(__file__).resolve().parents[4]
# The ROS message imports trigger a third-party deprecation warning (lark).
pytestmark = pytest.mark.filterwarnings("ignore:module 'sre_:DeprecationWarning")
COMMON_NAMESPACES = ["ring", "guides", "planet", "carrier", "cardan_point", "links", "tail_link",
                     "joints", "pivots"]  # fmt: skip


def test_rviz_config_shows_the_markers_in_the_tail_frame():
    config = yaml.safe_load((ROOT / "config" / "fishtail.rviz").read_text(encoding="utf-8"))
    manager = config["Visualization Manager"]
    assert manager["Global Options"]["Fixed Frame"] == "tail_mechanism"
    displays = {display["Class"]: display for display in manager["Displays"]}
    markers = displays["rviz_default_plugins/MarkerArray"]
    assert markers["Topic"]["Value"] == "/" + TAIL_MARKERS.name
    assert markers["Enabled"] is True
    assert manager["Views"]["Current"]["Class"] == "rviz_default_plugins/TopDownOrtho"


# --------------------------------------------------------------------------------------------
# The kinematics node


@pytest.fixture
def node():
    """A kinematics node in this process, in a namespace of its own."""
    import rclpy

    from fishtail_kinematics.nodes.kinematics_node import KinematicsNode

    namespace = f"/test_markers_{os.getpid()}_{time.monotonic_ns()}"
    rclpy.init(args=["--ros-args", "-r", f"__ns:={namespace}"])
    kinematics = KinematicsNode()
    try:
        yield kinematics
    finally:
        kinematics.destroy_node()
        rclpy.try_shutdown()


def motor_message(angle: float, velocity: float = 4.0, seconds: int = 1):
    from sensor_msgs.msg import JointState

    message = JointState(name=["carrier_joint"], position=[angle], velocity=[velocity])
    message.header.stamp.sec = seconds
    return message


def set_parameter(node, name, value):
    from rclpy.parameter import Parameter

    return node.set_parameters([Parameter(name, value=value)])[0]


def test_markers_rate_parameter_throttles_and_switches_off(node):
    assert node.get_parameter("markers_rate_hz").value == 30.0
    assert node.markers.timer.timer_period_ns == pytest.approx(1e9 / 30.0, abs=1)
    assert set_parameter(node, "markers_rate_hz", 0.0).successful
    assert node.markers.timer is None
    result = set_parameter(node, "markers_rate_hz", 150.0)
    assert not result.successful and "out of range" in result.reason
    assert node.markers.timer is None
    assert set_parameter(node, "markers_rate_hz", 100.0).successful
    assert node.markers.timer.timer_period_ns == pytest.approx(1e7, abs=1)
    assert set_parameter(node, "markers_trail_length", 3).successful
    assert node.markers.trail.maxlen == 3
    assert not set_parameter(node, "markers_trail_length", -1).successful


def test_per_message_path_builds_no_markers(node, monkeypatch):
    builds = []
    real_build = marker_publisher.build_markers
    monkeypatch.setattr(
        marker_publisher, "build_markers", lambda *a: builds.append(1) or real_build(*a)
    )
    for k in range(200):
        node._on_motor_state(motor_message(0.01 * k, seconds=k))
    assert builds == []
    state, _ = node.markers.latest
    assert state.motor_angle == pytest.approx(1.99)
    # A tick extends the trail once per new state, and builds only when someone subscribes.
    node.markers.on_tick()
    node.markers.on_tick()
    assert len(node.markers.trail) == 1 and builds == []
    node.markers.build(*node.markers.latest)
    assert len(builds) == 1


def test_geometry_change_resets_the_trail_and_clears_rviz(node):
    for k in range(5):
        node._on_motor_state(motor_message(0.5 * k, seconds=k))
        node.markers.on_tick()
    assert len(node.markers.trail) == 5
    first = node.markers.build(*node.markers.latest)
    assert first.markers[0].action == first.markers[0].DELETEALL
    again = node.markers.build(*node.markers.latest)
    assert all(marker.action == marker.ADD for marker in again.markers)
    assert [m.ns for m in again.markers] == [*COMMON_NAMESPACES, "tip_trail"]

    assert set_parameter(node, "mechanism", "undulatory").successful
    assert node.markers.latest is None and len(node.markers.trail) == 0
    node._on_motor_state(motor_message(2.3, seconds=10))  # on from 2.0: the motor turns one way
    array = node.markers.build(*node.markers.latest)
    assert array.markers[0].action == array.markers[0].DELETEALL
    links = next(m for m in array.markers if m.ns == "links")
    assert len(links.points) == 8  # four links of mechanism 2
    # A refused geometry leaves the markers alone.
    assert not set_parameter(node, "crank_link_m", 5.0).successful
    assert node.markers.latest is not None


def test_a_pivot_shift_redraws_s_where_it_is_and_keeps_the_trail(node):
    from sensor_msgs.msg import JointState

    from fishtail_common.interface import PIVOT_JOINT

    for k in range(3):
        node._on_motor_state(motor_message(0.5 * k, seconds=k))
        node.markers.on_tick()
    before = node.markers.build(*node.markers.latest)
    pivots = next(m for m in before.markers if m.ns == "pivots")
    g = OscillatoryGeometry()
    assert pivots.points[1].x == pytest.approx(g.pivot_offset_m)

    node._on_pivot_state(JointState(name=[PIVOT_JOINT], position=[0.02]))
    assert node.tail.pivot_shift_m == 0.02
    # The carrier has not moved: the newest pose is solved again with S shifted.
    state, _ = node.markers.latest
    assert state.motor_angle == 1.0 and state.tip_x == node.tail.solve(1.0, 4.0).tip_x
    after = node.markers.build(*node.markers.latest)
    assert all(marker.action == marker.ADD for marker in after.markers)  # no DELETEALL
    pivots = next(m for m in after.markers if m.ns == "pivots")
    assert pivots.points[1].x == pytest.approx(g.pivot_offset_m + 0.02)
    tip = next(m for m in after.markers if m.ns == "tail_link").points[-1]
    assert math.hypot(tip.x - g.pivot_offset_m - 0.02, tip.y) == pytest.approx(g.tail_link_m)
    assert len(node.markers.trail) == 3
    # A shift the engine refuses changes nothing.
    node._on_pivot_state(JointState(name=[PIVOT_JOINT], position=[1.0]))
    assert node.tail.pivot_shift_m == 0.02 and node.pivot_refused == 1


def test_node_publishes_the_marker_array_in_its_frame(node):
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from visualization_msgs.msg import Marker, MarkerArray

    received = []
    listener = rclpy.create_node("marker_listener", namespace=node.get_namespace())
    listener.create_subscription(MarkerArray, "tail/markers", received.append, 10)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    executor.add_node(listener)
    try:
        deadline = time.monotonic() + 15.0
        angle = 0.0
        while len(received) < 3 and time.monotonic() < deadline:
            angle += 0.05
            node._on_motor_state(motor_message(angle, seconds=int(angle * 100)))
            executor.spin_once(timeout_sec=0.01)
    finally:
        executor.shutdown()
        listener.destroy_node()
    assert len(received) >= 3, "no tail/markers received within 15 s"
    array = received[-1]
    frames = {marker.header.frame_id for marker in array.markers}
    assert frames == {"tail_mechanism"}
    kinds = {marker.ns: marker.type for marker in array.markers}
    assert kinds["ring"] == Marker.LINE_STRIP and kinds["joints"] == Marker.SPHERE_LIST
    assert kinds["tip_trail"] == Marker.LINE_STRIP
    tip = next(m for m in array.markers if m.ns == "tail_link").points[-1]
    g = OscillatoryGeometry()
    assert math.hypot(tip.x - g.pivot_offset_m, tip.y) == pytest.approx(g.tail_link_m)
