"""``fishtail-swim``: steady swimming, runs to CSV, figures, GIF, motor sizing, turns, URDF.

The tail comes from a kinematics parameter file (``--config config/oscillatory.yaml``), the fish
from ``--fish`` (``config/fish.yaml``); flags named after the parameters override both. Bad input
ends with a one-line error and exit status 2.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TextIO

import numpy as np

from fishtail_common.bag_reading import BagError
from fishtail_common.command_line import (
    OneLineErrorParser,
    UsageError,
    add_parameter_options,
    spaced_range,
    value_list,
)
from fishtail_common.parameters import ParameterSpec, ParameterValueError
from fishtail_kinematics.engine.errors import FishtailKinematicsError
from fishtail_plant.errors import SwimError
from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.linkage_load.tail_load import TailLoad
from fishtail_plant.motor.full_duty_run import DEFAULT_RUN_LIMITS
from fishtail_swim.offline import animate, recorded_run, run_output
from fishtail_swim.offline.fit_command import add_fit_parser, run_fit
from fishtail_swim.offline.inputs import (
    PROGRAM,
    link_inertia_from_arguments,
    swimmer_arguments,
    swimmer_from_arguments,
)
from fishtail_swim.offline.motor_options import (
    add_motor_arguments,
    check_figure_path,
    motor_parameters_from_arguments,
)
from fishtail_swim.offline.motor_sizing import size_motor
from fishtail_swim.offline.motor_sizing_report import plot_torque_speed, write_sizing_report
from fishtail_swim.offline.options import CARRIER_SPEED, MAX_STEPS, MAX_VALUES, STEPS_PER_BEAT
from fishtail_swim.offline.progress import Progress
from fishtail_swim.offline.steady_table import (
    balance_columns,
    balance_rows,
    check_columns,
    check_rows,
    checked_indices,
)
from fishtail_swim.offline.tables import write_table
from fishtail_swim.offline.tail_beats import CardanBeats, TailBeats
from fishtail_swim.offline.tail_options import DEFAULT_SPEEDS, add_tail_options, tail_choice
from fishtail_swim.offline.time_run import (
    run_beats_from_rest,
    run_figures,
    run_from_rest,
)
from fishtail_swim.offline.turning import add_turning_parser, run_turning
from fishtail_swim.offline.urdf_command import add_urdf_parser, run_urdf

#: How many carrier speeds --speed-range spreads from the first to the last.
SPEED_COUNT = ParameterSpec("count", 5, "carrier speeds", "", 1, MAX_VALUES)
#: The time of a run from rest.
DURATION = ParameterSpec(
    "duration", 60.0,
    f"simulated time: at least one beat, at most {MAX_STEPS} RK4 steps (duration x speed / 2 pi "
    "x steps per beat)",
    "s", 0.0, exclusive_minimum=True,
)  # fmt: skip
#: The options of an animation: a simulated run needs --speed and --duration, a recorded one
#: takes a window (--start, --duration) and a gap.
FPS = ParameterSpec(
    "fps", 20.0, "frames per simulated or recorded second, played in real time",
    "frames/s", 0.0, animate.MAX_FPS, exclusive_minimum=True,
)  # fmt: skip
ANIMATION_SPEED = dataclasses.replace(
    CARRIER_SPEED, description="carrier speed, which a simulated run needs"
)
ANIMATION_DURATION = dataclasses.replace(
    DURATION, description="time drawn, which a simulated run needs (a recording: to its end)"
)
START = ParameterSpec(
    "start", 0.0, "where the GIF starts, after the first fish/odom sample", "s", 0.0
)
GAP = ParameterSpec(
    "gap", recorded_run.DEFAULT_GAP_S, "fish/odom samples further apart than this are a gap: the "
    "fish is not drawn there and its path is broken", "s", 0.0, exclusive_minimum=True,
)  # fmt: skip


def _speed_list(text: str) -> FloatArray:
    return np.array(value_list(CARRIER_SPEED, text, MAX_VALUES))


def _speed_range(text: str) -> FloatArray:
    return np.linspace(*spaced_range(CARRIER_SPEED, SPEED_COUNT, text))


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (exposed for tests)."""
    swimmer = swimmer_arguments()
    parser = OneLineErrorParser(prog=PROGRAM, description=(__doc__ or "").splitlines()[0])
    commands = parser.add_subparsers(dest="command", required=True)
    steady = commands.add_parser(
        "steady", parents=[swimmer],
        help="cycle-average steady speed, thrust, power, efficiency and St over carrier speeds "
        "(a servo tail: over beat frequencies and amplitudes)",
    )  # fmt: skip
    speeds = steady.add_mutually_exclusive_group()
    speeds.add_argument(
        "--speeds", type=_speed_list,
        help=f"carrier speeds [rad/s], comma-separated ({DEFAULT_SPEEDS})",
    )  # fmt: skip
    speeds.add_argument(
        "--speed-range", dest="speeds", type=_speed_range, metavar="FIRST:LAST:COUNT",
        help="COUNT carrier speeds evenly from FIRST to LAST rad/s",
    )  # fmt: skip
    steady.add_argument("--csv", action="store_true", help="CSV instead of an aligned table")
    steady.add_argument(
        "--check", action="store_true",
        help="also step the free body (sway and yaw free) from rest at the first, middle and last "
        "speed, and print its figures beside the balance's",
    )  # fmt: skip
    add_tail_options(steady, sweep=True)
    simulate = commands.add_parser(
        "simulate", parents=[swimmer], help="a time-stepped run from rest to CSV (and figures)"
    )
    add_parameter_options(simulate, [CARRIER_SPEED, DURATION, STEPS_PER_BEAT])
    simulate.add_argument("--output", type=Path, required=True, help="CSV file to write")
    simulate.add_argument("--figures", type=Path, metavar="DIR", help="write PNG figures here")
    add_tail_options(simulate, sweep=False)
    # None when not given, so that the servo tail can refuse it; the Cardan tail's default stays.
    simulate.set_defaults(speed=None)
    animation = commands.add_parser(
        "animate", parents=[swimmer],
        help="a time-stepped run from rest, or a recorded run (--bag), as a GIF: top view of the "
        "fish with its linkage",
        description="Without --bag: a fish from rest at a constant carrier speed (--speed, "
        "--duration). With --bag DIR: a run recorded by fishtail-record (fish/odom; the carrier "
        "angle from tail/state or motor/joint_state, the pivot shift from pivot/joint_state or "
        "tail/state, goals from goal_pose). The bag does not carry the tail's geometry or the "
        "fish's size: --config and --fish (and their flags) give them, as for a simulated run.",
    )  # fmt: skip
    add_parameter_options(animation, [ANIMATION_SPEED, ANIMATION_DURATION], optional=True)
    animation.add_argument(
        "--output", type=Path,
        help="GIF file to write (a simulated run: required; a recorded one: <bag name>.gif here)",
    )  # fmt: skip
    add_parameter_options(animation, [FPS, STEPS_PER_BEAT])
    recorded = animation.add_argument_group("a recorded run")
    recorded.add_argument(
        "--bag", type=Path, metavar="DIR",
        help="rosbag2 bag (directory, .mcap or .db3) recorded by fishtail-record: draw it",
    )  # fmt: skip
    add_parameter_options(recorded, [START, GAP])
    recorded.add_argument(
        "--namespace", help="namespace the suite was recorded under (when the bag holds several)"
    )
    add_fit_parser(commands, swimmer)
    _add_motor_parser(commands, swimmer)
    add_turning_parser(commands, swimmer)
    add_urdf_parser(commands, swimmer)
    return parser


