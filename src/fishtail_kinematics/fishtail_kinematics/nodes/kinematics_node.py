"""Kinematics node: carrier angle in, tail pose out.

Topics (relative names):
  sub ``motor/joint_state``  sensor_msgs/JointState (the driver's carrier joint), sensor-data QoS
  pub ``tail/joint_states``  sensor_msgs/JointState: theta1, theta2, theta3 (+ theta4, theta5 for
                             the undulatory mechanism), positions [rad] and velocities [rad/s]
  pub ``tail/tip``           geometry_msgs/PointStamped, tip T in frame ``frame_id`` (origin O)
  pub ``tail/state``         fishtail_msgs/TailState, everything, stamped like the encoder sample
  pub ``tail/markers``       visualization_msgs/MarkerArray for RViz (config/fishtail.rviz): ring,
                             planet, Cardan point, links, joints, tip trail; at
                             ``markers_rate_hz`` (0 = off), built on a timer from the latest state
  pub ``/diagnostics``       diagnostic_msgs/DiagnosticArray: STALE without input; WARN when
                             samples were dropped (counts per reason in ``dropped_<reason>``) or
                             the input has gaps or a low rate (``input_rate_hz``,
                             ``longest_gap_ms``, ...); else OK

Implausible ``motor/joint_state`` samples are dropped before the engine sees them, by the rules
of :mod:`fishtail_kinematics.engine.input_guard`; gaps and rate are judged by
:mod:`fishtail_kinematics.engine.stream_timing`. Geometry parameters are validated by the engine
when set: an infeasible linkage is refused with the engine's reason and the previous geometry
stays in force; a set that changes nothing is not news and is not logged.
"""

from __future__ import annotations

import math
import sys

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PointStamped
from rcl_interfaces.msg import IntegerRange, ParameterDescriptor, SetParametersResult
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState

from fishtail_kinematics.engine.errors import FishtailKinematicsError
from fishtail_kinematics.engine.input_guard import (
    GUARD_PARAMETERS,
    GUARD_REASONS,
    REASON_TEXT,
    CarrierGuard,
    DropCounts,
    input_status,
)
from fishtail_kinematics.engine.mechanisms import UndulatoryTail, make_tail
from fishtail_kinematics.engine.parameters import (
    MECHANISM_PARAMETER,
    changes_text,
    geometry_changes,
    geometry_from_parameters,
    geometry_parameters_in,
)
from fishtail_kinematics.engine.stream_timing import StreamTiming
from fishtail_kinematics.nodes.marker_publisher import TailMarkerPublisher
from fishtail_kinematics.nodes.ros_common import (
    LEVEL_STALE,
    declare_geometry_parameters,
    diagnostic_array,
    float_descriptor,
    geometry_parameter_values,
    run_node,
)
from fishtail_msgs.msg import TailState

INPUT_TOPIC = "motor/joint_state"
DIAGNOSTICS_PERIOD_S = 1.0
#: Drop reasons of the node itself, besides the guard's.
NO_CARRIER_JOINT = "no_carrier_joint"
ENGINE_REFUSED = "engine_refused"
OSCILLATORY_JOINTS = ["theta1", "theta2", "theta3"]
UNDULATORY_JOINTS = [*OSCILLATORY_JOINTS, "theta4", "theta5"]
_NAN = float("nan")


