"""Reading the suite's rosbag2 bags with rosbags, one message at a time: the suite's one reader.

``fishtail-analyse``, ``fishtail-swim animate --bag`` and ``fishtail-view --bag`` all open bags
here (:class:`BagFile`), so that they agree on types, topics and errors and keep only what they
take from each message. Every problem with the input raises :class:`BagError` (or the reader's
own error class) with a one-line message. What the reader does: docs/recording.md ("One bag
reader").

>>> round(yaw_of_quaternion(0.0, 0.0, math.sin(0.3), math.cos(0.3)), 12)  # 0.6 rad about z
0.6
"""

from __future__ import annotations

import math
from collections.abc import Generator, Sequence
from pathlib import Path
from types import TracebackType
from typing import Any

from fishtail_common.bag_types import register_package_types
from fishtail_common.interface import Topic


class BagError(Exception):
    """The bag cannot be read; the message is one line for the user."""


def describe_error(error: BaseException) -> str:
    """An exception as one line without a trailing full stop."""
    text = " ".join(str(error).split()) or type(error).__name__
    return text.rstrip(".")


def bag_typestore(connections: Sequence[Any]) -> Any:
    """The Jazzy typestore plus the definitions the bag carries, plus installed fishtail_msgs."""
    from rosbags.interfaces import MessageDefinitionFormat
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    for connection in connections:
        definition = connection.msgdef
        if (
            connection.msgtype in store.fielddefs
            or definition.format != MessageDefinitionFormat.MSG
        ):
            continue
        types = get_types_from_msg(definition.data, connection.msgtype)
        store.register(
            {name: fields for name, fields in types.items() if name not in store.fielddefs}
        )
    try:
        register_package_types(store, "fishtail_msgs")  # adds only what the bag did not carry
    except LookupError:
        pass  # not installed: the bag must carry the definitions (BagFile.check says so)
    return store


def topic_under(namespace: str, suffix: str) -> str:
    """The absolute name of the suite's topic ``suffix`` under ``namespace`` ("" for none)."""
    return "/" + "/".join(p for p in (namespace.strip("/"), suffix) if p)


def pick_topic(
    connections: Sequence[Any],
    msgtype: str,
    suffix: str,
    namespace: str | None,
    any_name: bool = True,
    error: type[Exception] = BagError,
) -> str | None:
    """The topic of ``msgtype`` named ``<namespace>/<suffix>``, None if there is none.

    Without a namespace, the topic ``/<suffix>`` or ``.../<suffix>``; without such a name and with
    ``any_name``: the one topic of that type, if there is one.

    Raises:
        BagError: (or ``error``) several candidates; the message asks for a namespace.
    """
    topics = sorted({c.topic for c in connections if c.msgtype == msgtype})
    if namespace is not None:
        wanted = topic_under(namespace, suffix)
        return wanted if wanted in topics else None
    named = [t for t in topics if t == "/" + suffix or t.endswith("/" + suffix)]
    candidates = named or (topics if any_name else [])
    if len(candidates) > 1:
        raise error(
            f"several {msgtype} topics ({', '.join(candidates)}): choose one with --namespace"
        )
    return candidates[0] if candidates else None


def allow_many_open_files() -> None:
    """Raise the soft limit of open files to the hard one, best effort.

    rosbags opens every storage file of a split bag at once; a long ``fishtail-record`` run has
    one file per segment, more than the common soft limit of 1024.
    """
    try:
        import resource

        soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
        if soft != resource.RLIM_INFINITY and (hard == resource.RLIM_INFINITY or soft < hard):
            resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
    except (ImportError, OSError, ValueError):
        pass


