"""``fishtail-run``: start the node suite, command the motor and show the tail live.

For machines without ``ros2 launch`` (ROS 2 from PyPI wheels): each node a process of its own
(:mod:`fishtail_bringup.supervisor`), or all in one with ``--one-process``, the carrier speed
published from a thread of its own (:mod:`fishtail_bringup.speed_commands`), and a console node
that prints the status line (:mod:`fishtail_bringup.console_node`). Options add the simulator,
the live view, the DC motor and its load, the pilot or the real firmware (``--help``;
README.md, "The two commands"). Ctrl-C (or ``--duration``) commands speed 0, sends SIGINT to every
node, waits for them and kills any that hang; a node that dies early ends the run with exit
status 1.
"""

from __future__ import annotations

import argparse
import math
import shutil
import sys
import tempfile
import time
from pathlib import Path

from fishtail_bringup import firmware_board
from fishtail_bringup.console_node import Console
from fishtail_bringup.speed_commands import (
    COMMAND_PERIOD_S,
    COMMAND_TIMEOUT_S,
    SpeedCommands,
    margin_text,
)
from fishtail_bringup.supervisor import Supervisor
from fishtail_bringup.view import PACING_OPTIONS
from fishtail_common.command_line import DURATION, add_parameter_options, flag_name
from fishtail_common.interface import (
    PILOT_NODE,
    SUITE_NODES,
    SWIM_NODE,
    VIEW_NODE,
    SuiteNode,
)
from fishtail_common.parameter_files import default_parameter_file
from fishtail_common.parameters import ParameterSpec
from fishtail_driver.parameters import DC_MOTOR_ENCODER, SPECS
from fishtail_pilot.pilot import GOAL_TOLERANCE
from fishtail_pilot.route import GoalRoute, square_route
from fishtail_pilot.steering import PIVOT_STEERING, STEERING
from fishtail_plant.linkage_load.surroundings import NO_LOAD, SURROUNDINGS

#: The driver's simulated motors (its motor_model parameter).
MOTOR_MODELS = SPECS["motor_model"].choices
#: The pilot's steering means (its steering parameter).
STEERING_CHOICES = STEERING.choices
#: The driver's parameter that gives it the simulated pivot actuator.
PIVOT_ACTUATOR = "pivot_actuator"
#: The speed this console commands, and the pilot's square route.
SPEED = ParameterSpec("speed", 4.0, "carrier speed of the one-way motor", "rad/s", 0.0)
SQUARE = ParameterSpec(
    "square", 1.0, "with the pilot: swim around a square of this side, anticlockwise, back to the "
    "start", "m", 0.0, exclusive_minimum=True,
)  # fmt: skip


def motor_parameters(motor: str | None, load: str) -> list[str]:
    """The driver's ``NAME:=VALUE`` items of ``--motor`` and ``--load`` (before --driver-param)."""
    items = [] if motor is None else [f"motor_model:={motor}"]
    if motor == "dc":
        items += [f"{name}:={value!r}" for name, value in DC_MOTOR_ENCODER.items()]
    if load != NO_LOAD:
        items.append(f"motor_load:={load}")
    return items


def view_options(arguments: argparse.Namespace) -> list[str]:
    """The live view's pacing options that were given, as fishtail-view's flags."""
    given = [(spec, getattr(arguments, spec.name)) for spec in PACING_OPTIONS]
    return [part for spec, value in given if value is not None
            for part in (flag_name(spec.name), str(value))]  # fmt: skip


