"""``fishtail-record``: record the suite's topics into a rosbag2 bag (MCAP storage).

For machines without ``ros2 bag record``. The bag is written with rosbags (rosbag2 format version
9, MCAP storage) from the raw CDR bytes that the subscriptions deliver, stamped with the receive
time, as rosbag2 does; ``ros2 bag info`` and rosbags read it.

Durability: rosbags' MCAP writer keeps a 1 MiB chunk in memory and writes the file's index only
when it closes, and a file without its index cannot be read. So the bag is written as a rosbag2
*split* bag: one storage file per ``--segment-sec`` seconds, each closed (index written, fsync'ed)
before ``metadata.yaml`` is atomically rewritten to list it. Consequences (docs/recording.md):

* Ctrl-C / SIGTERM / ``--duration``: the open segment is closed too, nothing received is lost;
* SIGKILL (or a crash): the bag opens with every completed segment; the open one (at most
  ``--segment-sec`` seconds of data) is lost and its directory ``<bag>_<k>/`` is left behind;
* a full disk (any OSError while writing): a one-line error, the failed segment is removed so the
  bag stays consistent, its messages and all new ones stay in memory (up to ``--max-buffer-mb``)
  and are written as soon as the disk has room again; the exit status is 1 if any message could
  not be written, with the count.
"""

from __future__ import annotations

import argparse
import collections
import dataclasses
import datetime
import importlib
import io
import math
import os
import shutil
import signal
import sys
import threading
import time
from collections.abc import Callable, Iterable
from pathlib import Path

from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import StoragePlugin
from rosbags.rosbag2.metadata import dump_qos_v9
from ruamel.yaml import YAML

from fishtail_common.bag_types import register_package_types, suite_typestore
from fishtail_common.interface import SUITE_TOPICS, QosKind

PROGRAM = "fishtail-record"
DEFAULT_SEGMENT_SEC = 5.0
DEFAULT_MAX_BUFFER_MB = 256.0
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


def _say(text: str) -> None:
    print(f"{PROGRAM}: {text}", flush=True)


def _error(text: str) -> None:
    print(f"{PROGRAM}: error: {text}", file=sys.stderr, flush=True)


# --------------------------------------------------------------------------------------------
# The bag: segments, metadata, failures (no rclpy here)


@dataclasses.dataclass
class _Topic:
    name: str
    msgtype: str
    msgdef: str
    digest: str
    qos: list[Qos]
    written: int = 0  # messages in closed, listed segments


@dataclasses.dataclass(frozen=True)
class _File:
    name: str
    start_ns: int
    end_ns: int
    count: int


@dataclasses.dataclass
class CloseReport:
    """What :meth:`SegmentedBag.close` achieved."""

    received: int
    written: int
    files: int
    unwritten: int  # still in memory when giving up (disk full), or dropped (memory limit)
    topics: dict[str, int]


