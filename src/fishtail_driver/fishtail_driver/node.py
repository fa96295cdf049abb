"""Driver node: commands the carrier speed and publishes the encoder angle.

Topics (relative, so a namespace moves the whole suite):
  sub ``motor/cmd_speed``    std_msgs/Float64, carrier speed [rad/s], >= 0 (one-way motor)
  pub ``motor/joint_state``  sensor_msgs/JointState, unwrapped carrier angle [rad] and speed
                             [rad/s], sensor-data QoS, at ``publish_rate_hz``, stamped with the
                             time the encoder was read (not the publish time); stamps strictly
                             increase (:mod:`fishtail_driver.stamping`)
  pub ``/diagnostics``       diagnostic_msgs/DiagnosticArray, every ``diagnostics_period_sec``;
                             WARN when motor/joint_state is rarer or has longer gaps than the
                             parameters promise (:mod:`fishtail_driver.rate_check`)

A watchdog, on a timer of its own (at most 50 ms, whatever the publish rate), stops the motor
when no command arrives for ``cmd_timeout_sec``; SIGINT and SIGTERM stop the motor before the
node exits. With the serial backend the watchdog cannot be disabled, and the backend stops
re-sending a non-zero speed once the node has not commanded it for ``cmd_timeout_sec`` plus
:data:`COMMAND_HOLD_MARGIN_S`, so the board's own 2 s auto-stop stops the motor if this node
hangs.

All callbacks run on one thread (:func:`spin_until_signal`'s EventsExecutor, and the
single-threaded executors of the tests and benchmarks), and :meth:`DriverNode.shutdown` runs after
spinning: the node's state needs no lock (the serial backend locks its own).
"""

from __future__ import annotations

import math
import signal
import sys
import threading
import time

import rclpy
from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from fishtail_driver.backends import EncoderSample, SimBackend, StopOutcome
from fishtail_driver.motor_model import MotorParameters
from fishtail_driver.rate_check import RateCheck
from fishtail_driver.stamping import ClockMapping, IncreasingStamps

BACKENDS = ("sim", "serial")
#: The serial backend keeps re-sending a non-zero speed for cmd_timeout_sec plus this [s].
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


def serial_watchdog_error(cmd_timeout_sec: float) -> str | None:
    """Why ``cmd_timeout_sec`` is not allowed with the serial backend, or None."""
    if cmd_timeout_sec > 0.0:
        return None
    return (
        "cmd_timeout_sec must be > 0 with backend serial: the watchdog is what stops the real "
        f"motor when commands stop (got {cmd_timeout_sec:g})"
    )


def joint_name_error(name: object) -> str | None:
    """Why ``name`` cannot name the carrier joint in motor/joint_state, or None."""
    if not isinstance(name, str) or not name.strip():
        return f"joint_name must not be empty: motor/joint_state names the joint (got {name!r})"
    return None


def _float_descriptor(text: str, low: float, high: float, read_only: bool = False):
    return ParameterDescriptor(
        description=text,
        floating_point_range=[FloatingPointRange(from_value=low, to_value=high)],
        read_only=read_only,
    )


