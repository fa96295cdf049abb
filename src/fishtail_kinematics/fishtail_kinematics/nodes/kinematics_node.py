"""Kinematics node: carrier angle in, tail pose out.

A thin rclpy shell around the engine: every plausible ``motor/joint_state`` sample (the input
guard drops the others) is solved with the latest pivot shift and published as
``tail/joint_states``, ``tail/tip`` and ``tail/state``, stamped like the encoder sample, with
RViz markers on a timer and its input's health on ``/diagnostics``. Geometry changes are
validated by the engine; a refused one leaves the previous geometry in force. Topics and
parameters: README.md ("Topics", "Parameters"); input rules, pivot shift and diagnostics:
docs/kinematics.md; markers: docs/visualisation.md.
"""

from __future__ import annotations

import math
import operator
import sys
from collections.abc import Callable
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PointStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState

from fishtail_common.interface import (
    DIAGNOSTICS,
    MECHANISM_CODES,
    MOTOR_JOINT_STATE,
    PIVOT_JOINT,
    PIVOT_JOINT_STATE,
    TAIL_FRAME,
    TAIL_JOINT_STATES,
    TAIL_STATE,
    TAIL_TIP,
    Level,
    Status,
)
from fishtail_common.parameters import ParameterSpec, ParameterValueError
from fishtail_common.ros import (
    ListenedPublisher,
    NodeFactory,
    SuiteNodeBase,
    declare,
    diagnostic_array,
    run_node,
    subscriber_qos,
    suite_publisher,
)
from fishtail_common.stream_timing import PersistentStatus, StreamTiming
from fishtail_kinematics.engine.errors import FishtailKinematicsError
from fishtail_kinematics.engine.geometry import (
    GEOMETRY_PARAMETERS,
    LinkageState,
)
from fishtail_kinematics.engine.input_guard import (
    ENGINE_REFUSED,
    FOLLOWER_REASONS,
    GUARD_PARAMETERS,
    MOTOR_JOINT_NAME,
    NO_CARRIER_JOINT,
    REASON_TEXT,
    STALE_TIMEOUT,
    CarrierGuard,
    CarrierJoint,
    DropCounts,
    input_status,
)
from fishtail_kinematics.engine.mechanisms import Tail, make_tail
from fishtail_kinematics.engine.parameters import (
    GEOMETRY_PARAMETER_NAMES,
    MECHANISM,
    changes_text,
    geometry_changes,
    geometry_from_parameters,
    geometry_parameters_in,
)
from fishtail_kinematics.nodes.marker_publisher import (
    MARKER_PARAMETERS,
    MARKERS_RATE,
    MARKERS_TRAIL_LENGTH,
    TailMarkerPublisher,
)
from fishtail_msgs.msg import TailState

INPUT_TOPIC = MOTOR_JOINT_STATE.name
DIAGNOSTICS_PERIOD_S = 1.0

FRAME_ID = ParameterSpec(
    "frame_id",
    TAIL_FRAME,
    f"frame of {TAIL_TIP.name}: origin O (ring-gear centre), x back along the body towards the "
    "tail, y left, z down",
    read_only=True,
)
#: Every parameter of the node.
PARAMETERS: tuple[ParameterSpec, ...] = (
    MECHANISM,
    *GEOMETRY_PARAMETERS,
    MOTOR_JOINT_NAME,
    FRAME_ID,
    STALE_TIMEOUT,
    *MARKER_PARAMETERS,
    *GUARD_PARAMETERS,
)
#: Engine state fields that TailState carries in a nested message (the tip and its velocity).
_NESTED_FIELDS = frozenset({"tip_x", "tip_y", "tip_x_dot", "tip_y_dot"})
_TAIL_STATE_FLOATS = tuple(
    name for name, kind in TailState.get_fields_and_field_types().items() if kind == "double"
)
_NAN = float("nan")


