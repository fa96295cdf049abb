"""``fishtail-swim turning``: the steady turn against modulation depth and against pivot shift.

The runs are the steering map's (:mod:`fishtail_pilot.steering_map`), each a batch stepped from
rest (:mod:`fishtail_plant.fish.steady_turn`). Yaw rates and radii are counter-clockwise positive
(a left turn, REP 103). The tables and their results: docs/steering.md.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path
from typing import NamedTuple, TextIO

import numpy as np

from fishtail_common.command_line import (
    OneLineErrorParser,
    UsageError,
    add_parameter_options,
    spaced_range,
    value_list,
)
from fishtail_common.parameters import ParameterSpec
from fishtail_kinematics.engine.carrier_profile import MAX_DEPTH
from fishtail_pilot.steering_map import (
    PHASE_COUNT,
    PIVOT_COUNT,
    PIVOT_STROKE_M,
    ModulationTurns,
    PivotTurns,
    modulation_study,
    pivot_study,
    scan_phases,
)
from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.fish.steady_turn import (
    AVERAGE_BEATS,
    SETTLED_RAD_PER_BEAT,
    TURN_BEATS,
    TURN_STEPS_PER_BEAT,
    SteadyTurn,
    TurnSettings,
)
from fishtail_swim.offline.inputs import PROGRAM, swimmer_from_arguments
from fishtail_swim.offline.motor_options import check_figure_path
from fishtail_swim.offline.options import CARRIER_SPEED, MAX_VALUES, STEPS_PER_BEAT
from fishtail_swim.offline.progress import Progress
from fishtail_swim.offline.tables import Column, write_table
from fishtail_swim.offline.turning_figure import plot_turning

MEANS = ("both", "modulation", "pivot")
DEFAULT_DEPTHS = "0.1,0.2,0.3,0.4,0.5,0.6,0.7,0.8,0.9"
DEFAULT_PIVOT_SHIFTS = f"{-PIVOT_STROKE_M:g}:{PIVOT_STROKE_M:g}:{PIVOT_COUNT}"
#: The options of the runs (the carrier speed and the steps a beat are every run's).
SPEED = dataclasses.replace(
    CARRIER_SPEED, description="mean carrier speed, on which r/f, U/f and the radius do not depend"
)
PHASES = ParameterSpec(
    "phases", PHASE_COUNT, "phases of the scan, evenly over a revolution", "", 3, 360
)
BEATS = ParameterSpec(
    "beats", TURN_BEATS, f"beats from rest; the figures are over the last {AVERAGE_BEATS}", "",
    AVERAGE_BEATS + 1, 100_000,
)  # fmt: skip
#: One item of --depths (depth 0 is always run).
DEPTH = ParameterSpec(
    "depth", MAX_DEPTH, "modulation depth", "", 0.0, MAX_DEPTH, exclusive_minimum=True
)
#: The ends and the count of --pivot-shifts.
PIVOT_SHIFT = ParameterSpec("pivot_shift_m", 0.0, "pivot shift from the design position", "m")
SHIFT_COUNT = ParameterSpec("count", PIVOT_COUNT, "pivot shifts", "", 2, 1000)


def _depth_list(text: str) -> FloatArray:
    return np.unique(value_list(DEPTH, text, MAX_VALUES))


def _shift_range(text: str) -> FloatArray:
    shifts = np.linspace(*spaced_range(PIVOT_SHIFT, SHIFT_COUNT, text, "LOW:HIGH:COUNT"))
    # Rounded to a nanometre (and -0 made 0), so that a shift meant to be 0 prints as 0, not as
    # linspace's -1e-17.
    return np.round(shifts, 9) + 0.0


def add_turning_parser(
    commands: argparse._SubParsersAction[OneLineErrorParser], swimmer: OneLineErrorParser
) -> None:
    """The ``turning`` subcommand and its options."""
    turning = commands.add_parser(
        "turning", parents=[swimmer],
        help="steady yaw rate, turning radius and speed against carrier modulation (one motor) "
        "and pivot shift",
        description="Steady turns of the fish from rest, one fish per steering input in one "
        "batch: a phase scan of the modulation at the deepest depth, each depth at the strongest "
        "phase each way, each pivot shift with the carrier unmodulated.",
    )  # fmt: skip
    add_parameter_options(turning, [SPEED])
    turning.add_argument("--means", choices=MEANS, default="both", help="what to tabulate (both)")
    turning.add_argument(
        "--depths", type=_depth_list, default=_depth_list(DEFAULT_DEPTHS), metavar="D1,D2,...",
        help=f"modulation depths, each way ({DEFAULT_DEPTHS}); the phase scan is at the deepest",
    )  # fmt: skip
    add_parameter_options(turning, [PHASES])
    turning.add_argument(
        "--pivot-shifts", type=_shift_range, default=_shift_range(DEFAULT_PIVOT_SHIFTS),
        metavar="LOW:HIGH:COUNT",
        help=f"pivot shifts [m] from the design position, + towards the tail "
        f"({DEFAULT_PIVOT_SHIFTS}); within the tail's assembly range",
    )  # fmt: skip
    add_parameter_options(
        turning, [BEATS, dataclasses.replace(STEPS_PER_BEAT, default=TURN_STEPS_PER_BEAT)]
    )
    turning.add_argument("--csv", action="store_true", help="CSV instead of aligned tables")
    turning.add_argument(
        "--figure", type=Path, metavar="FILE.png",
        help="write the figure (r/f against phase, depth and pivot shift) here",
    )  # fmt: skip


class TurningRuns(NamedTuple):
    """What one ``turning`` run computed (a means not asked for is None)."""

    speed_rad_s: float
    settings: TurnSettings
    modulation: ModulationTurns | None
    pivot: PivotTurns | None

    @property
    def unsteered(self) -> SteadyTurn:
        """The reference run: carrier unmodulated, pivot at the design position."""
        if self.modulation is not None:
            return self.modulation.unmodulated
        assert self.pivot is not None
        return self.pivot.unshifted


def run_turning(arguments: argparse.Namespace, out: TextIO) -> None:
    """Run the asked means' batches, print their tables (and draw the figure).

    Raises:
        UsageError: pivot shifts outside the tail's assembly range, or a figure that cannot be
            written.
    """
    swimmer = swimmer_from_arguments(arguments)
    tail, fish = swimmer.tail, swimmer.fish
    shifts: FloatArray = arguments.pivot_shifts
    with_modulation = arguments.means in ("both", "modulation")
    with_pivot = arguments.means in ("both", "pivot")
    if with_pivot:
        low, high = tail.pivot_shift_range()
        if shifts[0] <= low or shifts[-1] >= high:
            raise UsageError(
                f"--pivot-shifts {shifts[0]:g}:{shifts[-1]:g}: the {tail.name} tail assembles "
                f"for shifts in ({low:.4g}, {high:.4g}) m only"
            )
    figure: Path | None = arguments.figure
    if figure is not None:
        check_figure_path(figure)
    settings = TurnSettings(arguments.beats, arguments.steps_per_beat)
    steps = settings.beats * settings.steps_per_beat
    progress = Progress("turning", steps * (2 * with_modulation + with_pivot))
    modulation = pivot = None
    if with_modulation:
        signed = np.concatenate([-arguments.depths[::-1], [0.0], arguments.depths])
        modulation = modulation_study(
            tail, fish, arguments.speed, signed, scan_phases(arguments.phases), settings,
            progress.update,
        )  # fmt: skip
    if with_pivot:
        done = 2 * steps * with_modulation
        pivot = pivot_study(
            tail, fish, arguments.speed, shifts, settings,
            lambda count: progress.update(done + count),
        )  # fmt: skip
    progress.finish()
    runs = TurningRuns(arguments.speed, settings, modulation, pivot)
    length = float(np.mean(fish.body_length_m))
    _write_report(runs, tail.name, length, out, arguments.csv)
    _warn_if_unsettled(runs)
    if figure is not None:
        try:
            plot_turning(
                modulation, pivot, float(runs.unsteered.yaw_per_beat_rad[0]), figure,
                f"{tail.name} tail, mean carrier {arguments.speed:g} rad/s",
            )  # fmt: skip
        except OSError as error:
            raise UsageError(f"cannot write {figure}: {error.strerror or error}") from None
        print(f"wrote {figure}", file=sys.stderr if arguments.csv else out)


def _turns(runs: TurningRuns) -> list[SteadyTurn]:
    studies: list[SteadyTurn] = []
    if runs.modulation is not None:
        studies += [runs.modulation.scan, runs.modulation.table]
    if runs.pivot is not None:
        studies.append(runs.pivot.table)
    return studies


def _warn_if_unsettled(runs: TurningRuns) -> None:
    # The figures are over the last beats: a transient still running there would bias them.
    worst = max(turn.transient_beats for turn in _turns(runs))
    if worst > runs.settings.beats - runs.settings.average_beats:
        print(
            f"{PROGRAM}: warning: the start-up transient had not died out after "
            f"{runs.settings.beats} beats (the heading change per beat still moves by more than "
            f"{SETTLED_RAD_PER_BEAT:g} rad): use more --beats",
            file=sys.stderr,
        )


def _radius_text(radius_m: float, length_m: float) -> str:
    if not math.isfinite(radius_m):
        return "straight"
    side = "left" if radius_m > 0.0 else "right"
    return f"{abs(radius_m):.4g} m ({abs(radius_m) / length_m:.3g} body lengths, {side})"


def _figure_columns(turn: SteadyTurn, reference: SteadyTurn, length_m: float) -> list[Column]:
    """The columns every table shares: yaw rate (per beat, beside the reference), radius, speed."""
    change = turn.yaw_per_beat_rad - reference.yaw_per_beat_rad[0]
    return [
        Column("r [rad/s]", turn.yaw_rate_rad_s, "+.5f", "yaw_rate_rad_s"),
        Column("r/f [rad]", turn.yaw_per_beat_rad, "+.5f", "yaw_per_beat_rad"),
        Column("r/f - unsteered", change, "+.5f", "yaw_per_beat_change_rad"),
        Column("radius [m]", turn.turning_radius_m, ".4g", "turning_radius_m"),
        Column(
            "radius [L]", turn.turning_radius_m / length_m, ".4g", "turning_radius_body_lengths"
        ),
        Column("mean fin [deg]", np.degrees(turn.mean_fin_angle_rad), "+.3f", "mean_fin_angle_deg"),
        Column("U [m/s]", turn.speed_m_s, ".4f", "speed_m_s"),
        Column("U/f [m]", turn.distance_per_beat_m, ".4f", "distance_per_beat_m"),
        Column("power [W]", turn.tail_power_w, ".4g", "tail_power_w"),
    ]


def _write_report(
    runs: TurningRuns, tail_name: str, length_m: float, out: TextIO, as_csv: bool
) -> None:
    settings = runs.settings
    reference = runs.unsteered
    notes = sys.stderr if as_csv else out
    frequency = runs.speed_rad_s / (2.0 * math.pi)
    print(
        f"{tail_name} tail, mean carrier speed {runs.speed_rad_s:g} rad/s (f = {frequency:.4g} "
        f"Hz); from rest, {settings.beats} beats at {settings.steps_per_beat} steps a beat, "
        f"figures over the last {settings.average_beats}",
        file=notes,
    )
    worst = max(_turns(runs), key=lambda turn: turn.transient_beats)
    print(
        f"transient: every fish's heading change per beat within {SETTLED_RAD_PER_BEAT:g} rad of "
        f"its last after {worst.transient_beats} beats (change over the last beat "
        f"{max(turn.last_drift_rad for turn in _turns(runs)):.1e} rad)",
        file=notes,
    )
    print(
        f"unsteered: r/f {reference.yaw_per_beat_rad[0]:+.5f} rad, radius "
        f"{_radius_text(float(reference.turning_radius_m[0]), length_m)}, U "
        f"{reference.speed_m_s[0]:.4f} m/s",
        file=notes,
    )
    sections = []
    if runs.modulation is not None:
        sections += _modulation_sections(runs.modulation, reference, length_m)
    if runs.pivot is not None:
        sections.append(_pivot_section(runs.pivot, reference, length_m))
    for title, columns in sections:
        # CSV: tables apart by a blank line, as steady --check's; text: each under its title.
        out.write("\n" if as_csv else f"\n{title}\n")
        write_table(columns, out, as_csv)


def _modulation_sections(
    study: ModulationTurns, reference: SteadyTurn, length_m: float
) -> list[tuple[str, list[Column]]]:
    strongest = study.strongest
    scan_title = (
        f"phase scan at depth {study.scan_depth:g}: strongest left at phase "
        f"{math.degrees(strongest.left_rad):.1f} deg (r/f {strongest.left_yaw_per_beat_rad:+.4f} "
        f"rad), strongest right at {math.degrees(strongest.right_rad):.1f} deg (r/f "
        f"{strongest.right_yaw_per_beat_rad:+.4f} rad)"
    )
    scan = [
        Column("phase [deg]", np.degrees(study.scan_phases_rad), ".1f", "phase_deg"),
        *_figure_columns(study.scan, reference, length_m),
    ]
    signed = study.signed_depth
    side = np.where(signed > 0.0, "left", np.where(signed < 0.0, "right", "none"))
    phase = np.where(signed >= 0.0, strongest.left_rad, strongest.right_rad)
    table = [
        Column("side", side, "s", "side"),
        Column("depth", np.abs(signed), ".3g", "depth"),
        Column("phase [deg]", np.where(signed == 0.0, np.nan, np.degrees(phase)), ".1f",
               "phase_deg"),
        *_figure_columns(study.table, reference, length_m),
    ]  # fmt: skip
    return [
        (scan_title, scan),
        ("modulation depth at the strongest phase each way (one motor)", table),
    ]


def _pivot_section(
    study: PivotTurns, reference: SteadyTurn, length_m: float
) -> tuple[str, list[Column]]:
    columns = [
        Column("shift [mm]", 1e3 * study.shifts_m, "+.1f", "pivot_shift_mm"),
        Column("bias [deg]", np.degrees(study.swing_bias_rad), "+.3f", "swing_bias_deg"),
        *_figure_columns(study.table, reference, length_m),
    ]
    return ("pivot shift, carrier unmodulated (+ towards the tail)", columns)
