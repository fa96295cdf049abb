"""The suite's floor: driver, kinematics and monitor stand-ins that compute nothing.

Each relay has the name, topics, message types, QoS profiles and publication rates of the suite
node it stands in for (:mod:`fishtail_common.interface`, :func:`fishtail_common.ros.qos_profile`),
so what it costs is what moving the suite's messages costs in rclpy, with no engine behind it:

* ``driver``: ``motor/joint_state`` at ``publish_rate_hz`` (the carrier angle advanced by the
  commanded speed), ``/diagnostics`` every ``diagnostics_period_sec``; takes ``motor/cmd_speed``.
* ``kinematics``: on each ``motor/joint_state`` sample, ``tail/joint_states``, ``tail/tip`` and
  ``tail/state`` stamped like the sample, its angle and speed copied, every other field constant;
  ``tail/markers`` at ``markers_rate_hz`` when subscribed (the kinematics node's throttle), a
  constant array of the kinematics node's markers and point counts; ``/diagnostics`` at 1 Hz.
* ``monitor``: takes ``tail/state``, ``motor/cmd_speed`` and ``fish/swimming``; one constant
  ``tail/symmetry`` report per carrier revolution (the monitor's beat on the oscillatory tail),
  stamped like the sample that starts the revolution; ``/diagnostics`` at 1 Hz with the monitor's
  two statuses, STALE until ``tail/state`` arrives and OK after.

bench/bench_suite.py composes them in one process or starts each as its own process::

    python bench/relay_nodes.py kinematics --ros-args --params-file config/oscillatory.yaml
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Point, PointStamped
from sensor_msgs.msg import JointState
from std_msgs.msg import ColorRGBA, Float64
from visualization_msgs.msg import Marker, MarkerArray

from fishtail_common.interface import (
    DIAGNOSTICS,
    FISH_SWIMMING,
    MECHANISM_CODES,
    MOTOR_CMD_SPEED,
    MOTOR_JOINT_STATE,
    TAIL_FRAME,
    TAIL_JOINT_STATES,
    TAIL_MARKERS,
    TAIL_STATE,
    TAIL_SYMMETRY,
    TAIL_TIP,
    Level,
    Status,
)
from fishtail_common.parameters import ParameterSpec
from fishtail_common.ros import (
    ListenedPublisher,
    SuiteNodeBase,
    declare,
    diagnostic_array,
    publisher_qos,
    run_node,
    subscriber_qos,
)
from fishtail_driver.parameters import SPECS as DRIVER_SPECS
from fishtail_kinematics.nodes.marker_publisher import MARKERS_RATE
from fishtail_msgs.msg import SwimFigures, SymmetryReport, TailState

#: The suite nodes' /diagnostics period [s] (the driver's is its diagnostics_period_sec).
DIAGNOSTICS_PERIOD_S = 1.0
TWO_PI = 2.0 * math.pi
#: tail/joint_states joint names by mechanism (those of the engine's tails).
JOINT_NAMES = {
    "oscillatory": ("theta1", "theta2", "theta3"),
    "undulatory": ("theta1", "theta2", "theta3", "theta4", "theta5"),
}
MECHANISM = ParameterSpec("mechanism", "oscillatory", "tail mechanism", choices=tuple(JOINT_NAMES))
#: (marker type, points) of each marker the kinematics node publishes for the oscillatory tail:
#: ring, guides, planet, carrier, Cardan point, links, tail link, joints, pivots, tip trail.
MARKER_LAYOUT = (
    (Marker.LINE_STRIP, 73),
    (Marker.LINE_LIST, 4),
    (Marker.LINE_STRIP, 49),
    (Marker.LINE_LIST, 4),
    (Marker.SPHERE_LIST, 1),
    (Marker.LINE_LIST, 4),
    (Marker.LINE_LIST, 2),
    (Marker.SPHERE_LIST, 2),
    (Marker.SPHERE_LIST, 2),
    (Marker.LINE_STRIP, 90),
)


def constant_status_values(*keys: str) -> dict[str, str]:
    """Diagnostic key values with the suite's keys and a constant value."""
    return {key: "0" for key in keys}


