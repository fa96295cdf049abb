"""The real ROSArduinoBridge firmware in simavr, its motors the DC motor: ``fishtail-avr-board``.

``make firmware`` builds the firmware for an Arduino Nano (ATmega328P, L298N driver, encoders on
the Arduino's pins) and ``avr_board``, a small C program on libsimavr that runs it at 16 MHz paced
to wall-clock time with its UART on a pty (``firmware/avr_board.c``). This command starts that
program in lockstep mode and is its motors: every millisecond of simulated time the simulator
writes ``D <microseconds> <left PWM> <right PWM>`` (what the firmware drives on the L298 inputs,
-255..255) and this side answers ``<left count> <right count>``, each channel's motor-shaft
encoder count after the motor (:class:`fishtail_driver.board_motors.DcChannelMotor`, the DC gear
motor the simulated backend and ``fishtail-fake-board --motor dc`` run, at duty PWM / 255,
optionally turning the tail: ``--load``) moved on by that millisecond. The simulator toggles the
firmware's encoder pins in quadrature to reach those counts.

Like ``fishtail-fake-board`` it prints the pty's path on stdout and keeps a symlink at ``--link``.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import signal
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import IO

from fishtail_driver.board_motors import DcChannelMotor
from fishtail_driver.protocol import PWM_MAX, Scale
from fishtail_driver.sim_load import MOTOR_LOADS, NO_LOAD, tail_load_from_files
from fishtail_swim.dynamics.dc_motor import (
    DcMotorParameters,
    LoadInertia,
    LoadTorque,
    zero_load,
    zero_load_inertia,
)

#: Where ``make firmware`` puts the firmware and the simulator, under the workspace root.
BUILD_DIR = Path("build") / "firmware"
ELF_NAME = "ROSArduinoBridge.elf"
SIMULATOR_NAME = "avr_board"


def default_build_dir() -> Path:
    """``build/firmware`` of the workspace (``FISHTAIL_ROOT`` if set, else the current folder)."""
    return Path(os.environ.get("FISHTAIL_ROOT", ".")) / BUILD_DIR


def built_artifacts(build_dir: Path | None = None) -> tuple[Path, Path] | None:
    """The firmware ELF and the simulator ``make firmware`` built, or None if either is missing."""
    folder = build_dir or default_build_dir()
    elf, simulator = folder / ELF_NAME, folder / SIMULATOR_NAME
    if elf.is_file() and simulator.is_file() and os.access(simulator, os.X_OK):
        return elf, simulator
    return None


class MotorSide:
    """The two channels' DC motors, answering the simulator's PWMs with encoder counts."""

    def __init__(self, motors: Sequence[DcChannelMotor]) -> None:
        """``motors``: left (the firmware's first) and right."""
        self.motors = list(motors)
        self._last_us: int | None = None
        #: The PWMs of the last exchange (left, right), as the firmware drove them.
        self.pwm = (0, 0)

    def exchange(self, line: str) -> str:
        """The answer to one ``D <us> <left PWM> <right PWM>`` line (ValueError if malformed)."""
        fields = line.split()
        if len(fields) != 4 or fields[0] != "D":
            raise ValueError(f"unexpected line from the simulator: {line!r}")
        now_us, left, right = int(fields[1]), int(fields[2]), int(fields[3])
        dt_s = 0.0 if self._last_us is None else (now_us - self._last_us) * 1e-6
        self._last_us = now_us
        # The PWM held over the millisecond that ends now was the one read at its start.
        for motor in self.motors:
            motor.advance(dt_s)
        self.pwm = (left, right)
        for motor, pwm in zip(self.motors, self.pwm, strict=True):
            motor.drive(max(-PWM_MAX, min(PWM_MAX, pwm)), 0, True)
        left_count, right_count = (motor.encoder_counts() for motor in self.motors)
        return f"{left_count} {right_count}\n"


def run_motor_side(
    side: MotorSide, from_simulator: IO[str], to_simulator: IO[str], announce: IO[str]
) -> None:
    """Serve the simulator until it ends: print its pty path (``P`` line), answer ``D`` lines."""
    for line in from_simulator:
        if line.startswith("P "):
            print(line[2:].strip(), file=announce, flush=True)
            continue
        to_simulator.write(side.exchange(line))
        to_simulator.flush()


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="fishtail-avr-board",
        description="The ROSArduinoBridge firmware in simavr on a pty (prints the device path), "
        "its motors the DC gear motor model. Build it first: make firmware.",
    )
    add = parser.add_argument
    add("--link", help="keep a symlink to the pty at this path (removed on exit)")
    add("--build-dir", type=Path, help="where make firmware put its output (build/firmware)")
    add("--counts-per-rev", type=int, default=64, help="encoder counts per motor turn")
    add("--gear-ratio", type=float, default=30.0, help="motor turns per carrier turn")
    add(
        "--load",
        choices=MOTOR_LOADS,
        default=NO_LOAD,
        help="what each motor turns: the tail of --config in air, in water held at rest, or "
        "towed at its swimming speed (the fish of --fish)",
    )
    add("--config", type=Path, help="--load's tail and link masses (config/oscillatory.yaml)")
    add("--fish", type=Path, help="--load's fish (config/fish.yaml)")
    add("--fast", action="store_true", help="do not pace simulated time to wall time")
    return parser  # fmt: skip


def _motors(args: argparse.Namespace) -> list[DcChannelMotor]:
    """The two channels' motors the arguments describe (ValueError)."""
    scale = Scale(args.counts_per_rev, args.gear_ratio)
    parameters = dataclasses.replace(DcMotorParameters(), gear_ratio=scale.gear_ratio)
    load: LoadTorque = zero_load
    load_inertia: LoadInertia = zero_load_inertia
    if args.load != NO_LOAD:
        tail = tail_load_from_files(args.load, args.config, args.fish)
        load, load_inertia = tail.torque, tail.inertia
    elif args.config is not None or args.fish is not None:
        raise ValueError("--config and --fish describe the tail of --load: give --load too")
    return [DcChannelMotor(parameters, scale, load, load_inertia) for _ in range(2)]


def main(argv: list[str] | None = None) -> int:
    """Entry point of ``fishtail-avr-board``."""
    args = _parser().parse_args(argv)
    artifacts = built_artifacts(args.build_dir)
    if artifacts is None:
        folder = args.build_dir or default_build_dir()
        print(
            f"fishtail-avr-board: error: no {ELF_NAME} and {SIMULATOR_NAME} in {folder}: "
            "run make firmware",
            file=sys.stderr,
        )
        return 2
    try:
        side = MotorSide(_motors(args))
    except ValueError as error:
        print(f"fishtail-avr-board: error: {error}", file=sys.stderr)
        return 2
    elf, simulator = artifacts
    command = [str(simulator), str(elf), "--exchange"]
    command += ["--link", args.link] if args.link else []
    command += ["--fast"] if args.fast else []
    process = subprocess.Popen(
        command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
    )
    assert process.stdin is not None and process.stdout is not None
    # The simulator ends on its own signal; forward ours, and finish when its output ends.
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, lambda *_: process.send_signal(signal.SIGTERM))
    try:
        run_motor_side(side, process.stdout, process.stdin, sys.stdout)
    except (BrokenPipeError, ValueError) as error:
        if isinstance(error, ValueError):
            print(f"fishtail-avr-board: error: {error}", file=sys.stderr)
        process.terminate()
    return process.wait()


if __name__ == "__main__":
    sys.exit(main())
