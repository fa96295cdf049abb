"""``fishtail-run``'s own node: the carrier's command or the route's goals, the latest values.

The status line it shows is made by :mod:`fishtail_bringup.console`'s plain functions.
"""

from __future__ import annotations

import math
import time

from fishtail_bringup.console import (
    fish_preparing_text,
    fish_text,
    level_name,
    motor_text,
    pilot_text,
    status_line,
    verdict_text,
)
from fishtail_common.interface import (
    DIAGNOSTICS,
    FISH_ODOM,
    GOAL_POSE,
    MOTOR_CMD_SPEED,
    MOTOR_JOINT_STATE,
    ODOM_FRAME,
    TAIL_STATE,
    TAIL_SYMMETRY,
)
from fishtail_pilot.route import GoalRoute

#: How often the carrier speed is sent (the driver's watchdog wants it at least every 0.5 s).
COMMAND_PERIOD_S = 0.1
#: How often the current waypoint is sent again (a goal sent before the pilot subscribed is lost).
GOAL_PERIOD_S = 1.0
#: The simulator's diagnostic value ``integrator`` while it prepares (compiles) its integrator.
INTEGRATOR_PREPARING = ("compiling", "loading", "preparing")


class Console:
    """The in-process node: commands the speed, keeps the latest values for the status line."""

    def __init__(
        self,
        speed_rad_s: float | None,
        namespace: str,
        say,
        swim: bool = False,
        route: GoalRoute | None = None,
    ) -> None:
        """Create the node with its publisher and subscriptions; ``say`` prints a line.

        ``swim``: also follow the simulated fish's odometry for the status line. ``route``: send
        its waypoints to the pilot on ``goal_pose`` in turn.
        """
        import rclpy
        from diagnostic_msgs.msg import DiagnosticArray
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64

        from fishtail_common.ros import publisher_qos, subscriber_qos
        from fishtail_msgs.msg import SymmetryReport, TailState

        self.rclpy = rclpy
        self.Float64 = Float64
        self.node = rclpy.create_node("fishtail_console", namespace=namespace or None)
        self.speed = speed_rad_s
        self.say = say
        self.state = None
        self.report = None
        self.fish = None
        self.swim = swim
        #: The torque on the carrier (motor/joint_state's effort) and the motor's current (the
        #: driver's /diagnostics), when the simulated motor has them.
        self.torque_n_m: float | None = None
        self.current_a: float | None = None
        self.diagnostics: dict[str, tuple[int, str]] = {}
        #: The simulator's integrator while it prepares: (phase, seconds so far, when received).
        self.integrator: tuple[str, float, float] | None = None
        # Only a console that commands the motor publishes the command topic: the computer that
        # does is the one whose loss the driver's watchdog answers.
        self.publisher = None
        if speed_rad_s is not None:
            self.publisher = self.node.create_publisher(
                Float64, MOTOR_CMD_SPEED.name, publisher_qos(MOTOR_CMD_SPEED)
            )
            self.node.create_timer(COMMAND_PERIOD_S, self.command)
        subscriptions = (
            (TailState, TAIL_STATE, self._on_state),
            (SymmetryReport, TAIL_SYMMETRY, self._on_report),
            (DiagnosticArray, DIAGNOSTICS, self._on_diagnostics),
            (JointState, MOTOR_JOINT_STATE, self._on_motor),
        )
        for message_type, topic, callback in subscriptions:
            self.node.create_subscription(message_type, topic.name, callback, subscriber_qos(topic))
        if swim:
            from nav_msgs.msg import Odometry

            self.node.create_subscription(
                Odometry, FISH_ODOM.name, self._on_fish, subscriber_qos(FISH_ODOM)
            )
        self.route = route
        #: The fish's odometry time [s] when the route's first goal was out: its start.
        self.route_started_s: float | None = None
        self.goal_sent = False
        self.goal_publisher = None
        if route is not None:
            from geometry_msgs.msg import PoseStamped

            self.goal = PoseStamped()
            self.goal.header.frame_id = ODOM_FRAME
            self.goal_publisher = self.node.create_publisher(
                PoseStamped, GOAL_POSE.name, publisher_qos(GOAL_POSE)
            )
            # Sent again every period: a goal published before the pilot subscribed is lost.
            self.node.create_timer(GOAL_PERIOD_S, self.send_goal)

    def send_goal(self) -> None:
        """Publish the route's current waypoint (nothing once the route is done)."""
        goal = None if self.route is None else self.route.current
        if goal is None or self.goal_publisher is None:
            return
        self.goal.header.stamp = self.node.get_clock().now().to_msg()
        self.goal.pose.position.x, self.goal.pose.position.y = goal
        self.goal_publisher.publish(self.goal)
        self.goal_sent = True

    def _on_state(self, message) -> None:
        self.state = message

    def _on_report(self, message) -> None:
        self.report = message

    def _on_fish(self, message) -> None:
        self.fish = message
        route = self.route
        if route is None:
            return
        reached = route.current
        position = message.pose.pose.position
        stamp = message.header.stamp
        now_s = stamp.sec + 1e-9 * stamp.nanosec
        if self.route_started_s is None and self.goal_sent:
            self.route_started_s = now_s
        how = route.update((position.x, position.y))
        if how is not None:
            assert reached is not None
            started = self.route_started_s
            into = "" if started is None else f", {now_s - started:.1f} s into the route"
            self.say(
                f"fishtail-run: waypoint ({reached[0]:g}, {reached[1]:g}) {how} at "
                f"({position.x:.3f}, {position.y:.3f}) m{into}"
                + ("; route done" if route.finished else "")
            )
            self.send_goal()

    def _on_motor(self, message) -> None:
        self.torque_n_m = float(message.effort[0]) if message.effort else None

    def _on_diagnostics(self, message) -> None:
        # Shown when a status changes level (and the first time, unless it is OK), so that a WARN
        # or ERROR from any node appears above the status line once, not every second.
        for status in message.status:
            values = {pair.key: pair.value for pair in status.values}
            if "current_a" in values:
                self.current_a = float(values["current_a"])
            if "integrator" in values:
                self._on_integrator(values)
            level = status.level[0]
            previous = self.diagnostics.get(status.name)
            self.diagnostics[status.name] = (level, status.message)
            if (previous is None and level != 0) or (previous is not None and previous[0] != level):
                name = level_name(level)
                self.say(f"[diagnostics] {status.name}: {name}: {status.message}")

    def _on_integrator(self, values: dict[str, str]) -> None:
        phase = values["integrator"]
        if phase not in INTEGRATOR_PREPARING:
            self.integrator = None
            return
        try:
            seconds = float(values.get("integrator_s", "0"))
        except ValueError:
            seconds = 0.0
        self.integrator = (phase, seconds, time.monotonic())

    def command(self, speed: float | None = None) -> None:
        """Publish the carrier speed (nothing when this console does not command the motor)."""
        value = self.speed if speed is None else speed
        if value is not None and self.publisher is not None:
            self.publisher.publish(self.Float64(data=value))

    def line(self, elapsed_s: float) -> str:
        """The current status line."""
        state = self.state
        report = self.report
        verdict = verdict_text(
            None if report is None else report.beat_index,
            None if report is None else report.verdict,
            "" if report is None else report.message,
        )
        line = status_line(
            elapsed_s,
            None if state is None else state.motor_velocity,
            None if state is None else state.motor_angle,
            None if state is None else state.theta3,
            None if state is None else (state.tip.x, state.tip.y),
            verdict,
        )
        if self.torque_n_m is not None:
            line += " | " + motor_text(self.torque_n_m, self.current_a)
        return line + (" | " + self._fish_part() if self.swim else "")

    def _fish_part(self) -> str:
        if self.integrator is not None:
            # Compiling on a first run: say so rather than show a fish that does not move.
            phase, seconds, received = self.integrator
            return fish_preparing_text(phase, seconds + time.monotonic() - received)
        fish = self.fish
        if fish is None:
            return fish_text(None, None)
        twist, orientation = fish.twist.twist.linear, fish.pose.pose.orientation
        heading = 2.0 * math.atan2(orientation.z, orientation.w)
        if self.route is None:
            return fish_text(math.hypot(twist.x, twist.y), heading)
        position = fish.pose.pose.position
        return f"{math.hypot(twist.x, twist.y):.3f} m/s " + pilot_text(
            (position.x, position.y), heading, self.route.current
        )
