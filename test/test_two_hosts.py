"""The fish and the shore on two hosts: DDS discovery and the suite's data across a real link.

Two Linux network namespaces stand for the two computers: "fish" runs the driver (simulated
motor), "shore" runs the kinematics and monitor nodes, ``fishtail-record`` and a probe process
that commands the motor and prints what it receives as JSON lines. A veth pair joins them with
link-local addresses; nothing else is reachable from either namespace. The test checks that the
samples really crossed the link (the fish's packet counter), not a shortcut such as Fast DDS's
shared-memory transport between processes of one machine.

Discovery is tested both ways that docs/two-computers.md recommends for real machines:
multicast (``ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET``) and, as where a Wi-Fi access point drops
multicast, unicast to a static peer (``LOCALHOST`` + ``ROS_STATIC_PEERS``, which uses no
multicast at all). Needs root and iproute2; skipped with the reason where namespaces or veth
links cannot be made.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest
from rosbags.rosbag2 import Reader

from fishtail_common.parameter_files import load_parameter_file
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_msgs.msg import SymmetryReport, TailState

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config" / "oscillatory.yaml"

#: A /30 of the link-local range: the two ends of the veth and nothing else.
FISH_ADDRESS = "169.254.74.1"
SHORE_ADDRESS = "169.254.74.2"
PREFIX_LENGTH = 30
#: Fast DDS's default multicast group for discovery (SPDP).
DDS_MULTICAST_GROUP = "239.255.0.1"

SPEED_RAD_S = 4.0  # the report's speed: a beat every 1.57 s
COMMAND_PERIOD_S = 0.1  # well inside the driver's 0.5 s watchdog
#: The sim motor (first-order lag of 0.15 s, no noise) converges to the command exactly; this
#: only leaves room for rounding.
SETTLED_TOLERANCE_RAD_S = 1e-6
SETTLED_SAMPLES = 20
#: Carrier revolutions of matched samples (tail state and the motor sample it came from) that the
#: shore must see at the commanded speed.
REVOLUTIONS = 2.0
#: Beats the recorder must have recorded (reports seen after it started recording them).
RECORDED_BEATS = 2
#: Same code, same float inputs as the kinematics node: bit-identical results expected; 1e-12
#: leaves room for an equivalent evaluation order.
TOLERANCE = 1e-12

#: Start-up of five Python processes on two shared cores plus discovery takes a few seconds;
#: waits get a wide margin (they end as soon as the event happens).
STREAM_TIMEOUT_S = 60.0
EXIT_TIMEOUT_S = 10.0
ANALYSE_TIMEOUT_S = 120.0
IP_TIMEOUT_S = 10.0
#: The kernel marks a new link running within about a second.
LINK_TIMEOUT_S = 10.0

_test_counter = itertools.count()

#: Polls the interface flags (SIOCGIFFLAGS) until IFF_RUNNING is set; exit status 1 on timeout.
WAIT_RUNNING_SCRIPT = """\
import fcntl, socket, struct, sys, time
SIOCGIFFLAGS, IFF_RUNNING = 0x8913, 0x40
name, timeout = sys.argv[1], float(sys.argv[2])
request = struct.pack("256s", name.encode())
deadline = time.monotonic() + timeout
with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
    while not struct.unpack("H", fcntl.ioctl(sock, SIOCGIFFLAGS, request)[16:18])[0] & IFF_RUNNING:
        if time.monotonic() > deadline:
            sys.exit(f"{name} still not running after {timeout} s")
        time.sleep(0.01)
"""


# --------------------------------------------------------------------------------------------
# Two hosts: network namespaces joined by a veth pair


def _ip(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        ["ip", *args], capture_output=True, text=True, timeout=IP_TIMEOUT_S, check=False
    )


def _ip_or_fail(*args: str) -> str:
    result = _ip(*args)
    if result.returncode != 0:
        pytest.fail(f"ip {' '.join(args)}: {result.stderr.strip()}")
    return result.stdout


@dataclasses.dataclass(frozen=True)
class Host:
    """One namespace: its name, the veth end inside it and that end's address."""

    namespace: str
    interface: str
    address: str