class SegmentedBag:
    """A rosbag2 split bag written segment by segment; see the module docstring.

    Thread use: :meth:`add_topic` and :meth:`append` from the receiving thread, everything else
    from one writer thread (or the same thread). ``clock`` is the monotonic clock that times the
    segments (a parameter so that tests can drive it).
    """

    def __init__(
        self,
        path: Path,
        typestore,
        segment_sec: float = DEFAULT_SEGMENT_SEC,
        max_buffer_bytes: int = int(DEFAULT_MAX_BUFFER_MB * 2**20),
        clock: Callable[[], float] = time.monotonic,
        custom_data: dict[str, str] | None = None,
    ) -> None:
        """Prepare (nothing is created before :meth:`open`)."""
        if not (math.isfinite(segment_sec) and segment_sec > 0.0):
            raise ValueError(f"segment_sec must be positive, got {segment_sec!r}")
        self.path = Path(path)
        self.typestore = typestore
        self.segment_sec = segment_sec
        self.max_buffer_bytes = max_buffer_bytes
        self.clock = clock
        self.custom_data = dict(custom_data or {})
        self.received = 0
        self.dropped = 0
        self.failures = 0
        self._queue: collections.deque[tuple[str, int, bytes]] = collections.deque()
        self._topics_lock = threading.Lock()
        self._topics: dict[str, _Topic] = {}
        self._definitions: dict[str, tuple[str, str]] = {}
        self._files: list[_File] = []
        self._next_index = 0
        self._writer: Writer | None = None
        self._segment_dir: Path | None = None
        self._segment_opened = 0.0
        self._segment_messages: list[tuple[str, int, bytes]] = []
        self._connections: dict[str, object] = {}
        self._retry_at: float | None = None
        self._failing_since: float | None = None
        self._metadata_dirty = False
        self._unlisted = 0  # messages in files that metadata.yaml does not list yet

    # ---- receiving side

    def add_topic(self, name: str, msgtype: str, qos: Iterable[Qos] = ()) -> None:
        """Declare a topic before its first :meth:`append` (its type must be in the typestore)."""
        with self._topics_lock:
            if name in self._topics:
                return
            if msgtype not in self._definitions:
                msgdef, _ = self.typestore.generate_msgdef(msgtype, ros_version=2)
                self._definitions[msgtype] = (msgdef, self.typestore.hash_rihs01(msgtype))
            msgdef, digest = self._definitions[msgtype]
            self._topics[name] = _Topic(name, msgtype, msgdef, digest, list(qos))

    def _topic_list(self) -> list[_Topic]:
        with self._topics_lock:
            return list(self._topics.values())

    def append(self, topic: str, timestamp_ns: int, data: bytes) -> None:
        """Queue one serialized message (CDR bytes as received) for writing."""
        self._queue.append((topic, timestamp_ns, data))
        self.received += 1

    # ---- writer side

    @property
    def file_count(self) -> int:
        """Storage files listed in metadata.yaml (complete segments)."""
        return len(self._files)

    @property
    def written(self) -> int:
        """Messages in complete, listed segments."""
        return sum(f.count for f in self._files) - self._unlisted

    @property
    def pending(self) -> int:
        """Messages received and not yet in a complete segment."""
        return len(self._queue) + len(self._segment_messages)

    @property
    def failing(self) -> bool:
        """Whether the last write failed (and has not succeeded since)."""
        return self._failing_since is not None

    def open(self) -> None:
        """Create the bag directory with a metadata.yaml that lists no file yet."""
        try:
            self.path.mkdir(parents=True)
        except FileExistsError:
            raise FileExistsError(f"{self.path} exists already; choose another --output") from None
        self._write_metadata()

    def service(self, final: bool = False) -> None:
        """Write what was received; close the segment when it is old enough (or ``final``)."""
        now = self.clock()
        if self._retry_at is not None and now < self._retry_at and not final:
            return
        self._retry_at = None
        # While failing, every attempt closes its segment at once: only a closed, listed segment
        # shows that the disk takes data again.
        retrying = self._failing_since is not None
        try:
            while self._queue:
                item = self._queue.popleft()
                self._segment_messages.append(item)
                self._write(item)
            due = now - self._segment_opened >= self.segment_sec
            if self._writer is not None and (final or due or retrying):
                self._close_segment()
            if self._metadata_dirty:
                self._write_metadata()
        except Exception as error:  # noqa: BLE001 - OSError mostly; whatever it is, keep the data
            self._fail(error, now)
            return
        if self._failing_since is not None and self._writer is None:
            _say(
                f"writing again after {now - self._failing_since:.1f} s; the bag now holds "
                f"{self.written} messages"
            )
            self._failing_since = None

    def close(self, retry_for_s: float = EXIT_RETRY_S) -> CloseReport:
        """Close the open segment and list it; on a full disk keep trying for ``retry_for_s``."""
        deadline = time.monotonic() + retry_for_s
        self.service(final=True)
        while (self.pending or self._metadata_dirty) and time.monotonic() < deadline:
            time.sleep(min(RETRY_PERIOD_S, max(0.0, deadline - time.monotonic())))
            self.service(final=True)
        unwritten = self.pending + self._unlisted
        if unwritten:
            self._abort_segment()
        topics = {t.name: t.written for t in self._topic_list() if t.written}
        return CloseReport(
            self.received, self.written, len(self._files), unwritten + self.dropped, topics
        )

    # ---- segments

    def _segment_name(self, index: int) -> str:
        return f"{self.path.name}_{index}"

    def _open_segment(self) -> None:
        name = self._segment_name(self._next_index)
        directory = self.path / name
        if directory.exists():  # left over from a failed attempt
            shutil.rmtree(directory)
        writer = Writer(directory, version=9, storage_plugin=StoragePlugin.MCAP)
        self._segment_dir = directory
        writer.open()
        for key, value in self.custom_data.items():
            writer.set_custom_data(key, value)
        self._writer = writer
        self._connections = {}
        self._segment_opened = self.clock()

    def _write(self, item: tuple[str, int, bytes]) -> None:
        topic_name, timestamp, data = item
        if self._writer is None:
            self._open_segment()
        connection = self._connections.get(topic_name)
        if connection is None:
            with self._topics_lock:
                topic = self._topics[topic_name]
            connection = self._writer.add_connection(
                topic.name,
                topic.msgtype,
                msgdef=topic.msgdef,
                rihs01=topic.digest,
                offered_qos_profiles=topic.qos,
            )
            self._connections[topic_name] = connection
        self._writer.write(connection, timestamp, data)

    def _close_segment(self) -> None:
        writer, directory = self._writer, self._segment_dir
        name = directory.name
        start, end = writer.min_timestamp, writer.max_timestamp
        counts = collections.Counter()
        for connection in writer.connections:
            counts[connection.topic] += writer.counts[connection.id]
        writer.close()
        self._writer = None
        storage = directory / f"{name}.mcap"
        _fsync_file(storage)
        target = self.path / f"{name}.mcap"
        os.replace(storage, target)
        shutil.rmtree(directory, ignore_errors=True)
        self._segment_dir = None
        self._files.append(_File(target.name, start, end, sum(counts.values())))
        self._next_index += 1
        with self._topics_lock:
            for topic_name, count in counts.items():
                self._topics[topic_name].written += count
        self._segment_messages = []
        # The file is complete; until metadata.yaml lists it, its messages count as unlisted.
        self._unlisted += sum(counts.values())
        self._metadata_dirty = True
        self._write_metadata()

    def _abort_segment(self) -> None:
        writer, self._writer = self._writer, None
        if writer is not None:
            try:
                writer.abort()
            except Exception:  # noqa: BLE001 - the file is removed below anyway
                pass
        if self._segment_dir is not None:
            shutil.rmtree(self._segment_dir, ignore_errors=True)
            self._segment_dir = None

    def _fail(self, error: Exception, now: float) -> None:
        self.failures += 1
        self._abort_segment()
        # Back to the front of the queue, in order: nothing received is given up.
        self._queue.extendleft(reversed(self._segment_messages))
        self._segment_messages = []
        self._retry_at = now + RETRY_PERIOD_S
        if self._failing_since is None:
            self._failing_since = now
            what = getattr(error, "strerror", None) or str(error) or type(error).__name__
            filename = getattr(error, "filename", None)
            where = f" ({filename})" if filename else ""
            _error(
                f"cannot write the bag: {what}{where}; the bag stays readable with the "
                f"{len(self._files)} complete segment(s), {self.pending} messages are kept in "
                f"memory and writing is retried every {RETRY_PERIOD_S:g} s"
            )
        self._limit_memory()

    def _limit_memory(self) -> None:
        if not self._queue:
            return
        size = sum(len(item[2]) + 64 for item in self._queue)
        dropped = 0
        while self._queue and size > self.max_buffer_bytes:
            size -= len(self._queue.popleft()[2]) + 64
            dropped += 1
        if dropped:
            if not self.dropped:
                _error(
                    f"memory limit of {self.max_buffer_bytes / 2**20:g} MiB for unwritten "
                    "messages reached: dropping the oldest"
                )
            self.dropped += dropped

    # ---- metadata.yaml

    def _write_metadata(self) -> None:
        files = self._files
        start = min((f.start_ns for f in files), default=0)
        end = max((f.end_ns for f in files), default=0)
        count = sum(f.count for f in files)
        topics = [t for t in self._topic_list() if t.written]
        information = {
            "version": 9,
            "storage_identifier": "mcap",
            "relative_file_paths": [f.name for f in files],
            "duration": {"nanoseconds": max(0, end - start)},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": count,
            "topics_with_message_count": [
                {
                    "topic_metadata": {
                        "name": t.name,
                        "type": t.msgtype,
                        "serialization_format": "cdr",
                        "offered_qos_profiles": dump_qos_v9(t.qos),
                        "type_description_hash": t.digest,
                    },
                    "message_count": t.written,
                }
                for t in topics
            ],
            "compression_format": "",
            "compression_mode": "",
            "files": [
                {
                    "path": f.name,
                    "starting_time": {"nanoseconds_since_epoch": f.start_ns},
                    "duration": {"nanoseconds": max(0, f.end_ns - f.start_ns)},
                    "message_count": f.count,
                }
                for f in files
            ],
            "custom_data": self.custom_data or None,
            "ros_distro": "jazzy",
        }
        yaml = YAML(typ="safe")
        yaml.default_flow_style = False
        yaml.width = 4096
        yaml.representer.ignore_aliases = lambda *_: True
        text = io.StringIO()
        yaml.dump({"rosbag2_bagfile_information": information}, text)
        _atomic_write(self.path / "metadata.yaml", text.getvalue())
        self._metadata_dirty = False
        self._unlisted = 0