class KinematicsNode(Node):
    """Thin shell around the engine: messages in, messages out, parameters validated."""

    def __init__(self) -> None:
        """Declare parameters, build the engine (raises on an infeasible geometry), wire topics."""
        super().__init__("kinematics")
        declare_geometry_parameters(self)
        self.declare_parameter(
            "motor_joint_name", "carrier_joint",
            ParameterDescriptor(description="joint of motor/joint_state that is the carrier"),
        )  # fmt: skip
        self.declare_parameter(
            "frame_id", "tail_mechanism",
            ParameterDescriptor(
                description="frame of tail/tip: origin O (ring-gear centre), x back along the body "
                "towards the tail, y left, z down",
                read_only=True,
            ),
        )  # fmt: skip
        self.declare_parameter(
            "stale_timeout_sec", 2.0,
            float_descriptor("diagnostics say STALE after this long without input [s]", 0.1, 600.0),
        )  # fmt: skip
        self.declare_parameter(
            "markers_rate_hz", 30.0,
            float_descriptor("tail/markers publication rate, 0 = off [Hz]", 0.0, 100.0),
        )  # fmt: skip
        self.declare_parameter(
            "markers_trail_length", 90,
            ParameterDescriptor(
                description="tip positions in the marker trail, one per marker tick",
                integer_range=[IntegerRange(from_value=0, to_value=10000, step=1)],
            ),
        )  # fmt: skip
        for name, (default, text, low, high) in GUARD_PARAMETERS.items():
            self.declare_parameter(name, default, float_descriptor(text, low, high))
        self.tail = make_tail(geometry_from_parameters(geometry_parameter_values(self)))
        self.frame_id = self.get_parameter("frame_id").value
        self.motor_joint_name = self.get_parameter("motor_joint_name").value
        self._joint_index_cache: tuple[tuple[str, ...], int | None] = ((), None)
        self._previous_input: tuple[int, float] | None = None  # (stamp ns, angle) accepted
        self.received = 0
        self.guard = CarrierGuard()
        self.guard.apply_parameters(
            {
                name: self.get_parameter(name).value
                for name in (*GUARD_PARAMETERS, "stale_timeout_sec")
            }
        )
        self.drops = DropCounts((*GUARD_REASONS, NO_CARRIER_JOINT, ENGINE_REFUSED))
        self._drop_log = {
            reason: f"{INPUT_TOPIC} sample dropped: {text}" for reason, text in REASON_TEXT.items()
        }
        self.timing = StreamTiming()
        self.last_input_ns: int | None = None

        self.joint_states = JointState()
        self.tip = PointStamped()
        self.state = TailState()
        self._configure_messages()
        self.joint_publisher = self.create_publisher(
            JointState, "tail/joint_states", qos_profile_sensor_data
        )
        self.tip_publisher = self.create_publisher(
            PointStamped, "tail/tip", qos_profile_sensor_data
        )
        self.state_publisher = self.create_publisher(
            TailState, "tail/state", qos_profile_sensor_data
        )
        self.diagnostics_publisher = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.create_subscription(
            JointState, "motor/joint_state", self._on_motor_state, qos_profile_sensor_data
        )
        self.markers = TailMarkerPublisher(
            self, self.tail.geometry, self.frame_id,
            self.get_parameter("markers_rate_hz").value,
            self.get_parameter("markers_trail_length").value,
        )  # fmt: skip
        self.create_timer(DIAGNOSTICS_PERIOD_S, self._on_diagnostics)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.get_logger().info(f"kinematics up: {self._geometry_text()}")

    def _geometry_text(self) -> str:
        drive = self.tail.drive if isinstance(self.tail, UndulatoryTail) else self.tail
        return (
            f"{self.get_parameter(MECHANISM_PARAMETER).value} mechanism, swing range "
            f"{math.degrees(drive.swing_range_rad):.3f} deg"
        )

    def _configure_messages(self) -> None:
        undulatory = isinstance(self.tail, UndulatoryTail)
        self.joint_states.name = UNDULATORY_JOINTS if undulatory else OSCILLATORY_JOINTS
        self.tip.header.frame_id = self.frame_id
        self.state.header.frame_id = self.frame_id
        self.state.mechanism = (
            TailState.MECHANISM_UNDULATORY if undulatory else TailState.MECHANISM_OSCILLATORY
        )
        if not undulatory:
            for field in (
                "theta4", "theta4_dot", "pin_u_distance", "pin_u_distance_rate",
                "slider_a_distance", "slider_a_distance_rate", "theta5", "theta5_dot",
            ):  # fmt: skip
                setattr(self.state, field, _NAN)

    def _on_set_parameters(self, parameters) -> SetParametersResult:
        changed = {p.name: p.value for p in parameters}
        current = geometry_parameter_values(self)
        # `ros2 param load` sets every parameter of the file: only real changes rebuild and log.
        geometry = geometry_changes(current, changed)
        if geometry:
            values = {**current, **geometry_parameters_in(changed)}
            try:
                tail = make_tail(geometry_from_parameters(values))
            except FishtailKinematicsError as error:
                self.get_logger().warning(f"geometry change refused: {error}")
                return SetParametersResult(successful=False, reason=str(error))
            self.tail = tail
            self._configure_messages()
            self.markers.reset(tail.geometry)
            self.get_logger().info(f"geometry changed: {changes_text(geometry)}")
        if "motor_joint_name" in changed:
            self.motor_joint_name = changed["motor_joint_name"]
            self._joint_index_cache = ((), None)
        self._apply_marker_parameters(changed)
        self.guard.apply_parameters(changed)
        return SetParametersResult(successful=True)

    def _apply_marker_parameters(self, changed: dict) -> None:
        if "markers_rate_hz" in changed:
            self.markers.set_rate(changed["markers_rate_hz"])
        if "markers_trail_length" in changed:
            self.markers.set_trail_length(changed["markers_trail_length"])

    def _joint_index(self, names) -> int | None:
        key = tuple(names)
        cached_names, index = self._joint_index_cache
        if key != cached_names:
            index = key.index(self.motor_joint_name) if self.motor_joint_name in key else None
            self._joint_index_cache = (key, index)
        return index

    def _reject(self, reason: str, text: str) -> None:
        self.drops.count(reason)
        self.get_logger().warning(text, throttle_duration_sec=2.0)

    def _on_motor_state(self, message: JointState) -> None:
        self.received += 1
        now_ns = self.get_clock().now().nanoseconds
        self.last_input_ns = now_ns
        index = self._joint_index(message.name)
        if index is None or index >= len(message.position):
            self._reject(
                NO_CARRIER_JOINT,
                f"{INPUT_TOPIC} has no position for joint {self.motor_joint_name!r}",
            )
            return
        angle = message.position[index]
        stamp = message.header.stamp
        stamp_ns = stamp.sec * 1_000_000_000 + stamp.nanosec
        previous = self._previous_input
        if index < len(message.velocity):
            velocity = message.velocity[index]
        elif previous is not None and stamp_ns > previous[0]:
            velocity = (angle - previous[1]) / ((stamp_ns - previous[0]) * 1e-9)
        else:
            velocity = 0.0
        reason = self.guard.check(stamp_ns, angle, velocity, now_ns)
        if reason is not None:
            self._reject(reason, self._drop_log[reason])
            return
        self._previous_input = (stamp_ns, angle)
        self.timing.observe(stamp_ns * 1e-9)
        try:
            state = self.tail.solve(float(angle), float(velocity))
        except FishtailKinematicsError as error:
            # Cannot happen for a validated geometry and plausible input; if it does, one sample
            # is dropped and reported rather than the node dying.
            self._reject(ENGINE_REFUSED, f"engine refused carrier angle {angle!r}: {error}")
            return
        self.publish_state(state, stamp)
        self.markers.latest = (state, stamp)

    def publish_state(self, s, stamp) -> None:
        """Fill and publish the three tail messages from an engine state."""
        undulatory = isinstance(self.tail, UndulatoryTail)
        joints = self.joint_states
        joints.header.stamp = stamp
        if undulatory:
            joints.position = [s.theta1, s.theta2, s.theta3, s.theta4, s.theta5]
            joints.velocity = [s.theta1_dot, s.theta2_dot, s.theta3_dot, s.theta4_dot, s.theta5_dot]
        else:
            joints.position = [s.theta1, s.theta2, s.theta3]
            joints.velocity = [s.theta1_dot, s.theta2_dot, s.theta3_dot]
        self.joint_publisher.publish(joints)

        tip = self.tip
        tip.header.stamp = stamp
        tip.point.x = s.tip_x
        tip.point.y = s.tip_y
        self.tip_publisher.publish(tip)

        state = self.state
        state.header.stamp = stamp
        state.motor_angle = s.motor_angle
        state.motor_velocity = s.motor_velocity
        state.slider_position = s.slider_position
        state.slider_velocity = s.slider_velocity
        state.theta1 = s.theta1
        state.theta1_dot = s.theta1_dot
        state.theta2 = s.theta2
        state.theta2_dot = s.theta2_dot
        state.theta3 = s.theta3
        state.theta3_dot = s.theta3_dot
        if undulatory:
            state.theta4 = s.theta4
            state.theta4_dot = s.theta4_dot
            state.pin_u_distance = s.pin_u_distance
            state.pin_u_distance_rate = s.pin_u_distance_rate
            state.slider_a_distance = s.slider_a_distance
            state.slider_a_distance_rate = s.slider_a_distance_rate
            state.theta5 = s.theta5
            state.theta5_dot = s.theta5_dot
        state.tip.x = s.tip_x
        state.tip.y = s.tip_y
        state.tip_velocity.x = s.tip_x_dot
        state.tip_velocity.y = s.tip_y_dot
        self.state_publisher.publish(state)

    def _on_diagnostics(self) -> None:
        now_ns = self.get_clock().now().nanoseconds
        stale_after = self.get_parameter("stale_timeout_sec").value
        level, text, input_values = input_status(
            INPUT_TOPIC, self.drops, self.timing.take_period(), DIAGNOSTICS_PERIOD_S
        )
        if self.last_input_ns is None or (now_ns - self.last_input_ns) * 1e-9 > stale_after:
            level, text = LEVEL_STALE, f"no {INPUT_TOPIC} received recently"
        elif level == 0:
            text = f"{self._geometry_text()}; {text}"
        values = {
            "received": str(self.received),
            "rejected": str(self.drops.dropped),
            **input_values,
        }
        self.diagnostics_publisher.publish(
            diagnostic_array(self, "kinematics", level, text, values)
        )


def main() -> int:
    """Entry point of ``ros2 run fishtail_kinematics node``."""
    return run_node(KinematicsNode, "kinematics", (FishtailKinematicsError,))


if __name__ == "__main__":
    sys.exit(main())