class HostProcess:
    """A command run with ``ip netns exec`` in its own process group, output to files.

    ``ip netns exec`` replaces itself with the command, so ``pid`` is the command's own and
    SIGINT reaches it directly.
    """

    def __init__(
        self, name: str, host: Host, argv: list[str], env: dict[str, str], log_dir: Path,
        on_line: Callable[[str], None] | None = None,
    ) -> None:  # fmt: skip
        """Start ``argv`` in ``host``'s namespace; ``on_line`` gets each stdout line instead."""
        self.name = name
        self.argv = ["ip", "netns", "exec", host.namespace, *argv]
        self.stdout_path = log_dir / f"{name}.stdout"
        self.stderr_path = log_dir / f"{name}.stderr"
        with open(self.stdout_path, "wb") as out, open(self.stderr_path, "wb") as err:
            self.popen = subprocess.Popen(
                self.argv, cwd=ROOT, env=env, stdin=subprocess.DEVNULL,
                stdout=subprocess.PIPE if on_line else out, stderr=err, start_new_session=True,
            )  # fmt: skip
        self.reader: threading.Thread | None = None
        if on_line is not None:
            self.reader = threading.Thread(
                target=self._read, args=(on_line,), name=f"{name}-stdout", daemon=True
            )
            self.reader.start()

    def _read(self, on_line: Callable[[str], None]) -> None:
        # Also kept in the file, for the failure report.
        with open(self.stdout_path, "a", encoding="utf-8") as copy:
            for line in self.popen.stdout:
                text = line.decode(errors="replace")
                copy.write(text)
                on_line(text)

    def running(self) -> bool:
        """Whether the process has not exited yet."""
        return self.popen.poll() is None

    def interrupt(self) -> None:
        """SIGINT, as Ctrl-C would."""
        if self.running():
            os.kill(self.popen.pid, signal.SIGINT)

    def wait(self, timeout: float) -> int | None:
        """Exit status after at most ``timeout`` seconds, None if it still runs."""
        try:
            status = self.popen.wait(timeout)
        except subprocess.TimeoutExpired:
            return None
        if self.reader is not None:
            self.reader.join(timeout)
        return status

    def kill(self) -> None:
        """SIGKILL the whole process group (teardown of a process that did not stop)."""
        if self.running():
            try:
                os.killpg(self.popen.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            self.popen.wait(EXIT_TIMEOUT_S)
        if self.reader is not None:
            self.reader.join(EXIT_TIMEOUT_S)

    def stdout(self) -> str:
        """What the process has printed so far."""
        return self.stdout_path.read_text(errors="replace")

    def output(self) -> str:
        """Command line, status, stdout and stderr, for a failure report."""
        return (
            f"$ {' '.join(self.argv)}\nexit status: {self.popen.poll()}\n"
            f"--- stdout (last 3000 characters)\n{self.stdout()[-3000:]}"
            f"--- stderr\n{self.stderr_path.read_text(errors='replace')}"
        )


class TwoHosts:
    """The namespaces "fish" and "shore", the veth between them and the processes in them."""

    def __init__(self, tag: str, log_dir: Path) -> None:
        """Name the namespaces after ``tag`` (unique per test and run); nothing is created yet."""
        self.fish = Host(f"fishtail-fish-{tag}", "to-shore", FISH_ADDRESS)
        self.shore = Host(f"fishtail-shore-{tag}", "to-fish", SHORE_ADDRESS)
        self.log_dir = log_dir
        self.processes: list[HostProcess] = []
        self._created: list[str] = []

    def create(self) -> None:
        """Create both namespaces and the link; skip the test where the system refuses."""
        for host in (self.fish, self.shore):
            result = _ip("netns", "add", host.namespace)
            if result.returncode != 0:
                pytest.skip(f"cannot create a network namespace: {result.stderr.strip()}")
            self._created.append(host.namespace)
        # Created directly inside the namespaces: the ends never appear in the root namespace,
        # so their names cannot clash with another run's.
        result = _ip(
            "link", "add", self.fish.interface, "netns", self.fish.namespace, "type", "veth",
            "peer", "name", self.shore.interface, "netns", self.shore.namespace,
        )  # fmt: skip
        if result.returncode != 0:
            pytest.skip(f"cannot create a veth pair: {result.stderr.strip()}")
        result = _ip("netns", "exec", self.fish.namespace, "true")
        if result.returncode != 0:
            pytest.skip(f"cannot run a command in a network namespace: {result.stderr.strip()}")
        for host in (self.fish, self.shore):
            in_ns = ("-n", host.namespace)
            # Loopback: processes on one host find each other through it.
            _ip_or_fail(*in_ns, "link", "set", "lo", "up")
            _ip_or_fail(
                *in_ns, "addr", "add", f"{host.address}/{PREFIX_LENGTH}", "dev", host.interface
            )
            _ip_or_fail(*in_ns, "link", "set", host.interface, "multicast", "on", "up")
        for host in (self.fish, self.shore):
            self._wait_until_running(host)

    def _wait_until_running(self, host: Host) -> None:
        """Wait until the kernel reports ``host``'s end of the link as running.

        An end comes up "running" only when the kernel's link watcher has seen the carrier, up
        to a second after ``ip link set up``; Fast DDS lists the running interfaces once, when a
        participant starts, and never listens for multicast on one that was not running then.
        ``ip`` does not show the flag, so a small script asks the kernel from inside the
        namespace (``-S``: no site hooks, standard library only, starts fast).
        """
        result = subprocess.run(
            ["ip", "netns", "exec", host.namespace, sys.executable, "-S", "-c",
             WAIT_RUNNING_SCRIPT, host.interface, str(LINK_TIMEOUT_S)],
            capture_output=True, text=True, timeout=LINK_TIMEOUT_S + IP_TIMEOUT_S, check=False,
        )  # fmt: skip
        if result.returncode != 0:
            pytest.fail(f"{host.interface} in {host.namespace} not running: {result.stderr}")

    def kill_all(self) -> None:
        """SIGKILL what still runs (a test that failed before stopping its processes)."""
        for process in self.processes:
            process.kill()

    def remove(self) -> None:
        """Delete the namespaces (the veth goes with them); run after kill_all."""
        errors = []
        for namespace in self._created:
            result = _ip("netns", "del", namespace)
            if result.returncode != 0:
                errors.append(f"ip netns del {namespace}: {result.stderr.strip()}")
        self._created.clear()
        if errors:
            pytest.fail("; ".join(errors))

    def start(
        self, name: str, host: Host, argv: list[str], env: dict[str, str],
        on_line: Callable[[str], None] | None = None,
    ) -> HostProcess:  # fmt: skip
        """Start ``argv`` on ``host``."""
        process = HostProcess(name, host, argv, env, self.log_dir, on_line)
        self.processes.append(process)
        return process

    def tx_packets(self, host: Host) -> int:
        """Packets sent out of ``host``'s end of the link."""
        data = json.loads(_ip_or_fail("-n", host.namespace, "-s", "-j", "link", "show", "dev",
                                      host.interface))  # fmt: skip
        return int(data[0]["stats64"]["tx"]["packets"])

    def multicast_groups(self, host: Host) -> set[str]:
        """IPv4 multicast groups joined on ``host``'s end of the link."""
        text = _ip_or_fail("-n", host.namespace, "maddr", "show", "dev", host.interface)
        return set(re.findall(r"^\s*inet\s+(\S+)", text, re.MULTILINE))


@pytest.fixture
def two_hosts(tmp_path) -> Iterator[TwoHosts]:
    """The two namespaces for this test; removed at teardown whatever happened."""
    if shutil.which("ip") is None:
        pytest.skip("iproute2's ip command is not installed")
    hosts = TwoHosts(f"{os.getpid()}-{next(_test_counter)}", tmp_path)
    try:
        hosts.create()
        yield hosts
    finally:
        hosts.kill_all()  # a namespace lives on while a process runs in it
        # Captured: pytest shows it only when the test fails.
        for process in hosts.processes:
            print(f"===== process {process.name}\n{process.output()}")
        hosts.remove()


# --------------------------------------------------------------------------------------------
# The shore's probe: commands the motor, prints what it receives


PROBE_SCRIPT = '''\
"""Shore probe: command motor/cmd_speed at a fixed rate; print received samples as JSON lines."""
import json
import sys

import rclpy
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from fishtail_common.ros import install_stop_handlers, spin_until
from fishtail_msgs.msg import SymmetryReport, TailState

speed, period = float(sys.argv[1]), float(sys.argv[2])


def emit(**fields):
    # json writes floats with repr(): they come back bit for bit.
    print(json.dumps(fields), flush=True)


def stamp_ns(message):
    return message.header.stamp.sec * 1_000_000_000 + message.header.stamp.nanosec


def on_motor(message):
    emit(kind="motor", stamp=stamp_ns(message), angle=message.position[0],
         velocity=message.velocity[0])


def on_tail(message):
    emit(kind="tail", stamp=stamp_ns(message), mechanism=message.mechanism,
         angle=message.motor_angle, velocity=message.motor_velocity, theta3=message.theta3,
         theta3_dot=message.theta3_dot, tip_x=message.tip.x, tip_y=message.tip.y)


def on_report(message):
    emit(kind="beat", index=message.beat_index, verdict=message.verdict, period=message.period)


stop = install_stop_handlers()  # rclpy's own handler would shut the context mid-spin
rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
node = rclpy.create_node("shore_probe")
sensor = QoSProfile(depth=1000)  # best effort like the publishers, deep enough not to drop
sensor.reliability = qos_profile_sensor_data.reliability
sensor.durability = qos_profile_sensor_data.durability
node.create_subscription(JointState, "motor/joint_state", on_motor, sensor)
node.create_subscription(TailState, "tail/state", on_tail, sensor)
node.create_subscription(SymmetryReport, "tail/symmetry", on_report, 50)
publisher = node.create_publisher(Float64, "motor/cmd_speed", 10)
node.create_timer(period, lambda: publisher.publish(Float64(data=speed)))
try:
    spin_until([node], stop)
finally:
    node.destroy_node()
    rclpy.try_shutdown()
'''


class ShoreLog:
    """The probe's JSON lines, by kind, and a way to wait until they satisfy a condition."""

    def __init__(self) -> None:
        """Start empty."""
        self.motor: dict[int, dict] = {}  # by stamp
        self.motor_order: list[int] = []
        self.tail: list[dict] = []
        self.beats: list[dict] = []
        self.changed = threading.Condition()

    def on_line(self, line: str) -> None:
        """Reader-thread callback: file one line (anything but a JSON object stays in the file)."""
        try:
            record = json.loads(line)
        except json.JSONDecodeError:
            return
        if not isinstance(record, dict):
            return
        with self.changed:
            if record.get("kind") == "motor":
                self.motor[record["stamp"]] = record
                self.motor_order.append(record["stamp"])
            elif record.get("kind") == "tail":
                self.tail.append(record)
            elif record.get("kind") == "beat":
                self.beats.append(record)
            self.changed.notify_all()

    def matched(self) -> list[tuple[dict, dict]]:
        """(motor sample, tail state) pairs with equal stamps, in arrival order of the tail."""
        with self.changed:
            return [(self.motor[t["stamp"]], t) for t in self.tail if t["stamp"] in self.motor]

    def wait_until(
        self, predicate: Callable[[], bool], what: str, processes: list[HostProcess],
        timeout: float = STREAM_TIMEOUT_S,
    ) -> None:  # fmt: skip
        """Wait for new lines until ``predicate()``; fail on timeout or if a process exits."""
        deadline = time.monotonic() + timeout
        while not predicate():
            dead = [p for p in processes if not p.running()]
            if dead:
                pytest.fail(f"{dead[0].name} exited while waiting for {what}:\n{dead[0].output()}")
            left = deadline - time.monotonic()
            if left <= 0:
                pytest.fail(f"timed out after {timeout:g} s waiting for {what} ({self.summary()})")
            with self.changed:
                # A line arriving wakes this up; the predicate is evaluated at most ~20 times a
                # second however fast lines come.
                self.changed.wait(min(left, 0.05))

    def summary(self) -> str:
        """Counts so far, for a timeout message."""
        with self.changed:
            last = self.motor[self.motor_order[-1]]["velocity"] if self.motor_order else None
            return (
                f"{len(self.motor)} motor samples (last velocity {last}), {len(self.tail)} tail "
                f"states, {len(self.beats)} symmetry reports"
            )


# --------------------------------------------------------------------------------------------
# The test


def engine_for(config_path: Path):
    """The engine for a parameter file, as the kinematics node builds it."""
    values = geometry_parameters_in(load_parameter_file(config_path))
    return make_tail(geometry_from_parameters(values))


def discovery_env(mode: str, peer: Host) -> dict[str, str]:
    """The environment of the processes on one host for a discovery mode.

    The rest is this process's environment (tools/env.sh's library and ament paths, and the
    ROS_DOMAIN_ID and ROS_LOG_DIR of the ros_domain fixture) passed on whole.
    """
    env = dict(os.environ)
    env.pop("ROS_LOCALHOST_ONLY", None)
    env.pop("ROS_STATIC_PEERS", None)
    if mode == "multicast":
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "SUBNET"
    else:
        # LOCALHOST keeps multicast off entirely (no multicast locators); the peer is contacted
        # by unicast, as on a network that drops multicast.
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
        env["ROS_STATIC_PEERS"] = peer.address
    return env


def settled(log: ShoreLog) -> bool:
    """The last SETTLED_SAMPLES motor samples all run at the commanded speed."""
    with log.changed:
        recent = log.motor_order[-SETTLED_SAMPLES:]
        return len(recent) == SETTLED_SAMPLES and all(
            abs(log.motor[s]["velocity"] - SPEED_RAD_S) <= SETTLED_TOLERANCE_RAD_S for s in recent
        )


def revolutions_at_speed(log: ShoreLog) -> float:
    """Carrier revolutions covered by matched samples at the commanded speed."""
    angles = [
        motor["angle"]
        for motor, _ in log.matched()
        if abs(motor["velocity"] - SPEED_RAD_S) <= SETTLED_TOLERANCE_RAD_S
    ]
    return (max(angles) - min(angles)) / (2.0 * math.pi) if angles else 0.0


@pytest.mark.parametrize("mode", ["multicast", "static_peers"])
def test_driver_on_the_fish_tail_on_the_shore(two_hosts, ros_domain, tmp_path, mode):
    """The shore commands the fish's motor and computes the fish's tail exactly."""
    fish, shore = two_hosts.fish, two_hosts.shore
    fish_env, shore_env = discovery_env(mode, shore), discovery_env(mode, fish)
    params = ["--ros-args", "--params-file", str(CONFIG)]
    python = sys.executable
    driver = two_hosts.start(
        "driver", fish, [python, "-m", "fishtail_driver.node", *params], fish_env
    )
    kinematics = two_hosts.start(
        "kinematics",
        shore,
        [python, "-m", "fishtail_kinematics.nodes.kinematics_node", *params],
        shore_env,
    )
    monitor = two_hosts.start(
        "monitor",
        shore,
        [python, "-m", "fishtail_kinematics.nodes.monitor_node", *params],
        shore_env,
    )
    bag = tmp_path / "shore_bag"
    recorder = two_hosts.start(
        "recorder", shore, [python, "-m", "fishtail_bringup.record", "-o", str(bag)], shore_env
    )
    script = tmp_path / "shore_probe.py"
    script.write_text(PROBE_SCRIPT, encoding="utf-8")
    log = ShoreLog()
    probe = two_hosts.start(
        "probe", shore,
        [python, str(script), repr(SPEED_RAD_S), repr(COMMAND_PERIOD_S)], shore_env,
        on_line=log.on_line,
    )  # fmt: skip
    nodes = [driver, kinematics, monitor, recorder, probe]

    # The shore's command reaches the fish: its motor settles at the commanded speed, as the
    # samples that reach the shore say.
    log.wait_until(lambda: settled(log), f"the motor to run at {SPEED_RAD_S} rad/s", nodes)
    log.wait_until(
        lambda: revolutions_at_speed(log) >= REVOLUTIONS,
        f"tail states over {REVOLUTIONS} carrier revolutions at speed",
        nodes,
    )
    # The recorder finds a topic once it has a publisher and records it from its first message;
    # tail/symmetry comes last (once a beat). Then it records whole beats.
    log.wait_until(lambda: "recording /tail/symmetry" in recorder.stdout(), "the recorder", nodes)
    beats_before = len(log.beats)
    log.wait_until(
        lambda: (
            len(log.beats) >= beats_before + RECORDED_BEATS
            and any(b["verdict"] == SymmetryReport.OK for b in log.beats)
        ),
        f"{RECORDED_BEATS} more symmetry reports, one of them OK",
        nodes,
    )

    fish_tx_packets = two_hosts.tx_packets(fish)
    groups = {
        name: two_hosts.multicast_groups(host) for name, host in (("fish", fish), ("shore", shore))
    }
    for process in nodes:
        process.interrupt()  # all at once: they shut down in parallel
    statuses = {process.name: process.wait(EXIT_TIMEOUT_S) for process in nodes}
    assert statuses == dict.fromkeys(statuses, 0), "\n".join(p.output() for p in nodes)

    # The driver's stamps reach the shore, in order.
    stamps = log.motor_order
    assert len(stamps) >= SETTLED_SAMPLES
    assert all(a < b for a, b in zip(stamps, stamps[1:], strict=False))
    # A tail state computed on the shore carries the stamp, angle and speed of the fish's sample
    # it came from. Both the probe and the kinematics node receive the samples best effort, so a
    # sample one of them missed is not matched; most are.
    matched = log.matched()
    assert len(matched) >= 0.5 * len(log.tail) > 0, log.summary()
    for motor, state in matched:
        assert (state["angle"], state["velocity"]) == (motor["angle"], motor["velocity"]), state

    # Every tail state is the engine's for its carrier angle and speed, to rounding.
    tail = engine_for(CONFIG)
    for state in log.tail:
        assert state["mechanism"] == TailState.MECHANISM_OSCILLATORY
        expected = tail.solve(float(state["angle"]), float(state["velocity"]))
        for field, want in (
            ("theta3", expected.theta3), ("theta3_dot", expected.theta3_dot),
            ("tip_x", expected.tip_x), ("tip_y", expected.tip_y),
        ):  # fmt: skip
            assert abs(state[field] - want) <= TOLERANCE, (
                f"{field} = {state[field]!r} on the shore but the engine gives {want!r} for "
                f"carrier angle {state['angle']!r} rad at {state['velocity']!r} rad/s"
            )
    print(
        f"{mode}: {len(stamps)} motor samples and {len(log.tail)} tail states on the shore "
        f"({len(matched)} matched), {len(log.beats)} beats, {fish_tx_packets} packets out of "
        f"the fish, multicast groups {groups}"
    )

    # The samples crossed the link, not a shortcut between the namespaces (each one the probe got
    # is at least one packet out of the fish).
    assert fish_tx_packets >= len(stamps), (fish_tx_packets, len(stamps))
    # Multicast discovery joins the DDS group on the link; the static-peer set-up never does.
    for name, joined in groups.items():
        assert (DDS_MULTICAST_GROUP in joined) == (mode == "multicast"), (name, joined)

    # The shore's bag holds the fish's samples and the shore's tail states, in agreement.
    with Reader(bag) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
    for topic in ("/motor/joint_state", "/tail/state", "/motor/cmd_speed", "/tail/symmetry"):
        assert counts.get(topic, 0) > 0, counts
    analysis = subprocess.run(
        [python, "-m", "fishtail_kinematics.offline.analyse_cli", str(bag), "--output-dir",
         str(tmp_path / "figures")],
        capture_output=True, text=True, timeout=ANALYSE_TIMEOUT_S, check=False,
    )  # fmt: skip
    report = analysis.stdout + analysis.stderr
    assert analysis.returncode == 0, report
    worst = re.search(r"disagreement: worst (\S+)", report)
    assert worst and float(worst[1]) <= TOLERANCE, report
