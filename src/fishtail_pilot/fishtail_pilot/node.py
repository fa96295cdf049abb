"""Pilot node: ``cmd_vel`` and ``goal_pose`` in, carrier speed profile and pivot position out.

A thin rclpy shell around the control law :class:`fishtail_pilot.pilot.Pilot`, so that the fish
is driven like any mobile base; its steering map is built at start-up from the same tail and fish
parameter files as the simulator's (:func:`fishtail_pilot.steering.steering_from_values`). It
stops the carrier when ``cmd_vel`` or the odometry stop. Topics, parameters and behaviour:
docs/steering.md ("The pilot").
"""

from __future__ import annotations

import math
import sys
from typing import Any

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import SetParametersResult
from rclpy.parameter import Parameter
from std_msgs.msg import Float64

from fishtail_common.interface import (
    CMD_VEL,
    DIAGNOSTICS,
    FISH_ODOM,
    GOAL_POSE,
    MOTOR_CMD_PROFILE,
    ODOM_FRAME,
    PIVOT_CMD_POSITION,
    Level,
    Status,
)
from fishtail_common.parameters import ParameterSpec, ParameterValueError, read_only
from fishtail_common.ros import (
    NodeFactory,
    SuiteNodeBase,
    declare,
    diagnostic_array,
    run_node,
    subscriber_qos,
    suite_publisher,
)
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
from fishtail_kinematics.engine.errors import FishtailKinematicsError
from fishtail_msgs.msg import CarrierSpeedProfile as ProfileMessage
from fishtail_pilot.pilot import (
    CONTROL_PARAMETERS,
    Mode,
    Pilot,
    PilotCommand,
    PilotSettings,
    goal_distance_text,
)
from fishtail_pilot.steering import STEERING_PARAMETERS, steering_from_values
from fishtail_plant.errors import SwimError
from fishtail_plant.fish.fish import FISH_PARAMETERS
from fishtail_plant.values import TAIL_PARAMETERS, fish_from_values, tail_from_values

DIAGNOSTICS_PERIOD_S = 1.0
#: At most one "goal ... m to go" line this often (s).
GOAL_LOG_PERIOD_S = 2.0
STOPPED = CarrierSpeedProfile(0.0)
CMD_TIMEOUT = ParameterSpec(
    "cmd_timeout_sec", 0.5,
    "stop the carrier when no cmd_vel arrives for this long (0: never; goals need no repeating)",
    "s", 0.0, 60.0,
)  # fmt: skip
ODOM_TIMEOUT = ParameterSpec(
    "odom_timeout_sec", 1.0, "stop the carrier when fish/odom stops for this long", "s", 0.05, 60.0
)
CONTROL_RATE = ParameterSpec(
    "control_rate_hz", 20.0, "how often the carrier command is sent while moving", "Hz", 1.0, 200.0
)


#: Set at run time, these take effect at once: each is a number the node reads on every tick or
#: send, and retuning a timeout or the command rate on a running fish is ordinary operation.
LIVE_PARAMETERS: tuple[ParameterSpec, ...] = (CMD_TIMEOUT, ODOM_TIMEOUT, CONTROL_RATE)

#: Every parameter of the node. The fish, the tail and the steering are fixed for its run (the
#: steering map is built from them at start-up), and so are the gains and limits (the law's
#: frozen PilotSettings); ROS refuses to set a read-only one.
PARAMETERS: tuple[ParameterSpec, ...] = (
    *read_only((*TAIL_PARAMETERS, *FISH_PARAMETERS, *STEERING_PARAMETERS)),
    *read_only(CONTROL_PARAMETERS),
    *LIVE_PARAMETERS,
)



def _number_or_empty(value: float) -> str:
    return "" if math.isnan(value) else f"{value:.4g}"

