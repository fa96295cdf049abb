"""A recording as arrays: a rosbag2 bag (MCAP or sqlite3) or the CSV of the CLI's table.

The carrier angle is ``motor/joint_state``'s where its stamp matches a ``tail/state``, else the
one ``tail/state`` carries (docs/recording.md, "fishtail-analyse"). Every problem with the input
raises :class:`AnalysisError` with a one-line message.
"""

from __future__ import annotations

import csv
import dataclasses
import math
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from fishtail_common.bag_reading import BagFile, describe_error, stamp_ns
from fishtail_common.interface import (
    CARRIER_JOINT,
    FISH_ODOM,
    FISH_SWIMMING,
    MECHANISM_CODES,
    MOTOR_JOINT_STATE,
    TAIL_STATE,
    TAIL_SYMMETRY,
)
from fishtail_kinematics.engine.geometry import FloatArray
from fishtail_kinematics.engine.mechanisms import TAIL_TYPES
from fishtail_kinematics.offline.table_columns import FIELD_OF_COLUMN

MECHANISM_OF_CODE = {code: name for name, code in MECHANISM_CODES.items()}
#: TailState field -> engine field, where they differ.
_ENGINE_FIELD_OF_MESSAGE = {
    ("tip", "x"): "tip_x",
    ("tip", "y"): "tip_y",
    ("tip_velocity", "x"): "tip_x_dot",
    ("tip_velocity", "y"): "tip_y_dot",
}
_MESSAGE_FIELD_OF_ENGINE = {engine: parts for parts, engine in _ENGINE_FIELD_OF_MESSAGE.items()}
#: Columns a CSV needs to be analysed.
_REQUIRED_COLUMNS = ("motor_angle_rad", "theta3", "theta3_dot", "Tx", "Ty")
_MCAP_MAGIC = b"\x89MCAP0\r\n"
_SQLITE_MAGIC = b"SQLite format 3\x00"


class AnalysisError(Exception):
    """The input cannot be analysed; the message is one line for the user."""


@dataclasses.dataclass(frozen=True)
class RecordedFish:
    """The fish's forward speed as recorded, on the recording's time axis (s after its origin).

    ``odom_*``: every ``fish/odom`` sample's header stamp and surge u (``twist.linear.x``, body
    frame, m/s). ``swim_*``: every ``fish/swimming`` message's window (one carrier revolution,
    ending at its stamp, lasting 1 / ``beat_frequency_hz``) and ``mean_speed_m_s``. Either may be
    empty. Which of them the swimming figures use:
    :mod:`~fishtail_kinematics.offline.recorded_speed`.
    """

    odom_topic: str | None
    odom_time_s: FloatArray
    odom_surge_m_s: FloatArray
    swim_topic: str | None
    swim_start_s: FloatArray
    swim_end_s: FloatArray
    swim_speed_m_s: FloatArray

    @property
    def empty(self) -> bool:
        """No fish/odom and no fish/swimming message."""
        return self.odom_time_s.size == 0 and self.swim_end_s.size == 0


@dataclasses.dataclass
class Recording:
    """What was read from a bag or a CSV, as arrays in time order.

    ``state`` holds recorded engine fields (empty when the bag has no tail/state); ``carrier_angle``
    and ``carrier_velocity`` are the engine's inputs, one per sample; ``time_s`` is seconds since
    the first sample and ``stamp_s`` the absolute stamps (as the monitor computes them).
    """

    source: Path
    kind: str  # "bag" or "csv"
    description: str
    mechanism: str | None
    time_s: FloatArray
    stamp_s: FloatArray
    carrier_angle: FloatArray
    carrier_velocity: FloatArray
    carrier_source: str
    state: dict[str, FloatArray]
    monitor_verdicts: list[int] = dataclasses.field(default_factory=list)
    notes: list[str] = dataclasses.field(default_factory=list)
    periodic: bool = False  # CSV: one carrier cycle
    #: The pivot shift of each tail/state sample, m; None where none was recorded (unshifted).
    pivot_shift_m: FloatArray | None = None
    #: The stamp (ns since the epoch) that ``time_s`` counts from (0 for a CSV).
    origin_ns: int = 0
    #: The fish's recorded speed (fish/odom, fish/swimming), None if the input has neither.
    fish: RecordedFish | None = None


