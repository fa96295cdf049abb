"""``fishtail-kinematics``: a cycle as CSV, figures, an animation, design and pivot-shift tables.

Geometry comes from a ROS 2 parameter file (``--config config/oscillatory.yaml``, the same file the
nodes load) and/or flags named after the parameters (``--pivot-offset-m 0.18``); flags win. Bad
input ends with a one-line error and exit status 2.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import math
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TextIO

import numpy as np

from fishtail_common.command_line import (
    OneLineErrorParser,
    UsageError,
    add_parameter_flags,
    add_parameter_options,
    finite_number,
)
from fishtail_common.parameter_files import ParameterFileError, load_parameter_file
from fishtail_common.parameters import ParameterSpec
from fishtail_kinematics.engine import design
from fishtail_kinematics.engine.errors import FishtailKinematicsError, PivotShiftError
from fishtail_kinematics.engine.geometry import (
    GEOMETRY_PARAMETERS,
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
from fishtail_kinematics.offline import animation, plots
from fishtail_kinematics.offline.table_columns import FIELD_OF_COLUMN, table_columns

PROGRAM = "fishtail-kinematics"
REPORT_SPEED_RAD_S = 4.0
#: The options of a cycle's sampling and its GIF (the geometry's are the engine's specs).
SAMPLES = ParameterSpec("samples", 36, "angles k*2pi/N over a revolution", "", 2, 10_000_000)
SPEED = ParameterSpec(
    "speed", REPORT_SPEED_RAD_S, "carrier speed of the one-way motor", "rad/s", 0.0
)
FRAMES = ParameterSpec("frames", 72, "frames per revolution", "", 2, animation.MAX_FRAMES)
FPS = ParameterSpec(
    "fps", 24.0, "GIF frame rate; its delays are whole centiseconds", "frames/s", 0.0,
    animation.MAX_FPS, exclusive_minimum=True,
)  # fmt: skip


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for tests and for the README's usage text)."""
    geometry = OneLineErrorParser(add_help=False)
    group = geometry.add_argument_group("geometry (SI units; flags override --config)")
    group.add_argument(
        "--config", type=Path, help="ROS 2 parameter file, e.g. config/oscillatory.yaml"
    )
    add_parameter_options(group, [MECHANISM], optional=True)
    add_parameter_flags(group, GEOMETRY_PARAMETERS)
    parser = OneLineErrorParser(prog=PROGRAM, description=(__doc__ or "").splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    table = commands.add_parser("table", parents=[geometry], help="one cycle as CSV")
    add_parameter_options(table, [SAMPLES, SPEED])
    table.add_argument("--output", type=Path, help="write the CSV here instead of stdout")
    plot = commands.add_parser("plot", parents=[geometry], help="the report's figures as PNG")
    add_parameter_options(plot, [dataclasses.replace(SAMPLES, default=720), SPEED])
    plot.add_argument("--output-dir", type=Path, default=Path("figures"))
    commands.add_parser("design", parents=[geometry], help="symmetric RS, range, assembly, mu")
    pivot = commands.add_parser(
        "pivot", parents=[geometry], help="swing bias and range against the pivot shift (Markdown)"
    )
    pivot.add_argument(
        "--shifts-mm", type=finite_number, nargs="+",
        default=[-40.0, -30.0, -20.0, -10.0, 0.0, 10.0, 20.0, 30.0, 40.0],
        help="pivot shifts of S in mm, + towards the tail (-40 ... 40 by 10)",
    )  # fmt: skip
    animate = commands.add_parser(
        "animate", parents=[geometry], help="one carrier revolution as an animated GIF"
    )
    animate.add_argument(
        "--output", dest="gif_path", type=Path, default=Path("tail.gif"),
        help="GIF file to write (tail.gif)",
    )  # fmt: skip
    add_parameter_options(animate, [FRAMES, FPS])
    return parser


def geometry_from_arguments(arguments: argparse.Namespace) -> Geometry:
    """Merge --config and flags into a validated geometry.

    Raises:
        ParameterFileError: ``--config`` cannot be read.
        FishtailKinematicsError: a bad parameter value or a geometry that does not assemble.
    """
    values: dict[str, object] = {}
    if arguments.config is not None:
        values.update(geometry_parameters_in(load_parameter_file(arguments.config)))
    if arguments.mechanism is not None:
        values[MECHANISM.name] = arguments.mechanism
    for spec in GEOMETRY_PARAMETERS:
        value = getattr(arguments, spec.name)
        if value is not None:
            values[spec.name] = value
    return geometry_from_parameters(values)


def _cycle(tail: Tail, samples: int, speed: float) -> tuple[FloatArray, LinkageState]:
    angles: FloatArray = np.arange(samples) * (2.0 * math.pi / samples)
    return angles, tail.solve(angles, speed)


def run_table(arguments: argparse.Namespace, out: TextIO) -> None:
    """Write one carrier cycle as CSV."""
    tail = make_tail(geometry_from_arguments(arguments))
    _, state = _cycle(tail, arguments.samples, arguments.speed)
    columns = table_columns(tail.state_fields)
    data = [np.asarray(getattr(state, FIELD_OF_COLUMN[c])) for c in columns]
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(columns)
    for row in zip(*data, strict=True):
        writer.writerow([f"{value:.12g}" for value in row])


def run_plot(arguments: argparse.Namespace, out: TextIO) -> None:
    """Write the report's figures for this geometry.

    Raises:
        UsageError: a speed that is not positive, or an output directory that cannot be created.
        ParameterFileError, FishtailKinematicsError: as :func:`geometry_from_arguments`.
    """
    if arguments.speed <= 0.0:
        raise UsageError("plot needs a positive --speed for its time axis")
    geometry = geometry_from_arguments(arguments)
    tail = make_tail(geometry)
    angles, state = _cycle(tail, arguments.samples, arguments.speed)
    time_s = plots.cycle_time(angles, arguments.speed)
    title = f"{tail.name}, {arguments.speed:g} rad/s"
    directory = arguments.output_dir
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise UsageError(f"cannot create {directory}: {error.strerror}") from None
    written = [
        plots.plot_tail_angle(
            time_s,
            np.asarray(state.theta3),
            np.asarray(state.theta3_dot),
            directory / "theta3.png",
            title,
        ),
        plots.plot_tip_path(
            np.asarray(state.tip_x), np.asarray(state.tip_y), directory / "tip_path.png", title
        ),
    ]
    drive_geometry = tail.drive.geometry
    offsets = np.linspace(0.5 * geometry.pivot_offset_m, 1.6 * geometry.pivot_offset_m, 221)
    written.append(
        plots.plot_swing_range(
            offsets,
            design.swing_range_vs_pivot_offset(drive_geometry, offsets),
            design.swing_range_vs_pivot_offset(drive_geometry, offsets, rederive_rocker=True),
            geometry.pivot_offset_m,
            directory / "swing_range.png",
            title,
        )
    )
    if tail.fin_joint is not None:
        fit = design.fit_fin_ratio(geometry)
        written.append(
            plots.plot_fin_angles(
                time_s,
                np.asarray(state.theta3),
                np.asarray(getattr(state, tail.fin_joint)),
                fit.mu,
                directory / f"theta3_{tail.fin_joint}.png",
                title,
            )
        )
    for path in written:
        print(path, file=out)


def run_design(arguments: argparse.Namespace, out: TextIO) -> None:
    """Print the design figures of a geometry, one `name: value` a line."""
    geometry = geometry_from_arguments(arguments)
    summary = design.design_summary(geometry)
    print(f"mechanism: {geometry.mechanism}", file=out)
    for name, value in summary.items():
        text = f"{value:.9g}" if isinstance(value, float) else str(value)
        print(f"{name}: {text}", file=out)


def run_pivot(arguments: argparse.Namespace, out: TextIO) -> None:
    """Print the feasible pivot shifts and a Markdown table of the swing at each given shift."""
    tail = make_tail(geometry_from_arguments(arguments))
    low, high = tail.pivot_shift_range()
    print(f"mechanism: {tail.name}", file=out)
    print(f"feasible pivot shifts: {1e3 * low:+.3f} mm < shift < {1e3 * high:+.3f} mm", file=out)
    print(
        "| shift mm | swing bias deg | swing range deg | theta3 at mid-stroke deg "
        "| fin angle min / max deg | fin mean deg |\n|---:|---:|---:|---:|---:|---:|",
        file=out,
    )
    for shift_mm in arguments.shifts_mm:
        try:
            e = design.pivot_shift_effect(tail, 1e-3 * shift_mm)
        except PivotShiftError:
            print(f"| {shift_mm:+g} | cannot assemble | | | | |", file=out)
            continue
        print(
            f"| {shift_mm:+g} | {math.degrees(e.swing_bias_rad):+.3f} "
            f"| {math.degrees(e.swing_range_rad):.3f} "
            f"| {math.degrees(e.mid_stroke_theta3_rad):+.3f} "
            f"| {math.degrees(e.fin_min_rad):+.2f} / {math.degrees(e.fin_max_rad):+.2f} "
            f"| {math.degrees(e.fin_mean_rad):+.3f} |",
            file=out,
        )


def run_animate(arguments: argparse.Namespace, out: TextIO) -> None:
    """Write one carrier revolution as an animated GIF and print its path.

    Raises:
        UsageError: an output that is not a .gif in an existing directory, or cannot be written.
        ParameterFileError, FishtailKinematicsError: as :func:`geometry_from_arguments`.
    """
    path = arguments.gif_path
    if path.suffix.lower() != ".gif":
        raise UsageError(f"--output must name a .gif file, got {path}")
    tail = make_tail(geometry_from_arguments(arguments))  # fails before any drawing
    if not path.parent.is_dir():
        raise UsageError(f"cannot write {path}: no directory {path.parent}")
    try:
        animation.animate_cycle(tail, path, arguments.frames, arguments.fps, f"{tail.name} tail")
    except OSError as error:
        raise UsageError(f"cannot write {path}: {error.strerror or error}") from None
    print(path, file=out)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``fishtail-kinematics``."""
    parser = build_parser()
    arguments = parser.parse_args(argv)
    command: Callable[[argparse.Namespace, TextIO], None] = {
        "table": run_table,
        "plot": run_plot,
        "design": run_design,
        "pivot": run_pivot,
        "animate": run_animate,
    }[arguments.command]
    try:
        if getattr(arguments, "output", None) is not None:
            try:
                with open(arguments.output, "w", encoding="utf-8", newline="") as out:
                    command(arguments, out)
            except OSError as error:
                raise UsageError(f"cannot write {arguments.output}: {error.strerror}") from None
        else:
            command(arguments, sys.stdout)
    except (FishtailKinematicsError, ParameterFileError, UsageError) as error:
        print(f"{PROGRAM}: error: {error}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # `fishtail-kinematics table | head` is normal use, not an error.
        sys.stderr.close()
        return 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