def stamp_ns(message: Any) -> int:
    """The message's header stamp in nanoseconds."""
    stamp = message.header.stamp
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def yaw_of_quaternion(x: float, y: float, z: float, w: float) -> float:
    """The heading (rotation about z, rad, in (-pi, pi]) of an orientation quaternion."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


class BagFile:
    """A rosbag2 bag (directory, ``.mcap`` or ``.db3``), open for reading; use it in ``with``.

    Raises:
        BagError: (or the ``error`` given) a path that does not exist, and opening, reading and
            deserialising failures, as ``<path>: not a readable rosbag2 bag: <why>``.
    """

    def __init__(self, path: str | Path, error: type[Exception] = BagError) -> None:
        """Open the bag at ``path`` and build its typestore."""
        from rosbags.rosbag2 import Reader

        self.path = Path(path)
        self.error = error
        if not self.path.exists():
            raise error(f"{self.path}: no such file or directory")
        if self.path.is_dir():
            allow_many_open_files()
        try:
            self.reader = Reader(self.path)
            self.reader.open()
        except Exception as cause:  # noqa: BLE001 - rosbags and sqlite raise many kinds
            raise self._unreadable(cause) from None
        try:
            self.connections: list[Any] = list(self.reader.connections)
            self.typestore = bag_typestore(self.connections)
        except Exception as cause:  # noqa: BLE001 - a damaged definition in the bag
            self.reader.close()
            raise self._unreadable(cause) from None

    def _unreadable(self, cause: BaseException) -> Exception:
        return self.error(f"{self.path}: not a readable rosbag2 bag: {describe_error(cause)}")

    def __enter__(self) -> BagFile:
        """The bag itself."""
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        """Close the bag."""
        self.close()

    def close(self) -> None:
        """Close the bag's files."""
        self.reader.close()

    @property
    def file_count(self) -> int:
        """How many storage files the bag has (a split bag's segments; a storage file alone: 1)."""
        from rosbags.rosbag2.reader import DirectoryReader

        storage = self.reader.storage
        return len(storage.storages) if isinstance(storage, DirectoryReader) else 1

    @property
    def message_count(self) -> int:
        """How many messages the bag holds, all topics."""
        return int(self.reader.message_count)

    @property
    def duration_ns(self) -> int:
        """From the first receive time to the last, ns."""
        return int(self.reader.duration)

    @property
    def end_ns(self) -> int:
        """The receive time just after the last message, ns."""
        return int(self.reader.end_time)

    def listing(self) -> str:
        """The bag's topics and types, for messages: ``/a (pkg/msg/A), ...`` or ``none``."""
        return ", ".join(f"{c.topic} ({c.msgtype})" for c in self.connections) or "none"

    def pick(self, topic: Topic, namespace: str | None, any_name: bool = True) -> str | None:
        """The bag's topic for ``topic`` under ``namespace``, as :func:`pick_topic` picks it."""
        return pick_topic(
            self.connections, topic.type, topic.name, namespace, any_name, error=self.error
        )

    def count(self, topic: str | None) -> int:
        """How many messages the bag holds on ``topic`` (0 for None)."""
        return sum(int(c.msgcount) for c in self.connections if c.topic == topic)

    def connections_of(self, *topics: str | None) -> list[Any]:
        """The connections of these topics (None entries ignored)."""
        wanted = {topic for topic in topics if topic is not None}
        return [c for c in self.connections if c.topic in wanted]

    def check(self, connections: Sequence[Any]) -> None:
        """Check that each connection's type is known as the definition it was recorded with.

        Raises:
            BagError: (or the bag's ``error``) a type with no definition, or one recorded with
                another definition (its hash).
        """
        for connection in connections:
            if connection.msgtype not in self.typestore.fielddefs:
                raise self.error(
                    f"{self.path}: no definition of {connection.msgtype} in the bag or installed"
                )
            digest = connection.digest
            if digest and self.typestore.hash_rihs01(connection.msgtype) != digest:
                raise self.error(
                    f"{self.path}: {connection.topic} was recorded with another definition of "
                    f"{connection.msgtype} (hash {digest})"
                )

    def messages(
        self, connections: Sequence[Any], start_ns: int | None = None, stop_ns: int | None = None
    ) -> Generator[tuple[Any, int, Any], None, None]:
        """(connection, receive time ns, message) in the bag's order, deserialised one by one.

        ``start_ns``/``stop_ns`` bound the receive time (rosbag2's timestamps), stop excluded.

        Raises:
            BagError: (or the bag's ``error``) as :meth:`check`, or a truncated or undecodable
                message.
        """
        self.check(connections)
        if not connections:
            return
        store = self.typestore
        try:
            for connection, timestamp, raw in self.reader.messages(
                connections=connections, start=start_ns, stop=stop_ns
            ):
                yield connection, timestamp, store.deserialize_cdr(raw, connection.msgtype)
        except self.error:
            raise
        except Exception as cause:  # noqa: BLE001 - a truncated chunk, a bad CDR payload
            raise self._unreadable(cause) from None
