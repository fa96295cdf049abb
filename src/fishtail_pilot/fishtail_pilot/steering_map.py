"""The steering map: each means of steering, its input against the steady yaw and distance per beat.

What the pilot needs at run time to turn a yaw demand into an actuator's input, built from the
tail and the fish in a fraction of a second (:func:`build_steering_map`). Heading change and
distance per beat do not depend on the beat frequency, so one table serves every carrier speed.
:class:`ModulationChannel` (a signed depth) and :class:`PivotChannel` (a pivot shift) each
satisfy :class:`fishtail_pilot.pilot.Steering`. How the tables are built and inverted:
docs/steering.md ("The steering map").

>>> import numpy as np
>>> steering = PivotChannel(np.array([-0.02, 0.0, 0.02]), np.array([-0.3, 0.01, 0.29]),
...                          np.array([0.25, 0.28, 0.25]))
>>> steering.yaw_per_beat_range_rad
(-0.3, 0.29)
>>> command = steering.command(1.0)  # beyond the left limit: the limit
>>> command.pivot_shift_m, command.yaw_per_beat_rad
(0.02, 0.29)
>>> round(steering.input_for(0.0), 6)  # the straight-swimming shift
-0.000645
"""

from __future__ import annotations

import abc
import math
import time
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.carrier_profile import MAX_DEPTH, CarrierSpeedProfile
from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_pilot.pilot import SteeringCommand
from fishtail_plant.errors import SwimInputError
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.steady_turn import (
    DEFAULT_SETTINGS,
    SteadyTurn,
    StrongestPhases,
    TurnSettings,
    modulation_turns,
    pivot_shift_turns,
    strongest_phases,
)
from fishtail_plant.pivot_actuator import PIVOT_STROKE

#: The map's carrier speed: one beat a second, so r̄ and r̄/f are the same numbers.
MAP_CARRIER_SPEED_RAD_S = 2.0 * math.pi
#: Phases of the scan for the strongest phases (15 degrees apart; the interpolant finds the best
#: between them).
PHASE_COUNT = 24
#: Depths of the table each way, 0 and the deepest included. r̄/f bends up towards the deepest
#: depth, so the depths crowd there (:func:`signed_depths`); with 16 the broken line is within
#: 2e-3 rad a beat of a 61-depth table for both tails (10 evenly spaced: 2e-2).
DEPTH_COUNT = 16
#: The pivot actuator's reach each way from the design position of S [m], and the table's rows.
PIVOT_STROKE_M = float(PIVOT_STROKE.default)
PIVOT_COUNT = 13
#: The fraction of the way to a limit of ``Tail.pivot_shift_range`` a table may reach: at the
#: limit the linkage cannot assemble over the whole stroke.
PIVOT_REACH = 0.95


def signed_depths(max_depth: float = MAX_DEPTH, count: int = DEPTH_COUNT) -> FloatArray:
    """The modulation table's inputs: -max_depth ... 0 ... max_depth, ``count`` each way with 0.

    Spaced as max_depth sin(pi k / 2 (count - 1)): closest where the table bends most.

    Raises:
        SwimInputError: ``max_depth`` outside (0, MAX_DEPTH] or fewer than 2 depths.
    """
    if not (0.0 < max_depth <= MAX_DEPTH) or count < 2:
        raise SwimInputError(
            f"the depth table needs 0 < max_depth <= {MAX_DEPTH} and 2 or more depths, got "
            f"{max_depth!r} and {count}"
        )
    one_way = max_depth * np.sin(np.linspace(0.0, 0.5 * np.pi, count))
    signed: FloatArray = np.concatenate([-one_way[:0:-1], one_way])
    return signed


def scan_phases(count: int = PHASE_COUNT) -> FloatArray:
    """``count`` phases equally spaced over a revolution from 0."""
    return np.arange(count, dtype=float) * (2.0 * math.pi / count)