def read_recording(path: str | Path, namespace: str | None = None) -> Recording:
    """Read a rosbag2 bag (directory, .mcap or .db3) or a CSV of ``fishtail-kinematics table``.

    Raises:
        AnalysisError: the input is missing, unreadable or not a usable recording.
    """
    path = Path(path)
    if not path.exists():
        raise AnalysisError(f"{path}: no such file or directory")
    if path.is_dir() or path.suffix in (".mcap", ".db3"):
        return read_bag(path, namespace)
    try:
        with open(path, "rb") as stream:
            head = stream.read(16)
    except OSError as error:
        raise AnalysisError(f"{path}: cannot read: {error.strerror}") from None
    if head.startswith(_MCAP_MAGIC) or head.startswith(_SQLITE_MAGIC):
        return read_bag(path, namespace)
    return read_csv(path)


# ---- bags


def read_bag(path: Path, namespace: str | None = None) -> Recording:
    """Read tail/state, motor/joint_state and tail/symmetry from a rosbag2 bag.

    Raises:
        AnalysisError: a damaged or foreign bag, or one without the carrier's messages.
    """
    with BagFile(path, error=AnalysisError) as bag:
        state_topic = bag.pick(TAIL_STATE, namespace)
        # Other JointState topics (tail/joint_states) are not the carrier.
        joint_topic = bag.pick(MOTOR_JOINT_STATE, namespace, any_name=False)
        report_topic = bag.pick(TAIL_SYMMETRY, namespace)
        # Only a topic named fish/odom: a bag may hold other odometry (a robot base's, ...).
        odom_topic = bag.pick(FISH_ODOM, namespace, any_name=False)
        swim_topic = bag.pick(FISH_SWIMMING, namespace)
        if state_topic is None and joint_topic is None:
            where = f" in namespace {namespace!r}" if namespace is not None else ""
            raise AnalysisError(
                f"{path}: no tail/state or motor/joint_state topic{where}: not a fishtail "
                f"recording (topics: {bag.listing()})"
            )
        states: list[Any] = []
        joints: list[Any] = []
        reports: list[Any] = []
        odoms: list[tuple[int, float]] = []  # (stamp ns, surge m/s): a whole Odometry is large
        swims: list[tuple[int, float, float]] = []  # (stamp ns, frequency Hz, speed m/s)
        sink = {state_topic: states, joint_topic: joints, report_topic: reports}
        for connection, _, message in bag.messages(
            bag.connections_of(state_topic, joint_topic, report_topic, odom_topic, swim_topic)
        ):
            if connection.topic == odom_topic:
                odoms.append((stamp_ns(message), float(message.twist.twist.linear.x)))
            elif connection.topic == swim_topic:
                swims.append(
                    (
                        stamp_ns(message),
                        float(message.beat_frequency_hz),
                        float(message.mean_speed_m_s),
                    )
                )
            else:
                sink[connection.topic].append(message)
        description = (
            f"rosbag2 bag, {bag.file_count} file(s), {bag.message_count} messages, "
            f"{bag.duration_ns * 1e-9:.1f} s"
        )
    if state_topic is not None and not states:
        if not joints:
            raise AnalysisError(f"{path}: the bag holds no tail/state or motor/joint_state message")
        state_topic = None
    if state_topic is None and not joints:
        raise AnalysisError(f"{path}: the bag holds no motor/joint_state message")
    recording = _recording_from_messages(path, description, states, joints)
    recording.monitor_verdicts = [int(r.verdict) for r in reports]
    if odoms or swims:
        recording.fish = _recorded_fish(
            recording.origin_ns, odom_topic if odoms else None, odoms,
            swim_topic if swims else None, swims,
        )  # fmt: skip
    return recording


def _recorded_fish(
    origin_ns: int,
    odom_topic: str | None,
    odoms: list[tuple[int, float]],
    swim_topic: str | None,
    swims: list[tuple[int, float, float]],
) -> RecordedFish:
    """The fish's samples in stamp order, repeated stamps and non-finite values dropped."""
    odom = sorted({stamp: surge for stamp, surge in odoms if math.isfinite(surge)}.items())
    odom_time = np.array([(stamp - origin_ns) * 1e-9 for stamp, _ in odom])
    odom_surge = np.array([surge for _, surge in odom])
    beats = sorted(
        {
            stamp: (frequency, speed)
            for stamp, frequency, speed in swims
            if math.isfinite(frequency) and frequency > 0.0 and math.isfinite(speed)
        }.items()
    )
    swim_end = np.array([(stamp - origin_ns) * 1e-9 for stamp, _ in beats])
    swim_start = swim_end - np.array([1.0 / frequency for _, (frequency, _) in beats])
    swim_speed = np.array([speed for _, (_, speed) in beats])
    return RecordedFish(
        odom_topic, odom_time, odom_surge, swim_topic, swim_start, swim_end, swim_speed
    )