class DriverRelay(SuiteNodeBase):
    """``motor/joint_state`` at the driver's rate; no motor, no watchdog, no stamp mapping."""

    def __init__(self, **node_options: Any) -> None:
        """Declare the driver's rate, joint and diagnostics parameters; the timers and topics."""
        super().__init__("driver", **node_options)
        values = declare(
            self,
            [DRIVER_SPECS[name] for name in ("publish_rate_hz", "joint_name",
                                             "diagnostics_period_sec")],
        )  # fmt: skip
        self.period_s = 1.0 / float(values["publish_rate_hz"])
        self.speed_rad_s = 0.0
        self.angle_rad = 0.0
        self.state_message = JointState()
        self.state_message.name = [str(values["joint_name"])]
        self.state_publisher = ListenedPublisher(self, JointState, MOTOR_JOINT_STATE)
        self.diagnostics_publisher = self.create_publisher(
            DiagnosticArray, DIAGNOSTICS.name, publisher_qos(DIAGNOSTICS)
        )
        self.create_subscription(
            Float64, MOTOR_CMD_SPEED.name, self._on_command, subscriber_qos(MOTOR_CMD_SPEED)
        )
        self.diagnostics = diagnostic_array(
            self,
            Status(
                "motor",
                Level.OK,
                "relay",
                constant_status_values(
                    "backend", "commanded_speed_rad_s", "watchdog_stops", "rejected_commands",
                    "clamped_commands", "joint_state_rate_hz", "joint_state_expected_rate_hz",
                    "joint_state_longest_gap_ms", "dropped_backward_stamps", "clock_steps",
                ),
            ),
        )  # fmt: skip
        self.create_timer(self.period_s, self._on_publish_tick)
        self.create_timer(float(values["diagnostics_period_sec"]), self._on_diagnostics)

    def _on_command(self, message: Float64) -> None:
        self.speed_rad_s = message.data

    def _on_publish_tick(self) -> None:
        # The angle advances so that the monitor relay sees revolutions, as the monitor sees beats.
        self.angle_rad += self.speed_rad_s * self.period_s
        if not self.state_publisher.listened:  # as the suite's publishers: nothing for nobody
            return
        message = self.state_message
        message.header.stamp = self.get_clock().now().to_msg()
        message.position = [self.angle_rad]
        message.velocity = [self.speed_rad_s]
        self.state_publisher.publish(message)

    def _on_diagnostics(self) -> None:
        self.diagnostics.header.stamp = self.get_clock().now().to_msg()
        self.diagnostics_publisher.publish(self.diagnostics)


class KinematicsRelay(SuiteNodeBase):
    """The kinematics node's three messages per sample, and its markers, with no engine."""

    def __init__(self, **node_options: Any) -> None:
        """Declare the mechanism and the marker rate; build the constant messages; wire topics."""
        super().__init__("kinematics", **node_options)
        values = declare(self, (MECHANISM, MARKERS_RATE))
        mechanism = str(values[MECHANISM.name])
        self.received = 0
        self.last_input_ns: int | None = None
        self.joint_values = [0.0] * len(JOINT_NAMES[mechanism])
        self.joint_states = JointState(name=list(JOINT_NAMES[mechanism]))
        self.tip = PointStamped()
        self.tip.header.frame_id = TAIL_FRAME
        # The unshifted pose of the zero carrier angle, as every other field here.
        self.state = TailState(
            mechanism=MECHANISM_CODES[mechanism], pivot_shift=0.0, swing_bias=0.0, fin_angle=0.0
        )
        self.state.header.frame_id = TAIL_FRAME
        self.markers = MarkerArray(markers=[constant_marker(kind, points)
                                            for kind, points in MARKER_LAYOUT])  # fmt: skip
        # As the suite's kinematics node: each message is built only while someone listens.
        self.joint_publisher = ListenedPublisher(self, JointState, TAIL_JOINT_STATES)
        self.tip_publisher = ListenedPublisher(self, PointStamped, TAIL_TIP)
        self.state_publisher = ListenedPublisher(self, TailState, TAIL_STATE)
        self.marker_publisher = ListenedPublisher(self, MarkerArray, TAIL_MARKERS)
        self.diagnostics_publisher = self.create_publisher(
            DiagnosticArray, DIAGNOSTICS.name, publisher_qos(DIAGNOSTICS)
        )
        self.create_subscription(
            JointState,
            MOTOR_JOINT_STATE.name,
            self._on_motor_state,
            subscriber_qos(MOTOR_JOINT_STATE),
        )
        rate_hz = float(values[MARKERS_RATE.name])
        if rate_hz > 0.0:
            self.create_timer(1.0 / rate_hz, self._on_markers_tick)
        self.create_timer(DIAGNOSTICS_PERIOD_S, self._on_diagnostics)

    def _on_motor_state(self, message: JointState) -> None:
        self.received += 1
        self.last_input_ns = self.get_clock().now().nanoseconds
        stamp = message.header.stamp
        if self.joint_publisher.listened:
            joints = self.joint_states
            joints.header.stamp = stamp
            joints.position = self.joint_values
            joints.velocity = self.joint_values
            self.joint_publisher.publish(joints)
        if self.tip_publisher.listened:
            tip = self.tip
            tip.header.stamp = stamp
            self.tip_publisher.publish(tip)
        if self.state_publisher.listened:
            state = self.state
            state.header.stamp = stamp
            state.motor_angle = message.position[0]
            state.motor_velocity = message.velocity[0]
            self.state_publisher.publish(state)

    def _on_markers_tick(self) -> None:
        # Like the kinematics node: nothing is sent while nobody subscribes.
        if not self.marker_publisher.listened:
            return
        stamp = self.get_clock().now().to_msg()
        for marker in self.markers.markers:
            marker.header.stamp = stamp
        self.marker_publisher.publish(self.markers)

    def _on_diagnostics(self) -> None:
        # "received" counts for real: bench_suite reads it to place losses before this node.
        values = {"received": str(self.received), "rejected": "0",
                  **constant_status_values("input_rate_hz", "longest_gap_ms")}  # fmt: skip
        self.diagnostics_publisher.publish(
            diagnostic_array(self, Status("kinematics", Level.OK, "relay", values))
        )


