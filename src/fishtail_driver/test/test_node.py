"""The driver node in this process (on the probe's context and executor): parameters and timing.

Covers what the process-level tests cannot reach cheaply: stamps at read time, the watchdog's own
timer, the serial-only refusal of a disabled watchdog (at start and at run time) and the command
hold it hands to the backend, the read-only speed limit, and the diagnostics' hardware_id.
"""

from __future__ import annotations

import math
import time

import pytest
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from fishtail_driver.backends import EncoderSample, StopOutcome
from fishtail_driver.node import COMMAND_HOLD_MARGIN_S, DriverNode, watchdog_period_s


def sensor_qos() -> QoSProfile:
    """Sensor-data QoS with a deep queue (nothing dropped while the test spins)."""
    qos = QoSProfile(depth=1000)
    qos.reliability = qos_profile_sensor_data.reliability
    qos.durability = qos_profile_sensor_data.durability
    return qos


@pytest.fixture
def driver_node(ros_probe):
    """``driver_node(**parameters)``: a DriverNode on the probe's executor; shut down after."""
    made: list[DriverNode] = []

    def make(**parameters) -> DriverNode:
        overrides = [Parameter(name, value=value) for name, value in parameters.items()]
        node = DriverNode(context=ros_probe.context, parameter_overrides=overrides)
        made.append(node)
        ros_probe.executor.add_node(node)
        return node

    yield make
    for node in made:
        ros_probe.executor.remove_node(node)
        node.shutdown()
        node.destroy_node()


def stamp_s(message) -> float:
    """A header stamp in seconds."""
    return message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec


class StaleBackend:
    """A backend whose every sample was read ``age_s`` before read() returns it."""

    name = "stale"
    hardware_id = "stale"

    def __init__(self, age_s: float) -> None:
        """Record the ROS (system) time of each read, for the expected stamps."""
        self.age_s = age_s
        self.reads: list[tuple[float, EncoderSample]] = []

    def read(self) -> EncoderSample:
        """A sample ``age_s`` old; remembers the wall time of the read."""
        wall, monotonic = time.time(), time.monotonic()
        sample = EncoderSample(monotonic - self.age_s, float(len(self.reads)), 0.0)
        self.reads.append((wall, sample))
        return sample

    def set_speed(self, speed_rad_s: float) -> None:
        """Ignored."""

    def stop(self) -> None:
        """Ignored."""

    def close(self) -> StopOutcome:
        """Nothing to stop."""
        return StopOutcome(True, True, "stale test backend")

    def status(self) -> tuple[int, str, dict[str, str]]:
        """OK."""
        return 0, "stale", {}


def test_joint_state_is_stamped_when_the_encoder_was_read(driver_node, ros_probe):
    """Stamp = ROS now minus the sample's age on the monotonic clock, not the publish time."""
    node = driver_node(publish_rate_hz=50.0)
    backend = StaleBackend(age_s=2.0)
    node.backend.close()
    node.backend = backend
    joints = ros_probe.record(JointState, "motor/joint_state", sensor_qos())
    ros_probe.spin_until(lambda: len(joints) >= 5, 10.0, "5 joint states")
    for message in joints:
        wall, _ = backend.reads[round(message.position[0])]
        # Off by the time between two clock readings, not by the sample's 2 s age.
        assert stamp_s(message) == pytest.approx(wall - 2.0, abs=0.2)


def test_sim_stamps_match_the_angle(driver_node, ros_probe):
    """Sim at a steady speed: angle differences over stamp differences give the speed."""
    speed = 4.0
    driver_node(publish_rate_hz=200.0, sim_time_constant_sec=0.01, cmd_timeout_sec=0.0)
    joints = ros_probe.record(JointState, "motor/joint_state", sensor_qos())
    commands = ros_probe.node.create_publisher(Float64, "motor/cmd_speed", 10)
    ros_probe.spin_until(
        lambda: commands.publish(Float64(data=speed)) or (joints and joints[-1].velocity[0] > 3.99),
        10.0,
        "the motor at speed",
    )
    start = len(joints)
    ros_probe.spin_until(lambda: len(joints) >= start + 100, 10.0, "100 more joint states")
    steady = joints[start:]
    count_rad = 2 * math.pi / 2048
    for before, after in zip(steady, steady[50:], strict=False):
        elapsed = stamp_s(after) - stamp_s(before)
        advance = after.position[0] - before.position[0]
        # One encoder count of quantisation at either end; the stamps are exact to the time
        # between reading the ROS and the monotonic clock (microseconds; 10 ms allowed for a
        # preemption in between).
        assert advance == pytest.approx(speed * elapsed, abs=2 * count_rad + speed * 0.01)


