"""``fishtail-record``: record the suite's topics into a rosbag2 bag (MCAP storage).

For machines without ``ros2 bag record``: the raw CDR bytes the subscriptions deliver, stamped
with the receive time, written with rosbags as a split bag
(:class:`~fishtail_bringup.segmented_bag.SegmentedBag`) so that a kill or a full disk loses
little; the exit status is 1 if any message could not be written. Options, layout and what
survives what: docs/recording.md ("fishtail-record").
"""

from __future__ import annotations

import argparse
import datetime
import importlib
import os
import signal
import sys
import threading
import time
from pathlib import Path

from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)

from fishtail_bringup.segmented_bag import (
    DEFAULT_MAX_BUFFER_MB,
    DEFAULT_SEGMENT_SEC,
    SegmentedBag,
)
from fishtail_common.bag_types import register_package_types, suite_typestore
from fishtail_common.command_line import DURATION, add_parameter_options
from fishtail_common.interface import SUITE_TOPICS, QosKind
from fishtail_common.parameters import ParameterSpec

PROGRAM = "fishtail-record"
#: Subscription queue depth: deep enough to ride out a pause of the writer (~0.5 s at 200 Hz).
SUBSCRIPTION_DEPTH = 100
#: How often the writer thread moves received messages into the open segment.
WRITE_PERIOD_S = 0.1
#: After a failed write, wait this long before trying again.
RETRY_PERIOD_S = 1.0
#: At exit on a full disk, keep trying this long before giving up on what is still in memory.
EXIT_RETRY_S = 3.0
#: How often topics whose type is not known yet are looked up in the ROS graph.
DISCOVERY_PERIOD_S = 0.5
#: On stop, messages already delivered are still taken until none has come for this long ...
DRAIN_IDLE_S = 0.05
#: ... or for at most this long (a publisher that never pauses must not hold the stop).
DRAIN_MAX_S = 0.5
#: The bag's durability options (docs/recording.md).
SEGMENT_SEC = ParameterSpec(
    "segment_sec", DEFAULT_SEGMENT_SEC,
    "close a storage file this often; a SIGKILL loses at most the open one", "s", 0.0,
    exclusive_minimum=True,
)  # fmt: skip
MAX_BUFFER_MB = ParameterSpec(
    "max_buffer_mb", DEFAULT_MAX_BUFFER_MB,
    "memory for messages that cannot be written (full disk) before the oldest are dropped",
    "MiB", 0.0, exclusive_minimum=True,
)  # fmt: skip


def _say(text: str) -> None:
    print(f"{PROGRAM}: {text}", flush=True)


def _error(text: str) -> None:
    print(f"{PROGRAM}: error: {text}", file=sys.stderr, flush=True)


# --------------------------------------------------------------------------------------------
# The ROS side


