"""Offline analysis of a recording: a rosbag2 bag (MCAP or sqlite3) or the CLI's CSV.

Pure Python (rosbags, numpy; no rclpy). From the recorded carrier angle the tail is recomputed with
the engine (vectorised) and compared with the recorded tail state, matched by stamp; the per-beat
symmetry table comes from :func:`fishtail_kinematics.engine.symmetry.beats_of` and
:func:`~fishtail_kinematics.engine.symmetry.judge`, the code the monitor node runs; the figures
are drawn by :mod:`fishtail_kinematics.offline.plots`.

Which carrier angle: ``motor/joint_state`` (the driver's encoder sample) for every ``tail/state``
with the same stamp, else the ``motor_angle`` that ``tail/state`` itself carries (the kinematics
node's input). A bag with ``motor/joint_state`` only is analysed from the recomputed tail.

Every problem with the input (missing, damaged, truncated, empty or foreign bag, bad CSV) raises
:class:`AnalysisError` with a one-line message.
"""

from __future__ import annotations

import csv
import dataclasses
import importlib
import math
import os
from collections import Counter
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from fishtail_kinematics.engine.errors import FishtailKinematicsError
from fishtail_kinematics.engine.mechanisms import (
    OscillatoryGeometry,
    UndulatoryGeometry,
    UndulatoryTail,
    make_tail,
)
from fishtail_kinematics.engine.parameters import (
    OSCILLATORY,
    UNDULATORY,
    geometry_from_parameters,
    geometry_parameters_in,
    load_parameter_file,
    mechanism_of,
)
from fishtail_kinematics.engine.swimming import SWIMMING_PARAMETERS
from fishtail_kinematics.engine.symmetry import (
    BeatStatistics,
    SymmetryTolerances,
    Verdict,
    beats_of,
    judge,
)
from fishtail_kinematics.offline import plots
from fishtail_kinematics.offline.cli import _FIELD_OF_COLUMN

TAIL_STATE_TYPE = "fishtail_msgs/msg/TailState"
SYMMETRY_REPORT_TYPE = "fishtail_msgs/msg/SymmetryReport"
JOINT_STATE_TYPE = "sensor_msgs/msg/JointState"
#: The driver's joint name (the kinematics node's ``motor_joint_name`` default).
CARRIER_JOINT = "carrier_joint"
#: TailState.mechanism values.
MECHANISM_OF_CODE = {1: OSCILLATORY, 2: UNDULATORY}

#: The recomputation "agrees" when no value differs by more than this (rad, m, rad/s, m/s). The
#: node solves per sample with ``math``, the analysis with numpy arrays: they differ by rounding.
AGREEMENT_TOLERANCE = 1e-9
#: Monitor defaults (parameters of the monitor node) used when the config does not set them.
DEFAULT_HYSTERESIS_RAD = 0.01
DEFAULT_GAP_RESET_S = 0.5

#: Engine state fields compared with the recording (inputs first).
OSCILLATORY_FIELDS = (
    "slider_position", "slider_velocity", "theta1", "theta1_dot", "theta2", "theta2_dot",
    "theta3", "theta3_dot", "tip_x", "tip_y", "tip_x_dot", "tip_y_dot",
)  # fmt: skip
UNDULATORY_FIELDS = (
    *OSCILLATORY_FIELDS,
    "theta4", "theta4_dot", "pin_u_distance", "pin_u_distance_rate", "slider_a_distance",
    "slider_a_distance_rate", "theta5", "theta5_dot",
)  # fmt: skip
#: TailState field -> engine field, where they differ.
_ENGINE_FIELD_OF_MESSAGE = {
    ("tip", "x"): "tip_x",
    ("tip", "y"): "tip_y",
    ("tip_velocity", "x"): "tip_x_dot",
    ("tip_velocity", "y"): "tip_y_dot",
}
_MCAP_MAGIC = b"\x89MCAP0\r\n"
_SQLITE_MAGIC = b"SQLite format 3\x00"


class AnalysisError(Exception):
    """The input cannot be analysed; the message is one line for the user."""


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
    time_s: np.ndarray
    stamp_s: np.ndarray
    carrier_angle: np.ndarray
    carrier_velocity: np.ndarray
    carrier_source: str
    state: dict[str, np.ndarray]
    monitor_verdicts: list[int] = dataclasses.field(default_factory=list)
    notes: list[str] = dataclasses.field(default_factory=list)
    periodic: bool = False  # CSV: one carrier cycle