def _declare_serial_parameters(node: Node) -> None:
    """Parameters of the serial backend (ROSArduinoBridge board); read-only, used at start.

    The encoder is described by ``encoder_counts_per_revolution`` and ``gear_ratio``, shared with
    the sim backend.
    """

    def integer(text: str, low: int, high: int) -> ParameterDescriptor:
        return ParameterDescriptor(
            description=text,
            integer_range=[IntegerRange(from_value=low, to_value=high, step=1)],
            read_only=True,
        )

    declare = node.declare_parameter
    declare("serial_port", "/dev/ttyACM0", ParameterDescriptor(
        description="serial: device path (prefer /dev/serial/by-id/...) or pyserial URL",
        read_only=True))  # fmt: skip
    declare("serial_baud", 57600, integer("serial: baud rate (the firmware's BAUDRATE)",
                                          300, 4_000_000))  # fmt: skip
    declare("serial_read_timeout_sec", 0.1, _float_descriptor(
        "serial: longest wait for one reply [s]", 0.005, 5.0, True))  # fmt: skip
    declare("serial_channel", "left", ParameterDescriptor(
        description="serial: motor channel of the tail on the board: left or right",
        read_only=True))  # fmt: skip
    declare("serial_pid_rate_hz", 30, integer(
        "serial: the firmware's PID_RATE [Hz]; the PID frame is 1000 // PID_RATE ms "
        "(30 -> 33 ms = 30.30 Hz); m speeds are encoder ticks per frame", 1, 1000))  # fmt: skip
    declare("serial_poll_rate_hz", 100.0, _float_descriptor(
        "serial: encoder ('e') polls per second [Hz]", 1.0, 1000.0, True))  # fmt: skip
    declare("serial_resend_period_sec", 0.5, _float_descriptor(
        "serial: re-send the current non-zero speed this often, within the board's 2 s "
        "auto-stop [s]", 0.05, 1.5, True))  # fmt: skip
    declare("serial_handshake_timeout_sec", 5.0, _float_descriptor(
        "serial: how long the board may take to answer after the port opens (boards that "
        "reset on open boot for 1-2 s) [s]", 0.1, 60.0, True))  # fmt: skip
    declare("serial_stale_timeout_sec", 1.0, _float_descriptor(
        "serial: no valid reply for this long: reconnect [s]", 0.1, 60.0, True))  # fmt: skip


def _make_serial_backend(node: Node, command_hold_s: float):
    """A SerialBackend configured from the node's parameters (ValueError if inconsistent)."""
    from fishtail_driver.serial_backend import SerialBackend, SerialConfig

    def value(name: str):
        return node.get_parameter(name).value

    channel = value("serial_channel")
    if channel not in ("left", "right"):
        raise ValueError(f"serial_channel must be 'left' or 'right', got {channel!r}")
    return SerialBackend(
        SerialConfig(
            port=value("serial_port"),
            baud=value("serial_baud"),
            read_timeout_s=value("serial_read_timeout_sec"),
            channel=channel,
            counts_per_revolution=value("encoder_counts_per_revolution"),
            gear_ratio=value("gear_ratio"),
            pid_rate_hz=value("serial_pid_rate_hz"),
            poll_rate_hz=value("serial_poll_rate_hz"),
            resend_period_s=value("serial_resend_period_sec"),
            max_speed_rad_s=value("max_speed_rad_s"),
            handshake_timeout_s=value("serial_handshake_timeout_sec"),
            stale_timeout_s=max(value("serial_stale_timeout_sec"),
                                2.0 * value("serial_read_timeout_sec")),
            command_hold_s=command_hold_s,
        )
    )  # fmt: skip


