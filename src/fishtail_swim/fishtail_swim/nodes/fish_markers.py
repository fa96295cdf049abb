"""``fish/markers`` of the simulator: the fish's body, path and tail in ``world``, on a timer.

The node's per-message path only stores the latest (state, carrier angle, stamp) in
:attr:`FishMarkerPublisher.latest`, so that markers cost nothing per sample; on each tick at
``markers_rate_hz`` the path grows by a point and, if anybody subscribes, one MarkerArray shows
the hull (:mod:`fishtail_plant.fish.outline`), the path of C and the tail from O to T. What each
shows: docs/swimming-dynamics.md ("The simulator node").
"""

from __future__ import annotations

from collections import deque
from typing import TYPE_CHECKING

from geometry_msgs.msg import Point
from rclpy.node import Node
from rclpy.timer import Timer
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from fishtail_common.interface import FISH_MARKERS
from fishtail_common.parameters import ParameterSpec
from fishtail_common.ros import ListenedPublisher
from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.fish.model import PSI, X, Y
from fishtail_plant.fish.outline import body_outline, body_to_world, tail_to_body

if TYPE_CHECKING:
    from builtin_interfaces.msg import Time

MARKERS_RATE = ParameterSpec(
    "markers_rate_hz", 10.0, f"{FISH_MARKERS.name} publication rate, 0 = off", "Hz", 0.0, 100.0,
    read_only=True,
)  # fmt: skip
MARKERS_PATH_LENGTH = ParameterSpec(
    "markers_path_length",
    3000,
    "positions of the centre of mass in the marker path, one per marker tick",
    minimum=0,
    maximum=100000,
    read_only=True,
)
MARKER_PARAMETERS = (MARKERS_RATE, MARKERS_PATH_LENGTH)
_LINE_WIDTH_M = 0.01


def _line_strip(frame: str, namespace: str, colour: tuple[float, float, float, float]) -> Marker:
    marker = Marker()
    marker.header.frame_id = frame
    marker.ns = namespace
    marker.id = 0
    marker.type = Marker.LINE_STRIP
    marker.action = Marker.ADD
    marker.pose.orientation.w = 1.0
    marker.scale.x = _LINE_WIDTH_M
    red, green, blue, alpha = colour
    marker.color = ColorRGBA(r=red, g=green, b=blue, a=alpha)
    return marker


class FishMarkerPublisher:
    """Publisher, throttle timer and path of ``fish/markers`` for one simulated fish."""

    def __init__(
        self,
        node: Node,
        tail: Tail,
        body_length_m: float,
        body_diameter_m: float,
        tail_origin_offset_m: float,
        rate_hz: float,
        path_length: int,
        frame: str,
    ) -> None:
        """Create the publisher and, unless ``rate_hz`` is 0, the timer; markers in ``frame``."""
        self.frame = frame
        self.tail = tail
        self.tail_origin_offset_m = tail_origin_offset_m
        #: The outline in the body frame, (outline.OUTLINE_POINTS, 2).
        self.outline = body_outline(body_length_m, body_diameter_m)
        self.publisher = ListenedPublisher(node, MarkerArray, FISH_MARKERS)
        #: (state (1, 6), carrier angle, header stamp) of the newest sample; set per message.
        self.latest: tuple[FloatArray, float, Time] | None = None
        self.path: deque[tuple[float, float]] = deque(maxlen=path_length)
        self.published = 0
        self._path_source: FloatArray | None = None
        self._delete_all = True
        self._body = _line_strip(frame, "body", (0.2, 0.5, 0.9, 1.0))
        self._path = _line_strip(frame, "path", (0.9, 0.9, 0.2, 0.8))
        self._tail = _line_strip(frame, "tail", (0.9, 0.3, 0.2, 1.0))
        self.timer: Timer | None = None
        if rate_hz > 0.0:
            self.timer = node.create_timer(1.0 / rate_hz, self.on_tick)

    def on_tick(self) -> None:
        """Extend the path from the newest state and publish the markers if anyone listens."""
        latest = self.latest
        if latest is None:
            return
        state, angle, stamp = latest
        if state is not self._path_source:
            self._path_source = state
            self.path.append((float(state[0, X]), float(state[0, Y])))
        if not self.publisher.listened:
            return
        self.publisher.publish(self.build(state, angle, stamp))

    def build(self, state: FloatArray, angle: float, stamp: Time) -> MarkerArray:
        """The MarkerArray of the fish in ``state`` with its tail at carrier ``angle``."""
        x, y, psi = float(state[0, X]), float(state[0, Y]), float(state[0, PSI])

        def world(points: FloatArray) -> list[Point]:
            return [Point(x=px, y=py) for px, py in body_to_world(points, x, y, psi).tolist()]

        tail = self.tail.solve(angle, 0.0)
        # O and the tip T, from the tail frame into the body.
        tail_points = tail_to_body(
            [[0.0, 0.0], [float(tail.tip_x), float(tail.tip_y)]], self.tail_origin_offset_m
        )
        self._body.points = world(self.outline)
        self._tail.points = world(tail_points)
        self._path.points = [Point(x=px, y=py) for px, py in self.path]
        markers = []
        if self._delete_all:
            clear = Marker()
            clear.header.frame_id = self.frame
            clear.header.stamp = stamp
            clear.action = Marker.DELETEALL
            markers.append(clear)
            self._delete_all = False
        for marker in (self._body, self._path, self._tail):
            marker.header.stamp = stamp
            markers.append(marker)
        self.published += 1
        return MarkerArray(markers=markers)