def _carrier_index(names: Sequence[str]) -> int | None:
    names = list(names)
    if CARRIER_JOINT in names:
        return names.index(CARRIER_JOINT)
    return 0 if len(names) == 1 else None


def _recording_from_messages(
    path: Path, description: str, states: list[Any], joints: list[Any]
) -> Recording:
    notes: list[str] = []
    carrier: dict[int, tuple[float, float]] = {}
    for message in joints:
        index = _carrier_index(message.name)
        if index is None or index >= len(message.position):
            continue
        velocity = message.velocity[index] if index < len(message.velocity) else math.nan
        carrier[stamp_ns(message)] = (float(message.position[index]), float(velocity))

    state: dict[str, FloatArray]
    pivot_shift: FloatArray | None = None
    if states:
        states = _sorted_unique(states, notes, TAIL_STATE.name)
        stamps = np.array([stamp_ns(m) for m in states], dtype=np.int64)
        codes = Counter(int(m.mechanism) for m in states)
        if len(codes) > 1:
            notes.append(
                f"tail/state mechanism codes {dict(codes)}: analysed as the most frequent one"
            )
        code = codes.most_common(1)[0][0]
        mechanism: str | None = MECHANISM_OF_CODE.get(code)
        if mechanism is None:
            raise AnalysisError(f"{path}: tail/state has an unknown mechanism code {code}")
        state = _state_arrays(states, TAIL_TYPES[mechanism].state_fields)
        if hasattr(states[0], "pivot_shift"):
            pivot_shift = np.array([float(m.pivot_shift) for m in states])
        angle = state["motor_angle"].copy()
        velocity = state["motor_velocity"].copy()
        matched = 0
        for i, stamp in enumerate(stamps.tolist()):
            sample = carrier.get(stamp)
            if sample is not None:
                matched += 1
                angle[i] = sample[0]
                if math.isfinite(sample[1]):
                    velocity[i] = sample[1]
        if not carrier:
            source = "motor_angle of tail/state (no motor/joint_state recorded)"
        elif matched == len(stamps):
            source = f"motor/joint_state (all {matched} tail states matched by stamp)"
        else:
            source = (
                f"motor/joint_state for {matched} of {len(stamps)} tail states matched by stamp, "
                "motor_angle of tail/state for the rest"
            )
    else:
        if not carrier:
            raise AnalysisError(
                f"{path}: motor/joint_state has no carrier joint ({CARRIER_JOINT!r} or a single "
                "joint)"
            )
        stamps = np.array(sorted(carrier), dtype=np.int64)
        angle = np.array([carrier[s][0] for s in stamps.tolist()])
        velocity = np.array([carrier[s][1] for s in stamps.tolist()])
        if not np.all(np.isfinite(velocity)):
            velocity = np.gradient(angle, stamps * 1e-9) if len(stamps) > 1 else velocity * 0.0
        state = {}
        mechanism = None
        source = "motor/joint_state (no tail/state recorded: nothing to compare with)"
    time_s = (stamps - stamps[0]) * 1e-9
    stamp_s = np.array([s // 1_000_000_000 + (s % 1_000_000_000) * 1e-9 for s in stamps.tolist()])
    return Recording(
        source=path,
        kind="bag",
        description=description,
        mechanism=mechanism,
        time_s=time_s,
        stamp_s=stamp_s,
        carrier_angle=angle,
        carrier_velocity=velocity,
        carrier_source=source,
        state=state,
        notes=notes,
        pivot_shift_m=pivot_shift,
        origin_ns=int(stamps[0]),
    )


def _sorted_unique(messages: list[Any], notes: list[str], topic: str) -> list[Any]:
    by_stamp: dict[int, Any] = {}
    for message in messages:
        by_stamp.setdefault(stamp_ns(message), message)
    if len(by_stamp) < len(messages):
        notes.append(
            f"{len(messages) - len(by_stamp)} {topic} messages with repeated stamps ignored"
        )
    return [by_stamp[s] for s in sorted(by_stamp)]


def _state_arrays(messages: list[Any], fields: Sequence[str]) -> dict[str, FloatArray]:
    """The engine fields that the TailState messages carry, one array each.

    TailState has no ``fin_angle_dot``, and a bag recorded before the pivot shift (with its own
    older definition) has no ``fin_angle`` either: the analysis recomputes what is missing.
    """
    carried = [
        name
        for name in fields
        if hasattr(messages[0], _MESSAGE_FIELD_OF_ENGINE.get(name, (name,))[0])
    ]
    columns: dict[str, list[float]] = {name: [] for name in carried}
    for message in messages:
        for name, values in columns.items():
            nested = _MESSAGE_FIELD_OF_ENGINE.get(name)
            if nested is None:
                values.append(getattr(message, name))
            else:
                values.append(getattr(getattr(message, nested[0]), nested[1]))
    return {name: np.asarray(values, dtype=float) for name, values in columns.items()}


# ---- the CLI's CSV


def read_csv(path: Path) -> Recording:
    """Read the CSV of ``fishtail-kinematics table`` (one carrier cycle).

    Raises:
        AnalysisError: an unreadable file, a missing column, fewer than 2 rows or a bad value.
    """
    try:
        with open(path, encoding="utf-8", newline="") as stream:
            rows = list(csv.reader(stream))
    except OSError as error:
        raise AnalysisError(f"{path}: cannot read: {error.strerror}") from None
    except (UnicodeDecodeError, csv.Error) as error:
        raise AnalysisError(
            f"{path}: neither a rosbag2 bag nor a CSV: {describe_error(error)}"
        ) from None
    rows = [row for row in rows if row]
    if not rows:
        raise AnalysisError(f"{path}: empty file")
    header = [name.strip() for name in rows[0]]
    missing = [name for name in _REQUIRED_COLUMNS if name not in header]
    if missing:
        raise AnalysisError(
            f"{path}: not a fishtail-kinematics table CSV (missing column(s) {', '.join(missing)})"
        )
    if len(rows) < 3:
        raise AnalysisError(f"{path}: needs at least 2 data rows, has {len(rows) - 1}")
    data = {}
    for column, name in enumerate(header):
        values = []
        for line, row in enumerate(rows[1:], start=2):
            if len(row) != len(header):
                raise AnalysisError(
                    f"{path}: line {line} has {len(row)} fields, the header {len(header)}"
                )
            try:
                value = float(row[column])
            except ValueError:
                raise AnalysisError(
                    f"{path}: line {line}, column {name}: not a number: {row[column]!r}"
                ) from None
            if not math.isfinite(value):
                # float() reads "nan" and "inf"; a table of the CLI never holds them.
                raise AnalysisError(
                    f"{path}: line {line}, column {name}: not a finite number: {row[column]!r}"
                )
            values.append(value)
        data[FIELD_OF_COLUMN.get(name, name)] = np.asarray(values)
    angle = data["motor_angle"]
    if not np.all(np.isfinite(angle)) or not np.all(np.diff(angle) > 0.0):
        raise AnalysisError(f"{path}: motor_angle_rad must be finite and increasing")
    # The first mechanism (the simplest) whose states have every table column of the file.
    columns = {name for name in data if name in FIELD_OF_COLUMN.values()}
    mechanism = next(
        (name for name, tail in TAIL_TYPES.items() if columns <= set(tail.state_fields)), None
    )
    if mechanism is None:
        raise AnalysisError(f"{path}: its columns are not those of any mechanism's table")
    fields = TAIL_TYPES[mechanism].state_fields
    state = {name: values for name, values in data.items() if name in fields}
    return Recording(
        source=path,
        kind="csv",
        description=f"CSV of fishtail-kinematics table, {len(angle)} samples of one carrier cycle",
        mechanism=mechanism,
        time_s=np.zeros_like(angle),  # set once the speed is known (needs the geometry)
        stamp_s=np.zeros_like(angle),
        carrier_angle=angle,
        carrier_velocity=np.zeros_like(angle),
        carrier_source="motor_angle_rad column",
        state=state,
        periodic=True,
    )
