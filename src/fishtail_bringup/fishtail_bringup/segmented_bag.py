"""A rosbag2 *split* bag written segment by segment, so that a killed writer loses little.

rosbags' MCAP writer writes a file's index only when it closes, and a file without its index
cannot be read: :class:`SegmentedBag` closes one storage file every ``segment_sec`` seconds
before listing it in ``metadata.yaml``, and keeps messages in memory (up to ``max_buffer_bytes``)
while the disk is full. No rclpy here: :mod:`fishtail_bringup.record` feeds it raw CDR bytes.
The layout and what survives what: docs/recording.md ("fishtail-record").
"""

from __future__ import annotations

import collections
import dataclasses
import io
import math
import os
import shutil
import sys
import threading
import time
from collections.abc import Callable, Iterable
from pathlib import Path

from rosbags.interfaces import Connection, Qos
from rosbags.rosbag2 import Writer
from rosbags.rosbag2.enums import StoragePlugin
from rosbags.rosbag2.metadata import dump_qos_v9
from ruamel.yaml import YAML

DEFAULT_SEGMENT_SEC = 5.0
DEFAULT_MAX_BUFFER_MB = 256.0
#: After a failed write, wait this long before trying again.
RETRY_PERIOD_S = 1.0
#: At exit on a full disk, keep trying this long before giving up on what is still in memory.
EXIT_RETRY_S = 3.0


def _print_info(text: str) -> None:
    print(f"bag: {text}", flush=True)


def _print_error(text: str) -> None:
    print(f"bag: error: {text}", file=sys.stderr, flush=True)


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
    """A rosbag2 split bag written segment by segment (docs/recording.md, "fishtail-record").

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
        say: Callable[[str], None] = _print_info,
        error: Callable[[str], None] = _print_error,
    ) -> None:
        """Prepare (nothing is created before :meth:`open`).

        ``say`` and ``error`` show what happens to the bag (a write failure, the recovery) to
        whoever runs it; by default on stdout and stderr.

        Raises:
            ValueError: ``segment_sec`` not positive and finite.
        """
        if not (math.isfinite(segment_sec) and segment_sec > 0.0):
            raise ValueError(f"segment_sec must be positive, got {segment_sec!r}")
        self.path = Path(path)
        self.typestore = typestore
        self.segment_sec = segment_sec
        self.max_buffer_bytes = max_buffer_bytes
        self.clock = clock
        self.custom_data = dict(custom_data or {})
        self._say = say
        self._error = error
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
        self._connections: dict[str, Connection] = {}
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
        """Create the bag directory with a metadata.yaml that lists no file yet.

        Raises:
            FileExistsError: the directory exists already.
            OSError: it cannot be created or written.
        """
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
            self._say(
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
        writer = self._writer
        assert writer is not None  # opened above
        connection = self._connections.get(topic_name)
        if connection is None:
            with self._topics_lock:
                topic = self._topics[topic_name]
            connection = writer.add_connection(
                topic.name,
                topic.msgtype,
                msgdef=topic.msgdef,
                rihs01=topic.digest,
                offered_qos_profiles=topic.qos,
            )
            self._connections[topic_name] = connection
        writer.write(connection, timestamp, data)

    def _close_segment(self) -> None:
        writer, directory = self._writer, self._segment_dir
        assert writer is not None and directory is not None  # only called with a segment open
        name = directory.name
        start, end = writer.min_timestamp, writer.max_timestamp
        counts: collections.Counter[str] = collections.Counter()
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
            self._error(
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
                self._error(
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