@dataclasses.dataclass(frozen=True)
class Disagreement:
    """Worst difference between the recomputed and the recorded tail state."""

    samples: int
    worst: float
    worst_field: str
    per_field: dict[str, float]

    @property
    def agrees(self) -> bool:
        """Within :data:`AGREEMENT_TOLERANCE` (a NaN counts as disagreement)."""
        return self.worst <= AGREEMENT_TOLERANCE


@dataclasses.dataclass(frozen=True)
class JudgedBeat:
    """One beat of the table with the monitor's verdict and reason."""

    beat: BeatStatistics
    verdict: Verdict
    reason: str


@dataclasses.dataclass
class Report:
    """Everything ``fishtail-analyse`` prints."""

    recording: Recording
    geometry: OscillatoryGeometry | UndulatoryGeometry
    geometry_source: str
    disagreement: Disagreement | None
    beats: list[JudgedBeat]
    figures: list[Path]
    swimming: SwimmingResult | None = None

    @property
    def frequencies_hz(self) -> np.ndarray:
        """Beat frequencies of the table."""
        return np.array([b.beat.frequency_hz for b in self.beats])


# --------------------------------------------------------------------------------------------
# Reading


def read_recording(path: str | Path, namespace: str | None = None) -> Recording:
    """Read a rosbag2 bag (directory, .mcap or .db3) or a CSV of ``fishtail-kinematics table``."""
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


def _describe(error: BaseException) -> str:
    text = " ".join(str(error).split()) or type(error).__name__
    return text.rstrip(".")


def _typestore_for(connections):
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
    if TAIL_STATE_TYPE not in store.fielddefs:
        _register_installed_fishtail_msgs(store)
    return store


def _register_installed_fishtail_msgs(store) -> None:
    from rosbags.typesys import get_types_from_msg

    try:
        from ament_index_python.packages import get_package_share_directory

        directory = Path(get_package_share_directory("fishtail_msgs")) / "msg"
    except Exception:  # noqa: BLE001 - not installed / no ament index: the bag must carry them
        return
    types = {}
    for file in sorted(directory.glob("*.msg")):
        text = file.read_text(encoding="utf-8")
        types.update(get_types_from_msg(text, f"fishtail_msgs/msg/{file.stem}"))
    store.register({name: fields for name, fields in types.items() if name not in store.fielddefs})


def _pick_topic(
    connections, msgtype: str, suffix: str, namespace: str | None, any_name: bool = True
) -> str | None:
    """The topic of ``msgtype`` named ``<namespace>/<suffix>``.

    Without such a name and with ``any_name``: the one topic of that type, if there is one.
    """
    topics = sorted({c.topic for c in connections if c.msgtype == msgtype})
    if namespace is not None:
        wanted = "/" + "/".join(p for p in (namespace.strip("/"), suffix) if p)
        return wanted if wanted in topics else None
    named = [t for t in topics if t == "/" + suffix or t.endswith("/" + suffix)]
    candidates = named or (topics if any_name else [])
    if len(candidates) > 1:
        raise AnalysisError(
            f"several {msgtype} topics ({', '.join(candidates)}): choose one with --namespace"
        )
    return candidates[0] if candidates else None


def _stamp_ns(message) -> int:
    stamp = message.header.stamp
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def read_bag(path: Path, namespace: str | None = None) -> Recording:
    """Read tail/state, motor/joint_state and tail/symmetry from a rosbag2 bag."""
    try:
        return _read_bag(path, namespace)
    except AnalysisError:
        raise
    except Exception as error:  # noqa: BLE001 - rosbags and sqlite raise many kinds on bad files
        raise AnalysisError(f"{path}: not a readable rosbag2 bag: {_describe(error)}") from None


