"""``fishtail-swim fit``: its options and the command (measurements in, report and fish file out).

Which fit serves which runs: the Cardan tail's quadratic set by the closed form (:mod:`.fit`),
its turning set with every yaw rate measured by the time-scaled free body (:mod:`.fit_free_body`),
everything else by bounded least squares (:mod:`.fit_least_squares`); leave-one-out
(:mod:`.fit_loo`) for all. docs/swimming-dynamics.md (``fit``).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path
from typing import TextIO

import numpy as np

from fishtail_common.bag_reading import BagError
from fishtail_common.command_line import OneLineErrorParser, UsageError, add_parameter_options
from fishtail_common.parameters import ParameterSpec
from fishtail_plant.fish.tail_drive import SERVO_TAIL_PARAMETERS_BY_NAME
from fishtail_swim.offline.fit import (
    DRAG,
    MAX_DRAG_RELATIVE_ERROR,
    MAX_RELATIVE_RESIDUAL,
    YAW_DAMPING,
    FitContradictedError,
    FitResult,
    check_model_agrees,
    fish_file_text,
    fit_drag,
)
from fishtail_swim.offline.fit_free_body import (
    FREE_BODY_BEATS,
    FREE_BODY_STEPS_PER_BEAT,
    RunSettings,
    fit_drag_and_yaw_damping,
)
from fishtail_swim.offline.fit_least_squares import fit_coefficients, run_model
from fishtail_swim.offline.fit_loo import leave_one_out
from fishtail_swim.offline.fit_measurements import (
    CARDAN,
    Measurements,
    parse_measurements,
    read_measurements,
)
from fishtail_swim.offline.fit_problem import COEFFICIENT_SETS, check_determined, coefficient_names
from fishtail_swim.offline.fit_report import write_fit_report
from fishtail_swim.offline.inputs import PROGRAM, Swimmer, swimmer_from_arguments
from fishtail_swim.offline.options import STEPS_PER_BEAT
from fishtail_swim.offline.recorded_measurements import measurements_from_bag
from fishtail_swim.offline.time_run import SUMMARY_BEATS

#: Free-body runs of fit (turning sets): long enough for the figures' last beats.
BEATS = ParameterSpec(
    "beats", FREE_BODY_BEATS, "beats of each run from rest", "", SUMMARY_BEATS + 1, 100_000
)
FIN_LENGTH = SERVO_TAIL_PARAMETERS_BY_NAME["servo_fin_length_m"]
_SETS_HELP = "; ".join(f"{name}: {', '.join(names)}" for name, names in COEFFICIENT_SETS.items())


def add_fit_parser(
    commands: argparse._SubParsersAction[OneLineErrorParser], swimmer: OneLineErrorParser
) -> None:
    """The ``fit`` command's parser and options."""
    fit = commands.add_parser(
        "fit", parents=[swimmer],
        help="fit damping coefficients (C_D; X_u; K_D with turns) to measured runs of a Cardan "
        "or servo tail; print residuals and leave-one-out errors; write a fish file",
    )  # fmt: skip
    fit.add_argument(
        "measurements", type=Path, metavar="MEASUREMENTS.csv", nargs="?",
        help="CSV with a header: carrier_speed_rad_s (Cardan) or amplitude_rad,bias_rad,"
        "frequency_hz (servo), then speed_m_s[,yaw_rate_rad_s][,turning_radius_m] (# comments; "
        "an empty turn cell is not measured); or --bag",
    )  # fmt: skip
    fit.add_argument(
        "--bag", type=Path, metavar="DIR",
        help="fit a recorded run instead: its steady segments (fish/odom with motor/joint_state "
        "or tail/state) become the measurements",
    )  # fmt: skip
    fit.add_argument(
        "--namespace", metavar="NS", help="--bag: the fish's namespace in the bag (e.g. /fish1)"
    )
    fit.add_argument(
        "--write-measurements", type=Path, metavar="FILE",
        help="--bag: also write the measurements the recording gave, as a file fit reads",
    )  # fmt: skip
    fit.add_argument(
        "--coefficients", choices=tuple(COEFFICIENT_SETS),
        help=f"the coefficients fitted ({_SETS_HELP}); default turning with measured turns, "
        "else quadratic",
    )  # fmt: skip
    fit.add_argument(
        "--output", type=Path, metavar="FILE",
        help="write the fitted fish as a parameter file (for --fish and the simulator node)",
    )  # fmt: skip
    fit.add_argument("--csv", action="store_true", help="CSV instead of an aligned table")
    fit.add_argument(
        "--force", action="store_true",
        help="report and write a fit the model contradicts (refused without it: an RMS speed "
        f"residual over {100 * MAX_RELATIVE_RESIDUAL:g} %% or a C_D standard error over "
        f"{100 * MAX_DRAG_RELATIVE_ERROR:g} %% of C_D), with a warning",
    )  # fmt: skip
    servo = fit.add_argument_group("servo tail (measurements with amplitude_rad, ...)")
    add_parameter_options(servo, [FIN_LENGTH])
    free = fit.add_argument_group("free-body runs (turning sets)")
    add_parameter_options(
        free, [BEATS, dataclasses.replace(STEPS_PER_BEAT, default=FREE_BODY_STEPS_PER_BEAT)]
    )