class SteeringChannel(abc.ABC):
    """One means of steering: its input against r̄/f [rad] and Ū/f [m], and both inversions."""

    # Plain attributes, not ClassVar: the pilot's Steering protocol asks for a ``name`` member.
    #: The means' name, as the pilot's ``steering`` parameter says it.
    name: str
    #: The input's unit ("" for a depth).
    input_unit: str

    def __init__(
        self,
        inputs: npt.ArrayLike,
        yaw_per_beat_rad: npt.ArrayLike,
        distance_per_beat_m: npt.ArrayLike,
    ) -> None:
        """Keep the table (inputs increasing), cut to its monotonic stretch round straight ahead.

        Raises:
            SwimInputError: columns of unequal length or under two rows, a non-finite value, or
                inputs that do not increase.
        """
        table = [np.asarray(values, dtype=float).ravel() for values in
                 (inputs, yaw_per_beat_rad, distance_per_beat_m)]  # fmt: skip
        if len({values.size for values in table}) != 1 or table[0].size < 2:
            raise SwimInputError("a steering table needs two or more rows of equal length")
        if not all(np.isfinite(values).all() for values in table):
            raise SwimInputError("a steering table must be finite")
        if np.any(np.diff(table[0]) <= 0.0):
            raise SwimInputError("a steering table's inputs must increase")
        first, last = _monotonic_stretch(table[1])
        self.inputs, self.yaw_per_beat_rad, self.distance_per_beat_m = (
            values[first : last + 1] for values in table
        )
        # The inverse reads the broken line from its lowest yaw to its highest.
        self._by_yaw = np.argsort(self.yaw_per_beat_rad)

    @property
    def input_range(self) -> tuple[float, float]:
        """The lowest and highest input the table covers."""
        return float(self.inputs[0]), float(self.inputs[-1])

    @property
    def yaw_per_beat_range_rad(self) -> tuple[float, float]:
        """The most rightward (most negative) and most leftward (most positive) r̄/f [rad]."""
        return float(self.yaw_per_beat_rad.min()), float(self.yaw_per_beat_rad.max())

    def yaw_rate_range(self, beat_frequency_hz: float) -> tuple[float, float]:
        """The steady yaw rates [rad/s] it reaches at ``beat_frequency_hz``, right then left."""
        low, high = self.yaw_per_beat_range_rad
        return low * beat_frequency_hz, high * beat_frequency_hz

    def yaw_per_beat_at(self, steering_input: float) -> float:
        """r̄/f [rad] at ``steering_input`` (held at the table's ends beyond them)."""
        return float(np.interp(steering_input, self.inputs, self.yaw_per_beat_rad))

    def distance_per_beat_at(self, steering_input: float) -> float:
        """Ū/f [m] at ``steering_input``: the speed at beat frequency f is this times f."""
        return float(np.interp(steering_input, self.inputs, self.distance_per_beat_m))

    def turning_radius_at(self, steering_input: float) -> float:
        """The signed radius [m] of the steady circle (> 0 left, inf straight), at any speed.

        As :func:`~fishtail_plant.fish.figures.beat_means` defines it: the beat-end positions,
        a chord Ū/f apart, turn by r̄/f a beat, so R = (Ū/f) / (2 sin(r̄/2f)).
        """
        turn = self.yaw_per_beat_at(steering_input)
        if turn == 0.0:
            return math.inf
        return self.distance_per_beat_at(steering_input) / (2.0 * math.sin(0.5 * turn))

    def input_for(self, yaw_per_beat_rad: float) -> float:
        """The input giving ``yaw_per_beat_rad`` (the range's end input beyond the range)."""
        order = self._by_yaw
        return float(np.interp(yaw_per_beat_rad, self.yaw_per_beat_rad[order], self.inputs[order]))

    def input_for_yaw_rate(self, yaw_rate_rad_s: float, beat_frequency_hz: float) -> float:
        """The input giving a steady yaw rate [rad/s] at ``beat_frequency_hz`` (> 0).

        Raises:
            SwimInputError: a beat frequency that is not > 0.
        """
        if not beat_frequency_hz > 0.0:
            raise SwimInputError(f"beat frequency must be > 0 Hz, got {beat_frequency_hz!r}")
        return self.input_for(yaw_rate_rad_s / beat_frequency_hz)

    @property
    def straight_input(self) -> float:
        """The input that swims straight (r̄ = 0); a range end if none does."""
        return self.input_for(0.0)

    def command(self, yaw_per_beat_rad: float) -> SteeringCommand:
        """The actuators' inputs for ``yaw_per_beat_rad``, and the r̄/f they give."""
        steering_input = self.input_for(yaw_per_beat_rad)
        return self._command(steering_input, self.yaw_per_beat_at(steering_input))

    @abc.abstractmethod
    def _command(self, steering_input: float, yaw_per_beat_rad: float) -> SteeringCommand:
        """The command of this means at ``steering_input``."""