def _read_bag(path: Path, namespace: str | None) -> Recording:
    from rosbags.rosbag2 import Reader

    reader = Reader(path)
    reader.open()
    try:
        connections = list(reader.connections)
        storage = getattr(reader.storage, "storages", None)
        file_count = len(storage) if storage is not None else 1
        listing = ", ".join(f"{c.topic} ({c.msgtype})" for c in connections) or "none"
        state_topic = _pick_topic(connections, TAIL_STATE_TYPE, "tail/state", namespace)
        # Other JointState topics (tail/joint_states) are not the carrier.
        joint_topic = _pick_topic(
            connections, JOINT_STATE_TYPE, "motor/joint_state", namespace, any_name=False
        )
        report_topic = _pick_topic(connections, SYMMETRY_REPORT_TYPE, "tail/symmetry", namespace)
        if state_topic is None and joint_topic is None:
            where = f" in namespace {namespace!r}" if namespace is not None else ""
            raise AnalysisError(
                f"{path}: no tail/state or motor/joint_state topic{where}: not a fishtail "
                f"recording (topics: {listing})"
            )
        wanted = [c for c in connections if c.topic in (state_topic, joint_topic, report_topic)]
        store = _typestore_for(connections)
        for connection in wanted:
            if connection.msgtype not in store.fielddefs:
                raise AnalysisError(
                    f"{path}: no definition of {connection.msgtype} in the bag or installed"
                )
            if connection.digest and store.hash_rihs01(connection.msgtype) != connection.digest:
                raise AnalysisError(
                    f"{path}: {connection.topic} was recorded with another definition of "
                    f"{connection.msgtype} (hash {connection.digest})"
                )
        states, joints, reports = [], [], []
        sink = {state_topic: states, joint_topic: joints, report_topic: reports}
        for connection, _, raw in reader.messages(connections=wanted):
            sink[connection.topic].append(store.deserialize_cdr(raw, connection.msgtype))
        message_count = reader.message_count
        duration_s = reader.duration * 1e-9
    finally:
        reader.close()
    description = f"rosbag2 bag, {file_count} file(s), {message_count} messages, {duration_s:.1f} s"
    if state_topic is not None and not states:
        if not joints:
            raise AnalysisError(f"{path}: the bag holds no tail/state or motor/joint_state message")
        state_topic = None
    if state_topic is None and not joints:
        raise AnalysisError(f"{path}: the bag holds no motor/joint_state message")
    recording = _recording_from_messages(path, description, states, joints)
    recording.monitor_verdicts = [int(r.verdict) for r in reports]
    return recording


def _carrier_index(names: Sequence[str]) -> int | None:
    names = list(names)
    if CARRIER_JOINT in names:
        return names.index(CARRIER_JOINT)
    return 0 if len(names) == 1 else None


def _recording_from_messages(path: Path, description: str, states, joints) -> Recording:
    notes: list[str] = []
    carrier: dict[int, tuple[float, float]] = {}
    for message in joints:
        index = _carrier_index(message.name)
        if index is None or index >= len(message.position):
            continue
        velocity = message.velocity[index] if index < len(message.velocity) else math.nan
        carrier[_stamp_ns(message)] = (float(message.position[index]), float(velocity))

    if states:
        states = _sorted_unique(states, notes, "tail/state")
        stamps = np.array([_stamp_ns(m) for m in states], dtype=np.int64)
        state = _state_arrays(states)
        codes = Counter(int(m.mechanism) for m in states)
        if len(codes) > 1:
            notes.append(
                f"tail/state mechanism codes {dict(codes)}: analysed as the most frequent one"
            )
        code = codes.most_common(1)[0][0]
        mechanism = MECHANISM_OF_CODE.get(code)
        if mechanism is None:
            raise AnalysisError(f"{path}: tail/state has an unknown mechanism code {code}")
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
    )


def _sorted_unique(messages, notes: list[str], topic: str):
    by_stamp = {}
    for message in messages:
        by_stamp.setdefault(_stamp_ns(message), message)
    if len(by_stamp) < len(messages):
        notes.append(
            f"{len(messages) - len(by_stamp)} {topic} messages with repeated stamps ignored"
        )
    return [by_stamp[s] for s in sorted(by_stamp)]


def _state_arrays(messages) -> dict[str, np.ndarray]:
    columns: dict[str, list[float]] = {"motor_angle": [], "motor_velocity": []}
    for name in UNDULATORY_FIELDS:
        columns[name] = []
    nested = {engine: parts for parts, engine in _ENGINE_FIELD_OF_MESSAGE.items()}
    for message in messages:
        for name, values in columns.items():
            if name in nested:
                outer, inner = nested[name]
                values.append(getattr(getattr(message, outer), inner))
            else:
                values.append(getattr(message, name))
    return {name: np.asarray(values, dtype=float) for name, values in columns.items()}