def qos_of_profile(profile) -> Qos:
    """The rosbags Qos record of an rclpy QoSProfile (enum values are rmw's in both)."""

    def duration(value) -> QosTime:
        nanoseconds = int(value.nanoseconds)
        return QosTime(sec=nanoseconds // 1_000_000_000, nsec=nanoseconds % 1_000_000_000)

    return Qos(
        history=QosHistory(int(profile.history)),
        depth=int(profile.depth),
        reliability=QosReliability(int(profile.reliability)),
        durability=QosDurability(int(profile.durability)),
        deadline=duration(profile.deadline),
        lifespan=duration(profile.lifespan),
        liveliness=QosLiveliness(int(profile.liveliness)),
        liveliness_lease_duration=duration(profile.liveliness_lease_duration),
        avoid_ros_namespace_conventions=bool(profile.avoid_ros_namespace_conventions),
    )


def _message_class(msgtype: str):
    package, kind, name = msgtype.split("/")
    return getattr(importlib.import_module(f"{package}.{kind}"), name)


class RecorderNode:
    """An rclpy node with one raw subscription per topic, feeding a :class:`SegmentedBag`."""

    def __init__(self, bag: SegmentedBag, topics: list[str], namespace: str) -> None:
        """Subscribe to the topics whose types are known; look the others up in the graph."""
        import rclpy
        from rclpy.expand_topic_name import expand_topic_name

        self.bag = bag
        self.node = rclpy.create_node("fishtail_recorder", namespace=namespace or None)
        node = self.node
        known = {
            expand_topic_name(topic.name, node.get_name(), node.get_namespace()): topic
            for topic in SUITE_TOPICS
        }
        self.waiting: dict[str, str] = {}  # resolved name -> name as given
        self.subscribed: dict[str, str] = {}  # resolved name -> type
        self.first_seen: set[str] = set()
        self.ignored: set[str] = set()
        for topic in topics:
            resolved = expand_topic_name(topic, node.get_name(), node.get_namespace())
            if resolved in self.subscribed or resolved in self.waiting:
                continue
            if resolved in known:
                suite_topic = known[resolved]
                reliable = suite_topic.qos is not QosKind.STATE  # best effort takes any publisher
                self._subscribe(resolved, suite_topic.type, reliable, durable=False)
            else:
                self.waiting[resolved] = topic
        if self.waiting:
            node.create_timer(DISCOVERY_PERIOD_S, self._discover)

    def _subscribe(self, resolved: str, msgtype: str, reliable: bool, durable: bool) -> None:
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=SUBSCRIPTION_DEPTH,
            reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
            durability=DurabilityPolicy.TRANSIENT_LOCAL if durable else DurabilityPolicy.VOLATILE,
        )
        bag = self.bag

        def on_message(data: bytes, topic=resolved, msgtype=msgtype) -> None:
            received_ns = time.time_ns()
            if topic not in self.first_seen:
                try:
                    self._first_message(topic, msgtype)
                except Exception as error:  # noqa: BLE001 - one topic must not stop the rest
                    _error(f"not recording {topic}: {error}")
                    self.first_seen.add(topic)
                    self.ignored.add(topic)
            if topic not in self.ignored:
                bag.append(topic, received_ns, data)

        self.node.create_subscription(_message_class(msgtype), resolved, on_message, qos, raw=True)
        self.subscribed[resolved] = msgtype

    def _first_message(self, topic: str, msgtype: str) -> None:
        self.first_seen.add(topic)
        offered = [
            qos_of_profile(info.qos_profile)
            for info in self.node.get_publishers_info_by_topic(topic)
        ]
        self.bag.add_topic(topic, msgtype, offered)
        _say(f"recording {topic} ({msgtype})")

    def _discover(self) -> None:
        """Subscribe to waiting topics once a publisher shows their type (like ros2 bag record)."""
        if not self.waiting:
            return
        types = dict(self.node.get_topic_names_and_types())
        for resolved in list(self.waiting):
            if resolved not in types or not types[resolved]:
                continue
            msgtype = types[resolved][0]
            del self.waiting[resolved]
            try:
                if msgtype not in self.bag.typestore.fielddefs:
                    register_package_types(self.bag.typestore, msgtype.split("/")[0])
                _message_class(msgtype)  # the subscription needs the Python class
            except Exception as error:  # noqa: BLE001 - LookupError, ImportError, parse errors
                _error(f"not recording {resolved}: no definition of {msgtype} ({error})")
                continue
            # Like rosbag2: reliable only if every publisher is, transient-local likewise.
            offered = [
                qos_of_profile(p.qos_profile)
                for p in self.node.get_publishers_info_by_topic(resolved)
            ]
            reliable = bool(offered) and all(
                q.reliability == QosReliability.RELIABLE for q in offered
            )
            durable = bool(offered) and all(
                q.durability == QosDurability.TRANSIENT_LOCAL for q in offered
            )
            try:
                self._subscribe(resolved, msgtype, reliable, durable)
            except Exception as error:  # noqa: BLE001 - e.g. an invalid topic name
                _error(f"not recording {resolved}: {error}")


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    parser = argparse.ArgumentParser(
        prog=PROGRAM,
        description=__doc__.splitlines()[0],
        epilog="Ctrl-C (or SIGTERM) stops the recording and closes the bag.",
    )
    parser.add_argument(
        "-o", "--output", type=Path,
        help="bag directory to create (default fishtail_<date>-<time>)",
    )  # fmt: skip
    parser.add_argument(
        "--topics", nargs="+", metavar="TOPIC", default=[topic.name for topic in SUITE_TOPICS],
        help="topics to record (default: the suite's: "
        + " ".join(topic.name for topic in SUITE_TOPICS) + ")",
    )  # fmt: skip
    parser.add_argument("--namespace", default="", help="namespace of the suite (relative topics)")
    add_parameter_options(parser, [SEGMENT_SEC, MAX_BUFFER_MB])
    add_parameter_options(parser, [DURATION], optional=True)
    return parser