def _monotonic_stretch(values: FloatArray) -> tuple[int, int]:
    """First and last row of the strictly monotonic run that steers the widest, both ways if any.

    Runs whose yaw crosses zero (they can swim straight and turn either way) come first; among
    them, or else among all, the one with the largest span of yaw per beat.
    """
    steps = np.sign(np.diff(values))
    runs: list[tuple[int, int]] = []
    start = 0
    for row in range(1, steps.size + 1):
        if row == steps.size or steps[row] != steps[start]:
            if steps[start] != 0.0:
                runs.append((start, row))
            start = row
    if not runs:
        raise SwimInputError("the steering table does not change its yaw per beat with its input")

    def span(run: tuple[int, int]) -> float:
        return float(np.ptp(values[run[0] : run[1] + 1]))

    straight = [run for run in runs if values[run[0]] * values[run[1]] <= 0.0]
    return max(straight or runs, key=span)


class ModulationChannel(SteeringChannel):
    """One motor: the signed depth s, at the strongest left (s >= 0) or right (s < 0) phase."""

    name = "modulation"
    input_unit = ""

    def __init__(
        self,
        signed_depth: npt.ArrayLike,
        yaw_per_beat_rad: npt.ArrayLike,
        distance_per_beat_m: npt.ArrayLike,
        left_phase_rad: float,
        right_phase_rad: float,
    ) -> None:
        """The table over signed depths, and the phases its two sides use."""
        super().__init__(signed_depth, yaw_per_beat_rad, distance_per_beat_m)
        self.left_phase_rad = left_phase_rad
        self.right_phase_rad = right_phase_rad

    def depth_and_phase(self, signed_depth: float) -> tuple[float, float]:
        """The profile's depth and phase [rad] for ``signed_depth`` (clipped to the table)."""
        low, high = self.input_range
        clipped = min(max(signed_depth, low), high)
        if clipped >= 0.0:
            return clipped, self.left_phase_rad
        return -clipped, self.right_phase_rad

    def profile(self, signed_depth: float, mean_speed_rad_s: float) -> CarrierSpeedProfile:
        """The carrier's command for ``signed_depth`` at the mean speed ``mean_speed_rad_s``."""
        depth, phase = self.depth_and_phase(signed_depth)
        return CarrierSpeedProfile(mean_speed_rad_s, depth, phase)

    def _command(self, steering_input: float, yaw_per_beat_rad: float) -> SteeringCommand:
        depth, phase = self.depth_and_phase(steering_input)
        return SteeringCommand(depth, phase, None, yaw_per_beat_rad)


class PivotChannel(SteeringChannel):
    """A second actuator: the pivot S shifted along the body axis [m], the carrier unmodulated."""

    name = "pivot"
    input_unit = "m"

    def _command(self, steering_input: float, yaw_per_beat_rad: float) -> SteeringCommand:
        return SteeringCommand(0.0, 0.0, steering_input, yaw_per_beat_rad)


class ModulationTurns(NamedTuple):
    """The runs behind the modulation table, at one carrier speed."""

    #: The reference: the unmodulated carrier (one fish).
    unmodulated: SteadyTurn
    scan_depth: float
    scan_phases_rad: FloatArray
    scan: SteadyTurn
    strongest: StrongestPhases
    signed_depth: FloatArray
    #: One fish per signed depth, at the strongest phase of its side.
    table: SteadyTurn


def modulation_study(
    tail: Tail,
    fish: FishParameters,
    mean_speed_rad_s: float,
    signed_depth: FloatArray,
    phases_rad: FloatArray,
    settings: TurnSettings = DEFAULT_SETTINGS,
    progress: Callable[[int], None] | None = None,
) -> ModulationTurns:
    """Scan the phase at the deepest depth, then run every signed depth at its strongest phase.

    Two batches: the scan (with the unmodulated fish as its first) and the table. ``progress``
    is called with the steps done over both.
    """
    scan_depth = float(np.abs(signed_depth).max())
    steps = settings.beats * settings.steps_per_beat
    depths = np.concatenate([[0.0], np.full(phases_rad.size, scan_depth)])
    both = modulation_turns(
        tail, fish, mean_speed_rad_s, depths, np.concatenate([[0.0], phases_rad]),
        settings, progress,
    )  # fmt: skip
    unmodulated, scan = both.take([0]), both.take(np.arange(1, depths.size))
    strongest = strongest_phases(phases_rad, scan.yaw_per_beat_rad)
    phases = np.where(signed_depth >= 0.0, strongest.left_rad, strongest.right_rad)
    table = modulation_turns(
        tail, fish, mean_speed_rad_s, np.abs(signed_depth), phases, settings,
        None if progress is None else _shifted(progress, steps),
    )  # fmt: skip
    return ModulationTurns(
        unmodulated, scan_depth, phases_rad, scan, strongest, signed_depth, table
    )


def _shifted(progress: Callable[[int], None], done: int) -> Callable[[int], None]:
    """``progress`` of a later batch: its steps counted after the ``done`` ones."""
    return lambda count: progress(done + count)