def _add_motor_parser(
    commands: argparse._SubParsersAction[OneLineErrorParser], swimmer: OneLineErrorParser
) -> None:
    motor = commands.add_parser(
        "motor", parents=[swimmer],
        help="size a DC gear motor for the tail: torque, current, voltage and power at each beat "
        "frequency, the highest beat frequency at full duty, a torque-speed figure",
        description="A motor too weak for the tail is an answer, not an error: its verdict says "
        "so and the exit status is 0; bad options (and values outside a small fish motor's "
        "ranges, shown below) end with one line and status 2, as does a full-duty run that "
        f"cannot settle within {DEFAULT_RUN_LIMITS.max_steps} steps (no verdict).",
    )  # fmt: skip
    add_motor_arguments(motor)


def run_steady(arguments: argparse.Namespace, out: TextIO) -> None:
    """Print the balance's table; with --check, the free body's figures for three rows.

    Raises:
        UsageError, ParameterValueError, FishtailKinematicsError: bad input
            (:func:`~fishtail_swim.offline.tail_options.tail_choice`).
        NoSteadySpeedError: a fish whose thrust never balances its drag.
    """
    tail = tail_choice(arguments)
    beats = tail.sweep(arguments)
    rows = balance_rows(tail.fish, beats)
    write_table(balance_columns(beats, rows), out, arguments.csv)
    if not arguments.check:
        return
    indices = checked_indices(rows.speed_m_s.size)
    checked = check_rows(tail.fish, beats, rows, indices)
    if not arguments.csv:
        out.write(
            "\nfree body (sway and yaw free), stepped from rest: figures over the last 2 of "
            "50 beats at 32 steps a beat\n"
        )
    else:
        out.write("\n")
    write_table(check_columns(beats.subset(indices), checked), out, arguments.csv)


