"""Real nodes under test: a ROS domain of their own, node processes, a probe node.

Every package's tests (and ``bench/``) start nodes the same way, so this lives once, here:
:func:`claim_domain` (a ROS_DOMAIN_ID no other process or parallel run holds), :class:`NodeProcess`
(a process in its own group, stopped with SIGINT, then its group killed) and :class:`Probe`
(recorders and waits). The probe waits for events, never for fixed times; a wait that times out
raises :class:`TimeoutError` naming what was awaited.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import signal
import subprocess
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.context import Context
from rclpy.experimental import EventsExecutor
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions
from std_msgs.msg import Float64

from fishtail_common.interface import DIAGNOSTICS, MOTOR_CMD_SPEED

#: Domain ids handed out: 0 is left to whatever else runs on the machine, and Fast DDS's ports for
#: ids above 101 run into the ephemeral port range.
DOMAIN_IDS = range(1, 102)
#: Fast DDS's default port mapping: every port of domain d lies in [7400 + 250 d, 7400 + 250 (d+1)).
_PORT_BASE, _DOMAIN_GAIN = 7400, 250
LOCK_DIR = Path(tempfile.gettempdir()) / "fishtail-ros-domains"

#: Discovery takes 0.3-2.5 s on this kind of machine; waits for it get a wide margin.
DISCOVERY_TIMEOUT_S = 15.0
#: How long a service call waits for its response before it sends the request again [s].
RESPONSE_RETRY_S = 5.0
#: How often a wait evaluates its predicate.
PREDICATE_PERIOD_S = 0.02
#: Queue depth of the probe's sensor-data subscriptions: deep enough that a busy test process does
#: not drop samples (best effort, so it still matches the nodes' sensor-data publishers).
PROBE_QUEUE_DEPTH = 1000
#: How long a process may take to exit after SIGINT before it is killed.
EXIT_TIMEOUT_S = 5.0


# ---- ROS domains


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


class DomainLock:
    """A claimed ROS domain id; :meth:`release` (or the end of a ``with``) frees it."""

    def __init__(self, domain: int, descriptor: int) -> None:
        """Hold ``domain`` through the locked ``descriptor``."""
        self.domain = domain
        self._descriptor: int | None = descriptor

    def release(self) -> None:
        """Unlock the id (idempotent)."""
        if self._descriptor is not None:
            fcntl.flock(self._descriptor, fcntl.LOCK_UN)
            os.close(self._descriptor)
            self._descriptor = None

    def __enter__(self) -> DomainLock:
        """The lock itself."""
        return self

    def __exit__(self, *_: object) -> None:
        """Release."""
        self.release()


def claim_domain(avoid: set[int] | frozenset[int] = frozenset()) -> DomainLock:
    """A domain id whose ports nobody has bound and that no other test run holds.

    Ids in ``avoid`` (those this run has used: their processes may still hold ports) are tried
    last.

    Raises:
        RuntimeError: every id is bound or locked.
    """
    LOCK_DIR.mkdir(parents=True, exist_ok=True)
    ports = _udp_ports_in_use()
    count = len(DOMAIN_IDS)
    start = os.getpid() % count  # parallel runs start at different places
    candidates = [DOMAIN_IDS[(start + step) % count] for step in range(count)]
    candidates.sort(key=lambda domain: domain in avoid)
    for domain in candidates:
        if _domain_bound(domain, ports):
            continue
        descriptor = os.open(LOCK_DIR / f"{domain}.lock", os.O_CREAT | os.O_RDWR, 0o666)
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(descriptor)
            continue
        return DomainLock(domain, descriptor)
    raise RuntimeError(f"no free ROS domain id in {DOMAIN_IDS}: all are bound or locked")


def isolated_ros_environment(domain: int, log_dir: Path) -> dict[str, str]:
    """The variables that put a process on ``domain``, on this machine only, logging to log_dir."""
    return {
        "ROS_DOMAIN_ID": str(domain),
        "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
        "ROS_LOG_DIR": str(log_dir),
        "PYTHONUNBUFFERED": "1",
        "RCUTILS_COLORIZED_OUTPUT": "0",
    }


#: Variables that would widen discovery beyond the claimed, localhost-only domain.
WIDENING_VARIABLES = ("ROS_LOCALHOST_ONLY", "ROS_STATIC_PEERS")


# ---- processes


def _default_sigint() -> None:
    """In the child before exec: SIGINT back to its default action.

    A background job of a non-interactive shell inherits an ignored SIGINT, and Python (so every
    node, and ``ros2 launch``) keeps it ignored; a signal test must not depend on how it was
    started.
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)