def default_output() -> Path:
    """fishtail_<date>-<time> in the current directory (like rosbag2's default name)."""
    return Path(datetime.datetime.now().strftime("fishtail_%Y_%m_%d-%H_%M_%S"))


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``fishtail-record``: :func:`record`, then exit at once.

    By the time :func:`record` returns the bag is closed, ``fsync``ed and listed, and the report
    printed: the interpreter's teardown (finalising rclpy's DDS participant, its threads and every
    module: 0.3-2.2 s measured on 2 busy cores, most of the 3.9 s a stop could take) has nothing
    left to save, so it is skipped (``os._exit`` after flushing stdout and stderr).
    """
    status = record(argv)
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):
            pass
    os._exit(status)


def _drain(executor, bag: SegmentedBag) -> None:
    """Take the messages already delivered to the subscriptions when the stop came."""
    deadline = time.monotonic() + DRAIN_MAX_S
    idle_since = time.monotonic()
    while (now := time.monotonic()) < deadline and now - idle_since < DRAIN_IDLE_S:
        before = bag.received
        executor.spin_once(timeout_sec=DRAIN_IDLE_S / 5)
        if bag.received != before:
            idle_since = time.monotonic()


def record(argv: list[str] | None = None) -> int:
    """Record until SIGINT, SIGTERM or ``--duration``; the exit status."""
    import rclpy
    from rclpy.signals import SignalHandlerOptions
    from rclpy.utilities import remove_ros_args

    full_argv = [PROGRAM, *(sys.argv[1:] if argv is None else argv)]
    arguments = build_parser().parse_args(remove_ros_args(full_argv)[1:])
    output = arguments.output or default_output()
    try:
        typestore = suite_typestore()
    except LookupError as error:
        _error(f"{error} (source tools/env.sh, or set AMENT_PREFIX_PATH)")
        return 2
    bag = SegmentedBag(
        output,
        typestore,
        segment_sec=arguments.segment_sec,
        max_buffer_bytes=int(arguments.max_buffer_mb * 2**20),
        custom_data={"recorder": PROGRAM, "segment_sec": f"{arguments.segment_sec:g}"},
        say=_say,
        error=_error,
    )
    try:
        bag.open()
    except OSError as error:
        _error(f"cannot create the bag: {error.strerror or error}")
        return 2

    stop = threading.Event()

    def on_signal(signum, _frame) -> None:
        if stop.is_set():  # a second Ctrl-C while closing: give up at once
            _error("interrupted again while closing: the open segment is lost")
            os._exit(1)
        stop.set()

    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, on_signal)
    rclpy.init(args=full_argv, signal_handler_options=SignalHandlerOptions.NO)
    from rclpy.experimental import EventsExecutor

    recorder = RecorderNode(bag, arguments.topics, arguments.namespace)
    executor = EventsExecutor()
    executor.add_node(recorder.node)
    writer_stop = threading.Event()

    def write_loop() -> None:
        while not writer_stop.wait(WRITE_PERIOD_S):
            bag.service()

    writer = threading.Thread(target=write_loop, name="bag-writer")
    writer.start()
    _say(
        f"recording {len(arguments.topics)} topic(s) to {output} "
        f"(a file every {arguments.segment_sec:g} s); Ctrl-C to stop"
    )
    started = time.monotonic()
    failed = False
    try:
        while not stop.is_set() and rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
            if arguments.duration and time.monotonic() - started >= arguments.duration:
                break
        if rclpy.ok():
            _drain(executor, bag)
    except Exception as error:  # noqa: BLE001 - still close the bag: nothing received is lost
        failed = True
        _error(f"stopped by an unexpected error: {error!r}; closing the bag")
    finally:
        executor.remove_node(recorder.node)
        executor.shutdown()
        recorder.node.destroy_node()
        rclpy.try_shutdown()
        writer_stop.set()
        writer.join()
    report = bag.close()
    for topic, count in sorted(report.topics.items()):
        _say(f"  {topic}: {count}")
    _say(
        f"{report.written} of {report.received} received messages in {report.files} file(s) "
        f"in {output}"
    )
    for resolved in recorder.waiting:
        _say(f"  {resolved}: never published, not recorded")
    if report.unwritten:
        _error(
            f"{report.unwritten} of {report.received} received messages could not be written "
            "(see the errors above)"
        )
        return 1
    return 1 if failed else 0


if __name__ == "__main__":
    main()
