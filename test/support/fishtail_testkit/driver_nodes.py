"""Fixtures of the tests that start the driver node: its process, a probe, a wait on a condition.

A conftest.py imports the fixtures it uses by name (``from fishtail_testkit.driver_nodes import
driver_run, ...``), which registers them for its tests.

* ``wait_until(predicate, timeout, what)``: poll a condition until it holds; fails the test naming
  ``what`` on timeout. Used instead of fixed sleeps.
* ``driver_process(params)``: the driver node as a process; ``driver_run(link, **params)``: the
  driver (backend:=serial) at ``link`` with the probe recording motor/joint_state and
  /diagnostics and publishing speed commands.
* ``ros_domain`` / ``ros`` / ``ros_probe``: :mod:`fishtail_common.pytest_fixtures`.
"""

from __future__ import annotations

import signal
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from fishtail_common import pytest_fixtures
from fishtail_common.testing import DISCOVERY_TIMEOUT_S, NodeProcess, Probe

POLL_S = 0.005

def _wait_until(predicate: Callable[[], object], timeout: float, what: str) -> float:
    start = time.monotonic()
    while not predicate():
        if time.monotonic() - start > timeout:
            pytest.fail(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(POLL_S)
    return time.monotonic() - start


@pytest.fixture
def wait_until() -> Callable[[Callable[[], object], float, str], float]:
    """``wait_until(predicate, timeout, what)``: seconds it took; fails the test on timeout."""
    return _wait_until


# The shared fixtures (a ROS domain of the test's own, the probe), registered for these tests by
# being names of this conftest.
ros_domain = pytest_fixtures.ros_domain
ros = pytest_fixtures.ros


@pytest.fixture
def ros_probe(ros: Probe) -> Probe:
    """This test's probe node (:class:`fishtail_common.testing.Probe`)."""
    return ros


@pytest.fixture
def driver_process(ros_domain, tmp_path) -> Callable[..., NodeProcess]:
    """Start the driver node: ``driver_process(params={...})``; stopped at teardown."""
    processes: list[NodeProcess] = []

    def start(params: dict[str, object]) -> NodeProcess:
        argv = [sys.executable, "-m", "fishtail_driver.node", "--ros-args"]
        for key, value in params.items():
            text = repr(value) if isinstance(value, float) else str(value)
            argv += ["-p", f"{key}:={text}"]
        process = NodeProcess(f"driver{len(processes)}", argv, tmp_path)
        processes.append(process)
        return process

    yield start
    for process in processes:
        process.stop()


class DriverRun:
    """The driver node (backend:=serial) at ``link``, the probe's recorders, a speed publisher."""

    def __init__(self, probe, driver_process, link: Path, **params) -> None:
        """Start the driver and subscribe; commands are published every 0.1 s once set."""
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.qos import QoSProfile, qos_profile_sensor_data
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64

        self.probe = probe
        self.driver = driver_process(
            params={
                "backend": "serial",
                "serial_port": str(link),
                "serial_poll_rate_hz": 100.0,
                "diagnostics_period_sec": 0.2,
                "cmd_timeout_sec": 0.5,
                # Above the poll rate: at equal rates the publish ticks and the polls alias and
                # some readings are never published (a WARN for the rate, rightly).
                "publish_rate_hz": 200.0,
                **params,
            }
        )
        sensor = QoSProfile(depth=5000)
        sensor.reliability = qos_profile_sensor_data.reliability
        sensor.durability = qos_profile_sensor_data.durability
        self.joints = probe.record(JointState, "motor/joint_state", sensor)
        self.diagnostics = probe.record(DiagnosticArray, "/diagnostics", 100)
        publisher = probe.node.create_publisher(Float64, "motor/cmd_speed", 10)
        self.speed: float | None = None

        def command() -> None:
            if self.speed is not None:
                publisher.publish(Float64(data=self.speed))

        probe.node.create_timer(0.1, command)

    def wait(self, predicate, timeout: float, what: str) -> None:
        """Spin until ``predicate()``; fails at once (with its output) if the driver exits."""

        def check() -> object:
            if self.driver.popen.poll() is not None:
                raise AssertionError(f"the driver exited while waiting for {what}:\n"
                                     f"{self.driver.output()}")  # fmt: skip
            return predicate()

        self.probe.spin_until(check, timeout, what)

    def statuses(self, mark: int = 0) -> list[tuple[int, str, dict[str, str]]]:
        """(level, message, values) of the driver's motor status, from diagnostics[mark:]."""
        found = []
        for array in self.diagnostics[mark:]:
            for status in array.status:
                if status.name.startswith("/driver:"):
                    level = status.level[0] if isinstance(status.level, bytes) else status.level
                    values = {pair.key: pair.value for pair in status.values}
                    found.append((int(level), status.message, values))
        return found

    def counter(self, key: str) -> int:
        """A counter of the newest status (0 before any status, or if never counted)."""
        found = self.statuses()
        return int(found[-1][2].get(key, "0") or 0) if found else 0

    def connected_mark(self) -> int:
        """Index into diagnostics of the first status saying connected."""
        for index, array in enumerate(list(self.diagnostics)):
            if any(pair.key == "connected" and pair.value == "true"
                   for status in array.status for pair in status.values):  # fmt: skip
                return index
        raise AssertionError("never connected")

    def angle(self) -> float:
        """The newest published angle."""
        return self.joints[-1].position[0] if self.joints else 0.0

    def start_motion(self, speed: float) -> None:
        """Wait for the connection and the command subscription, then command ``speed``."""
        self.wait(lambda: any(v.get("connected") == "true" for _, _, v in self.statuses()),
                  DISCOVERY_TIMEOUT_S, "the driver connected to the board")  # fmt: skip
        self.wait(lambda: self.probe.node.count_subscribers("motor/cmd_speed") >= 1,
                  DISCOVERY_TIMEOUT_S, "the driver's command subscription")  # fmt: skip
        self.speed = speed

    def stop(self) -> str:
        """SIGINT: the driver must exit 0 without a traceback; returns its output."""
        self.driver.send_signal(signal.SIGINT)
        status = self.driver.wait(10.0)
        output = self.driver.output()
        assert status == 0, output
        assert "Traceback" not in output, output
        return output


@pytest.fixture
def driver_run(ros_probe, driver_process) -> Callable[..., DriverRun]:
    """``driver_run(link, **params)``: a :class:`DriverRun`; the driver is stopped at teardown."""

    def start(link: Path, **params) -> DriverRun:
        return DriverRun(ros_probe, driver_process, link, **params)

    return start