def read_csv(path: Path) -> Recording:
    """Read the CSV of ``fishtail-kinematics table`` (one carrier cycle)."""
    try:
        with open(path, encoding="utf-8", newline="") as stream:
            rows = list(csv.reader(stream))
    except OSError as error:
        raise AnalysisError(f"{path}: cannot read: {error.strerror}") from None
    except (UnicodeDecodeError, csv.Error) as error:
        raise AnalysisError(
            f"{path}: neither a rosbag2 bag nor a CSV: {_describe(error)}"
        ) from None
    rows = [row for row in rows if row]
    if not rows:
        raise AnalysisError(f"{path}: empty file")
    header = [name.strip() for name in rows[0]]
    required = ("motor_angle_rad", "theta3", "theta3_dot", "Tx", "Ty")
    missing = [name for name in required if name not in header]
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
        data[_FIELD_OF_COLUMN.get(name, name)] = np.asarray(values)
    angle = data["motor_angle"]
    if not np.all(np.isfinite(angle)) or not np.all(np.diff(angle) > 0.0):
        raise AnalysisError(f"{path}: motor_angle_rad must be finite and increasing")
    mechanism = UNDULATORY if "theta5" in data else OSCILLATORY
    state = {name: values for name, values in data.items() if name in UNDULATORY_FIELDS}
    state["motor_angle"] = angle
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


# --------------------------------------------------------------------------------------------
# Geometry


def default_config_path(mechanism: str) -> Path | None:
    """config/<mechanism>.yaml of the workspace, else the copy installed with fishtail_bringup."""
    root = os.environ.get("FISHTAIL_ROOT")
    if root and (Path(root) / "config" / f"{mechanism}.yaml").is_file():
        return Path(root) / "config" / f"{mechanism}.yaml"
    try:
        from ament_index_python.packages import get_package_share_directory

        path = (
            Path(get_package_share_directory("fishtail_bringup")) / "config" / f"{mechanism}.yaml"
        )
    except Exception:  # noqa: BLE001 - no ament index here: built-in report geometry
        return None
    return path if path.is_file() else None


def choose_geometry(
    mechanism: str | None, config: Path | None
) -> tuple[OscillatoryGeometry | UndulatoryGeometry, str, dict[str, object]]:
    """Geometry, where it came from, and all parameters of the file (for tolerances etc.)."""
    if config is None:
        path = default_config_path(mechanism or OSCILLATORY)
        if path is None:
            geometry = geometry_from_parameters({"mechanism": mechanism or OSCILLATORY})
            return geometry, "built-in report geometry (no config file found)", {}
        config, origin = path, f"{path} (default for the recorded mechanism)"
    else:
        origin = str(config)
    try:
        values = load_parameter_file(config)
        geometry = geometry_from_parameters(geometry_parameters_in(values))
        make_tail(geometry)  # validates assembly
    except FishtailKinematicsError as error:
        raise AnalysisError(f"{config}: {error}") from None
    if mechanism is not None and mechanism_of(geometry) != mechanism:
        raise AnalysisError(
            f"the recording is of the {mechanism} mechanism but {config} describes the "
            f"{mechanism_of(geometry)} one"
        )
    return geometry, origin, values


def tolerances_from(values: Mapping[str, object]) -> tuple[SymmetryTolerances, float, float]:
    """Monitor tolerances, hysteresis and gap reset from a parameter file's values."""
    names = [f.name for f in dataclasses.fields(SymmetryTolerances)]
    chosen = {name: float(values[name]) for name in names if name in values}
    try:
        tolerances = SymmetryTolerances(**chosen)
    except (TypeError, ValueError) as error:
        raise AnalysisError(f"bad symmetry tolerances in the config: {error}") from None
    hysteresis = float(values.get("hysteresis_rad", DEFAULT_HYSTERESIS_RAD))
    gap = float(values.get("gap_reset_sec", DEFAULT_GAP_RESET_S))
    return tolerances, hysteresis, gap


# --------------------------------------------------------------------------------------------
# Analysis


def recompute(tail, recording: Recording):
    """The engine's state for the recording's carrier inputs (one vectorised call)."""
    try:
        return tail.solve(recording.carrier_angle, recording.carrier_velocity)
    except FishtailKinematicsError as error:
        raise AnalysisError(f"the engine cannot follow the recording: {error}") from None