def pivot_shifts(
    tail: Tail, stroke_m: float = PIVOT_STROKE_M, count: int = PIVOT_COUNT
) -> FloatArray:
    """``count`` shifts evenly across ``stroke_m`` each way, kept within reach of the linkage.

    Raises:
        SwimInputError: a stroke that is not > 0 or fewer than 2 shifts.
    """
    low, high = tail.pivot_shift_range()
    if not (stroke_m > 0.0 and count >= 2):
        raise SwimInputError(
            f"a pivot table needs a stroke > 0 and 2 or more shifts, got {stroke_m!r}, {count}"
        )
    return np.linspace(max(-stroke_m, PIVOT_REACH * low), min(stroke_m, PIVOT_REACH * high), count)


class PivotTurns(NamedTuple):
    """The runs behind the pivot table, at one carrier speed (unmodulated)."""

    #: The reference: the pivot at the design position (one fish).
    unshifted: SteadyTurn
    shifts_m: FloatArray
    #: The swing's mid-line from the body axis at each shift (the engine's ``swing_bias_rad``).
    swing_bias_rad: FloatArray
    table: SteadyTurn


def pivot_study(
    tail: Tail,
    fish: FishParameters,
    carrier_speed_rad_s: float,
    shifts_m: FloatArray,
    settings: TurnSettings = DEFAULT_SETTINGS,
    progress: Callable[[int], None] | None = None,
) -> PivotTurns:
    """Every pivot shift and the unshifted tail, one batch."""
    shifts = np.concatenate([[0.0], shifts_m])
    both = pivot_shift_turns(tail, fish, carrier_speed_rad_s, shifts, settings, progress)
    bias = np.array([tail.with_pivot_shift(float(shift)).swing_bias_rad for shift in shifts_m])
    return PivotTurns(both.take([0]), shifts_m, bias, both.take(np.arange(1, shifts.size)))


class SteeringMap(NamedTuple):
    """Both means of steering a tail, each a :class:`~fishtail_pilot.pilot.Steering` for a pilot."""

    modulation: ModulationChannel
    pivot: PivotChannel
    #: Ū/f [m] swimming with the carrier unmodulated and the pivot unshifted (the pilot's
    #: speed feed-forward).
    straight_distance_per_beat_m: float
    #: r̄/f [rad] of that unsteered swimming (the Cardan tails turn slightly).
    unsteered_yaw_per_beat_rad: float
    #: How long the build took [s].
    build_time_s: float

    def means(self, name: str) -> SteeringChannel:
        """The means called ``name``.

        Raises:
            ValueError: no means of that name (naming the available ones).
        """
        available = {channel.name: channel for channel in (self.modulation, self.pivot)}
        if name not in available:
            raise ValueError(f"no steering means {name!r}: available {sorted(available)}")
        return available[name]


def build_steering_map(
    tail: Tail,
    fish: FishParameters,
    max_depth: float = MAX_DEPTH,
    depth_count: int = DEPTH_COUNT,
    phase_count: int = PHASE_COUNT,
    pivot_stroke_m: float = PIVOT_STROKE_M,
    pivot_count: int = PIVOT_COUNT,
    settings: TurnSettings = DEFAULT_SETTINGS,
) -> SteeringMap:
    """Run the steady turns of ``tail`` on ``fish`` and tabulate them per beat.

    Three batches, well under a second with the compiled integrator (docs/steering.md).

    Raises:
        SwimInputError: table sizes or a stroke the functions above refuse.
    """
    started = time.perf_counter()
    study = modulation_study(
        tail, fish, MAP_CARRIER_SPEED_RAD_S, signed_depths(max_depth, depth_count),
        scan_phases(phase_count), settings,
    )  # fmt: skip
    modulation = ModulationChannel(
        study.signed_depth, study.table.yaw_per_beat_rad, study.table.distance_per_beat_m,
        study.strongest.left_rad, study.strongest.right_rad,
    )  # fmt: skip
    pivot = pivot_study(
        tail, fish, MAP_CARRIER_SPEED_RAD_S, pivot_shifts(tail, pivot_stroke_m, pivot_count),
        settings,
    )  # fmt: skip
    return SteeringMap(
        modulation,
        PivotChannel(pivot.shifts_m, pivot.table.yaw_per_beat_rad, pivot.table.distance_per_beat_m),
        float(study.unmodulated.distance_per_beat_m[0]),
        float(study.unmodulated.yaw_per_beat_rad[0]),
        time.perf_counter() - started,
    )