def test_watchdog_runs_on_its_own_timer(driver_node, ros_probe):
    """At publish_rate_hz 1, with the publish timer even cancelled, silence stops the motor."""
    node = driver_node(publish_rate_hz=1.0, cmd_timeout_sec=0.2)
    assert node.watchdog_timer.timer_period_ns == round(watchdog_period_s(0.2) * 1e9)
    node.publish_timer.cancel()
    commands = ros_probe.node.create_publisher(Float64, "motor/cmd_speed", 10)
    ros_probe.spin_until(
        lambda: ros_probe.node.count_subscribers("motor/cmd_speed") >= 1, 10.0, "the subscription"
    )
    commands.publish(Float64(data=3.0))
    ros_probe.spin_until(lambda: node.commanded_speed == 3.0, 5.0, "the command")
    ros_probe.spin_until(lambda: node.watchdog_stops == 1, 5.0, "the watchdog")
    assert node.backend.motor.target_rad_s == 0.0 and node.watchdog_tripped


def test_watchdog_period():
    """A quarter of the timeout, at most 50 ms, at least 5 ms; 50 ms when disabled."""
    assert watchdog_period_s(0.5) == 0.05
    assert watchdog_period_s(60.0) == 0.05
    assert watchdog_period_s(0.1) == pytest.approx(0.025)
    assert watchdog_period_s(0.001) == 0.005
    assert watchdog_period_s(0.0) == 0.05


def test_max_speed_is_read_only(driver_node):
    """The backends take the limit at start, so changing it at run time is refused."""
    node = driver_node()
    (result,) = node.set_parameters([Parameter("max_speed_rad_s", value=5.0)])
    assert not result.successful and "read-only" in result.reason
    assert node.get_parameter("max_speed_rad_s").value == 20.0 and node.max_speed == 20.0


def test_serial_refuses_a_disabled_watchdog_at_run_time(driver_node, ros_probe, tmp_path):
    """cmd_timeout_sec 0 refused with backend serial; other values reach the backend's hold."""
    port = tmp_path / "no-board"
    node = driver_node(backend="serial", serial_port=str(port), cmd_timeout_sec=0.5,
                       diagnostics_period_sec=0.1)  # fmt: skip
    assert node.backend.command_hold_s == pytest.approx(0.5 + COMMAND_HOLD_MARGIN_S)
    (result,) = node.set_parameters([Parameter("cmd_timeout_sec", value=0.0)])
    assert not result.successful
    assert "cmd_timeout_sec must be > 0 with backend serial" in result.reason
    assert node.get_parameter("cmd_timeout_sec").value == 0.5 and node.cmd_timeout_sec == 0.5
    (result,) = node.set_parameters([Parameter("cmd_timeout_sec", value=2.0)])
    assert result.successful
    assert node.backend.command_hold_s == pytest.approx(2.0 + COMMAND_HOLD_MARGIN_S)
    assert node.watchdog_timer.timer_period_ns == round(0.05 * 1e9)
    # hardware_id: the port path (ERROR: no board there).
    arrays = ros_probe.record(DiagnosticArray, "/diagnostics", 50)
    ros_probe.spin_until(lambda: arrays, 10.0, "diagnostics")
    (status,) = arrays[-1].status
    assert status.hardware_id == str(port) and status.level == b"\x02"


def test_sim_allows_a_disabled_watchdog_and_reports_hardware_id_sim(driver_node, ros_probe):
    """The sim backend may run without a watchdog; its hardware_id is "sim"."""
    node = driver_node(diagnostics_period_sec=0.1)
    (result,) = node.set_parameters([Parameter("cmd_timeout_sec", value=0.0)])
    assert result.successful
    arrays = ros_probe.record(DiagnosticArray, "/diagnostics", 50)
    ros_probe.spin_until(lambda: arrays, 10.0, "diagnostics")
    assert arrays[-1].status[0].hardware_id == "sim"


def test_serial_refuses_a_disabled_watchdog_at_start(driver_process, tmp_path):
    """Exit status 2 and one line naming the reason, before anything is opened."""
    driver = driver_process(params={"backend": "serial", "serial_port": str(tmp_path / "tty"),
                                    "cmd_timeout_sec": 0.0})  # fmt: skip
    assert driver.wait(30.0) == 2, driver.output()
    errors = [line for line in driver.output().splitlines() if line.startswith("driver: error:")]
    assert len(errors) == 1, driver.output()
    assert "cmd_timeout_sec must be > 0 with backend serial" in errors[0]