def compare(recomputed, recorded: Mapping[str, np.ndarray], fields: Sequence[str]) -> Disagreement:
    """Largest absolute difference per field; NaN (or a missing field) counts as infinite."""
    per_field = {}
    for name in fields:
        if name not in recorded:
            continue
        difference = np.abs(np.asarray(getattr(recomputed, name)) - recorded[name])
        if difference.size == 0:
            continue
        per_field[name] = float(np.max(np.where(np.isnan(difference), np.inf, difference)))
    if not per_field:
        return Disagreement(0, 0.0, "", {})
    worst_field = max(per_field, key=per_field.get)
    samples = len(next(iter(recorded.values())))
    return Disagreement(samples, per_field[worst_field], worst_field, per_field)


def beat_table(
    stamp_s: np.ndarray,
    theta3: np.ndarray,
    tolerances: SymmetryTolerances,
    hysteresis_rad: float = DEFAULT_HYSTERESIS_RAD,
    gap_reset_s: float = DEFAULT_GAP_RESET_S,
    carrier_rad: np.ndarray | None = None,
) -> list[JudgedBeat]:
    """Per-beat statistics and verdicts; a gap longer than ``gap_reset_s`` restarts the beat.

    Same code path as the monitor: :func:`beats_of` (its :class:`BeatTracker`, gap detection
    and reset) and :func:`judge`, weighted by the carrier angle when it is given, as the monitor
    does. A beat with a shorter gap is NOT_JUDGED.
    """
    stamp_s = np.asarray(stamp_s, float)
    theta3 = np.asarray(theta3, float)
    carrier = None if carrier_rad is None else np.asarray(carrier_rad, float)
    judged = []
    for beat in beats_of(stamp_s, theta3, hysteresis_rad, carrier, gap_reset_s):
        verdict, reason = judge(beat, tolerances)
        judged.append(JudgedBeat(beat, verdict, reason))
    return judged


def _csv_speed(tail, recording: Recording) -> float:
    unit = np.asarray(tail.solve(recording.carrier_angle, 1.0).theta3_dot)
    measured = recording.state["theta3_dot"]
    norm = float(np.dot(unit, unit))
    return float(np.dot(unit, measured) / norm) if norm > 0.0 else 0.0


def _periodic_extension(recording: Recording, speed: float, cycles: int = 3):
    """Times and theta3 of a one-cycle table repeated ``cycles`` times (the motion is periodic)."""
    angle = recording.carrier_angle
    period_angle = 2.0 * math.pi
    angles = np.concatenate([angle + k * period_angle for k in range(cycles)])
    theta3 = np.tile(recording.state["theta3"], cycles)
    return angles / speed, theta3


def analyse(
    path: str | Path,
    config: str | Path | None = None,
    output_dir: str | Path | None = None,
    namespace: str | None = None,
    overrides: Mapping[str, float] | None = None,
) -> Report:
    """Read, recompute, tabulate the beats and write the figures.

    ``overrides`` replace values of the parameter file (e.g. the swimming parameters).
    """
    recording = read_recording(path, namespace)
    geometry, geometry_source, values = choose_geometry(
        recording.mechanism, None if config is None else Path(config)
    )
    values = {**values, **(overrides or {})}
    if recording.mechanism is None:
        recording.mechanism = mechanism_of(geometry)
    tolerances, hysteresis, gap = tolerances_from(values)
    tail = make_tail(geometry)
    undulatory = isinstance(tail, UndulatoryTail)

    if recording.kind == "csv":
        speed = _csv_speed(tail, recording)
        if not (math.isfinite(speed) and speed > 1e-12):
            recording.notes.append("speed 0 in the CSV: the time axis is the carrier angle [rad]")
            speed = 1.0
        recording.carrier_velocity = np.full_like(recording.carrier_angle, speed)
        recording.time_s = recording.carrier_angle / speed
        recording.stamp_s = recording.time_s
        recording.notes.append(
            f"carrier speed {speed:.6g} rad/s (from theta3_dot); the cycle is treated as periodic"
        )

    recomputed = recompute(tail, recording)
    fields = UNDULATORY_FIELDS if undulatory else OSCILLATORY_FIELDS
    disagreement = None
    if recording.state:
        compared = list(fields)
        if recording.kind == "bag" and not recording.carrier_source.startswith("motor_angle"):
            compared = ["motor_angle", "motor_velocity", *compared]
        disagreement = compare(recomputed, recording.state, compared)
    # Recorded values where the recording has them (a CSV has no tip velocity), else recomputed.
    source = {name: np.asarray(getattr(recomputed, name)) for name in fields}
    source.update(recording.state)

    if recording.periodic:
        times, theta3 = _periodic_extension(recording, recording.carrier_velocity[0])
        beats = beat_table(times, theta3, tolerances, hysteresis, math.inf)[:1]
    else:
        beats = beat_table(
            recording.stamp_s, source["theta3"], tolerances, hysteresis, gap,
            recording.carrier_angle,
        )  # fmt: skip

    figures = write_figures(recording, source, geometry, output_dir)
    report = Report(recording, geometry, geometry_source, disagreement, beats, figures)
    report.swimming = swimming_hook(recording, source, undulatory, values)
    return report