class KinematicsNode(SuiteNodeBase):
    """Thin shell around the engine: messages in, messages out, parameters validated."""

    def __init__(self, **node_options: Any) -> None:
        """Declare parameters, build the engine (raises on an infeasible geometry), wire topics."""
        super().__init__("kinematics", **node_options)
        values = declare(self, PARAMETERS)
        #: The tail every carrier sample is solved with: the design's, S shifted by the latest
        #: pivot/joint_state the engine accepted.
        self.tail = make_tail(geometry_from_parameters(geometry_parameters_in(values)))
        self.pivot_refused = 0  # pivot shifts the engine refused, since start
        self._pivot_refusal = ""  # why the latest pivot/joint_state was refused
        self._pivot_refusal_in_period = False
        self.frame_id = str(values[FRAME_ID.name])
        self.motor_joint_name = str(values[MOTOR_JOINT_NAME.name])
        self.stale_timeout_s = float(values[STALE_TIMEOUT.name])
        self.carrier_joint = CarrierJoint(self.motor_joint_name)
        self._previous_input: tuple[int, float] | None = None  # (stamp ns, angle) accepted
        self.received = 0
        self.guard = CarrierGuard()
        self.guard.apply_parameters(values)
        self.drops = DropCounts(FOLLOWER_REASONS)
        self._drop_log = {
            reason: f"{INPUT_TOPIC} sample dropped: {text}" for reason, text in REASON_TEXT.items()
        }
        self.timing = StreamTiming()
        # Gaps and rate WARN once they persist, OK once cleared (no flapping).
        self.timing_status = PersistentStatus()
        self.last_input_ns: int | None = None

        self.joint_states = JointState()
        self.tip = PointStamped()
        self.state = TailState()
        self._joint_positions: Callable[[LinkageState], Any] = operator.attrgetter("theta1")
        self._joint_rates: Callable[[LinkageState], Any] = operator.attrgetter("theta1_dot")
        self._copied_fields: tuple[str, ...] = ()
        self._configure_messages()
        # A message that nobody subscribes to is not built (ListenedPublisher).
        self.joint_publisher = ListenedPublisher(self, JointState, TAIL_JOINT_STATES)
        self.tip_publisher = ListenedPublisher(self, PointStamped, TAIL_TIP)
        self.state_publisher = ListenedPublisher(self, TailState, TAIL_STATE)
        self.diagnostics_publisher = suite_publisher(self, DiagnosticArray, DIAGNOSTICS)
        self.create_subscription(
            JointState, INPUT_TOPIC, self._on_motor_state, subscriber_qos(MOTOR_JOINT_STATE)
        )
        self.create_subscription(
            JointState,
            PIVOT_JOINT_STATE.name,
            self._on_pivot_state,
            subscriber_qos(PIVOT_JOINT_STATE),
        )
        self.markers = TailMarkerPublisher(
            self,
            self.tail,
            self.frame_id,
            float(values[MARKERS_RATE.name]),
            int(values[MARKERS_TRAIL_LENGTH.name]),
        )
        self.create_timer(DIAGNOSTICS_PERIOD_S, self._on_diagnostics)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.get_logger().info(f"kinematics up: {self._geometry_text()}")

    def _geometry_text(self) -> str:
        text = (
            f"{self.tail.name} mechanism, swing range "
            f"{math.degrees(self.tail.drive.swing_range_rad):.3f} deg"
        )
        if self.tail.pivot_shift_m != 0.0:
            text += (
                f", pivot shifted {1000.0 * self.tail.pivot_shift_m:+.2f} mm (swing bias "
                f"{math.degrees(self.tail.swing_bias_rad):+.3f} deg)"
            )
        return text

    def _configure_messages(self) -> None:
        """Set what the tail's mechanism decides once: joint names, fields to copy, NaN fields."""
        tail: Tail = self.tail
        self.joint_states.name = list(tail.joint_names)
        self._joint_positions = operator.attrgetter(*tail.joint_names)
        self._joint_rates = operator.attrgetter(*tail.joint_rate_names())
        # TailState carries the fin angle but not its rate (fin_angle_dot is theta3_dot or
        # theta5_dot, which it has).
        self._copied_fields = tuple(
            name
            for name in tail.state_fields
            if name not in _NESTED_FIELDS and name in _TAIL_STATE_FLOATS
        )
        self.tip.header.frame_id = self.frame_id
        self.state.header.frame_id = self.frame_id
        self.state.mechanism = MECHANISM_CODES[tail.name]
        for name in _TAIL_STATE_FLOATS:
            if name not in tail.state_fields:
                setattr(self.state, name, _NAN)  # a field of another mechanism
        # Not state fields: the tail's own, set again whenever the pivot moves.
        self.state.pivot_shift = tail.pivot_shift_m
        self.state.swing_bias = tail.swing_bias_rad

    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        changed = {p.name: p.value for p in parameters}
        if MOTOR_JOINT_NAME.name in changed:
            # The descriptor cannot say "not empty"; an empty name would drop every sample.
            try:
                MOTOR_JOINT_NAME.check(changed[MOTOR_JOINT_NAME.name])
            except ParameterValueError as error:
                return SetParametersResult(successful=False, reason=str(error))
        current = {name: self.get_parameter(name).value for name in GEOMETRY_PARAMETER_NAMES}
        # `ros2 param load` sets every parameter of the file: only real changes rebuild and log.
        geometry = geometry_changes(current, changed)
        if geometry:
            values = {**current, **geometry_parameters_in(changed)}
            try:
                # The pivot stays where the actuator holds it: the new links must assemble there.
                tail = make_tail(geometry_from_parameters(values)).with_pivot_shift(
                    self.tail.pivot_shift_m
                )
            except FishtailKinematicsError as error:
                self.get_logger().warning(f"geometry change refused: {error}")
                return SetParametersResult(successful=False, reason=str(error))
            self.tail = tail
            self._configure_messages()
            self.markers.reset(tail)
            self.get_logger().info(f"geometry changed: {changes_text(geometry)}")
        if MOTOR_JOINT_NAME.name in changed:
            self.motor_joint_name = changed[MOTOR_JOINT_NAME.name]
            self.carrier_joint.rename(self.motor_joint_name)
        if STALE_TIMEOUT.name in changed:
            self.stale_timeout_s = changed[STALE_TIMEOUT.name]
        if MARKERS_RATE.name in changed:
            self.markers.set_rate(changed[MARKERS_RATE.name])
        if MARKERS_TRAIL_LENGTH.name in changed:
            self.markers.set_trail_length(changed[MARKERS_TRAIL_LENGTH.name])
        self.guard.apply_parameters(changed)
        return SetParametersResult(successful=True)

    def _on_pivot_state(self, message: JointState) -> None:
        """Swap to the tail with S where the actuator says it is, if the engine accepts it."""
        try:
            shift = message.position[list(message.name).index(PIVOT_JOINT)]
        except (ValueError, IndexError):
            self._refuse_pivot(f"no position for joint {PIVOT_JOINT!r}")
            return
        if shift == self.tail.pivot_shift_m:
            return
        try:
            # About 15 us for mechanism 1, 0.3 ms for mechanism 2 (its first shift: some 50 ms).
            tail = self.tail.with_pivot_shift(shift)
        except FishtailKinematicsError as error:
            self._refuse_pivot(str(error))
            return
        self.tail = tail
        self.state.pivot_shift = tail.pivot_shift_m
        self.state.swing_bias = tail.swing_bias_rad
        self.markers.set_tail(tail)

    def _refuse_pivot(self, reason: str) -> None:
        self.pivot_refused += 1
        self._pivot_refusal = (
            f"{PIVOT_JOINT_STATE.name} refused, solving with the pivot shifted "
            f"{self.tail.pivot_shift_m!r} m: {reason}"
        )
        self._pivot_refusal_in_period = True
        self.get_logger().warning(self._pivot_refusal, throttle_duration_sec=2.0)

    def _reject(self, reason: str, text: str) -> None:
        self.drops.count(reason)
        self.get_logger().warning(text, throttle_duration_sec=2.0)

    def _on_motor_state(self, message: JointState) -> None:
        self.received += 1
        now_ns = self.get_clock().now().nanoseconds
        self.last_input_ns = now_ns
        index = self.carrier_joint.index(message.name)
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

    def publish_state(self, s: LinkageState, stamp: Any) -> None:
        """Fill and publish the three tail messages from an engine state, those anyone wants."""
        if self.joint_publisher.listened:
            joints = self.joint_states
            joints.header.stamp = stamp
            joints.position = self._joint_positions(s)
            joints.velocity = self._joint_rates(s)
            self.joint_publisher.publish(joints)

        if self.tip_publisher.listened:
            tip = self.tip
            tip.header.stamp = stamp
            tip.point.x = s.tip_x
            tip.point.y = s.tip_y
            self.tip_publisher.publish(tip)

        if not self.state_publisher.listened:
            return
        state = self.state
        state.header.stamp = stamp
        for name in self._copied_fields:
            setattr(state, name, getattr(s, name))
        state.tip.x = s.tip_x
        state.tip.y = s.tip_y
        state.tip_velocity.x = s.tip_x_dot
        state.tip_velocity.y = s.tip_y_dot
        self.state_publisher.publish(state)

    def _on_diagnostics(self) -> None:
        now_ns = self.get_clock().now().nanoseconds
        level, text, input_values = input_status(
            INPUT_TOPIC,
            self.drops,
            self.timing.take_period(),
            DIAGNOSTICS_PERIOD_S,
            self.timing_status,
        )
        if (
            self.last_input_ns is None
            or (now_ns - self.last_input_ns) * 1e-9 > self.stale_timeout_s
        ):
            level, text = Level.STALE, f"no {INPUT_TOPIC} received recently"
        elif level == Level.OK:
            text = f"{self._geometry_text()}; {text}"
        if self._pivot_refusal_in_period:
            text = f"{self._pivot_refusal}; {text}"
            if level == Level.OK:
                level = Level.WARN
        self._pivot_refusal_in_period = False
        values = {
            "received": str(self.received),
            "rejected": str(self.drops.dropped),
            "pivot_shift_m": f"{self.tail.pivot_shift_m!r}",
            "swing_bias_deg": f"{math.degrees(self.tail.swing_bias_rad):.6f}",
            "pivot_refused": str(self.pivot_refused),
            **input_values,
        }
        self.diagnostics_publisher.publish(
            diagnostic_array(self, Status("kinematics", level, text, values))
        )


#: How a process creates this node (its own ``main``, or ``fishtail-run --one-process``).
FACTORY = NodeFactory(KinematicsNode, "kinematics", (FishtailKinematicsError,))


def main() -> int:
    """Entry point of ``ros2 run fishtail_kinematics node``."""
    return run_node(FACTORY.create, FACTORY.label, FACTORY.startup_errors)


if __name__ == "__main__":
    sys.exit(main())
