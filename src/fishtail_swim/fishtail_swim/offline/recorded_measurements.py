"""Steady segments of a recorded run, as the measurements ``fishtail-swim fit`` takes.

A bag of a run (``fish/odom`` from motion capture or the simulator, the carrier from
``motor/joint_state`` or ``tail/state``) is read through the suite's one reader
(:class:`~fishtail_common.bag_reading.BagFile`) into a few numpy arrays. The run is cut into beats
(one carrier turn each), the beats into stretches where the carrier speed holds, and each stretch
is trimmed at its start until the fish's speed has settled; what remains of at least
``min_beats`` beats is a steady segment. Each segment gives the mean carrier speed, the fish's mean
speed and its mean yaw rate over its whole beats, and :meth:`MeasuredSegments.csv_text` writes
them as a measurements file. Topics, the criterion, tolerances and refusals: docs/recording.md
("Steady segments for fit").

The segments themselves: :mod:`.steady_segments`.
"""

from __future__ import annotations

import dataclasses
import math
from array import array
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fishtail_common.bag_reading import BagError, BagFile, stamp_ns, yaw_of_quaternion
from fishtail_common.interface import CARRIER_JOINT, FISH_ODOM, MOTOR_JOINT_STATE, TAIL_STATE
from fishtail_plant.fish.fish import FloatArray
from fishtail_swim.offline.recorded_samples import joint_sample
from fishtail_swim.offline.steady_segments import (
    RecordedSamples,
    SteadyCriterion,
    SteadySegment,
    steady_segments,
)

__all__ = ["CSV_HEADER", "MeasuredSegments", "measurements_from_bag", "read_recorded_samples"]

#: The header of the measurements file (fit's column names).
CSV_HEADER = "carrier_speed_rad_s,speed_m_s,yaw_rate_rad_s"
TWO_PI = 2.0 * math.pi


@dataclasses.dataclass(frozen=True)
class MeasuredSegments:
    """The steady segments of a recorded run and where they come from."""

    source: str
    odom_topic: str
    carrier_source: str
    criterion: SteadyCriterion
    segments: tuple[SteadySegment, ...]
    #: Stretches left out and other remarks, for the user.
    notes: tuple[str, ...] = ()

    @property
    def carrier_speed_rad_s(self) -> FloatArray:
        """Each segment's mean carrier speed."""
        return np.array([s.carrier_speed_rad_s for s in self.segments], dtype=float)

    @property
    def speed_m_s(self) -> FloatArray:
        """Each segment's mean fish speed."""
        return np.array([s.speed_m_s for s in self.segments], dtype=float)

    @property
    def yaw_rate_rad_s(self) -> FloatArray:
        """Each segment's mean yaw rate (counter-clockwise seen from above positive)."""
        return np.array([s.yaw_rate_rad_s for s in self.segments], dtype=float)

    def csv_text(self) -> str:
        """The measurements file: ``#`` comments, the header, one row per segment."""
        lines = [
            f"# steady segments of {self.source}",
            f"# fish: {self.odom_topic}; carrier: {self.carrier_source}",
            f"# criterion: {self.criterion.describe()}",
            "# times in s after the first fish/odom stamp; means over each segment's whole beats",
        ]
        for number, segment in enumerate(self.segments, start=1):
            lines.append(
                f"# segment {number}: {segment.start_s:.3f} to {segment.end_s:.3f} s, "
                f"{segment.beats} beats, settled {segment.settle_s:.2f} s after the carrier "
                "speed changed"
            )
        lines += [f"# {note}" for note in self.notes]
        lines.append(CSV_HEADER)
        lines += [
            f"{s.carrier_speed_rad_s:.6g},{s.speed_m_s:.6g},{s.yaw_rate_rad_s:.6g}"
            for s in self.segments
        ]
        return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------------
# Reading the bag


@dataclasses.dataclass
class _Column:
    """A growing column of stamps and values (compact: C arrays, not Python floats)."""

    stamps: array[int] = dataclasses.field(default_factory=lambda: array("q"))
    values: list[array[float]] = dataclasses.field(default_factory=list)

    def add(self, stamp: int, values: Sequence[float]) -> None:
        if not self.values:
            self.values = [array("d") for _ in values]
        self.stamps.append(stamp)
        for column, value in zip(self.values, values, strict=True):
            column.append(value)

    def sorted(self, origin_ns: int, count: int) -> tuple[FloatArray, list[FloatArray]]:
        """Times (s since ``origin_ns``) and values, by stamp, repeated stamps dropped."""
        stamps = np.frombuffer(self.stamps, dtype=np.int64)
        values = [np.frombuffer(v, dtype=np.float64) for v in self.values] or [
            np.empty(0) for _ in range(count)
        ]
        order = np.argsort(stamps, kind="stable")
        stamps = stamps[order]
        keep = np.diff(stamps, prepend=stamps[:1] - 1) > 0
        time_s = np.asarray((stamps[keep] - origin_ns) * 1e-9, dtype=np.float64)
        return time_s, [v[order][keep] for v in values]