def default_output_dir(source: Path) -> Path:
    """``<input name>_figures`` in the current directory (the name without a file suffix)."""
    resolved = source.resolve()
    return Path(f"{resolved.stem if resolved.is_file() else resolved.name}_figures")


def write_figures(
    recording: Recording,
    state: Mapping[str, np.ndarray],
    geometry,
    output_dir: str | Path | None,
) -> list[Path]:
    """theta3 and its rate against time, the tip path, and theta3 with theta5 (mechanism 2)."""
    directory = Path(output_dir) if output_dir is not None else default_output_dir(recording.source)
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise AnalysisError(f"cannot create {directory}: {error.strerror}") from None
    title = f"{recording.source.name}, {mechanism_of(geometry)}"
    time_s = recording.time_s
    try:
        written = [
            plots.plot_tail_angle(
                time_s, state["theta3"], state["theta3_dot"], directory / "theta3.png", title
            ),
            plots.plot_tip_path(state["tip_x"], state["tip_y"], directory / "tip_path.png", title),
        ]
        if isinstance(geometry, UndulatoryGeometry):
            theta3, theta5 = state["theta3"], state["theta5"]
            denominator = float(np.dot(theta3, theta3))
            mu = float(np.dot(theta3, theta5) / denominator) if denominator > 0.0 else math.nan
            written.append(
                plots.plot_fin_angles(
                    time_s, theta3, theta5, mu, directory / "theta3_theta5.png", title
                )
            )
    except OSError as error:
        raise AnalysisError(f"cannot write figures to {directory}: {error.strerror}") from None
    return written


# --------------------------------------------------------------------------------------------
# Swimming figures: fishtail_kinematics.engine.swimming.swimming_figures(time_s, tip_y,
# tip_y_velocity, fin_angle, parameters), printed by format_report(); without that module (a
# trimmed install) swimming_hook() returns None and nothing is printed.

#: Swimming parameters the analysis passes when neither --config nor a flag sets them: the
#: monitor node's parameter defaults.
SWIMMING_DEFAULTS = {name: spec[0] for name, spec in SWIMMING_PARAMETERS.items()}


@dataclasses.dataclass(frozen=True)
class SwimmingResult:
    """What the swimming module returned, and the parameters it was given."""

    figures: object
    parameters: dict[str, float]


def swimming_hook(
    recording: Recording,
    state: Mapping[str, np.ndarray],
    undulatory: bool,
    values: Mapping[str, object],
) -> SwimmingResult | None:
    """``swimming.swimming_figures(...)`` for the recording, or None if the module is absent.

    The fin angle is the last link's: theta3 (mechanism 1) or theta5 (mechanism 2). ``values``
    (config file and flags) may set forward_speed_m_s, fin_span_m and water_density_kg_m3.
    """
    try:
        swimming = importlib.import_module("fishtail_kinematics.engine.swimming")
    except ImportError:
        return None
    chosen = {
        name: float(values[name]) if name in values else default
        for name, default in SWIMMING_DEFAULTS.items()
    }
    time_s = recording.time_s
    series = [state["tip_y"], state["tip_y_dot"], state["theta5" if undulatory else "theta3"]]
    if recording.periodic:  # one carrier cycle: repeat it so that whole beats exist
        cycles = 3
        period = 2.0 * math.pi / recording.carrier_velocity[0]
        time_s = np.concatenate([time_s + k * period for k in range(cycles)])
        series = [np.tile(values_, cycles) for values_ in series]
    try:
        parameter_type = getattr(swimming, "SwimmingParameters", None)
        parameters = parameter_type(**chosen) if parameter_type is not None else dict(chosen)
        figures = swimming.swimming_figures(time_s, *series, parameters)
    except (FishtailKinematicsError, ValueError, TypeError) as error:
        recording.notes.append(f"swimming figures not available: {_describe(error)}")
        return None
    return SwimmingResult(figures, chosen)