def _run_steps(arguments: argparse.Namespace, beats: TailBeats) -> tuple[float, int]:
    """The step and the step count of a run of --duration, checked before anything is allocated.

    Raises:
        UsageError: a run shorter than one beat or longer than MAX_STEPS steps.
    """
    period = float(beats.beat_period_s[0])
    rate = beats.rate_text(0)
    step = period / arguments.steps_per_beat
    exact = arguments.duration / step - 1e-9
    if not exact <= MAX_STEPS:  # also an overflow to inf
        longest = MAX_STEPS * step
        raise UsageError(
            f"--duration {arguments.duration:g} s at {beats.rate_flag} {rate} and "
            f"--steps-per-beat {arguments.steps_per_beat} is {exact:.3g} RK4 steps, over the "
            f"limit of {MAX_STEPS} a run: take --duration at most "
            f"{longest:.6g} s, or fewer steps per beat"
        )
    steps = math.ceil(exact)
    if steps * step < period * (1.0 - 1e-9):
        raise UsageError(
            f"--duration {arguments.duration:g} s is shorter than one beat ({period:.6g} s at "
            f"{rate})"
        )
    return step, steps


def run_simulate(arguments: argparse.Namespace, out: TextIO) -> None:
    """Step the fish from rest, write the CSV (and figures), print the summary.

    Raises:
        UsageError: a run shorter than one beat, or output that cannot be written; and the
            errors of :func:`~fishtail_swim.offline.tail_options.tail_choice`.
        SwimInputError: a run that diverges.
    """
    tail = tail_choice(arguments)
    beats = tail.run(arguments)
    step, steps = _run_steps(arguments, beats)
    directory: Path | None = arguments.figures
    if directory is not None:
        try:
            directory.mkdir(parents=True, exist_ok=True)
        except OSError as error:
            raise UsageError(f"cannot create {directory}: {error.strerror}") from None
    if not arguments.output.parent.is_dir():
        raise UsageError(f"cannot write {arguments.output}: no directory {arguments.output.parent}")
    progress = Progress("simulate", steps)
    run = run_beats_from_rest(tail.fish, beats, step, steps, progress)
    figures = run_figures(run)
    try:
        run_output.write_run_csv(run, arguments.output)
        written = [] if directory is None else run_output.write_figures(run, figures, directory)
    except OSError as error:
        raise UsageError(f"cannot write: {error.strerror or error}") from None
    run_output.print_summary(run, figures, tail.fish, out)
    for path in [arguments.output, *written]:
        print(f"wrote {path}", file=out)