def _finite(values: Sequence[float], bag: Path, topic: str, stamp: int) -> Sequence[float]:
    if not all(math.isfinite(v) for v in values):
        raise BagError(
            f"{bag}: {topic} has a value that is not a finite number (stamp {stamp * 1e-9:.3f} s):"
            " cannot measure steady speeds from it"
        )
    return values


def _odom_values(message: Any) -> tuple[float, float, float]:
    pose = message.pose.pose
    q = pose.orientation
    psi = yaw_of_quaternion(float(q.x), float(q.y), float(q.z), float(q.w))
    return float(pose.position.x), float(pose.position.y), psi


def read_recorded_samples(
    bag_dir: str | Path, namespace: str | None = None
) -> tuple[RecordedSamples, str, str]:
    """The bag's fish poses and carrier angles, with the odometry topic and the carrier's source.

    The carrier comes from ``carrier_joint`` of motor/joint_state (the encoder), else from the
    ``motor_angle`` of tail/state (the kinematics node's echo of it). Samples sit at their header
    stamps.

    Raises:
        BagError: a missing or unreadable bag, no fish/odom messages, no carrier topic with
            messages, or a value that is not a finite number.
    """
    path = Path(bag_dir)
    with BagFile(path) as bag:
        odom_topic = bag.pick(FISH_ODOM, namespace)
        if not bag.count(odom_topic):
            raise BagError(
                f"{path}: no fish/odom messages, which the fish's speed is measured from "
                f"(topics: {bag.listing()})"
            )
        joint_topic = bag.pick(MOTOR_JOINT_STATE, namespace, any_name=False)
        state_topic = bag.pick(TAIL_STATE, namespace)
        if bag.count(joint_topic):
            carrier_topic, carrier_source = joint_topic, f"{CARRIER_JOINT} of {joint_topic}"
        elif bag.count(state_topic):
            carrier_topic, carrier_source = state_topic, f"motor_angle of {state_topic}"
        else:
            raise BagError(
                f"{path}: no carrier (no motor/joint_state or tail/state messages), which the "
                f"beats and carrier speeds come from (topics: {bag.listing()})"
            )
        odom, carrier = _Column(), _Column()
        for connection, _, message in bag.messages(bag.connections_of(odom_topic, carrier_topic)):
            stamp = stamp_ns(message)
            if connection.topic == odom_topic:
                odom.add(stamp, _finite(_odom_values(message), path, odom_topic or "", stamp))
            elif carrier_topic == state_topic:
                motor = (float(message.motor_angle),)
                carrier.add(stamp, _finite(motor, path, carrier_topic or "", stamp))
            else:
                sample = joint_sample(message, CARRIER_JOINT)
                if sample is not None:
                    carrier.add(stamp, _finite(sample[:1], path, carrier_topic or "", stamp))
    if not carrier.stamps:
        raise BagError(f"{path}: {carrier_topic} has no {CARRIER_JOINT} samples")
    origin = int(min(odom.stamps))
    odom_time, (x, y, psi) = odom.sorted(origin, 3)
    carrier_time, (angle,) = carrier.sorted(origin, 1)
    samples = RecordedSamples(odom_time, x, y, psi, carrier_time, angle, origin)
    return samples, odom_topic or "", carrier_source


def measurements_from_bag(
    bag_dir: str | Path,
    criterion: SteadyCriterion | None = None,
    namespace: str | None = None,
) -> MeasuredSegments:
    """The steady segments of the run recorded in ``bag_dir`` and their means.

    Raises:
        BagError: as :func:`read_recorded_samples`.
        NoSteadySegmentError: no stretch of the run meets ``criterion`` (the line says why).
    """
    criterion = criterion or SteadyCriterion()
    samples, odom_topic, carrier_source = read_recorded_samples(bag_dir, namespace)
    segments, notes = steady_segments(samples, criterion, str(bag_dir))
    return MeasuredSegments(str(bag_dir), odom_topic, carrier_source, criterion, segments, notes)