def swimming_text(result: SwimmingResult) -> str:
    """One line for the swimming figures (their repr if the fields are not the expected ones)."""
    p = result.parameters
    assumed = (
        f"U = {p['forward_speed_m_s']:g} m/s, fin span {p['fin_span_m']:g} m, "
        f"rho = {p['water_density_kg_m3']:g} kg/m^3"
    )
    figures = result.figures
    try:
        st = figures.strouhal_number
        band = "inside" if 0.2 <= st <= 0.4 else "outside"
        text = (
            f"f = {figures.beat_frequency_hz:.4f} Hz, A = {figures.tip_excursion_m:.4f} m "
            f"(tip, peak to peak), St = f A / U = {st:.3f} ({band} 0.2-0.4), mean thrust "
            f"(Lighthill, at the tip) = {figures.mean_thrust_n:.4g} N over {figures.beats} beats"
        )
    except (AttributeError, TypeError, ValueError):
        text = str(figures)
    return f"swimming ({assumed}): {text}"


# --------------------------------------------------------------------------------------------
# Text


def format_report(report: Report) -> str:
    """The report as text (what ``fishtail-analyse`` prints)."""
    recording = report.recording
    lines = [
        f"input: {recording.source} ({recording.description})",
        f"mechanism: {mechanism_of(report.geometry)}; geometry: {report.geometry_source}",
        f"carrier angle: {recording.carrier_source}",
    ]
    lines += [f"note: {note}" for note in recording.notes]
    d = report.disagreement
    if d is None:
        lines.append("disagreement: n/a (no recorded tail state)")
    elif not d.per_field:
        lines.append("disagreement: n/a (no comparable field)")
    else:
        verdict = (
            f"agrees (tolerance {AGREEMENT_TOLERANCE:g})"
            if d.agrees
            else "DISAGREES: was the recording made with another geometry? (--config FILE)"
        )
        lines.append(
            f"disagreement: worst {d.worst:.3g} in {d.worst_field} over {d.samples} recomputed "
            f"tail states: {verdict}"
        )
    lines.append("")
    origin = float(recording.stamp_s[0]) if recording.stamp_s.size else 0.0
    lines += beat_table_lines(report.beats, origin)
    frequencies = report.frequencies_hz
    if frequencies.size:
        lines.append(
            f"beat frequency: {np.mean(frequencies):.4f} Hz (mean of {frequencies.size} beats, "
            f"min {np.min(frequencies):.4f}, max {np.max(frequencies):.4f})"
        )
    else:
        lines.append("beat frequency: n/a (no complete beat)")
    if recording.monitor_verdicts:
        counts = Counter(recording.monitor_verdicts)
        lines.append(
            f"monitor (tail/symmetry in the recording): {len(recording.monitor_verdicts)} beats, "
            + ", ".join(f"{counts.get(int(v), 0)} {v.name}" for v in Verdict)
        )
    if report.swimming is not None:
        lines.append(swimming_text(report.swimming))
    lines.append("figures: " + " ".join(str(path) for path in report.figures))
    return "\n".join(lines)


def beat_table_lines(beats: Sequence[JudgedBeat], origin_s: float = 0.0) -> list[str]:
    """The per-beat symmetry table (start times relative to ``origin_s``), a summary last."""
    if not beats:
        return ["symmetry: no complete beat (theta3 must cross zero upwards twice)"]
    lines = [
        f"{'beat':>4} {'start s':>8} {'period s':>8} {'freq Hz':>7} {'+peak°':>7} {'-peak°':>7} "
        f"{'mean°':>7} {'+share':>6}  verdict     reason"
    ]
    for judged in beats:
        b = judged.beat
        lines.append(
            f"{b.index:>4} {b.start_s - origin_s:>8.3f} {b.period_s:>8.4f} {b.frequency_hz:>7.4f} "
            f"{math.degrees(b.positive_peak_rad):>7.3f} {math.degrees(b.negative_peak_rad):>7.3f} "
            f"{math.degrees(b.mean_angle_rad):>7.3f} {b.positive_time_share:>6.4f}  "
            f"{judged.verdict.name:<10}  {judged.reason}"
        )
    counts = Counter(judged.verdict for judged in beats)
    lines.append(
        f"symmetry: {len(beats)} beats: "
        + ", ".join(f"{counts.get(v, 0)} {v.name}" for v in Verdict)
    )
    return lines
