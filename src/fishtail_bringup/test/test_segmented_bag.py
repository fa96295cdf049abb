"""The segmented bag in-process: the clock and disk faults under the test's control."""

from __future__ import annotations

import errno
import os
from pathlib import Path

import pytest
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability
from rosbags.interfaces import QosTime as T
from rosbags.rosbag2 import Reader
from rosbags.rosbag2.storage_mcap import McapWriter

from fishtail_bringup import segmented_bag
from fishtail_common.bag_types import suite_typestore

FLOAT64 = "std_msgs/msg/Float64"
QOS = Qos(
    QosHistory.KEEP_LAST, 10, QosReliability.RELIABLE, QosDurability.VOLATILE, T(0, 0), T(0, 0),
    QosLiveliness.AUTOMATIC, T(0, 0), False,
)  # fmt: skip


@pytest.fixture(scope="module")
def store():
    return suite_typestore()


class Clock:
    """A monotonic clock that moves only when told."""

    def __init__(self) -> None:
        """Start at an arbitrary time."""
        self.now = 100.0

    def __call__(self) -> float:
        """The current time [s]."""
        return self.now

    def advance(self, seconds: float) -> None:
        """Move the clock on."""
        self.now += seconds


class Disk:
    """Makes rosbags' MCAP writer and the metadata writer fail with ENOSPC while ``full``."""

    def __init__(self, monkeypatch) -> None:
        """Patch the writers (undone by monkeypatch at teardown)."""
        self.full = False
        self.metadata_full = False
        original_close = McapWriter.close
        original_metadata = segmented_bag._atomic_write
        disk = self

        def close(writer, *args):
            if disk.full:
                writer.bio.write(b"\x00" * 100)  # part of the index reaches the disk
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            return original_close(writer, *args)

        def atomic_write(path, text):
            if disk.metadata_full:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
            return original_metadata(path, text)

        monkeypatch.setattr(McapWriter, "close", close)
        monkeypatch.setattr(segmented_bag, "_atomic_write", atomic_write)


def float_message(store, value: float) -> bytes:
    return bytes(store.serialize_cdr(store.types[FLOAT64](data=value), FLOAT64))


def contents(store, path: Path) -> tuple[int, list[float]]:
    """(number of storage files, values in order) of the bag, read with rosbags."""
    with Reader(path) as reader:
        values = [
            store.deserialize_cdr(raw, connection.msgtype).data
            for connection, _, raw in reader.messages()
        ]
        assert reader.message_count == len(values)
        return len(reader.storage.files), values


def feed(store, bag, values, start_ns: int = 1_000) -> None:
    for value in values:
        bag.append("/a", start_ns + int(value) * 1000, float_message(store, value))


def test_closed_segments_are_listed_and_the_open_one_is_not(store, tmp_path):
    clock = Clock()
    path = tmp_path / "bag"
    bag = segmented_bag.SegmentedBag(path, store, segment_sec=1.0, clock=clock)
    bag.open()
    assert contents(store, path) == (0, [])  # a bag from the first moment
    bag.add_topic("/a", FLOAT64, [QOS])
    for segment in range(3):
        feed(store, bag, range(10 * segment, 10 * segment + 10))
        bag.service()  # written into the open segment, not listed yet
        assert contents(store, path) == (segment, list(range(10 * segment)))
        clock.advance(1.0)
        bag.service()
        assert contents(store, path) == (segment + 1, list(range(10 * segment + 10)))
    feed(store, bag, range(30, 35))
    bag.service()
    # What a SIGKILL now would leave: the complete segments, and the open one's directory.
    assert contents(store, path) == (3, list(range(30)))
    assert (path / "bag_3").is_dir()
    report = bag.close()
    assert contents(store, path) == (4, list(range(35)))
    assert not (path / "bag_3").exists() and (path / "bag_3.mcap").is_file()
    assert (report.received, report.written, report.files, report.unwritten) == (35, 35, 4, 0)
    assert report.topics == {"/a": 35}
    metadata = (path / "metadata.yaml").read_text()
    assert "- bag_0.mcap" in metadata and "- bag_3.mcap" in metadata
    assert "*id" not in metadata and "&id" not in metadata  # no YAML aliases for yaml-cpp


