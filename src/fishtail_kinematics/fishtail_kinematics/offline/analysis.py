"""Offline analysis of a recording: recompute the tail, compare, tabulate the beats, swimming.

What ``fishtail-analyse`` computes (no rclpy), with the monitor's own code, so that a recording
is judged as the running suite judged it. The figures are drawn by
:mod:`~fishtail_kinematics.offline.analysis_figures`, the text by
:mod:`~fishtail_kinematics.offline.analysis_report`. What is compared and how:
docs/recording.md ("fishtail-analyse").
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import numpy.typing as npt

from fishtail_common.parameter_files import default_parameter_file, load_parameter_file
from fishtail_kinematics.engine.errors import FishtailKinematicsError
from fishtail_kinematics.engine.geometry import (
    INPUT_FIELDS,
    FloatArray,
    Geometry,
    LinkageState,
)
from fishtail_kinematics.engine.mechanisms import Tail, make_tail
from fishtail_kinematics.engine.parameters import (
    MECHANISM,
    geometry_from_parameters,
    geometry_parameters_in,
)
from fishtail_kinematics.engine.swimming import (
    SwimmingFigures,
    SwimmingParameters,
    figures_from_kinematics,
    tip_kinematics,
)
from fishtail_kinematics.engine.symmetry import (
    DEFAULT_GAP_RESET_S,
    DEFAULT_HYSTERESIS_RAD,
    GAP_RESET,
    HYSTERESIS,
    TOLERANCE_PARAMETERS,
    BeatStatistics,
    SymmetryTolerances,
    Verdict,
    beats_of,
    judge,
)
from fishtail_kinematics.offline.analysis_figures import write_figures
from fishtail_kinematics.offline.recorded_speed import SOURCE_ASSUMED, beat_speed
from fishtail_kinematics.offline.recording import (
    AnalysisError,
    RecordedFish,
    Recording,
    describe_error,
    read_recording,
)

#: The recomputation "agrees" when no value differs by more than this (rad, m, rad/s, m/s). The
#: node solves per sample with ``math``, the analysis with numpy arrays: they differ by rounding.
AGREEMENT_TOLERANCE = 1e-9
#: A one-cycle CSV is repeated this often so that whole beats exist.
_CSV_CYCLES = 3


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


@dataclasses.dataclass(frozen=True)
class BeatSwimming:
    """The swimming figures of one beat, with the forward speed U used and where it came from."""

    index: int  # 1-based
    start_s: float  # on the recording's time axis (s after its first sample)
    end_s: float
    forward_speed_m_s: float
    speed_source: str  # fish/odom, fish/swimming or assumed (recorded_speed.SOURCE_*)
    figures: SwimmingFigures


@dataclasses.dataclass(frozen=True)
class SwimmingResult:
    """The swimming figures of the recording, and the parameters they assume.

    ``parameters.forward_speed_m_s`` is the time-mean of the beats' U; ``per_beat`` has each
    beat's U (recorded where the recording has the fish, else assumed) and figures. When some U
    was recorded, the overall mean thrust is the time-mean of the beats' thrusts.
    """

    figures: SwimmingFigures
    parameters: SwimmingParameters
    per_beat: tuple[BeatSwimming, ...] = ()
    assumed_speed_m_s: float = math.nan  # the forward_speed_m_s parameter
    #: Why a recorded speed was not used where none was (for the report).
    assumed_because: str = ""

    @property
    def recorded_beats(self) -> int:
        """How many beats have a recorded U."""
        return sum(beat.speed_source != SOURCE_ASSUMED for beat in self.per_beat)

    @property
    def speed_origin(self) -> str:
        """``recorded`` (every beat), ``assumed`` (none) or ``partly recorded``."""
        recorded = self.recorded_beats
        if recorded == 0:
            return "assumed"
        return "recorded" if recorded == len(self.per_beat) else "partly recorded"

    @property
    def speed_sources(self) -> list[str]:
        """The recorded sources used, in order of first use."""
        return list(
            dict.fromkeys(b.speed_source for b in self.per_beat if b.speed_source != SOURCE_ASSUMED)
        )


@dataclasses.dataclass
class Report:
    """Everything ``fishtail-analyse`` prints."""

    recording: Recording
    geometry: Geometry
    geometry_source: str
    disagreement: Disagreement | None
    beats: list[JudgedBeat]
    figures: list[Path]
    swimming: SwimmingResult | None = None

    @property
    def frequencies_hz(self) -> FloatArray:
        """Beat frequencies of the table."""
        return np.array([b.beat.frequency_hz for b in self.beats])


# ---- the geometry and the monitor's settings


def choose_geometry(
    mechanism: str | None, config: Path | None
) -> tuple[Geometry, str, dict[str, object]]:
    """Geometry, where it came from, and all parameters of the file (for tolerances etc.).

    Raises:
        AnalysisError: the file does not describe a tail that assembles, or describes another
            mechanism than the recording's.
    """
    if config is None:
        chosen = mechanism or str(MECHANISM.default)
        try:
            path: Path | None = default_parameter_file(chosen)
        except LookupError:
            path = None
        if path is None or not path.is_file():
            geometry = geometry_from_parameters({MECHANISM.name: chosen})
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
    if mechanism is not None and geometry.mechanism != mechanism:
        raise AnalysisError(
            f"the recording is of the {mechanism} mechanism but {config} describes the "
            f"{geometry.mechanism} one"
        )
    return geometry, origin, values


def tolerances_from(values: Mapping[str, object]) -> tuple[SymmetryTolerances, float, float]:
    """Monitor tolerances, hysteresis and gap reset from a parameter file's values.

    Each value is checked as the monitor checks its parameter; those not given are its defaults.

    Raises:
        AnalysisError: a value the monitor would refuse.
    """
    try:
        chosen = {
            spec.name: float(spec.check(values.get(spec.name, spec.default)))
            for spec in (*TOLERANCE_PARAMETERS, HYSTERESIS, GAP_RESET)
        }
        hysteresis = chosen.pop(HYSTERESIS.name)
        gap = chosen.pop(GAP_RESET.name)
        tolerances = SymmetryTolerances(**chosen)
    except ValueError as error:
        raise AnalysisError(f"bad symmetry tolerances in the config: {error}") from None
    return tolerances, hysteresis, gap


# ---- recomputing and comparing


def recompute(tail: Tail, recording: Recording) -> LinkageState:
    """The engine's state for the recording's carrier inputs and pivot shifts.

    One vectorised call per distinct recorded pivot shift (one in all for an unshifted tail).

    Raises:
        AnalysisError: the engine cannot solve a recorded input (e.g. an infeasible pivot shift).
    """
    angle, velocity = recording.carrier_angle, recording.carrier_velocity
    shifts = recording.pivot_shift_m
    try:
        if shifts is None or not np.any(shifts):
            return tail.solve(angle, velocity)
        state = tail.empty_state(angle.shape)
        for shift in np.unique(shifts).tolist():
            chosen = shifts == shift
            part = tail.with_pivot_shift(shift).solve(angle[chosen], velocity[chosen])
            for target, value in zip(state, part, strict=True):
                np.asarray(target)[chosen] = value
        return state
    except FishtailKinematicsError as error:
        raise AnalysisError(f"the engine cannot follow the recording: {error}") from None


def compare(
    recomputed: LinkageState, recorded: Mapping[str, FloatArray], fields: Sequence[str]
) -> Disagreement:
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
    worst_field = max(per_field, key=lambda name: per_field[name])
    samples = len(next(iter(recorded.values())))
    return Disagreement(samples, per_field[worst_field], worst_field, per_field)


def beat_table(
    stamp_s: npt.ArrayLike,
    theta3: npt.ArrayLike,
    tolerances: SymmetryTolerances,
    hysteresis_rad: float = DEFAULT_HYSTERESIS_RAD,
    gap_reset_s: float = DEFAULT_GAP_RESET_S,
    carrier_rad: npt.ArrayLike | None = None,
) -> list[JudgedBeat]:
    """Per-beat statistics and verdicts; a gap longer than ``gap_reset_s`` restarts the beat.

    The monitor's own :func:`beats_of` and :func:`judge` (weighted by the carrier angle when it
    is given), so that a recording is judged as the monitor judged it. A beat with a shorter gap is
    NOT_JUDGED.
    """
    judged = []
    for beat in beats_of(stamp_s, theta3, hysteresis_rad, carrier_rad, gap_reset_s):
        verdict, reason = judge(beat, tolerances)
        judged.append(JudgedBeat(beat, verdict, reason))
    return judged


def swimming_of(
    recording: Recording,
    state: Mapping[str, FloatArray],
    fin_angle_field: str,
    values: Mapping[str, object],
    fish: RecordedFish | None = None,
) -> SwimmingResult | None:
    """The swimming figures of the recording; None (with a note saying why) if there are none.

    The fin angle is the last link's (theta3, or the fin joint's). ``values`` (config file and
    flags) may set the swimming parameters; the others are the monitor's defaults. ``fish``, the
    recorded fish, gives each beat its U where it covers the beat
    (:func:`~fishtail_kinematics.offline.recorded_speed.beat_speed`); elsewhere U is the
    ``forward_speed_m_s`` of ``values``.
    """
    time_s = recording.time_s
    tip_y, tip_y_dot, fin_angle = state["tip_y"], state["tip_y_dot"], state[fin_angle_field]
    if recording.periodic:  # one carrier cycle: repeat it so that whole beats exist
        period = 2.0 * math.pi / recording.carrier_velocity[0]
        time_s = np.concatenate([time_s + k * period for k in range(_CSV_CYCLES)])
        tip_y, tip_y_dot, fin_angle = (
            np.tile(series, _CSV_CYCLES) for series in (tip_y, tip_y_dot, fin_angle)
        )
    try:
        assumed = SwimmingParameters.from_values(values)
        overall = tip_kinematics(time_s, tip_y, tip_y_dot, fin_angle)
        per_beat = []
        for index, beat in enumerate(beats_of(time_s, fin_angle), start=1):
            speed, source = beat_speed(fish, beat.start_s, beat.end_s, assumed.forward_speed_m_s)
            kinematics = tip_kinematics(time_s, tip_y, tip_y_dot, fin_angle, beats=[beat])
            parameters = dataclasses.replace(assumed, forward_speed_m_s=speed)
            per_beat.append(
                BeatSwimming(
                    index, beat.start_s, beat.end_s, speed, source,
                    figures_from_kinematics(kinematics, parameters),
                )
            )  # fmt: skip
        durations = np.array([b.end_s - b.start_s for b in per_beat])
        mean_speed = float(
            np.dot(durations, [b.forward_speed_m_s for b in per_beat]) / np.sum(durations)
        )
        parameters = dataclasses.replace(assumed, forward_speed_m_s=mean_speed)
        figures = figures_from_kinematics(overall, parameters)
        if any(b.speed_source != SOURCE_ASSUMED for b in per_beat):
            thrust = float(np.dot(durations, [b.figures.mean_thrust_n for b in per_beat]))
            figures = dataclasses.replace(figures, mean_thrust_n=thrust / float(np.sum(durations)))
    except ValueError as error:
        recording.notes.append(f"swimming figures not available: {describe_error(error)}")
        return None
    if fish is None:
        because = "the recording has no fish/odom or fish/swimming"
    else:
        because = "the recorded fish/odom and fish/swimming do not cover these beats"
    return SwimmingResult(figures, parameters, tuple(per_beat), assumed.forward_speed_m_s, because)


def _csv_speed(tail: Tail, recording: Recording) -> float:
    unit = np.asarray(tail.solve(recording.carrier_angle, 1.0).theta3_dot)
    measured = recording.state["theta3_dot"]
    norm = float(np.dot(unit, unit))
    return float(np.dot(unit, measured) / norm) if norm > 0.0 else 0.0


def _periodic_extension(recording: Recording, speed: float) -> tuple[FloatArray, FloatArray]:
    """Times and theta3 of a one-cycle table repeated (the motion is periodic)."""
    angle = recording.carrier_angle
    angles = np.concatenate([angle + k * 2.0 * math.pi for k in range(_CSV_CYCLES)])
    theta3 = np.tile(recording.state["theta3"], _CSV_CYCLES)
    return angles / speed, theta3


def _date_csv(tail: Tail, recording: Recording) -> None:
    """Give a CSV's cycle times and speeds, from its theta3_dot."""
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