class NodeProcess:
    """One process (a node, ``ros2 launch`` ...) in its own process group, its output to files.

    SIGINT is restored in it; :meth:`stop` sends SIGINT, waits, then kills the whole group.
    """

    def __init__(
        self,
        name: str,
        argv: list[str],
        log_dir: Path,
        cwd: Path | None = None,
        env: dict[str, str] | None = None,
    ) -> None:
        """Start the process; its stdout and stderr go to ``log_dir/<name>.{stdout,stderr}``.

        ``env`` defaults to this process's environment, passed on whole (the venv's
        LD_LIBRARY_PATH, AMENT_PREFIX_PATH and the ROS variables).
        """
        self.name = name
        self.argv = argv
        self.stdout_path = log_dir / f"{name}.stdout"
        self.stderr_path = log_dir / f"{name}.stderr"
        with open(self.stdout_path, "wb") as out, open(self.stderr_path, "wb") as err:
            self.popen = subprocess.Popen(
                argv, cwd=cwd, env=dict(os.environ) if env is None else env,
                stdin=subprocess.DEVNULL, stdout=out, stderr=err, start_new_session=True,
                preexec_fn=_default_sigint,
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
        """Signal the process itself (not its group), if it still runs."""
        if self.popen.poll() is None:
            os.kill(self.pid, signum)

    def wait(self, timeout: float) -> int | None:
        """Exit status after at most ``timeout`` seconds, None if it still runs."""
        try:
            return self.popen.wait(timeout)
        except subprocess.TimeoutExpired:
            return None

    def stop(self, timeout: float = EXIT_TIMEOUT_S) -> None:
        """SIGINT, wait up to ``timeout``, then SIGKILL the whole process group.

        The group is killed even when the process itself has exited: children it left behind
        (the nodes of a ``ros2 launch`` ended by SIGTERM) must not outlive it.
        """
        if self.popen.poll() is None:
            self.send_signal(signal.SIGINT)
            self.wait(timeout)
        with contextlib.suppress(ProcessLookupError):
            os.killpg(self.pid, signal.SIGKILL)
        self.popen.wait(timeout)


# ---- the probe node


class Recorder:
    """Messages of one subscription, each with its receive time (time.time_ns())."""

    def __init__(self) -> None:
        """Start empty."""
        self.messages: list[Any] = []
        self.receive_ns: list[int] = []

    def __call__(self, message: Any) -> None:
        """Subscription callback."""
        self.receive_ns.append(time.time_ns())
        self.messages.append(message)

    def __len__(self) -> int:
        """Number of messages received."""
        return len(self.messages)

    def __getitem__(self, index: Any) -> Any:
        """A message (or a slice of them), in the order received."""
        return self.messages[index]

    def __iter__(self) -> Iterator[Any]:
        """The messages in the order received."""
        return iter(self.messages)

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
    """A context of its own on ``domain``, a node, an EventsExecutor and waiting helpers."""

    def __init__(self, domain: int, name: str = "probe") -> None:
        """Initialise the context (leaving Ctrl-C to the caller), the node and the executor."""
        self.context = Context()
        rclpy.init(
            context=self.context, domain_id=domain, signal_handler_options=SignalHandlerOptions.NO
        )
        self.node = rclpy.create_node(name, context=self.context)
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
        """Process callbacks until ``predicate()`` is true; seconds it took.

        Raises:
            TimeoutError: naming ``what``, after ``timeout`` seconds.
        """
        start = time.monotonic()
        deadline = start + timeout
        while not predicate():
            if time.monotonic() > deadline:
                raise TimeoutError(f"timed out after {timeout:g} s waiting for {what}")
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

    def record(self, msg_type: Any, topic: str, qos: QoSProfile | int | None = None) -> Recorder:
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
        return self.record(DiagnosticArray, DIAGNOSTICS.name, 50)

    def command_speed(
        self, speed: float | None, period_s: float = 0.1, topic: str = MOTOR_CMD_SPEED.name
    ) -> SpeedCommander:
        """Keep commanding ``speed`` (set ``.speed = None`` on the result to stop)."""
        return SpeedCommander(self, topic, speed, period_s)

    def call(
        self, srv_type: Any, service: str, request: Any, timeout: float = DISCOVERY_TIMEOUT_S
    ) -> Any:
        """Call a service once it is available; its response.

        A request that gets no response within :data:`RESPONSE_RETRY_S` is sent again, until
        ``timeout``: the server can take a request before it has matched the client's response
        reader, and then gives the response up ("failed to send response (timeout)") and the
        client waits for ever. So the service must take a repeated request as one (as
        ``set_parameters`` and ``get_parameters`` do).
        """
        client = self.node.create_client(srv_type, service)
        try:
            self.spin_until(client.service_is_ready, timeout, f"service {service}")
            deadline = time.monotonic() + timeout
            while True:
                future = client.call_async(request)
                wait_s = min(RESPONSE_RETRY_S, max(deadline - time.monotonic(), 0.0))
                try:
                    self.spin_until(future.done, wait_s, f"the response of {service}")
                    return future.result()
                except TimeoutError:
                    client.remove_pending_request(future)
                    if time.monotonic() >= deadline:
                        raise TimeoutError(
                            f"timed out after {timeout:g} s waiting for the response of "
                            f"{service}"
                        ) from None
        finally:
            self.node.destroy_client(client)

    # ---- message helpers

    @staticmethod
    def stamp_ns(message: Any) -> int:
        """A message's header stamp in nanoseconds (the key that matches messages of a sample)."""
        stamp = message.header.stamp
        return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)

    @staticmethod
    def statuses(recorder: Recorder, node_name: str) -> list[tuple[int, int, Any]]:
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
    def values(status: Any) -> dict[str, str]:
        """A DiagnosticStatus's key values as a dict."""
        return {pair.key: pair.value for pair in status.values}