class DriverNode(Node):
    """Thin shell: parameters, command watchdog, publishing and diagnostics around a backend."""

    def __init__(self, **node_options) -> None:
        """Declare parameters, start the backend and the timers.

        ``node_options`` go to :class:`rclpy.node.Node` (``context``, ``parameter_overrides`` ...).
        """
        super().__init__("driver", **node_options)
        self.declare_parameter(
            "backend", "sim",
            ParameterDescriptor(description="motor backend: sim or serial", read_only=True),
        )  # fmt: skip
        self.declare_parameter(
            "publish_rate_hz", 200.0,
            _float_descriptor("encoder publish rate [Hz]", 1.0, 1000.0),
        )  # fmt: skip
        self.declare_parameter(
            "cmd_timeout_sec", 0.5,
            _float_descriptor("stop the motor when no command arrives for this long [s]; "
                              "0 disables the watchdog (sim backend only)", 0.0, 60.0),
        )  # fmt: skip
        self.declare_parameter(
            "max_speed_rad_s", 20.0,
            _float_descriptor("commands above this carrier speed are clamped [rad/s]", 0.1, 1000.0,
                              read_only=True),
        )  # fmt: skip
        self.declare_parameter(
            "joint_name", "carrier_joint",
            ParameterDescriptor(description="name of the carrier joint in motor/joint_state "
                                            "(not empty)"),
        )  # fmt: skip
        self.declare_parameter(
            "diagnostics_period_sec", 1.0,
            _float_descriptor("period of /diagnostics [s]", 0.1, 60.0, read_only=True),
        )  # fmt: skip
        self.declare_parameter(
            "rate_warn_fraction", 0.8,
            _float_descriptor("WARN when motor/joint_state's rate over the last "
                              "max(diagnostics_period_sec, 1 s) is below this fraction of the "
                              "promised rate: publish_rate_hz, with backend serial at most "
                              "serial_poll_rate_hz; 0 disables", 0.0, 1.0),
        )  # fmt: skip
        self.declare_parameter(
            "gap_warn_sec", 0.1,
            _float_descriptor("WARN when motor/joint_state has a gap longer than this (and than "
                              "3 promised periods) in that window [s]; 0 disables", 0.0, 60.0),
        )  # fmt: skip
        self.declare_parameter(
            "encoder_counts_per_revolution", 2048,
            ParameterDescriptor(
                description="encoder counts per motor-shaft revolution",
                integer_range=[IntegerRange(from_value=1, to_value=10_000_000)],
                read_only=True,
            ),
        )  # fmt: skip
        self.declare_parameter(
            "gear_ratio", 1.0,
            _float_descriptor("motor-shaft turns per carrier turn", 0.001, 10000.0, read_only=True),
        )  # fmt: skip
        self.declare_parameter(
            "sim_time_constant_sec", 0.15,
            _float_descriptor("sim: first-order speed time constant [s]", 0.001, 100.0, True),
        )  # fmt: skip
        self.declare_parameter(
            "sim_speed_noise_rad_s", 0.0,
            _float_descriptor("sim: std of a stationary speed disturbance (correlation time: the "
                              "time constant) [rad/s]", 0.0, 100.0, True),
        )  # fmt: skip
        self.declare_parameter(
            "sim_seed", 0,
            ParameterDescriptor(description="sim: noise seed", read_only=True),
        )  # fmt: skip

        _declare_serial_parameters(self)

        backend_name = self.get_parameter("backend").value
        if backend_name not in BACKENDS:
            raise ValueError(f"backend must be one of {', '.join(BACKENDS)}, got {backend_name!r}")
        reason = joint_name_error(self.get_parameter("joint_name").value)
        if reason is not None:
            raise ValueError(reason)
        self.cmd_timeout_sec = self.get_parameter("cmd_timeout_sec").value
        if backend_name == "serial":
            reason = serial_watchdog_error(self.cmd_timeout_sec)
            if reason is not None:
                raise ValueError(reason)
            self.backend = _make_serial_backend(self, self.cmd_timeout_sec + COMMAND_HOLD_MARGIN_S)
        else:
            self.backend = SimBackend(
                MotorParameters(
                    time_constant_s=self.get_parameter("sim_time_constant_sec").value,
                    max_speed_rad_s=self.get_parameter("max_speed_rad_s").value,
                    counts_per_revolution=self.get_parameter("encoder_counts_per_revolution").value,
                    gear_ratio=self.get_parameter("gear_ratio").value,
                    speed_noise_rad_s=self.get_parameter("sim_speed_noise_rad_s").value,
                    seed=self.get_parameter("sim_seed").value,
                )
            )
        self.backend.start()

        self.commanded_speed = 0.0
        self.last_command_ns: int | None = None
        self.watchdog_stops = 0
        self.rejected_commands = 0
        self.clamped_commands = 0
        self.watchdog_tripped = False
        self.phase_rebases_seen = 0
        self.max_speed = self.get_parameter("max_speed_rad_s").value
        self.clock_mapping = ClockMapping()
        self.stamps = IncreasingStamps()
        self.rate_check = RateCheck(
            time.monotonic(),
            max(self.get_parameter("diagnostics_period_sec").value, RATE_WINDOW_MIN_S),
            self.get_parameter("rate_warn_fraction").value,
            self.get_parameter("gap_warn_sec").value,
        )

        self.state_message = JointState()
        self.state_message.name = [self.get_parameter("joint_name").value]
        self.state_publisher = self.create_publisher(
            JointState, "motor/joint_state", qos_profile_sensor_data
        )
        self.diagnostics_publisher = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.create_subscription(Float64, "motor/cmd_speed", self._on_command, 10)
        self.publish_timer = self.create_timer(
            1.0 / self.get_parameter("publish_rate_hz").value, self._on_publish_tick
        )
        self.watchdog_timer = self.create_timer(
            watchdog_period_s(self.cmd_timeout_sec), self._check_watchdog
        )
        self.create_timer(self.get_parameter("diagnostics_period_sec").value, self._on_diagnostics)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.get_logger().info(
            f"driver up: backend {backend_name}, "
            f"{self.get_parameter('publish_rate_hz').value:g} Hz, "
            f"watchdog {self.cmd_timeout_sec:g} s"
        )

    def _on_set_parameters(self, parameters) -> SetParametersResult:
        # Ranges and read-only are enforced by the descriptors before this runs.
        for parameter in parameters:
            reason = None
            if parameter.name == "cmd_timeout_sec" and self.backend.name == "serial":
                reason = serial_watchdog_error(parameter.value)
            elif parameter.name == "joint_name":
                reason = joint_name_error(parameter.value)
            if reason is not None:
                return SetParametersResult(successful=False, reason=reason)
        for parameter in parameters:
            if parameter.name == "publish_rate_hz":
                self.publish_timer.cancel()
                self.destroy_timer(self.publish_timer)
                self.publish_timer = self.create_timer(1.0 / parameter.value, self._on_publish_tick)
                # The promise changed: measure the new rate from now on.
                self.rate_check.restart(time.monotonic())
            elif parameter.name == "joint_name":
                self.state_message.name = [parameter.value]
            elif parameter.name == "rate_warn_fraction":
                self.rate_check.min_rate_fraction = parameter.value
            elif parameter.name == "gap_warn_sec":
                self.rate_check.max_gap_s = parameter.value
            elif parameter.name == "cmd_timeout_sec":
                self.cmd_timeout_sec = parameter.value
                self.watchdog_timer.cancel()
                self.destroy_timer(self.watchdog_timer)
                self.watchdog_timer = self.create_timer(
                    watchdog_period_s(parameter.value), self._check_watchdog
                )
                if self.backend.name == "serial":
                    self.backend.set_command_hold(parameter.value + COMMAND_HOLD_MARGIN_S)
        return SetParametersResult(successful=True)

    def _on_command(self, message: Float64) -> None:
        speed = message.data
        if not math.isfinite(speed) or speed < 0.0:
            self.rejected_commands += 1
            self.get_logger().warning(
                f"refused speed command {speed!r} rad/s: the motor turns one way, "
                "commands must be finite and >= 0",
                throttle_duration_sec=1.0,
            )
            return
        if speed > self.max_speed:
            self.clamped_commands += 1
            self.get_logger().warning(
                f"speed command {speed:g} rad/s clamped to max_speed_rad_s = {self.max_speed:g}",
                throttle_duration_sec=1.0,
            )
            speed = self.max_speed
        self.commanded_speed = speed
        self.last_command_ns = self.get_clock().now().nanoseconds
        if self.watchdog_tripped:
            self.get_logger().info("commands resumed")
        self.watchdog_tripped = False
        self.backend.set_speed(speed)

    def _check_watchdog(self) -> None:
        if self.cmd_timeout_sec <= 0.0 or self.last_command_ns is None or self.watchdog_tripped:
            return
        age_s = (self.get_clock().now().nanoseconds - self.last_command_ns) * 1e-9
        if age_s > self.cmd_timeout_sec and self.commanded_speed > 0.0:
            self.watchdog_tripped = True
            self.watchdog_stops += 1
            self.commanded_speed = 0.0
            self.backend.stop()
            self.get_logger().warning(
                f"no speed command for {age_s:.2f} s (cmd_timeout_sec = {self.cmd_timeout_sec:g}):"
                " motor stopped"
            )

    def _sample_stamp(self, sample: EncoderSample) -> Time | None:
        """The ROS time at which ``sample`` was read, or None if it is not after the last stamp.

        One mapping from the monotonic clock (on which backends date samples) to ROS time,
        observed here with the ROS clock read between two monotonic readings; see
        :mod:`fishtail_driver.stamping`.
        """
        before = time.monotonic_ns()
        ros_ns = self.get_clock().now().nanoseconds
        after = time.monotonic_ns()
        self.clock_mapping.observe(before, ros_ns, after)
        stamp_ns = self.stamps.admit(self.clock_mapping.to_ros_ns(round(sample.monotonic_s * 1e9)))
        if stamp_ns is None:
            return None
        return Time(sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)

    def _on_publish_tick(self) -> None:
        sample = self.backend.read()
        if sample is None:
            return
        stamp = self._sample_stamp(sample)
        if stamp is None:
            return  # counted: dropped_backward_stamps
        message = self.state_message
        message.header.stamp = stamp
        message.position = [sample.angle_rad]
        message.velocity = [sample.velocity_rad_s]
        self.state_publisher.publish(message)
        self.rate_check.record(sample.monotonic_s)

    def expected_rate_hz(self) -> float:
        """The motor/joint_state rate the parameters promise (serial: at most the poll rate)."""
        rate = self.get_parameter("publish_rate_hz").value
        if self.backend.name == "serial":
            rate = min(rate, self.get_parameter("serial_poll_rate_hz").value)
        return rate

    def _on_diagnostics(self) -> None:
        level, text, values = self.backend.status()
        rebases = int(values.get("phase_rebases", "0") or 0)
        if rebases > self.phase_rebases_seen:
            self.phase_rebases_seen = rebases
            self.get_logger().warning(
                f"encoder angle re-based ({values.get('last_phase_rebase', '')}; {rebases} since "
                "start): the motion during the board's reset or outage is unknown, so the carrier "
                "phase reference may have shifted; if the tail pose is off, re-calibrate the "
                "kinematics node's phase_rad (docs/serial.md)"
            )
        if self.watchdog_tripped and level == 0:
            level, text = 1, f"no speed command for over {self.cmd_timeout_sec:g} s: motor stopped"
        rate = self.rate_check.report(time.monotonic(), self.expected_rate_hz())
        if rate.shortfall is not None:
            level = max(level, 1)
            text = f"{text}; motor/joint_state: {rate.shortfall}"
        values = {
            **values,
            "backend": self.backend.name,
            "commanded_speed_rad_s": f"{self.commanded_speed:.4f}",
            "watchdog_stops": str(self.watchdog_stops),
            "rejected_commands": str(self.rejected_commands),
            "clamped_commands": str(self.clamped_commands),
            "joint_state_rate_hz": f"{rate.rate_hz:.1f}",
            "joint_state_expected_rate_hz": f"{rate.expected_rate_hz:g}",
            "joint_state_longest_gap_ms": f"{rate.longest_gap_s * 1e3:.1f}",
            "dropped_backward_stamps": str(self.stamps.dropped),
            "clock_steps": str(self.clock_mapping.steps),
        }
        self.publish_diagnostics(level, text, values)

    def publish_diagnostics(self, level: int, text: str, values: dict[str, str]) -> None:
        """Publish one DiagnosticStatus for the motor."""
        status = DiagnosticStatus(
            level=bytes([level]),
            name=f"{self.get_fully_qualified_name()}: motor",
            message=text,
            hardware_id=self.backend.hardware_id,
            values=[KeyValue(key=key, value=value) for key, value in values.items()],
        )
        array = DiagnosticArray(status=[status])
        array.header.stamp = self.get_clock().now().to_msg()
        self.diagnostics_publisher.publish(array)

    def shutdown(self) -> StopOutcome:
        """Stop the motor and release the backend; logs whether the stop got through.

        Safe to call twice.
        """
        self.commanded_speed = 0.0
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


def install_stop_handlers() -> threading.Event:
    """An event set by SIGINT or SIGTERM; installed before anything slow, so no signal is missed."""
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    return stop


def spin_until_signal(node: Node, stop: threading.Event) -> None:
    """Spin ``node`` on an EventsExecutor until ``stop`` is set."""
    from rclpy.experimental import EventsExecutor

    executor = EventsExecutor()
    executor.add_node(node)
    try:
        while not stop.is_set() and rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
    finally:
        executor.remove_node(node)
        executor.shutdown()


def main(args: list[str] | None = None) -> int:
    """Entry point of ``ros2 run fishtail_driver driver``."""
    stop = install_stop_handlers()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = DriverNode()
    except (ValueError, rclpy.exceptions.ParameterException) as error:
        print(f"driver: error: {error}", file=sys.stderr)
        rclpy.shutdown()
        return 2
    try:
        spin_until_signal(node, stop)
    finally:
        node.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
