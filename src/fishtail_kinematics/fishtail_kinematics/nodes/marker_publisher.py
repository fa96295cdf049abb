"""``tail/markers`` of the kinematics node: RViz markers of the latest state, on a throttle timer.

The node's per-message path only stores the latest (state, stamp) in :attr:`latest`, so that
markers cost nothing per sample; on each tick at ``markers_rate_hz`` the tip joins the trail and,
if anybody subscribes, the markers of :func:`fishtail_kinematics.engine.markers.build_markers`
are published as one ``MarkerArray`` (the geometry-only ones converted once per geometry, a
DELETEALL first after a geometry change). Costs and parameters: docs/visualisation.md ("RViz").
"""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING

from geometry_msgs.msg import Point
from rclpy.node import Node
from rclpy.timer import Timer
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from fishtail_common.interface import TAIL_MARKERS
from fishtail_common.parameters import ParameterSpec
from fishtail_common.ros import ListenedPublisher
from fishtail_kinematics.engine.errors import FishtailKinematicsError
from fishtail_kinematics.engine.geometry import LinkageState
from fishtail_kinematics.engine.markers import (
    LINE_LIST,
    LINE_STRIP,
    SPHERE_LIST,
    STATIC_NAMESPACES,
    MarkerSpec,
    build_markers,
)
from fishtail_kinematics.engine.mechanisms import Tail

if TYPE_CHECKING:
    from builtin_interfaces.msg import Time

MARKERS_RATE = ParameterSpec(
    "markers_rate_hz", 30.0, f"{TAIL_MARKERS.name} publication rate, 0 = off", "Hz", 0.0, 100.0
)
MARKERS_TRAIL_LENGTH = ParameterSpec(
    "markers_trail_length",
    90,
    "tip positions in the marker trail, one per marker tick",
    minimum=0,
    maximum=10000,
)
MARKER_PARAMETERS = (MARKERS_RATE, MARKERS_TRAIL_LENGTH)
_MARKER_TYPES = {
    LINE_STRIP: Marker.LINE_STRIP,
    LINE_LIST: Marker.LINE_LIST,
    SPHERE_LIST: Marker.SPHERE_LIST,
}


def marker_message(spec: MarkerSpec, frame_id: str, stamp: Time) -> Marker:
    """One ``visualization_msgs/Marker`` (action ADD, identity pose, z = 0) from a spec."""
    marker = Marker()
    marker.header.frame_id = frame_id
    marker.header.stamp = stamp
    marker.ns = spec.namespace
    marker.id = spec.marker_id
    marker.type = _MARKER_TYPES[spec.kind]
    marker.action = Marker.ADD
    marker.pose.orientation.w = 1.0
    size = float(spec.size_m)
    marker.scale.x = size
    if spec.kind == SPHERE_LIST:
        marker.scale.y = size
        marker.scale.z = size
    red, green, blue, alpha = spec.colour
    marker.color = ColorRGBA(r=red, g=green, b=blue, a=alpha)
    marker.points = [Point(x=x, y=y) for x, y in spec.points.tolist()]
    return marker


def delete_all_marker(frame_id: str, stamp: Time) -> Marker:
    """A DELETEALL marker: RViz drops every marker of the display it reaches."""
    clear = Marker()
    clear.header.frame_id = frame_id
    clear.header.stamp = stamp
    clear.action = Marker.DELETEALL
    return clear


class TailMarkerPublisher:
    """Publisher, throttle timer and tip trail of ``tail/markers`` for one node."""

    def __init__(
        self, node: Node, tail: Tail, frame_id: str, rate_hz: float, trail_length: int
    ) -> None:
        """Create the publisher and, unless ``rate_hz`` is 0, the timer."""
        self._node = node
        self.frame_id = frame_id
        self.tail = tail
        self.publisher = ListenedPublisher(node, MarkerArray, TAIL_MARKERS)
        #: (engine state, header stamp) of the newest input; set by the node per message.
        self.latest: tuple[LinkageState, Time] | None = None
        self.trail: deque[tuple[float, float]] = deque(maxlen=trail_length)
        self.timer: Timer | None = None
        self.published = 0
        self._trail_source: LinkageState | None = None
        self._delete_all = True
        self._static_markers: dict[str, Marker] = {}
        self.set_rate(rate_hz)

    def set_rate(self, rate_hz: float) -> None:
        """Tick at ``rate_hz`` from now on; 0 stops the markers."""
        if self.timer is not None:
            self._node.destroy_timer(self.timer)
            self.timer = None
        if rate_hz > 0.0:
            self.timer = self._node.create_timer(1.0 / rate_hz, self.on_tick)

    def set_trail_length(self, length: int) -> None:
        """Keep the last ``length`` tip positions (the newest ones are kept on shrinking)."""
        self.trail = deque(self.trail, maxlen=length)

    def reset(self, tail: Tail) -> None:
        """A new geometry (maybe a new mechanism): forget the state and trail, clear RViz."""
        self.tail = tail
        self.latest = None
        self._trail_source = None
        self.trail.clear()
        self._delete_all = True
        self._static_markers.clear()

    def set_tail(self, tail: Tail) -> None:
        """The same linkage with its pivot moved: the trail goes on, S is redrawn where it is.

        The newest state is solved again with ``tail`` (a few us), so that the markers show the
        new pose even while the carrier stands still.
        """
        self.tail = tail
        self._static_markers.clear()
        if self.latest is not None:
            state, stamp = self.latest
            try:
                angle, speed = float(state.motor_angle), float(state.motor_velocity)
                self.latest = (tail.solve(angle, speed), stamp)
            except FishtailKinematicsError:
                self.latest = None

    def on_tick(self) -> None:
        """Extend the trail from the newest state and publish the markers if anyone listens."""
        latest = self.latest
        if latest is None:
            return
        state, stamp = latest
        if state is not self._trail_source:
            self._trail_source = state
            self.trail.append((float(state.tip_x), float(state.tip_y)))
        if not self.publisher.listened:
            return
        self.publisher.publish(self.build(state, stamp))

    def build(self, state: LinkageState, stamp: Time) -> MarkerArray:
        """The MarkerArray for ``state`` with the current trail."""
        markers = []
        if self._delete_all:
            markers.append(delete_all_marker(self.frame_id, stamp))
            self._delete_all = False
        for spec in build_markers(self.tail, state, list(self.trail)):
            marker = self._static_markers.get(spec.namespace)
            if marker is None:
                marker = marker_message(spec, self.frame_id, stamp)
                if spec.namespace in STATIC_NAMESPACES:
                    self._static_markers[spec.namespace] = marker
            else:
                marker.header.stamp = stamp
            markers.append(marker)
        self.published += 1
        return MarkerArray(markers=markers)