def test_full_disk_keeps_the_bag_consistent_and_retries(store, tmp_path, capsys, monkeypatch):
    disk = Disk(monkeypatch)
    clock = Clock()
    path = tmp_path / "bag"
    bag = segmented_bag.SegmentedBag(path, store, segment_sec=1.0, clock=clock)
    bag.open()
    bag.add_topic("/a", FLOAT64, [QOS])
    feed(store, bag, range(10))
    bag.service()
    clock.advance(1.0)
    bag.service()
    assert contents(store, path) == (1, list(range(10)))

    disk.full = True
    feed(store, bag, range(10, 20))
    bag.service()
    clock.advance(1.0)
    bag.service()  # closing the segment fails
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "No space left on device" in err
    assert "the bag stays readable with the 1 complete segment(s), 10 messages" in err
    assert bag.failing and bag.pending == 10
    assert contents(store, path) == (1, list(range(10)))
    assert sorted(p.name for p in path.iterdir()) == ["bag_0.mcap", "metadata.yaml"]

    feed(store, bag, range(20, 25))
    clock.advance(0.5)
    bag.service()  # too early for a retry
    clock.advance(0.6)
    bag.service()  # retried, still full: no new error line
    assert capsys.readouterr().err == ""
    assert bag.pending == 15

    disk.full = False
    clock.advance(1.1)
    bag.service()
    assert "writing again" in capsys.readouterr().out
    assert not bag.failing and bag.pending == 0
    assert contents(store, path) == (2, list(range(25)))
    report = bag.close()
    assert (report.received, report.written, report.unwritten) == (25, 25, 0)


def test_full_disk_at_exit_reports_what_was_not_written(store, tmp_path, monkeypatch):
    disk = Disk(monkeypatch)
    clock = Clock()
    path = tmp_path / "bag"
    bag = segmented_bag.SegmentedBag(path, store, segment_sec=1.0, clock=clock)
    bag.open()
    bag.add_topic("/a", FLOAT64, [QOS])
    feed(store, bag, range(10))
    bag.service()
    clock.advance(1.0)
    bag.service()
    disk.full = True
    feed(store, bag, range(10, 17))
    report = bag.close(retry_for_s=0.0)
    assert (report.received, report.written, report.unwritten) == (17, 10, 7)
    assert contents(store, path) == (1, list(range(10)))
    assert sorted(p.name for p in path.iterdir()) == ["bag_0.mcap", "metadata.yaml"]


def test_metadata_that_cannot_be_rewritten_is_retried(store, tmp_path, monkeypatch, capsys):
    disk = Disk(monkeypatch)
    clock = Clock()
    path = tmp_path / "bag"
    bag = segmented_bag.SegmentedBag(path, store, segment_sec=1.0, clock=clock)
    bag.open()
    bag.add_topic("/a", FLOAT64, [QOS])
    disk.metadata_full = True
    feed(store, bag, range(10))
    bag.service()
    clock.advance(1.0)
    bag.service()
    assert "metadata.yaml" in capsys.readouterr().err
    assert contents(store, path) == (0, [])  # the old metadata.yaml still holds
    assert bag.written == 0
    disk.metadata_full = False
    clock.advance(1.0)
    bag.service()
    assert contents(store, path) == (1, list(range(10)))
    assert bag.close().unwritten == 0


def test_memory_limit_drops_the_oldest(store, tmp_path, monkeypatch, capsys):
    disk = Disk(monkeypatch)
    clock = Clock()
    bag = segmented_bag.SegmentedBag(
        tmp_path / "bag", store, segment_sec=1.0, clock=clock, max_buffer_bytes=50 * 100
    )
    bag.open()
    bag.add_topic("/a", FLOAT64, [QOS])
    disk.full = True
    feed(store, bag, range(200))
    bag.service()
    clock.advance(1.0)
    bag.service()
    assert "memory limit" in capsys.readouterr().err
    assert bag.dropped > 100 and bag.pending == 200 - bag.dropped
    disk.full = False
    clock.advance(1.0)
    bag.service()
    _, values = contents(store, tmp_path / "bag")
    assert values == list(range(bag.dropped, 200))  # the newest survive, in order
    assert bag.close().unwritten == bag.dropped


def test_existing_output_is_refused(tmp_path, store):
    (tmp_path / "bag").mkdir()
    with pytest.raises(FileExistsError, match="exists already"):
        segmented_bag.SegmentedBag(tmp_path / "bag", store).open()
