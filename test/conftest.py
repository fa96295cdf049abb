"""Fixtures of the integration tests: a ROS domain per test, node processes and a probe node.

Every test gets

* ``ros_domain``: its own ROS_DOMAIN_ID (unique in this run, not bound by any other process on the
  machine, and locked against a parallel run of this suite), localhost-only discovery and
  ROS_LOG_DIR in the test's tmp_path, all set in this process's environment (children inherit it);
* ``start_node``: starts a node as its own process (own process group, stdout and stderr to files
  in tmp_path, shown in the report when the test fails) and stops it at teardown: SIGINT, a wait
  with a timeout, then SIGKILL to the process group;
* ``ros``: a :class:`Probe`, this process's own rclpy context on the test's domain with a helper
  node, and helpers that spin until something happens, with a timeout (never a fixed sleep).

Helpers live here (and are reached through fixtures) because pytest imports test files with
``--import-mode=importlib``: the test directory is not an importable package.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import pytest
import rclpy
import yaml
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.context import Context
from rclpy.experimental import EventsExecutor
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import Float64

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config"

#: Domain ids handed out: 0 is left to whatever else runs on the machine, and Fast DDS's ports for
#: ids above 101 run into the ephemeral port range.
DOMAIN_IDS = range(1, 102)
#: Fast DDS's default port mapping: every port of domain d lies in [7400 + 250 d, 7400 + 250 (d+1)).
_PORT_BASE, _DOMAIN_GAIN = 7400, 250
_LOCK_DIR = Path(tempfile.gettempdir()) / "fishtail-ros-domains"
_domains_used_in_this_run: set[int] = set()

#: Discovery takes 0.3-2.5 s on this kind of machine; waits for it get a wide margin.
DISCOVERY_TIMEOUT_S = 15.0
#: How often spin_until evaluates its predicate.
PREDICATE_PERIOD_S = 0.02
#: Queue depth of the probe's sensor-data subscriptions: deep enough that a busy test process
#: does not drop samples (best effort, so it still matches the nodes' sensor-data publishers).
PROBE_QUEUE_DEPTH = 1000

#: How long a node may take to exit after SIGINT/SIGTERM before teardown kills it.
EXIT_TIMEOUT_S = 5.0

NODE_MODULES = {
    "driver": "fishtail_driver.node",
    "kinematics": "fishtail_kinematics.node",
    "monitor": "fishtail_kinematics.monitor_node",
}

_PROCESSES_KEY = pytest.StashKey[list]()


def pytest_configure(config):
    """Silence a third-party deprecation warning that the ROS message imports trigger."""
    config.addinivalue_line("filterwarnings", "ignore:module 'sre_:DeprecationWarning:lark")


# --------------------------------------------------------------------------------------------
# ROS domain per test


def _udp_ports_in_use() -> set[int]:
    ports = set()
    for table in ("/proc/net/udp", "/proc/net/udp6"):
        with contextlib.suppress(OSError), open(table, encoding="ascii") as stream:
            next(stream, None)  # header
            for line in stream:
                fields = line.split()
                if len(fields) > 1 and ":" in fields[1]:
                    ports.add(int(fields[1].rsplit(":", 1)[1], 16))
    return ports


def _domain_bound(domain: int, ports: set[int]) -> bool:
    low = _PORT_BASE + _DOMAIN_GAIN * domain
    return any(low <= port < low + _DOMAIN_GAIN for port in ports)


def _claim_domain() -> tuple[int, int]:
    """A free domain id and the descriptor of the lock that holds it for this test."""
    _LOCK_DIR.mkdir(parents=True, exist_ok=True)
    ports = _udp_ports_in_use()
    count = len(DOMAIN_IDS)
    start = os.getpid() % count  # parallel runs start at different places
    # Ids not yet used in this run first; only when they are all gone (a run of more than 101
    # tests), ids of finished tests whose processes have released their ports.
    candidates = [DOMAIN_IDS[(start + step) % count] for step in range(count)]
    candidates.sort(key=lambda domain: domain in _domains_used_in_this_run)
    for domain in candidates:
        if _domain_bound(domain, ports):
            continue
        descriptor = os.open(_LOCK_DIR / f"{domain}.lock", os.O_CREAT | os.O_RDWR, 0o666)
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(descriptor)
            continue
        _domains_used_in_this_run.add(domain)
        return domain, descriptor
    pytest.fail(f"no free ROS domain id in {DOMAIN_IDS}: all are bound or locked")


@pytest.fixture
def ros_domain(monkeypatch, tmp_path) -> int:
    """This test's ROS_DOMAIN_ID, with localhost discovery and logs in tmp_path."""
    domain, lock = _claim_domain()
    log_dir = tmp_path / "ros_log"
    log_dir.mkdir()
    monkeypatch.setenv("ROS_DOMAIN_ID", str(domain))
    monkeypatch.setenv("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    monkeypatch.delenv("ROS_LOCALHOST_ONLY", raising=False)
    monkeypatch.delenv("ROS_STATIC_PEERS", raising=False)
    monkeypatch.setenv("ROS_LOG_DIR", str(log_dir))
    monkeypatch.setenv("PYTHONUNBUFFERED", "1")
    monkeypatch.setenv("RCUTILS_COLORIZED_OUTPUT", "0")
    try:
        yield domain
    finally:
        fcntl.flock(lock, fcntl.LOCK_UN)
        os.close(lock)


# --------------------------------------------------------------------------------------------
# Node processes


def _parameter_text(value: object) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return repr(value)  # always a float literal, so the parameter stays a double
    return str(value)


def _default_sigint() -> None:
    """In the child before exec: SIGINT back to its default action.

    A background job of a non-interactive shell inherits an ignored SIGINT, and Python (so every
    node, and ``ros2 launch``) keeps it ignored; a signal test must not depend on how pytest was
    started.
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)


class NodeProcess:
    """One process (a node, ``ros2 launch`` ...) started in its own process group."""

    def __init__(self, name: str, argv: list[str], log_dir: Path) -> None:
        """Start the process; its stdout and stderr go to ``log_dir/<name>.{stdout,stderr}``."""
        self.name = name
        self.argv = argv
        self.stdout_path = log_dir / f"{name}.stdout"
        self.stderr_path = log_dir / f"{name}.stderr"
        with open(self.stdout_path, "wb") as out, open(self.stderr_path, "wb") as err:
            # os.environ is passed on whole: the venv's LD_LIBRARY_PATH, AMENT_PREFIX_PATH and
            # the ROS variables the ros_domain fixture set.
            self.popen = subprocess.Popen(
                argv, cwd=ROOT, env=dict(os.environ), stdin=subprocess.DEVNULL,
                stdout=out, stderr=err, start_new_session=True, preexec_fn=_default_sigint,
            )  # fmt: skip
        self.pid = self.popen.pid

    @property
    def returncode(self) -> int | None:
        """Exit status, or None while it runs."""
        return self.popen.poll()

    def stdout(self) -> str:
        """Everything the process wrote to stdout so far."""
        return self.stdout_path.read_text(errors="replace")

    def stderr(self) -> str:
        """Everything the process wrote to stderr so far (rclpy's console log goes here)."""
        return self.stderr_path.read_text(errors="replace")

    def output(self) -> str:
        """Command line, status, stdout and stderr, for a failure report."""
        return (
            f"$ {' '.join(self.argv)}\nexit status: {self.returncode}\n"
            f"--- stdout\n{self.stdout()}--- stderr\n{self.stderr()}"
        )

    def send_signal(self, signum: int) -> None:
        """Signal the node process itself (not its group), if it still runs."""
        if self.popen.poll() is None:
            os.kill(self.pid, signum)

    def wait(self, timeout: float) -> int | None:
        """Exit status after at most ``timeout`` seconds, None if it still runs."""
        try:
            return self.popen.wait(timeout)
        except subprocess.TimeoutExpired:
            return None

    def stop(self) -> None:
        """SIGINT, wait up to EXIT_TIMEOUT_S, then SIGKILL the whole process group.

        The group is killed even when the process itself has exited: children it left behind
        (the nodes of a ``ros2 launch`` ended by SIGTERM) must not outlive the test.
        """
        if self.popen.poll() is None:
            self.send_signal(signal.SIGINT)
            self.wait(EXIT_TIMEOUT_S)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.pid, signal.SIGKILL)
        self.popen.wait(EXIT_TIMEOUT_S)


@pytest.fixture
def start_process(request, ros_domain, tmp_path) -> Callable[[str, list[str]], NodeProcess]:
    """Start processes on the test's domain: ``start_process(label, argv)``; stopped at teardown.

    Teardown sends SIGINT to each process (all at once, so they shut down in parallel), waits,
    then kills each process group.
    """
    processes: list[NodeProcess] = []
    request.node.stash[_PROCESSES_KEY] = processes

    def start(label: str, argv: list[str]) -> NodeProcess:
        if any(p.name == label for p in processes):
            label = f"{label}-{len(processes)}"
        process = NodeProcess(label, argv, tmp_path)
        processes.append(process)
        return process

    yield start
    for process in processes:
        process.send_signal(signal.SIGINT)
    for process in processes:
        process.stop()


@pytest.fixture
def start_node(start_process) -> Callable[..., NodeProcess]:
    """Start node processes: ``start_node("driver", params={...}, params_file=..., name=...)``.

    ``node`` is ``driver``, ``kinematics``, ``monitor`` or a module name; ``params`` become
    ``-p name:=value`` (floats stay doubles), after ``--params-file`` so that they override it.
    """

    def start(
        node: str,
        *,
        params: dict[str, object] | None = None,
        params_file: str | Path | None = None,
        name: str | None = None,
    ) -> NodeProcess:
        module = NODE_MODULES.get(node, node)
        argv = [sys.executable, "-m", module, "--ros-args"]
        if params_file is not None:
            argv += ["--params-file", str(params_file)]
        for key, value in (params or {}).items():
            argv += ["-p", f"{key}:={_parameter_text(value)}"]
        return start_process(name or node, argv)

    return start


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Attach the node processes' command lines and output to a failed test's report."""
    outcome = yield
    report = outcome.get_result()
    if report.failed:
        for process in item.stash.get(_PROCESSES_KEY, []):
            report.sections.append((f"node process {process.name}", process.output()))


# --------------------------------------------------------------------------------------------
# The test's own ROS node


class Recorder:
    """Messages of one subscription, each with its receive time (time.time_ns())."""

    def __init__(self) -> None:
        """Start empty."""
        self.messages: list = []
        self.receive_ns: list[int] = []

    def __call__(self, message) -> None:
        """Subscription callback."""
        self.receive_ns.append(time.time_ns())
        self.messages.append(message)

    def __len__(self) -> int:
        """Number of messages received."""
        return len(self.messages)

    def clear(self) -> None:
        """Forget what was received."""
        self.messages.clear()
        self.receive_ns.clear()


class SpeedCommander:
    """Publishes ``speed`` on motor/cmd_speed every ``period_s`` while ``speed`` is not None."""

    def __init__(self, probe: Probe, topic: str, speed: float | None, period_s: float) -> None:
        """Create the publisher and the timer (publishing starts at the first tick)."""
        self.speed = speed
        self.sent: list[tuple[int, float]] = []  # (time.time_ns(), speed)
        self.publisher = probe.node.create_publisher(Float64, topic, 10)
        self.timer = probe.node.create_timer(period_s, self._tick)

    def _tick(self) -> None:
        if self.speed is not None:
            self.publish(self.speed)

    def publish(self, speed: float) -> None:
        """Publish one command now."""
        self.publisher.publish(Float64(data=float(speed)))
        self.sent.append((time.time_ns(), speed))


class Probe:
    """The test process's rclpy context (on the test's domain), a node and waiting helpers."""

    def __init__(self, domain: int) -> None:
        """Initialise a context of our own on ``domain``, a node ``probe`` and an executor."""
        self.context = Context()
        rclpy.init(
            context=self.context,
            domain_id=domain,
            signal_handler_options=SignalHandlerOptions.NO,  # leave Ctrl-C to pytest
        )
        self.node = rclpy.create_node("probe", context=self.context)
        self.executor = EventsExecutor(context=self.context)
        self.executor.add_node(self.node)

    def close(self) -> None:
        """Destroy the node and shut the context down."""
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()

    # ---- waiting

    def spin_for(self, seconds: float) -> None:
        """Process callbacks for ``seconds`` (a measurement window, not a synchronisation)."""
        deadline = time.monotonic() + seconds
        while (left := deadline - time.monotonic()) > 0.0:
            self.executor.spin_once(timeout_sec=min(left, 0.05))

    def spin_until(self, predicate: Callable[[], object], timeout: float, what: str) -> float:
        """Process callbacks until ``predicate()`` is true; seconds it took. Fails on timeout."""
        start = time.monotonic()
        deadline = start + timeout
        while not predicate():
            if time.monotonic() > deadline:
                pytest.fail(f"timed out after {timeout:g} s waiting for {what}")
            # spin_once handles one event: evaluate the predicate (which may be costly) only every
            # PREDICATE_PERIOD_S, not once per message.
            self.spin_for(PREDICATE_PERIOD_S)
        return time.monotonic() - start

    def wait_for_messages(self, recorder: Recorder, count: int, timeout: float, what: str) -> None:
        """Spin until ``recorder`` holds at least ``count`` messages."""
        self.spin_until(lambda: len(recorder) >= count, timeout, f"{count} messages on {what}")

    def wait_for_publishers(
        self, topic: str, count: int = 1, timeout: float = DISCOVERY_TIMEOUT_S
    ) -> None:
        """Spin until ``topic`` has ``count`` publishers (discovery of the node processes)."""
        self.spin_until(
            lambda: self.node.count_publishers(topic) >= count,
            timeout,
            f"{count} publisher(s) of {topic}",
        )

    def wait_for_subscribers(
        self, topic: str, count: int = 1, timeout: float = DISCOVERY_TIMEOUT_S
    ) -> None:
        """Spin until ``topic`` has ``count`` subscriptions."""
        self.spin_until(
            lambda: self.node.count_subscribers(topic) >= count,
            timeout,
            f"{count} subscription(s) of {topic}",
        )

    # ---- topics and services

    def record(self, msg_type, topic: str, qos: QoSProfile | int | None = None) -> Recorder:
        """Subscribe to ``topic`` and record what arrives.

        The default QoS is sensor data's (best effort, volatile) with a deep queue.
        """
        recorder = Recorder()
        if qos is None:
            qos = QoSProfile(depth=PROBE_QUEUE_DEPTH)
            qos.reliability = qos_profile_sensor_data.reliability
            qos.durability = qos_profile_sensor_data.durability
            qos.history = qos_profile_sensor_data.history
        self.node.create_subscription(msg_type, topic, recorder, qos)
        return recorder

    def record_diagnostics(self) -> Recorder:
        """Record /diagnostics (reliable, as the nodes publish it)."""
        return self.record(DiagnosticArray, "/diagnostics", 50)

    def command_speed(
        self, speed: float | None, period_s: float = 0.1, topic: str = "motor/cmd_speed"
    ) -> SpeedCommander:
        """Keep commanding ``speed`` (set ``.speed = None`` on the result to stop)."""
        return SpeedCommander(self, topic, speed, period_s)

    def call(self, srv_type, service: str, request, timeout: float = DISCOVERY_TIMEOUT_S):
        """Call a service once it is available; its response."""
        client = self.node.create_client(srv_type, service)
        try:
            self.spin_until(client.service_is_ready, timeout, f"service {service}")
            future = client.call_async(request)
            self.spin_until(future.done, timeout, f"the response of {service}")
            return future.result()
        finally:
            self.node.destroy_client(client)

    # ---- message helpers

    @staticmethod
    def stamp_ns(message) -> int:
        """A message's header stamp in nanoseconds (the key that matches messages of a sample)."""
        return message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec

    @staticmethod
    def statuses(recorder: Recorder, node_name: str) -> list[tuple[int, int, object]]:
        """(receive time ns, level, DiagnosticStatus) of the statuses that ``node_name`` sent."""
        prefix = f"/{node_name}:"
        found = []
        for received, array in zip(recorder.receive_ns, recorder.messages, strict=True):
            for status in array.status:
                if status.name.startswith(prefix):
                    level = status.level[0] if isinstance(status.level, bytes) else status.level
                    found.append((received, int(level), status))
        return found

    @staticmethod
    def values(status) -> dict[str, str]:
        """A DiagnosticStatus's key values as a dict."""
        return {pair.key: pair.value for pair in status.values}


@pytest.fixture
def ros(ros_domain) -> Probe:
    """This test's probe node on the test's domain."""
    probe = Probe(ros_domain)
    try:
        yield probe
    finally:
        probe.close()


@pytest.fixture(scope="session")
def config_dir() -> Path:
    """The workspace's config/ directory (report geometries)."""
    return CONFIG


@pytest.fixture
def params_file(tmp_path) -> Callable[..., Path]:
    """Write a parameter file: a config/ file with some values changed, ``/**`` for every node.

    ``params_file("oscillatory.yaml", pivot_offset_m=0.17)`` returns the new file's path.
    """

    def write(base: str, **changes: object) -> Path:
        with open(CONFIG / base, encoding="utf-8") as stream:
            document = yaml.safe_load(stream)
        document["/**"]["ros__parameters"].update(changes)
        suffix = "_".join(f"{key}-{value}" for key, value in changes.items()) or "copy"
        path = tmp_path / f"{Path(base).stem}_{suffix}.yaml"
        with open(path, "w", encoding="utf-8") as stream:
            yaml.safe_dump(document, stream)
        return path

    return write