def _fsync_file(path: Path) -> None:
    descriptor = os.open(path, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


def _atomic_write(path: Path, text: str) -> None:
    """Write ``path`` so that a reader sees either the old or the new content, never a mix."""
    temporary = path.with_name(path.name + ".tmp")
    try:
        with open(temporary, "w", encoding="utf-8") as stream:
            stream.write(text)
            stream.flush()
            os.fsync(stream.fileno())
        os.replace(temporary, path)
    except OSError:
        _unlink_quietly(temporary)
        raise
    directory = os.open(path.parent, os.O_RDONLY)
    try:
        os.fsync(directory)
    finally:
        os.close(directory)


def _unlink_quietly(path: Path) -> None:
    try:
        path.unlink()
    except OSError:
        pass


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
                reliable = suite_topic.qos is not QosKind.SENSOR_DATA
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


def _positive(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (math.isfinite(value) and value > 0.0):
        raise argparse.ArgumentTypeError(f"must be a positive number, got {text}")
    return value


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
    parser.add_argument(
        "--segment-sec", type=_positive, default=DEFAULT_SEGMENT_SEC,
        help="close a storage file this often [s]; a SIGKILL loses at most the open one "
        f"({DEFAULT_SEGMENT_SEC:g})",
    )  # fmt: skip
    parser.add_argument(
        "--max-buffer-mb", type=_positive, default=DEFAULT_MAX_BUFFER_MB,
        help="memory for messages that cannot be written (full disk) before the oldest are "
        f"dropped [MiB] ({DEFAULT_MAX_BUFFER_MB:g})",
    )  # fmt: skip
    parser.add_argument("--duration", type=_positive, help="stop after this many seconds")
    return parser


def default_output() -> Path:
    """fishtail_<date>-<time> in the current directory (like rosbag2's default name)."""
    return Path(datetime.datetime.now().strftime("fishtail_%Y_%m_%d-%H_%M_%S"))


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``fishtail-record``."""
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
    sys.exit(main())