def constant_marker(kind: int, points: int) -> Marker:
    """One marker in the tail frame with ``points`` points at the origin."""
    marker = Marker(type=kind, action=Marker.ADD)
    marker.header.frame_id = TAIL_FRAME
    marker.pose.orientation.w = 1.0
    marker.scale.x = marker.scale.y = marker.scale.z = 0.005
    marker.color = ColorRGBA(r=1.0, g=1.0, b=1.0, a=1.0)
    marker.points = [Point() for _ in range(points)]
    return marker


class MonitorRelay(SuiteNodeBase):
    """The monitor's subscriptions, one report per carrier revolution, its diagnostics."""

    def __init__(self, **node_options: Any) -> None:
        """Build the constant report and wire the monitor's topics."""
        super().__init__("monitor", **node_options)
        self.last_input_ns: int | None = None
        self.revolution: int | None = None
        self.beats = 0
        self.commanded_speed = 0.0
        self.simulated_speed_m_s = math.nan
        self.report = SymmetryReport(message="relay")
        self.report_publisher = self.create_publisher(
            SymmetryReport, TAIL_SYMMETRY.name, publisher_qos(TAIL_SYMMETRY)
        )
        self.diagnostics_publisher = self.create_publisher(
            DiagnosticArray, DIAGNOSTICS.name, publisher_qos(DIAGNOSTICS)
        )
        self.create_subscription(
            TailState, TAIL_STATE.name, self._on_state, subscriber_qos(TAIL_STATE)
        )
        self.create_subscription(
            Float64, MOTOR_CMD_SPEED.name, self._on_command, subscriber_qos(MOTOR_CMD_SPEED)
        )
        self.create_subscription(
            SwimFigures, FISH_SWIMMING.name, self._on_swimming, subscriber_qos(FISH_SWIMMING)
        )
        self.create_timer(DIAGNOSTICS_PERIOD_S, self._on_diagnostics)

    def _on_command(self, message: Float64) -> None:
        self.commanded_speed = message.data

    def _on_swimming(self, message: SwimFigures) -> None:
        self.simulated_speed_m_s = message.mean_speed_m_s

    def _on_state(self, message: TailState) -> None:
        self.last_input_ns = self.get_clock().now().nanoseconds
        revolution = int(message.motor_angle // TWO_PI)
        if revolution == self.revolution:
            return
        if self.revolution is not None:
            self.beats += 1
            report = self.report
            report.header = message.header
            report.beat_index = self.beats
            self.report_publisher.publish(report)
        self.revolution = revolution

    def _on_diagnostics(self) -> None:
        if self.last_input_ns is None:
            level, text = Level.STALE, f"no {TAIL_STATE.name} received recently"
        else:
            level, text = Level.OK, "relay"
        values = constant_status_values("beats", "beats_not_judged")
        self.diagnostics_publisher.publish(
            diagnostic_array(
                self,
                Status(f"{TAIL_STATE.name} input", level, text, {}),
                Status("tail swing symmetry", level, text, values),
            )
        )


#: The relays by the name of the suite node they stand in for.
RELAYS: dict[str, Callable[..., SuiteNodeBase]] = {
    "driver": DriverRelay,
    "kinematics": KinematicsRelay,
    "monitor": MonitorRelay,
}


def main(node: str, args: list[str] | None = None) -> int:
    """Run the relay of suite node ``node`` until SIGINT/SIGTERM (``args``: ROS arguments)."""
    if node not in RELAYS:
        print(f"relay_nodes: unknown node {node!r}; one of {', '.join(RELAYS)}", file=sys.stderr)
        return 2
    return run_node(RELAYS[node], f"relay {node}", args=args)


if __name__ == "__main__":
    if len(sys.argv) < 2:
        print(f"usage: relay_nodes.py {{{','.join(RELAYS)}}} [--ros-args ...]", file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1], sys.argv))