def _check_gif_output(path: Path) -> None:
    # Said before the run rather than after it; Pillow picks the format by the file's suffix.
    if path.suffix.lower() != ".gif":
        raise UsageError(f"--output {path}: the animation is a GIF, name it *.gif")
    if path.is_dir():
        raise UsageError(f"cannot write {path}: it is a directory")
    directory = path.parent
    if not directory.is_dir():
        raise UsageError(f"cannot write {path}: no directory {directory}")
    if not os.access(directory, os.W_OK) or (path.exists() and not os.access(path, os.W_OK)):
        raise UsageError(f"cannot write {path}: permission denied")


def run_animate(arguments: argparse.Namespace, out: TextIO) -> None:
    """Write a run as a GIF, one frame every 1/fps s: simulated from rest, or recorded (--bag).

    Raises:
        UsageError: options of the other kind of run, a missing option, a frame count outside
            [2, MAX_FRAMES], an output that is not a writable .gif, or a bag that cannot be read;
            and the errors of :func:`~fishtail_swim.offline.inputs.swimmer_from_arguments`.
    """
    if arguments.bag is not None:
        _animate_recording(arguments, out)
        return
    for option, given in (("--start", arguments.start != 0.0), ("--namespace", arguments.namespace),
                          ("--gap", arguments.gap != recorded_run.DEFAULT_GAP_S)):  # fmt: skip
        if given:
            raise UsageError(f"{option} is for a recorded run: add --bag DIR")
    for option, value in (("--speed", arguments.speed), ("--duration", arguments.duration),
                          ("--output", arguments.output)):  # fmt: skip
        if value is None:
            raise UsageError(f"a simulated run needs {option} (or draw a recorded one: --bag DIR)")
    swimmer = swimmer_from_arguments(arguments)
    count = animate.frame_count(arguments.duration, arguments.fps)
    if not 2 <= count <= animate.MAX_FRAMES:
        raise UsageError(
            f"--duration {arguments.duration:g} s at --fps {arguments.fps:g}: frame count "
            f"{count:.6g}, but a GIF takes 2 to {animate.MAX_FRAMES} frames (change the duration "
            "or the fps)"
        )
    step, steps = _run_steps(arguments, CardanBeats(swimmer.tail, np.array([arguments.speed])))
    times = animate.frame_times(arguments.duration, arguments.fps)
    _check_gif_output(arguments.output)
    speed = float(arguments.speed)
    run = run_from_rest(
        swimmer, np.array([speed]), step, steps, Progress("animate (stepping)", steps)
    )
    frames = animate.fish_frames(
        run.trajectory.time_s, run.trajectory.state[:, 0], swimmer.tail, swimmer.fish, speed,
        times,
    )  # fmt: skip
    title = f"{swimmer.tail.name} tail, carrier {speed:g} rad/s"
    try:
        animate.write_gif(
            frames, arguments.output, arguments.fps, title,
            Progress("animate (drawing)", times.size),
        )  # fmt: skip
    except OSError as error:
        raise UsageError(f"cannot write {arguments.output}: {error.strerror or error}") from None
    print(f"wrote {arguments.output} ({times.size} frames)", file=out)