def _fit(
    swimmer: Swimmer,
    measurements: Measurements,
    names: tuple[str, ...],
    fin_length_m: float,
    settings: RunSettings,
) -> FitResult:
    # The Cardan tail's quadratic and turning sets keep their exact closed form and time-scaled
    # free body (both need every force quadratic, so no linear damping in the fish, and time
    # scaling every yaw rate measured).
    quadratic = not swimmer.fish.has_linear_damping
    if measurements.kind == CARDAN and names == (DRAG,) and quadratic:
        return fit_drag(swimmer, measurements)
    whole_yaw = measurements.yaw_rate_rad_s is not None and bool(
        np.isfinite(measurements.yaw_rate_rad_s).all()
    )
    if (
        measurements.kind == CARDAN
        and names == (DRAG, YAW_DAMPING)
        and whole_yaw
        and measurements.turning_radius_m is None
        and quadratic
    ):
        return fit_drag_and_yaw_damping(swimmer, measurements, settings)
    return fit_coefficients(swimmer, measurements, names, fin_length_m, settings)


def _measurements(arguments: argparse.Namespace, out: TextIO) -> tuple[Measurements, str]:
    """The measurements of the file, or of the recording's steady segments; and their source.

    Raises:
        UsageError: both a file and --bag, or neither; options of --bag without it; a bag that
            cannot be read or has no steady segment (the line says why).
    """
    bag: Path | None = arguments.bag
    if (bag is None) == (arguments.measurements is None):
        raise UsageError("fit takes a MEASUREMENTS.csv file or --bag DIR (one of them)")
    if bag is None:
        if arguments.write_measurements is not None or arguments.namespace is not None:
            raise UsageError("--write-measurements and --namespace go with --bag")
        return read_measurements(arguments.measurements), str(arguments.measurements)
    try:
        segments = measurements_from_bag(bag, namespace=arguments.namespace)
    except BagError as error:
        raise UsageError(str(error)) from None
    text = segments.csv_text()
    source = f"{bag} (steady segments)"
    written: Path | None = arguments.write_measurements
    if written is not None:
        try:
            written.write_text(text, "utf-8")
        except OSError as error:
            raise UsageError(f"cannot write {written}: {error.strerror or error}") from None
    notes = sys.stderr if arguments.csv else out
    print(f"{len(segments.segments)} steady segment(s) in {bag}:", file=notes)
    for line in text.splitlines():
        if line.startswith("#"):
            print(f"  {line.lstrip('# ')}", file=notes)
    if written is not None:
        print(f"wrote {written}", file=notes)
    return parse_measurements(text.splitlines(), source), source


def run_fit(arguments: argparse.Namespace, out: TextIO) -> None:
    """Fit the coefficient set, print the rows, values and leave-one-out errors, write the file.

    Raises:
        MeasurementError: an unusable measurements file.
        FitRefusedError: an under-determined or degenerate fit, no coefficients in range that
            reproduce the measurements, or (without --force) a fit the model contradicts.
        UsageError: an output that cannot be written; and the errors of
            :func:`~fishtail_swim.offline.inputs.swimmer_from_arguments`.
    """
    measurements, source = _measurements(arguments, out)
    swimmer = swimmer_from_arguments(arguments)
    output: Path | None = arguments.output
    if output is not None and not output.parent.is_dir():
        raise UsageError(f"cannot write {output}: no directory {output.parent}")
    names = coefficient_names(arguments.coefficients, measurements)
    check_determined(names, measurements)
    settings = RunSettings(arguments.beats, arguments.steps_per_beat)
    fin_length = float(arguments.servo_fin_length_m)
    result = _fit(swimmer, measurements, names, fin_length, settings)
    warnings = list(result.warnings)
    try:
        check_model_agrees(result, measurements)
    except FitContradictedError as error:
        if not arguments.force:
            raise
        warnings.append(f"{error.reason} (reported and written: --force)")
    model = run_model(swimmer, measurements, names, fin_length, settings)
    loo = leave_one_out(model, measurements, result)
    if not loo.converged:
        warnings.append("a leave-one-out fit stopped before converging")
    write_fit_report(result, measurements, loo, out, arguments.csv)
    # CSV output stays parseable: the notes go to stderr.
    notes = sys.stderr if arguments.csv else out
    for warning in warnings:
        print(f"{PROGRAM}: warning: {warning}", file=sys.stderr)
    if output is not None:
        try:
            output.write_text(fish_file_text(result, source), "utf-8")
        except OSError as error:
            raise UsageError(f"cannot write {output}: {error.strerror or error}") from None
        print(f"wrote {output}", file=notes)