def _point(text: str) -> tuple[float, float]:
    try:
        x, y = (float(part) for part in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected X,Y in metres, got {text!r}") from None
    if not (math.isfinite(x) and math.isfinite(y)):
        raise argparse.ArgumentTypeError(f"{text!r} is not a finite point")
    return x, y


def _node_names(text: str) -> tuple[SuiteNode, ...]:
    known = {node.name: node for node in SUITE_NODES}
    names = [name.strip() for name in text.split(",") if name.strip()]
    unknown = [name for name in names if name not in known]
    if unknown or not names:
        raise argparse.ArgumentTypeError(
            f"unknown node {', '.join(unknown) or '(none)'}: choose from {', '.join(known)}"
        )
    return tuple(node for node in SUITE_NODES if node.name in names)


def build_parser() -> argparse.ArgumentParser:
    """Command-line options."""
    parser = argparse.ArgumentParser(prog="fishtail-run", description=__doc__.splitlines()[0])
    parser.add_argument("--mechanism", choices=("oscillatory", "undulatory"), default="oscillatory")
    parser.add_argument("--config", type=Path, help="parameter file (default config/<mechanism>)")
    add_parameter_options(parser, [SPEED])
    add_parameter_options(parser, [DURATION], optional=True)
    parser.add_argument("--namespace", default="", help="namespace for the whole suite")
    parser.add_argument(
        "--nodes",
        type=_node_names,
        default=SUITE_NODES,
        metavar="NAME,...",
        help="start only these nodes (default: "
        + ",".join(node.name for node in SUITE_NODES)
        + "); e.g. driver on the fish's computer, kinematics,monitor on the shore",
    )
    parser.add_argument(
        "--swim",
        action="store_true",
        help="also start the swimming simulator (fishtail_swim, fish from config/fish.yaml) and "
        "show the fish's speed and heading",
    )
    parser.add_argument(
        "--view",
        action="store_true",
        help="also start the live view (fishtail-view: the linkage, plots, verdicts and fish in a "
        "browser or Rerun's viewer; it prints the address)",
    )
    add_parameter_options(
        parser.add_argument_group("what the live view sends (--view; default: fishtail-view's)"),
        PACING_OPTIONS,
        optional=True,
    )
    parser.add_argument(
        "--fish",
        type=Path,
        help="fish parameter file of --swim and --load (default config/fish.yaml)",
    )
    parser.add_argument(
        "--motor",
        choices=MOTOR_MODELS,
        help="the simulated motor (the driver's motor_model; default first_order): dc is the DC "
        "gear motor under the board's speed loop, with gear_ratio 30 and "
        "encoder_counts_per_revolution 64 (its gearbox and encoder; --driver-param overrides)",
    )
    parser.add_argument(
        "--firmware",
        nargs="?",
        const=firmware_board.AUTO,
        choices=(*firmware_board.FIRMWARES, firmware_board.AUTO),
        help="the driver on the real motor-board firmware in simavr (make firmware) over a "
        "serial link, its motor the DC gear motor (instead of --motor): fishtail, the project's "
        "(the board follows the speed profile), where built, else stock; --firmware stock: the "
        "stock ROSArduinoBridge (the driver follows the profile)",
    )
    parser.add_argument(
        "--load",
        choices=SURROUNDINGS,
        default=NO_LOAD,
        help="with --motor dc: what the motor turns (the driver's motor_load): the tail of the "
        "parameter file in air, in water with the fish held at rest or towed at the speed it swims "
        "at (the fish of --fish)",
    )
    parser.add_argument(
        "--pilot",
        action="store_true",
        help="also start the simulator and the pilot, which commands the carrier from cmd_vel "
        "and goal_pose (this console then sends no speed)",
    )
    route = parser.add_mutually_exclusive_group()
    route.add_argument(
        "--goal", type=_point, metavar="X,Y", help="with the pilot: swim to (X, Y) m in world"
    )
    add_parameter_options(route, [SQUARE], optional=True)
    parser.add_argument(
        "--steering",
        choices=STEERING_CHOICES,
        help="the pilot's steering means (default modulation: the carrier's speed within a "
        "revolution; pivot: the driver's simulated pivot actuator)",
    )
    parser.add_argument(
        "--one-process",
        action="store_true",
        help="run the nodes in one process on one executor (a quarter to a third less CPU than a "
        "process per node at 1 kHz, lower latency; a node that crashes takes the others with "
        "it); the live view keeps its own process",
    )
    parser.add_argument(
        "--no-command",
        action="store_true",
        help="do not publish motor/cmd_speed (another computer commands the motor)",
    )
    parser.add_argument(
        "--driver-param",
        action="append",
        default=[],
        metavar="NAME:=VALUE",
        help="extra driver parameter, e.g. backend:=serial (repeatable)",
    )
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``fishtail-run``."""
    parser = build_parser()
    arguments = parser.parse_args(argv)
    loaded = arguments.load != NO_LOAD
    piloted = arguments.pilot or arguments.goal is not None or arguments.square is not None
    if arguments.steering is not None and not piloted:
        parser.error("--steering is the pilot's: add --pilot (or --goal, --square)")
    if arguments.firmware and arguments.motor is not None:
        parser.error("--firmware drives the firmware's DC motor: leave out --motor")
    if loaded and arguments.motor != "dc" and not arguments.firmware:
        parser.error(f"--load {arguments.load} needs --motor dc (only the DC motor feels a load)")
    if arguments.firmware:
        arguments.firmware = firmware_board.pick_firmware(arguments.firmware)
        if missing := firmware_board.missing_firmware(arguments.firmware):
            print(f"fishtail-run: error: --firmware: {missing}", file=sys.stderr)
            return 2
    try:
        config = arguments.config or default_parameter_file(arguments.mechanism)
        fish_config = None
        if arguments.swim or loaded or piloted:
            fish_config = arguments.fish or default_parameter_file("fish")
    except LookupError as error:
        print(f"fishtail-run: error: {error}", file=sys.stderr)
        return 2
    for path in (config, fish_config):
        if path is not None and not path.is_file():
            print(f"fishtail-run: error: no parameter file {path}", file=sys.stderr)
            return 2
    try:
        tuning = None
        if arguments.firmware:
            tuning = firmware_board.board_tuning(
                arguments.firmware, arguments.load, config, fish_config
            )
    except ValueError as error:
        print(f"fishtail-run: error: --firmware: {error}", file=sys.stderr)
        return 2
    import rclpy
    from rclpy.signals import SignalHandlerOptions

    from fishtail_common.ros import install_stop_handlers

    stop = install_stop_handlers()
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    swim = arguments.swim or piloted
    nodes = (*arguments.nodes, SWIM_NODE) if swim else arguments.nodes
    nodes = (*nodes, PILOT_NODE) if piloted else nodes
    nodes = (*nodes, VIEW_NODE) if arguments.view else nodes
    steering = arguments.steering or STEERING.default
    pilot_params = [f"{STEERING.name}:={steering}"] if piloted else []
    pivot_params = [f"{PIVOT_ACTUATOR}:=sim"] if piloted and steering == PIVOT_STEERING else []
    boards: dict[str, list[str]] = {}
    motor_params = motor_parameters(arguments.motor, arguments.load)
    if arguments.firmware:
        link = Path(tempfile.mkdtemp(prefix="fishtail-firmware-")) / firmware_board.LINK_NAME
        command = firmware_board.board_command(
            link, arguments.load, config, fish_config, arguments.firmware
        )
        boards[firmware_board.BOARD_LABEL] = command
        motor_params = firmware_board.driver_parameters(link, tuning)
    # The driver's own parameters after --motor's, so that --driver-param overrides them.
    driver_params = motor_params + pivot_params + arguments.driver_param
    supervisor = Supervisor(
        config,
        arguments.namespace,
        driver_params,
        nodes,
        fish_config,
        driver_reads_fish=loaded and not arguments.firmware,
        one_process=arguments.one_process,
        pilot_params=pilot_params,
        boards=boards,
        view_options=view_options(arguments),
    )
    speed = None if arguments.no_command or piloted else arguments.speed
    route = None
    if arguments.goal is not None:
        route = GoalRoute([arguments.goal], float(GOAL_TOLERANCE.default))
    elif arguments.square is not None:
        route = GoalRoute(square_route(arguments.square), float(GOAL_TOLERANCE.default))
    interactive = sys.stdout.isatty()
    if interactive:
        supervisor.clear_line = "\r\033[K"
    supervisor.say(
        f"fishtail-run: {', '.join(node.name for node in nodes)} with {config}, "
        + ("in one process, " if arguments.one_process else "")
        + (f"{arguments.motor} motor, " if arguments.motor else "")
        + (
            f"on the firmware in simavr ({firmware_board.describe(arguments.firmware, tuning)}), "
            if arguments.firmware
            else ""
        )
        + (f"turning the tail ({arguments.load}), " if loaded else "")
        + (
            f"piloted ({steering} steering)"
            if piloted
            else "motor commanded elsewhere"
            if speed is None
            else f"at {speed:g} rad/s"
        )
        + (f" for {arguments.duration:g} s" if arguments.duration else " until Ctrl-C")
    )
    supervisor.start()
    # The speed goes out from its own thread: nothing the console's loop does can delay it.
    commands = None if speed is None else SpeedCommands(speed, arguments.namespace)
    if commands is not None:
        commands.start()
    console = Console(None, arguments.namespace, supervisor.say, swim, route)
    executor = rclpy.executors.SingleThreadedExecutor()
    executor.add_node(console.node)
    started = time.monotonic()
    next_print = started
    early_exit: list[tuple[str, int]] = []
    try:
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.05)
            now = time.monotonic()
            if arguments.duration and now - started >= arguments.duration:
                break
            early_exit = supervisor.dead()
            if early_exit:
                break
            if now >= next_print:
                line = console.line(now - started)
                with supervisor.print_lock:
                    if interactive:
                        sys.stdout.write("\r\033[K" + line)
                    else:
                        sys.stdout.write(line + "\n")
                    sys.stdout.flush()
                next_print = now + (0.25 if interactive else 1.0)
    finally:
        if commands is not None:
            commands.stop(0.0)
        if interactive:
            sys.stdout.write("\n")
        statuses = supervisor.stop()
        summary = console.line(time.monotonic() - started)
        executor.shutdown()
        console.node.destroy_node()
        if commands is not None:
            commands.close()
        rclpy.try_shutdown()
        for command in boards.values():  # the link's folder (the board removed the link)
            shutil.rmtree(Path(command[command.index("--link") + 1]).parent, ignore_errors=True)
    print(f"fishtail-run: last state: {summary}")
    if commands is not None:
        print(
            "fishtail-run: "
            + margin_text(commands.lateness_s(), COMMAND_PERIOD_S, COMMAND_TIMEOUT_S)
        )
    for name, status in early_exit:
        print(f"fishtail-run: error: node process {name} exited early with status {status}")
    failed = {name: status for name, status in statuses.items() if status != 0}
    if failed:
        print(f"fishtail-run: nodes ended with non-zero status: {failed}")
    return 1 if early_exit or failed else 0


if __name__ == "__main__":
    sys.exit(main())