def _animate_recording(arguments: argparse.Namespace, out: TextIO) -> None:
    """Read the bag's window into frames and write them as a GIF."""
    simulated = {
        "--speed": arguments.speed is not None,
        "--steps-per-beat": arguments.steps_per_beat != STEPS_PER_BEAT.default,
    }
    for option, given in simulated.items():
        if given:
            raise UsageError(f"{option} is for a simulated run, not with --bag")
    bag: Path = arguments.bag
    named = bag.resolve()
    output: Path = arguments.output or Path(
        f"{named.stem if named.suffix in ('.mcap', '.db3') else named.name}.gif"
    )
    _check_gif_output(output)
    swimmer = swimmer_from_arguments(arguments)
    try:
        run = recorded_run.read_recorded_run(
            bag, arguments.fps, arguments.start, arguments.duration, arguments.gap,
            arguments.namespace, max_frames=animate.MAX_FRAMES,
        )  # fmt: skip
    except BagError as error:
        raise UsageError(str(error)) from None
    if run.mechanism is not None and run.mechanism != swimmer.tail.name:
        run.notes.append(
            f"tail/state records the {run.mechanism} mechanism, the linkage is drawn with the "
            f"{swimmer.tail.name} one of --config"
        )
    for note in run.notes:
        print(f"{PROGRAM}: note: {note}", file=sys.stderr)
    frames = animate.recorded_frames(run, swimmer.tail, swimmer.fish)
    title = f"{bag.name}: {swimmer.tail.name} tail, recorded"
    count = frames.time_s.size
    try:
        animate.write_gif(
            frames, output, arguments.fps, title, Progress("animate (drawing)", count)
        )  # fmt: skip
    except OSError as error:
        raise UsageError(f"cannot write {output}: {error.strerror or error}") from None
    print(
        f"wrote {output} ({count} frames, {run.time_s[0]:.2f} to {run.time_s[-1]:.2f} s of "
        f"{bag}; fish/odom {run.odometry_samples} samples, {run.gaps} gaps; carrier: "
        f"{run.carrier_source}; pivot: {run.pivot_source}; {run.goals.shape[0]} goals)",
        file=out,
    )


def run_motor(arguments: argparse.Namespace, out: TextIO) -> None:
    """Print the motor's sizing for the tail (and draw its torque-speed figure).

    Raises:
        UsageError: a bad motor option (or one outside its range) or a figure that cannot be
            written; and the errors of
            :func:`~fishtail_swim.offline.inputs.swimmer_from_arguments`.
        UnsettledRunError: a full-duty run that cannot settle within its limits (no verdict).
    """
    parameters = motor_parameters_from_arguments(arguments)
    swimmer = swimmer_from_arguments(arguments)
    figure: Path | None = arguments.figure
    if figure is not None:
        check_figure_path(figure)
    surroundings = arguments.surroundings
    inertia = link_inertia_from_arguments(arguments)
    load = TailLoad(swimmer.tail, inertia, swimmer.fish, surroundings)
    progress = Progress("motor (time-stepped)", 1.0)
    sizing = size_motor(parameters, load, arguments.frequencies, progress=progress.update)
    progress.finish()
    described = f"{swimmer.tail.name} tail, {surroundings}"
    write_sizing_report(sizing, described, out)
    if figure is not None:
        try:
            plot_torque_speed(sizing, figure, f"Motor and load at the carrier: {described}")
        except OSError as error:
            raise UsageError(f"cannot write {figure}: {error.strerror or error}") from None
        print(f"wrote {figure}", file=out)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``fishtail-swim``."""
    parser = build_parser()
    arguments = parser.parse_args(argv)
    command: Callable[[argparse.Namespace, TextIO], None] = {
        "steady": run_steady,
        "simulate": run_simulate,
        "animate": run_animate,
        "fit": run_fit,
        "motor": run_motor,
        "turning": run_turning,
        "urdf": run_urdf,
    }[arguments.command]
    try:
        command(arguments, sys.stdout)
    except (SwimError, FishtailKinematicsError, ParameterValueError, UsageError) as error:
        message = " ".join(str(error).split())
        print(f"{PROGRAM}: error: {message}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        # `fishtail-swim steady | head` is normal use, not an error.
        sys.stderr.close()
        return 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
