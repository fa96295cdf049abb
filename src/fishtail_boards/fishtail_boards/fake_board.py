"""An emulated ROSArduinoBridge motor board on a pseudo-terminal: ``fishtail-fake-board``.

A board to run the serial path without hardware, with the faults hardware has: it prints the
pty's path (again after every emulated replug) and keeps ``--link`` pointing at it, as
``/dev/serial/by-id`` does. The firmware is :mod:`fishtail_boards.board_firmware`'s, the motors
:mod:`fishtail_boards.board_motors`' (with ``--load``, turning the tail of ``--config`` and
``--fish``), the pty and the fault injection :mod:`fishtail_boards.board_pty`'s. Options and
faults: docs/serial.md ("The emulated board").
"""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path

from fishtail_boards.board_firmware import FIRMWARES, VARIANTS
from fishtail_boards.board_motors import MOTOR_KINDS
from fishtail_boards.board_pty import BoardConfig, FakeBoard
from fishtail_plant.linkage_load.surroundings import NO_LOAD, SURROUNDINGS
from fishtail_plant.motor.dc_motor import LoadInertia, LoadTorque, zero_load, zero_load_inertia
from fishtail_plant.values import tail_load_from_files


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="fishtail-fake-board",
        description="Emulated ROSArduinoBridge motor board on a pty (prints the device path).",
        epilog="Signals: SIGUSR1 resets the board (counts back to 0, deaf for --boot-ms); "
        "SIGUSR2 switches the reply delay of --delay-ms off and on again; "
        "SIGINT, SIGTERM and SIGHUP end it.",
    )
    add = parser.add_argument
    add("--link", help="keep a symlink to the current pty at this path (removed on exit)")
    add("--log", help="append every command the board runs to this file")
    add("--baud", type=int, default=57600, help="what 'b' answers; line rate for --pace-baud")
    add("--pace-baud", action="store_true", help="delay each byte by 10 bits at --baud")
    add(
        "--variant",
        choices=VARIANTS,
        default="hbrobotics",
        help="hbrobotics: 'b' -> ' 57600', no 'o'; joshnewans: 'b' -> '57600', 'o' raw PWM",
    )
    add(
        "--firmware",
        choices=FIRMWARES,
        default="stock",
        help="stock: ROSArduinoBridge as it is ('v', 'f', 'i', 'k' are Invalid Command); "
        "fishtail: the project's firmware (firmware/CHANGES.md): 'v' capabilities, 'f' the "
        "carrier speed profile followed at every PID frame, 'i' the PID rate, 'k' the profile "
        "controller (lead, feed-forward, its own PID), in the firmware's integers",
    )
    add(
        "--motor",
        choices=MOTOR_KINDS,
        default="ideal",
        help="ideal: first-order lag at the loop's target; first-order: the lag driven by the "
        "PWM; dc: DC gear motor (Pololu 37D, --gear-ratio) at duty PWM/255",
    )
    add(
        "--load",
        choices=SURROUNDINGS,
        default=NO_LOAD,
        help="with --motor dc: what each motor turns: the tail of --config in air, in water held "
        "at rest, or towed at its swimming speed (the fish of --fish)",
    )
    add("--config", type=Path, help="--load's tail and link masses (config/oscillatory.yaml)")
    add("--fish", type=Path, help="--load's fish (config/fish.yaml)")
    add("--counts-per-rev", type=int, default=2048, help="encoder counts per motor turn")
    add("--gear-ratio", type=float, default=1.0, help="motor turns per carrier turn")
    add("--pid-rate", type=int, default=30, help="the firmware's PID_RATE [Hz]")
    add("--time-constant", type=float, default=0.05, help="motor speed time constant [s]")
    add("--max-speed", type=float, default=20.0, help="carrier speed limit [rad/s]")
    add("--encoder-offset", type=int, default=0, help="initial encoder count (test the wrap)")
    add("--arg-buffer", type=int, default=32, help="firmware argument buffer size [bytes]")
    add("--boot-ms", type=float, default=0.0, help="input ignored this long after power-up")
    add("--delay-ms", type=float, default=0.0, help="delay every reply (a slow board)")
    add(
        "--delay-after-s",
        type=float,
        default=None,
        help="answer at once until this long after start, then delay replies by --delay-ms",
    )
    add(
        "--delay-for-s",
        type=float,
        default=None,
        help="delay replies for this long only (from --delay-after-s), then answer at once "
        "again; replies already queued keep their time",
    )
    add("--drop-rate", type=float, default=0.0, help="probability of losing a command/reply")
    add("--garble-rate", type=float, default=0.0, help="probability of corrupting an exchange")
    add("--reset-after-s", type=float, default=None, help="reset the board once, after this")
    add("--disconnect-after-s", type=float, default=None, help="unplug once, after this")
    add("--disconnect-for-s", type=float, default=1.0, help="how long an unplug lasts")
    add("--seed", type=int, default=0, help="seed of the fault injection")
    return parser  # fmt: skip


def _load(args: argparse.Namespace) -> tuple[LoadTorque, LoadInertia]:
    """The load callables that ``--load``, ``--config`` and ``--fish`` describe (ValueError)."""
    if args.load == NO_LOAD:
        if args.config is not None or args.fish is not None:
            raise ValueError("--config and --fish describe the tail of --load: give --load too")
        return zero_load, zero_load_inertia
    if args.motor != "dc":
        raise ValueError(f"--load {args.load} needs --motor dc (the {args.motor} motor feels none)")
    tail = tail_load_from_files(args.load, args.config, args.fish)
    return tail.torque, tail.inertia


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``fishtail-fake-board``."""
    args = _parser().parse_args(argv)
    try:
        load, load_inertia = _load(args)
        config = BoardConfig(
            baud=args.baud,
            pace_baud=args.pace_baud,
            variant=args.variant,
            firmware=args.firmware,
            counts_per_revolution=args.counts_per_rev,
            gear_ratio=args.gear_ratio,
            motor=args.motor,
            load=load,
            load_inertia=load_inertia,
            pid_rate_hz=args.pid_rate,
            time_constant_s=args.time_constant,
            max_speed_rad_s=args.max_speed,
            encoder_offset=args.encoder_offset,
            arg_buffer_bytes=args.arg_buffer,
            boot_ms=args.boot_ms,
            delay_ms=args.delay_ms,
            delay_after_s=args.delay_after_s,
            delay_for_s=args.delay_for_s,
            drop_rate=args.drop_rate,
            garble_rate=args.garble_rate,
            reset_after_s=args.reset_after_s,
            disconnect_after_s=args.disconnect_after_s,
            disconnect_for_s=args.disconnect_for_s,
            seed=args.seed,
        )
        board = FakeBoard(config, link=args.link, log_path=args.log)
    except (ValueError, OSError) as error:
        print(f"fishtail-fake-board: error: {error}", file=sys.stderr)
        return 2
    emulated = "the project's firmware (fishtail 1)" if args.firmware == "fishtail" else "stock"
    print(
        f"fishtail-fake-board: emulating ROSArduinoBridge ({args.variant}), {emulated}",
        file=sys.stderr, flush=True,
    )  # fmt: skip
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, lambda *_: board.stop())
    signal.signal(signal.SIGUSR1, lambda *_: board.request_reset())
    signal.signal(signal.SIGUSR2, lambda *_: board.request_slow_toggle())
    try:
        board.run()
    except BrokenPipeError:
        pass
    finally:
        board.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