def analyse(
    path: str | Path,
    config: str | Path | None = None,
    output_dir: str | Path | None = None,
    namespace: str | None = None,
    overrides: Mapping[str, float] | None = None,
    use_recorded_speed: bool = True,
) -> Report:
    """Read, recompute, tabulate the beats and write the figures.

    ``overrides`` replace values of the parameter file (e.g. the swimming parameters).
    ``use_recorded_speed``: the swimming figures take U from the recorded fish where the bag has
    one (else, and with False, the assumed ``forward_speed_m_s``).

    Raises:
        AnalysisError: unusable input, geometry or tolerances, or figures that cannot be written.
    """
    recording = read_recording(path, namespace)
    geometry, geometry_source, values = choose_geometry(
        recording.mechanism, None if config is None else Path(config)
    )
    values = {**values, **(overrides or {})}
    if recording.mechanism is None:
        recording.mechanism = geometry.mechanism
    tolerances, hysteresis, gap = tolerances_from(values)
    tail = make_tail(geometry)
    if recording.kind == "csv":
        _date_csv(tail, recording)

    recomputed = recompute(tail, recording)
    fields = [name for name in tail.state_fields if name not in INPUT_FIELDS]
    disagreement = None
    if recording.state:
        compared = list(fields)
        if recording.kind == "bag" and not recording.carrier_source.startswith("motor_angle"):
            compared = [*INPUT_FIELDS, *compared]
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

    figures = write_figures(recording, source, tail, output_dir)
    report = Report(recording, geometry, geometry_source, disagreement, beats, figures)
    fish = recording.fish if use_recorded_speed else None
    report.swimming = swimming_of(recording, source, tail.fin_angle_field(), values, fish)
    if report.swimming is not None and recording.fish is not None and not use_recorded_speed:
        report.swimming = dataclasses.replace(
            report.swimming, assumed_because="the recorded fish's speed not used, as asked"
        )
    return report