class PilotNode(SuiteNodeBase):
    """Thin shell around :class:`Pilot`."""

    def __init__(self, **node_options: Any) -> None:
        """Declare parameters, build the steering map (a few seconds), wire the topics."""
        super().__init__("pilot", **node_options)
        values = declare(self, PARAMETERS)
        tail = tail_from_values(values)
        fish = fish_from_values(values)
        steering, speed_per_beat_m = steering_from_values(values, tail, fish)
        settings = PilotSettings(
            speed_per_beat_m=speed_per_beat_m,
            **{spec.name: float(values[spec.name]) for spec in CONTROL_PARAMETERS},
        )
        self.pilot = Pilot(settings, steering)
        self.cmd_timeout_ns = 0
        self.odom_timeout_ns = 0
        self.control_period_ns = 0
        for spec in LIVE_PARAMETERS:
            self._apply(spec.name, float(values[spec.name]))
        self.last_cmd_ns: int | None = None
        self.last_odom_ns: int | None = None
        #: The odometry's frame (the simulator's odom_frame_id), where goals are flown.
        self.odom_frame = ODOM_FRAME
        self.last_sent_ns: int | None = None
        # The carrier is taken as stopped at start-up: an idle pilot sends nothing until it has
        # something to move (manual commands beside it stay in charge).
        self.sent: PilotCommand = self.pilot.command
        self.refusals: list[str] = []
        #: The latest refusal logged, until a command or goal is accepted.
        self.last_refusal: str | None = None
        self.odometry_lost = False
        self.dropped_reported = 0
        self.profile_message = ProfileMessage()
        self.pivot_message = Float64()

        self.profile_publisher = suite_publisher(self, ProfileMessage, MOTOR_CMD_PROFILE)
        self.pivot_publisher = (
            suite_publisher(self, Float64, PIVOT_CMD_POSITION)
            if steering.command(0.0).pivot_shift_m is not None
            else None
        )
        self.diagnostics_publisher = suite_publisher(self, DiagnosticArray, DIAGNOSTICS)
        self.create_subscription(Twist, CMD_VEL.name, self._on_cmd_vel, subscriber_qos(CMD_VEL))
        self.create_subscription(
            PoseStamped, GOAL_POSE.name, self._on_goal, subscriber_qos(GOAL_POSE)
        )
        self.create_subscription(Odometry, FISH_ODOM.name, self._on_odom, subscriber_qos(FISH_ODOM))
        self.create_timer(0.05, self._on_watchdog)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.create_timer(DIAGNOSTICS_PERIOD_S, self._on_diagnostics)
        low, high = steering.yaw_per_beat_range_rad
        self.get_logger().info(
            f"pilot up: {steering.name} steering, {speed_per_beat_m:.4g} m per beat, yaw per beat "
            f"{low:.4g} to {high:.4g} rad (tightest turn: radius "
            f"{self.pilot.min_turning_radius_m(1.0):.3g} m left, "
            f"{self.pilot.min_turning_radius_m(-1.0):.3g} m right)"
        )

    def _apply(self, name: str, value: float) -> None:
        """Put a live parameter's value in force."""
        if name == CMD_TIMEOUT.name:
            self.cmd_timeout_ns = round(value * 1e9)
        elif name == ODOM_TIMEOUT.name:
            self.odom_timeout_ns = round(value * 1e9)
        elif name == CONTROL_RATE.name:
            self.control_period_ns = round(1e9 / value)

    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        # Read-only parameters and ranges are refused by the descriptors before this runs; the
        # specs check again, so that a value is applied only if every one in the call is valid.
        specs = {spec.name: spec for spec in LIVE_PARAMETERS}
        checked = []
        for parameter in parameters:
            spec = specs.get(parameter.name)
            if spec is None:
                continue  # not a live one (use_sim_time ...)
            try:
                checked.append((parameter.name, float(spec.check(parameter.value))))
            except ParameterValueError as error:
                return SetParametersResult(successful=False, reason=str(error))
        for name, value in checked:
            self._apply(name, value)
            self.get_logger().info(f"{name} = {value:g}: in force now")
        return SetParametersResult(successful=True)

    def _now_ns(self) -> int:
        return int(self.get_clock().now().nanoseconds)

    def _refuse(self, reason: str) -> None:
        self.refusals.append(reason)
        # The same refusal again (fishtail-run sends its goal every second) goes to
        # /diagnostics, not to the log a line every few seconds.
        if reason != self.last_refusal:
            self.get_logger().warning(reason, throttle_duration_sec=2.0)
        self.last_refusal = reason

    def _on_cmd_vel(self, message: Twist) -> None:
        reason = self.pilot.set_velocity(float(message.linear.x), float(message.angular.z))
        if reason is not None:
            self._refuse(reason)
            return
        self.last_cmd_ns = self._now_ns()
        self.last_refusal = None

    def _on_goal(self, message: PoseStamped) -> None:
        frame = message.header.frame_id
        if frame not in ("", self.odom_frame):
            # No tf here to relate another frame (map, ...) to the odometry: refused, never
            # flown as if it were the odometry frame.
            self._refuse(
                f"goal_pose in frame {frame!r} refused: goals are in the odometry frame "
                f"{self.odom_frame!r} (or an empty frame_id)"
            )
            return
        position = message.pose.position
        reason = self.pilot.set_goal(float(position.x), float(position.y))
        if reason is not None:
            self._refuse(reason)
            return
        self.last_refusal = None
        # Throttled: a burst of goals (a script, a stuck button) does not flood the log; the
        # latest goal is always on /diagnostics.
        self.get_logger().info(
            f"goal ({position.x:.3f}, {position.y:.3f}) m: "
            f"{goal_distance_text(self.pilot.distance_to_goal_m())}",
            throttle_duration_sec=GOAL_LOG_PERIOD_S,
        )

    def _on_odom(self, message: Odometry) -> None:
        if message.header.frame_id:
            self.odom_frame = message.header.frame_id
        now_ns = self._now_ns()
        self.last_odom_ns = now_ns
        if self.odometry_lost:
            self.odometry_lost = False
            self.get_logger().info(f"{FISH_ODOM.name} is back: {self.pilot.mode.value} resumed")
        stamp = message.header.stamp
        pose = message.pose.pose
        orientation = pose.orientation
        yaw = 2.0 * math.atan2(orientation.z, orientation.w)
        was_goal = self.pilot.mode is Mode.GOAL
        was_valid = self.pilot.feedback_valid
        command = self.pilot.observe(
            stamp.sec + stamp.nanosec * 1e-9,
            pose.position.x,
            pose.position.y,
            yaw,
            message.twist.twist.linear.x,
            message.twist.twist.angular.z,
        )
        if was_valid and not self.pilot.feedback_valid:
            self.get_logger().error(
                f"{FISH_ODOM.name} not finite: sample dropped, carrier stopped until a finite one",
                throttle_duration_sec=2.0,
            )
        elif self.pilot.feedback_valid and not was_valid:
            self.get_logger().info(
                f"{FISH_ODOM.name} finite again: {self.pilot.mode.value} resumed"
            )
        if was_goal and self.pilot.goal_reached:
            self.get_logger().info(
                f"goal reached: fish at ({pose.position.x:.3f}, {pose.position.y:.3f}) m"
            )
        refusal = self.pilot.pop_refusal()
        if refusal is not None:
            # Given up in flight (or judged on the first odometry): said as a refused goal is.
            self._refuse(refusal)
        self._send(command, now_ns)

    def _send(self, command: PilotCommand, now_ns: int, force: bool = False) -> None:
        """Publish ``command``: a moving one at the control rate, a stop once, then silence."""
        stop = command.carrier.mean_speed_rad_s == 0.0
        if stop and not force:
            # A new stop goes out at once, a stop already sent never again: idle, the pilot
            # leaves the motor to whoever else commands it (the driver's watchdog stops it).
            if command == self.sent:
                return
        elif not force:
            due = self.last_sent_ns is None or now_ns - self.last_sent_ns >= self.control_period_ns
            if not due:
                return
        profile = command.carrier
        message = self.profile_message
        message.mean_speed = profile.mean_speed_rad_s
        message.modulation_depth = profile.depth
        message.modulation_phase = profile.phase_rad
        self.profile_publisher.publish(message)
        if self.pivot_publisher is not None and command.pivot_shift_m is not None:
            self.pivot_message.data = command.pivot_shift_m
            self.pivot_publisher.publish(self.pivot_message)
        self.sent = command
        self.last_sent_ns = now_ns

    def _on_watchdog(self) -> None:
        now_ns = self._now_ns()
        pilot = self.pilot
        if (
            pilot.mode is Mode.VELOCITY
            and self.cmd_timeout_ns > 0
            and self.last_cmd_ns is not None
            and now_ns - self.last_cmd_ns > self.cmd_timeout_ns
        ):
            self.get_logger().info("no cmd_vel for cmd_timeout_sec: stopping the carrier")
            self._send(pilot.stop(), now_ns, force=True)
        if (
            pilot.mode is not Mode.IDLE
            and not self.odometry_lost
            and self.last_odom_ns is not None
            and now_ns - self.last_odom_ns > self.odom_timeout_ns
        ):
            # Blind, the carrier stops; the command or the goal stands, and the pilot resumes
            # when odometry comes back.
            self.odometry_lost = True
            self.get_logger().error(f"no {FISH_ODOM.name}: carrier stopped until it is back")
            self._send(PilotCommand(STOPPED, pilot.command.pivot_shift_m), now_ns, force=True)

    def _on_diagnostics(self) -> None:
        pilot = self.pilot
        level, text = Level.OK, f"{pilot.mode.value}"
        values = {
            "mode": pilot.mode.value,
            "speed_command_m_s": f"{pilot.speed_command_m_s:.4g}",
            "yaw_rate_command_rad_s": f"{pilot.yaw_rate_command_rad_s:.4g}",
            "mean_speed_m_s": f"{pilot.mean_speed_m_s:.4g}",
            "mean_heading_rad": f"{pilot.mean_heading_rad:.4g}",
            "x_m": f"{pilot.position_m[0]:.4g}",
            "y_m": f"{pilot.position_m[1]:.4g}",
            # Empty while the fish's position is unknown (before the first odometry).
            "distance_to_goal_m": _number_or_empty(pilot.distance_to_goal_m()),
            "carrier_mean_speed_rad_s": f"{pilot.command.carrier.mean_speed_rad_s:.4g}",
            "modulation_depth": f"{pilot.command.carrier.depth:.4g}",
        }
        values["dropped_odometry_samples"] = str(pilot.dropped_samples)
        if pilot.goal is not None:
            values["goal_x_m"] = f"{pilot.goal[0]:.4g}"
            values["goal_y_m"] = f"{pilot.goal[1]:.4g}"
        if pilot.command.pivot_shift_m is not None:
            values["pivot_shift_m"] = f"{pilot.command.pivot_shift_m:.4g}"
        if pilot.mode is Mode.GOAL:
            text = f"to goal: {goal_distance_text(pilot.distance_to_goal_m())}"
        elif pilot.goal_reached:
            text = "goal reached"
        for report in pilot.limit_reports.values():
            level = Level.WARN
            values[f"achievable_{report.quantity}_{report.unit.replace('/', '_')}"] = (
                f"{report.achievable:.4g}"
            )
            text = (
                f"{report.quantity} {report.requested:.4g} {report.unit} is beyond reach: "
                f"{report.achievable:.4g} {report.unit} at most ({report.reason})"
            )
        if self.refusals:
            level = Level.WARN
            text = f"refused: {self.refusals[-1]}"
            values["refused"] = str(len(self.refusals))
            self.refusals.clear()
        dropped = pilot.dropped_samples - self.dropped_reported
        self.dropped_reported = pilot.dropped_samples
        if dropped and level is Level.OK:
            level = Level.WARN
            text = f"{dropped} {FISH_ODOM.name} samples not finite, dropped"
        if not pilot.feedback_valid:
            level, text = Level.ERROR, f"{FISH_ODOM.name} not finite: carrier stopped"
        if self.odometry_lost:
            level, text = Level.ERROR, f"no {FISH_ODOM.name}: carrier stopped"
        elif self.last_odom_ns is None:
            level, text = Level.STALE, f"no {FISH_ODOM.name} received yet"
        self.diagnostics_publisher.publish(
            diagnostic_array(self, Status("pilot", level, text, values))
        )


#: How a process creates this node (its own ``main``, or ``fishtail-run --one-process``).
FACTORY = NodeFactory(PilotNode, "pilot", (FishtailKinematicsError, SwimError))


def main() -> int:
    """Entry point of ``ros2 run fishtail_swim pilot``."""
    return run_node(FACTORY.create, FACTORY.label, FACTORY.startup_errors)


if __name__ == "__main__":
    sys.exit(main())
