"""Driver node: commands the carrier speed and publishes the encoder angle.

The one node that owns the motor (through a backend of :mod:`fishtail_driver.backends`): it
follows ``motor/cmd_speed`` or a ``motor/cmd_profile`` at every encoder sample (or lets the
motor board follow it, where its firmware can: docs/serial.md), publishes
``motor/joint_state`` stamped when the encoder was read, reports on ``/diagnostics``, and stops
the motor from its own watchdog when commands stop and before it exits. All callbacks run on one
thread, so the node's state needs no lock (the serial backend locks its own). Topics and
parameters: README.md ("Topics", "Parameters"), docs/serial.md, docs/motor-load.md ("Running the
suite on the loaded motor").
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray
from rcl_interfaces.msg import SetParametersResult
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from fishtail_common.interface import (
    DIAGNOSTICS,
    MOTOR_CMD_PROFILE,
    MOTOR_CMD_SPEED,
    MOTOR_JOINT_STATE,
    Level,
    Status,
)
from fishtail_common.parameters import ParameterValue, ParameterValueError
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
from fishtail_common.stream_timing import PersistentStatus, RateCheck
from fishtail_driver.backends import StopOutcome
from fishtail_driver.board_profile import TUNING_NOT_SET
from fishtail_driver.parameters import (
    DRIVER_PARAMETERS,
    SPECS,
    ParameterValues,
    load_refusal,
    make_backend,
    pivot_refusal,
)
from fishtail_driver.pivot_output import make_pivot_output
from fishtail_driver.profile_command import CarrierCommand, CommandRefusedError
from fishtail_driver.stamping import ClockMapping, IncreasingStamps
from fishtail_msgs.msg import CarrierSpeedProfile
from fishtail_plant.linkage_load.surroundings import NO_LOAD
from fishtail_plant.values import read_only_load_parameters, tail_load_from_values

if TYPE_CHECKING:
    from fishtail_plant.linkage_load.tail_load import TailLoad

#: A backend keeps a non-zero speed alive for cmd_timeout_sec plus this [s].
COMMAND_HOLD_MARGIN_S = 0.25
#: The watchdog is checked at least this often [s].
WATCHDOG_PERIOD_MAX_S = 0.05
#: The sample rate is measured over max(diagnostics_period_sec, this) [s]: a shorter window holds
#: too few samples for a rate (at 100 Hz, one sample more or less in 0.2 s is 5 %).
RATE_WINDOW_MIN_S = 1.0


def watchdog_period_s(cmd_timeout_sec: float) -> float:
    """How often to check the watchdog: a quarter of the timeout, at most 50 ms, at least 5 ms."""
    if cmd_timeout_sec <= 0.0:
        return WATCHDOG_PERIOD_MAX_S
    return min(WATCHDOG_PERIOD_MAX_S, max(cmd_timeout_sec / 4.0, 0.005))


class DriverNode(SuiteNodeBase):
    """Thin shell: parameters, command watchdog, publishing and diagnostics around a backend."""

    def __init__(self, **node_options: Any) -> None:
        """Declare parameters, start the backend and the timers.

        ``node_options`` go to :class:`rclpy.node.Node` (``context``, ``parameter_overrides`` ...).

        Raises:
            ValueError: with the reason, for a value the parameters, the load or the backend
                refuse, before anything is opened.
        """
        super().__init__("driver", **node_options)
        values = declare(self, DRIVER_PARAMETERS)
        self.cmd_timeout_sec = float(values["cmd_timeout_sec"])
        self.motor_load = str(values["motor_load"])
        reason = pivot_refusal(values)
        if reason is not None:
            raise ValueError(reason)
        load = self._tail_load(values)
        if load is None:
            self.backend = make_backend(values)
        else:
            self.backend = make_backend(values, load.torque, load.inertia)
        reason = self.backend.watchdog_refusal(self.cmd_timeout_sec)
        if reason is not None:
            raise ValueError(reason)
        self.backend.set_command_hold(self.cmd_timeout_sec + COMMAND_HOLD_MARGIN_S)

        self.max_speed = float(values["max_speed_rad_s"])
        self.command = CarrierCommand(self.max_speed)
        self.last_command_ns: int | None = None
        self.watchdog_stops = 0
        self.watchdog_tripped = False
        self.phase_rebases_seen = 0
        self.firmware_logged = ""  # the motor board's firmware, once logged
        self.publish_rate_hz = float(values["publish_rate_hz"])
        self.max_sample_rate_hz = self.backend.max_sample_rate_hz
        self.clock_mapping = ClockMapping()
        self.stamps = IncreasingStamps()
        self.rate_check = RateCheck(
            time.monotonic(),
            max(float(values["diagnostics_period_sec"]), RATE_WINDOW_MIN_S),
            float(values["rate_warn_fraction"]),
            float(values["gap_warn_sec"]),
        )
        # A shortfall WARNs once it persists and clears once gone a while (no flapping).
        self.rate_status = PersistentStatus()
        self.diagnostics_period_s = float(values["diagnostics_period_sec"])

        self.state_message = JointState()
        self.state_message.name = [str(values["joint_name"])]
        self.state_publisher = ListenedPublisher(self, JointState, MOTOR_JOINT_STATE)
        self.diagnostics_publisher = suite_publisher(self, DiagnosticArray, DIAGNOSTICS)
        self.create_subscription(
            Float64, MOTOR_CMD_SPEED.name, self._on_command, subscriber_qos(MOTOR_CMD_SPEED)
        )
        self.create_subscription(
            CarrierSpeedProfile,
            MOTOR_CMD_PROFILE.name,
            self._on_profile,
            subscriber_qos(MOTOR_CMD_PROFILE),
        )
        self.pivot = make_pivot_output(self, values, self._stamp)
        self.publish_timer = self.create_timer(1.0 / self.publish_rate_hz, self._on_publish_tick)
        self.watchdog_timer = self.create_timer(
            watchdog_period_s(self.cmd_timeout_sec), self._check_watchdog
        )
        self.create_timer(float(values["diagnostics_period_sec"]), self._on_diagnostics)
        self._appliers: dict[str, Callable[[Any], None]] = {
            "publish_rate_hz": self._apply_publish_rate,
            "joint_name": self._apply_joint_name,
            "rate_warn_fraction": self._apply_rate_warn_fraction,
            "gap_warn_sec": self._apply_gap_warn,
            "cmd_timeout_sec": self._apply_cmd_timeout,
        }
        self.add_on_set_parameters_callback(self._on_set_parameters)
        # Started last: nothing above can fail after the port is open and the I/O thread runs,
        # so a refused start-up never leaves them behind.
        self.backend.start()
        loaded = ""
        if load is not None:
            loaded = f", motor turning the {load.model.tail.name} tail ({self.motor_load})"
        self.get_logger().info(
            f"driver up: backend {self.backend.name}, {self.publish_rate_hz:g} Hz, "
            f"watchdog {self.cmd_timeout_sec:g} s{loaded}"
        )

    def _tail_load(self, values: ParameterValues) -> TailLoad | None:
        """With a ``motor_load``: declare the tail's, links' and fish's parameters; their load."""
        if self.motor_load == NO_LOAD:
            return None
        reason = load_refusal(values)
        if reason is not None:
            raise ValueError(reason)
        return tail_load_from_values(declare(self, read_only_load_parameters()), self.motor_load)

    # ---- parameters changed at run time

    def _refusal(self, parameter: Parameter) -> str | None:
        """Why ``parameter``'s new value is refused, or None."""
        spec = SPECS.get(parameter.name)
        if spec is None:
            return None  # not ours (use_sim_time ...)
        try:
            value: ParameterValue = spec.check(parameter.value)
        except ParameterValueError as error:
            return str(error)
        if parameter.name == "cmd_timeout_sec":
            return self.backend.watchdog_refusal(float(value))
        return None

    def _on_set_parameters(self, parameters: list[Parameter]) -> SetParametersResult:
        # Ranges and read-only are also enforced by the descriptors before this runs.
        for parameter in parameters:
            reason = self._refusal(parameter)
            if reason is not None:
                return SetParametersResult(successful=False, reason=reason)
        for parameter in parameters:
            apply = self._appliers.get(parameter.name)
            if apply is not None:
                apply(parameter.value)
        return SetParametersResult(successful=True)

    def _apply_publish_rate(self, rate_hz: float) -> None:
        self.publish_rate_hz = rate_hz
        self.publish_timer.cancel()
        self.destroy_timer(self.publish_timer)
        self.publish_timer = self.create_timer(1.0 / rate_hz, self._on_publish_tick)
        # The promise changed: measure the new rate from now on.
        self.rate_check.restart(time.monotonic())

    def _apply_joint_name(self, name: str) -> None:
        self.state_message.name = [name]

    def _apply_rate_warn_fraction(self, fraction: float) -> None:
        self.rate_check.min_rate_fraction = fraction

    def _apply_gap_warn(self, gap_s: float) -> None:
        self.rate_check.max_gap_s = gap_s

    def _apply_cmd_timeout(self, timeout_s: float) -> None:
        self.cmd_timeout_sec = timeout_s
        self.watchdog_timer.cancel()
        self.destroy_timer(self.watchdog_timer)
        self.watchdog_timer = self.create_timer(watchdog_period_s(timeout_s), self._check_watchdog)
        self.backend.set_command_hold(timeout_s + COMMAND_HOLD_MARGIN_S)

    # ---- commands, watchdog, publishing

    @property
    def commanded_speed(self) -> float:
        """The carrier speed last asked of the backend [rad/s]."""
        return self.command.commanded_speed_rad_s

    def _on_command(self, message: Float64) -> None:
        try:
            clamped = self.command.set_speed(message.data)
        except CommandRefusedError as refusal:
            self.get_logger().warning(str(refusal), throttle_duration_sec=1.0)
            return
        if clamped is not None:
            self.get_logger().warning(clamped, throttle_duration_sec=1.0)
        self._command_accepted()

    def _on_profile(self, message: CarrierSpeedProfile) -> None:
        try:
            self.command.set_profile(
                message.mean_speed, message.modulation_depth, message.modulation_phase
            )
        except CommandRefusedError as refusal:
            self.get_logger().warning(str(refusal), throttle_duration_sec=1.0)
            return
        self._command_accepted()

    def _command_accepted(self) -> None:
        """A speed or a profile is in force: feed the watchdog, command its speed now."""
        self.last_command_ns = self.get_clock().now().nanoseconds
        if self.watchdog_tripped:
            self.get_logger().info("commands resumed")
        self.watchdog_tripped = False
        self.backend.set_profile(self.command.profile, self.command.commanded_speed_rad_s)

    def _check_watchdog(self) -> None:
        if self.cmd_timeout_sec <= 0.0 or self.last_command_ns is None or self.watchdog_tripped:
            return
        age_s = (self.get_clock().now().nanoseconds - self.last_command_ns) * 1e-9
        if age_s > self.cmd_timeout_sec and self.command.moving:
            self.watchdog_tripped = True
            self.watchdog_stops += 1
            self.command.stop()
            self.backend.stop()
            self.get_logger().warning(
                f"no speed command for {age_s:.2f} s (cmd_timeout_sec = {self.cmd_timeout_sec:g}):"
                " motor stopped"
            )

    def _stamp(self, monotonic_s: float, stamps: IncreasingStamps) -> Time | None:
        """The ROS time of ``monotonic_s``, or None if it is not after the last of ``stamps``.

        One mapping from the monotonic clock (on which backends date samples) to ROS time,
        observed here with the ROS clock read between two monotonic readings; see
        :mod:`fishtail_driver.stamping`. Each published stream has its own ``stamps``.
        """
        before = time.monotonic_ns()
        ros_ns = self.get_clock().now().nanoseconds
        after = time.monotonic_ns()
        self.clock_mapping.observe(before, ros_ns, after)
        stamp_ns = stamps.admit(self.clock_mapping.to_ros_ns(round(monotonic_s * 1e9)))
        if stamp_ns is None:
            return None
        return Time(sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)

    def _on_publish_tick(self) -> None:
        self.pivot.publish(time.monotonic())
        sample = self.backend.read()
        if sample is None:
            return
        # A modulated profile's speed at the angle just measured (None: a flat one, already sent).
        speed = self.command.follow(sample.angle_rad)
        if speed is not None and not self.backend.profile_on_board:
            self.backend.set_profile(self.command.profile, speed)
        stamp = self._stamp(sample.monotonic_s, self.stamps)
        if stamp is None:
            return  # counted: dropped_backward_stamps
        self.rate_check.record(sample.monotonic_s)
        if not self.state_publisher.listened:
            return  # nobody to build it for (the rate above is the backend's, all the same)
        message = self.state_message
        message.header.stamp = stamp
        message.position = [sample.angle_rad]
        message.velocity = [sample.velocity_rad_s]
        message.effort = [] if sample.effort_n_m is None else [sample.effort_n_m]
        self.state_publisher.publish(message)

    def expected_rate_hz(self) -> float:
        """The motor/joint_state rate the parameters promise (at most the backend's sample rate)."""
        return min(self.publish_rate_hz, self.max_sample_rate_hz)

    # ---- diagnostics and exit

    def _on_diagnostics(self) -> None:
        level, text, values = self.backend.status()
        firmware = values.get("firmware", "")
        if values.get("profile_tuning", TUNING_NOT_SET) != TUNING_NOT_SET:
            firmware += f"; profile tuning: {values['profile_tuning']}"
        if values.get("connected") == "true" and firmware != self.firmware_logged:
            self.firmware_logged = firmware
            self.get_logger().info(f"motor board on {self.backend.hardware_id}: {firmware}")
        rebases = int(values.get("phase_rebases", "0") or 0)
        if rebases > self.phase_rebases_seen:
            self.phase_rebases_seen = rebases
            self.get_logger().warning(
                f"encoder angle re-based ({values.get('last_phase_rebase', '')}; {rebases} since "
                "start): the motion during the board's reset or outage is unknown, so the carrier "
                "phase reference may have shifted; if the tail pose is off, re-calibrate the "
                "kinematics node's phase_rad (docs/serial.md)"
            )
        if self.watchdog_tripped and level == Level.OK:
            level = Level.WARN
            text = f"no speed command for over {self.cmd_timeout_sec:g} s: motor stopped"
        refusal = self.command.pending_refusal
        if refusal is not None:
            level = max(level, Level.WARN)
            text = f"{text}; {refusal}"
        rate = self.rate_check.report(
            time.monotonic(), self.expected_rate_hz(), self.rate_status.warning
        )
        if self.rate_status.update(self.diagnostics_period_s, rate.shortfall, rate.longest_gap_s):
            level = max(level, Level.WARN)
            shortfall = rate.shortfall or f"recovering from: {self.rate_status.last_problem}"
            text = f"{text}; motor/joint_state: {shortfall}"
        values = {
            **values,
            "backend": self.backend.name,
            **({} if self.motor_load == NO_LOAD else {"motor_load": self.motor_load}),
            **self.command.status_values(),
            "watchdog_stops": str(self.watchdog_stops),
            "joint_state_rate_hz": f"{rate.rate_hz:.1f}",
            "joint_state_expected_rate_hz": f"{rate.expected_rate_hz:g}",
            "joint_state_longest_gap_ms": f"{rate.longest_gap_s * 1e3:.1f}",
            "dropped_backward_stamps": str(self.stamps.dropped),
            "clock_steps": str(self.clock_mapping.steps),
        }
        # The motor's status last: readers that keep one status per node keep that one.
        motor = Status("motor", level, text, values, self.backend.hardware_id)
        self.diagnostics_publisher.publish(diagnostic_array(self, *self.pivot.statuses(), motor))

    def shutdown(self) -> StopOutcome:
        """Stop the motor and release the backend; logs whether the stop got through.

        Safe to call twice (the node's exit runs it through :meth:`before_exit`).
        """
        self.command.stop()
        self.backend.stop()
        outcome = self.backend.close()
        if outcome.confirmed:
            # The wording of the confirmed case is what scripts and tests look for.
            self.get_logger().info(f"motor commanded to stop; driver exiting ({outcome.detail})")
        elif outcome.sent:
            self.get_logger().warning(
                f"stop command sent but not confirmed: {outcome.detail}; the board stops the "
                "motor by itself within 2 s of the last speed command it received; driver exiting"
            )
        else:
            self.get_logger().error(
                f"the stop command could not be sent: {outcome.detail}; the board stops the "
                "motor by itself within 2 s of the last speed command it received; driver exiting"
            )
        return outcome

    def before_exit(self) -> None:
        """Stop the motor and release the backend (run_node calls this once spinning ends)."""
        self.shutdown()


#: How a process creates this node (its own ``main``, or ``fishtail-run --one-process``).
FACTORY = NodeFactory(DriverNode, "driver")


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run fishtail_driver driver``."""
    return run_node(FACTORY.create, FACTORY.label, FACTORY.startup_errors, args=args)


if __name__ == "__main__":
    sys.exit(main())