class BackwardBackend(StaleBackend):
    """Samples read 1 ms apart, except that every tenth one is dated 5 ms before its predecessor.

    A stamp built from such a sample would go back in time; the node must not publish it.
    """

    name = "backward"
    hardware_id = "backward"

    def __init__(self) -> None:
        """Start at the current monotonic time."""
        super().__init__(age_s=0.0)
        self.start_s = time.monotonic()

    def read(self) -> EncoderSample:
        """Sample k (angle k) dated start + k ms, or 5 ms earlier for every tenth."""
        k = len(self.reads)
        when = self.start_s + 0.001 * k - (0.006 if k % 10 == 9 else 0.0)
        sample = EncoderSample(when, float(k), 0.0)
        self.reads.append((time.time(), sample))
        return sample


def test_stamps_never_go_back_even_when_sample_times_do(driver_node, ros_probe):
    """Stamps strictly increase; samples that would be stamped earlier are dropped and counted."""
    node = driver_node(publish_rate_hz=200.0, diagnostics_period_sec=0.1)
    node.backend.close()
    node.backend = BackwardBackend()
    joints = ros_probe.record(JointState, "motor/joint_state", sensor_qos())
    arrays = ros_probe.record(DiagnosticArray, "/diagnostics", 50)
    ros_probe.spin_until(lambda: len(joints) >= 60, 10.0, "60 joint states")
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in joints]
    assert all(b > a for a, b in zip(stamps, stamps[1:], strict=False)), "a stamp went back"
    published = {round(m.position[0]) for m in joints}
    assert not any(k % 10 == 9 for k in published), "a sample dated back in time was published"

    def dropped() -> int:
        values = {kv.key: kv.value for a in arrays[-1:] for kv in a.status[0].values}
        return int(values.get("dropped_backward_stamps", "0"))

    ros_probe.spin_until(lambda: dropped() >= 5, 10.0, "dropped_backward_stamps on /diagnostics")


def test_sim_is_ok_with_the_measured_rate_and_increasing_stamps(driver_node, ros_probe):
    """A healthy sim at 200 Hz: OK with the measured rate and longest gap; stamps increase."""
    driver_node(publish_rate_hz=200.0, diagnostics_period_sec=0.5)
    joints = ros_probe.record(JointState, "motor/joint_state", sensor_qos())
    arrays = ros_probe.record(DiagnosticArray, "/diagnostics", 50)

    def ok_with_rate() -> bool:
        for array in arrays:
            values = {kv.key: kv.value for kv in array.status[0].values}
            if array.status[0].level == b"\x00" and "joint_state_rate_hz" in values:
                return float(values["joint_state_expected_rate_hz"]) == 200.0
        return False

    ros_probe.spin_until(ok_with_rate, 10.0, "OK with the measured rate")
    ros_probe.spin_until(lambda: len(joints) >= 400, 10.0, "400 joint states")
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in joints]
    assert all(b > a for a, b in zip(stamps, stamps[1:], strict=False)), "a stamp went back"


def test_sim_rate_below_the_promise_is_a_warning(driver_node, ros_probe):
    """Samples far rarer than publish_rate_hz promises (the publish timer stalled): WARN."""
    node = driver_node(publish_rate_hz=200.0, diagnostics_period_sec=0.2)
    arrays = ros_probe.record(DiagnosticArray, "/diagnostics", 50)
    node.publish_timer.cancel()
    stalled = ros_probe.node.create_timer(0.1, node._on_publish_tick)

    def warned() -> bool:
        return any(a.status[0].level == b"\x01" and "rate" in a.status[0].message for a in arrays)

    ros_probe.spin_until(warned, 10.0, "WARN for the rate")
    stalled.cancel()
    status = next(a.status[0] for a in arrays if a.status[0].level == b"\x01")
    values = {kv.key: kv.value for kv in status.values}
    assert float(values["joint_state_rate_hz"]) < 0.8 * 200.0
    assert float(values["joint_state_longest_gap_ms"]) >= 90.0


def test_joint_name_can_change_at_run_time_but_never_to_empty(driver_node, ros_probe):
    """An empty (or blank) name is refused with the reason; another name is taken over."""
    node = driver_node(publish_rate_hz=100.0)
    for bad in ("", "   "):
        (result,) = node.set_parameters([Parameter("joint_name", value=bad)])
        assert not result.successful and "joint_name must not be empty" in result.reason
    assert node.get_parameter("joint_name").value == "carrier_joint"
    (result,) = node.set_parameters([Parameter("joint_name", value="tail_carrier")])
    assert result.successful, result.reason
    joints = ros_probe.record(JointState, "motor/joint_state", sensor_qos())
    ros_probe.spin_until(lambda: joints, 10.0, "a joint state")
    assert joints[-1].name == ["tail_carrier"]
