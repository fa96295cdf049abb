"""The real ROSArduinoBridge firmware in simavr, its motors the DC motor: ``fishtail-avr-board``.

To check a host against the firmware itself rather than our emulation of it: this command runs
``make firmware``'s simulator of an Arduino Nano in lockstep and is its motors, answering each
simulated millisecond's PWM with the encoder counts of a
:class:`~fishtail_boards.board_motors.DcChannelMotor` (optionally turning the tail). It keeps a
pty link like ``fishtail-fake-board``; :class:`SimulatedBoard` runs the same in a thread of the
caller. Build, options, the lockstep protocol and its limits: docs/serial.md ("The real firmware
in a simulator").
"""

from __future__ import annotations

import argparse
import bisect
import contextlib
import dataclasses
import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import IO

from fishtail_boards.board_motors import DcChannelMotor
from fishtail_boards.usb_cable import UsbCable
from fishtail_plant.linkage_load.surroundings import NO_LOAD, SURROUNDINGS
from fishtail_plant.motor.board_units import PWM_MAX, Scale
from fishtail_plant.motor.dc_motor import (
    DcMotorParameters,
    LoadInertia,
    LoadTorque,
    zero_load,
    zero_load_inertia,
)
from fishtail_plant.motor.motor_file import read_motor_file
from fishtail_plant.values import tail_load_from_files

#: Where ``make firmware`` puts the firmware and the simulator, under the workspace root.
BUILD_DIR = Path("build") / "firmware"
ELF_NAME = "ROSArduinoBridge.elf"
SIMULATOR_NAME = "avr_board"
SYMBOLS_NAME = "symbols.txt"
FUNCTIONS_NAME = "functions.txt"
#: The project's firmware (firmware/fishtail.patch on the same sketch), in this folder of the
#: build, with its own symbols and a link to the simulator (docs/firmware.md).
PROJECT_FIRMWARE_DIR = "fishtail"
#: Where the ATmega's SRAM appears in the ELF's addresses (avr-gcc's data-space offset).
DATA_SPACE_OFFSET = 0x800000
#: Offsets in the firmware's ``SetPointInfo`` (diff_controller.h): float target, long Encoder,
#: long PrevEnc, int PrevInput, int ITerm, long output.
SET_POINT_ENCODER, SET_POINT_PREV_ENC, SET_POINT_OUTPUT = 4, 8, 16


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


def firmware_variables(build_dir: Path | None = None) -> dict[str, tuple[int, int]]:
    """The firmware's global variables: name -> (data-space address, size in bytes).

    From the ``symbols.txt`` that ``make firmware`` writes with avr-nm; FileNotFoundError if
    the build predates it.
    """
    folder = build_dir or default_build_dir()
    found = {}
    for line in (folder / SYMBOLS_NAME).read_text().splitlines():
        name, address, size = line.split()
        found[name] = (int(address, 16) - DATA_SPACE_OFFSET, int(size, 16))
    return found


def firmware_functions(build_dir: Path | None = None) -> dict[str, int]:
    """The firmware's functions: (mangled) name -> byte address in flash, for --time-function.

    From the ``functions.txt`` that ``make firmware`` writes with avr-nm; FileNotFoundError if
    the build predates it.
    """
    folder = build_dir or default_build_dir()
    found = {}
    for line in (folder / FUNCTIONS_NAME).read_text().splitlines():
        name, address, _ = line.split()
        found[name] = int(address, 16)
    return found


def encoder_offset_pokes(variables: dict[str, tuple[int, int]], offset: int) -> list[str]:
    """``--poke`` arguments that start both channels' counts at ``offset`` (signed 32-bit).

    The counts and the loop's Encoder and PrevEnc are set together: what ``setup()``'s resetPID
    would have read had the board powered up with its counts there.
    """
    value = offset & 0xFFFFFFFF
    left_pid, right_pid = variables["leftPID"][0], variables["rightPID"][0]
    addresses = [variables["left_enc_pos"][0], variables["right_enc_pos"][0]]
    for base in (left_pid, right_pid):
        addresses += [base + SET_POINT_ENCODER, base + SET_POINT_PREV_ENC]
    return [arg for address in addresses for arg in ("--poke", f"{address:#x}:4={value}")]


class MotorSide:
    """The two channels' DC motors, answering the simulator's PWMs with encoder counts."""

    def __init__(
        self,
        motors: Sequence[DcChannelMotor],
        observer: Callable[[int, tuple[int, int], tuple[int, ...]], None] | None = None,
    ) -> None:
        """``motors``: left (the firmware's first) and right.

        ``observer(microseconds, pwm, watched)`` is called at every exchange with the simulated
        time, the PWMs and the watched firmware variables (``--watch``) of that line.
        """
        self.motors = list(motors)
        self.observer = observer
        self._last_us: int | None = None
        #: The PWMs of the last exchange (left, right), as the firmware drove them.
        self.pwm = (0, 0)
        #: Simulated time of the last exchange [us] (0 before the first).
        self.now_us = 0

    def exchange(self, line: str) -> str:
        """The answer to one ``D <us> <left PWM> <right PWM> [watched...]`` line.

        Raises:
            ValueError: a line that is not such a line.
        """
        fields = line.split()
        if len(fields) < 4 or fields[0] != "D":
            raise ValueError(f"unexpected line from the simulator: {line!r}")
        now_us, left, right = int(fields[1]), int(fields[2]), int(fields[3])
        self.now_us = now_us
        dt_s = 0.0 if self._last_us is None else (now_us - self._last_us) * 1e-6
        self._last_us = now_us
        # The PWM held over the millisecond that ends now was the one read at its start.
        for motor in self.motors:
            motor.advance(dt_s)
        self.pwm = (left, right)
        for motor, pwm in zip(self.motors, self.pwm, strict=True):
            motor.drive(max(-PWM_MAX, min(PWM_MAX, pwm)), 0, True)
        if self.observer is not None:
            self.observer(now_us, self.pwm, tuple(int(field) for field in fields[4:]))
        left_count, right_count = (motor.encoder_counts() for motor in self.motors)
        return f"{left_count} {right_count}\n"


def run_motor_side(
    side: MotorSide,
    from_simulator: IO[str],
    to_simulator: IO[str],
    announce: Callable[[str], None],
) -> None:
    """Serve the simulator until it ends: announce its pty path (``P`` line), answer ``D`` lines."""
    for line in from_simulator:
        if line.startswith("P "):
            announce(line[2:].strip())
            continue
        to_simulator.write(side.exchange(line))
        to_simulator.flush()


def simulator_command(
    build_dir: Path | None, link: Path | str | None, fast: bool, extra: Sequence[str] = ()
) -> list[str]:
    """The simulator's command line in lockstep mode.

    Raises:
        FileNotFoundError: the firmware or the simulator is not built (``make firmware``).
    """
    artifacts = built_artifacts(build_dir)
    if artifacts is None:
        folder = build_dir or default_build_dir()
        missing = f"no {ELF_NAME} and {SIMULATOR_NAME} in {folder}: run make firmware"
        raise FileNotFoundError(missing)
    elf, simulator = artifacts
    command = [str(simulator), str(elf), "--exchange", *extra]
    command += ["--link", str(link)] if link else []
    command += ["--fast"] if fast else []
    return command


class SimulatedBoard:
    """The firmware in simavr, its motors served by a thread of this process.

    The simulated clock is the firmware's own (``millis()``, its PID frames, its auto-stop):
    :meth:`simulated_at` maps a host ``time.monotonic()`` to it, so that a caller measures the
    firmware's behaviour in the firmware's time whether or not the host kept up with wall time.
    """

    #: How much of the host-to-simulated clock mapping is kept [exchanges, one per ms].
    HISTORY = 20000

    def __init__(
        self,
        motors: Sequence[DcChannelMotor],
        link: Path,
        build_dir: Path | None = None,
        extra: Sequence[str] = (),
        fast: bool = False,
        observer: Callable[[int, tuple[int, int], tuple[int, ...]], None] | None = None,
        stderr: IO[bytes] | None = None,
        cable: bool = False,
    ) -> None:
        """Start the simulator (FileNotFoundError if not built).

        :attr:`ready` is set once the pty is there and the firmware has started. With ``cable``
        the host's port at ``link`` is a :class:`~fishtail_boards.usb_cable.UsbCable` that
        :meth:`unplug` and :meth:`replug` pull and plug back; without, the link points at the
        simulator's UART pty itself.
        """
        self.link = link
        self._with_cable = cable
        self.cable: UsbCable | None = None
        self.side = MotorSide(motors, self._observe)
        self._observer = observer
        self._lock = threading.Lock()
        self._host_s: list[float] = []
        self._simulated_s: list[float] = []
        self.path: str | None = None
        self.ready = threading.Event()
        self.process = subprocess.Popen(
            simulator_command(build_dir, None if cable else link, fast, extra),
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=stderr, text=True, bufsize=1,
            start_new_session=True,
        )  # fmt: skip
        self._thread = threading.Thread(target=self._serve, name="avr-motors", daemon=True)
        self._thread.start()

    def _announce(self, path: str) -> None:
        if self._with_cable:
            self.cable = UsbCable(path, self.link)
        self.path = path

    def _observe(self, now_us: int, pwm: tuple[int, int], watched: tuple[int, ...]) -> None:
        # The simulator announces its pty once the firmware has started and --poke is applied.
        if self.path is not None:
            self.ready.set()
        with self._lock:
            self._host_s.append(time.monotonic())
            self._simulated_s.append(now_us * 1e-6)
            if len(self._host_s) > 2 * self.HISTORY:
                del self._host_s[: self.HISTORY], self._simulated_s[: self.HISTORY]
        if self._observer is not None:
            self._observer(now_us, pwm, watched)

    def _serve(self) -> None:
        assert self.process.stdout is not None and self.process.stdin is not None
        # Ends when the simulator does (stop()) or says something this side cannot answer.
        with contextlib.suppress(BrokenPipeError, ValueError, OSError):
            run_motor_side(self.side, self.process.stdout, self.process.stdin, self._announce)

    def simulated_s(self) -> float:
        """The simulated time of the newest exchange [s]."""
        return self.side.now_us * 1e-6

    def simulated_at(self, host_s: float) -> float:
        """The simulated time at host time ``host_s`` (the newest exchange at or before it)."""
        with self._lock:
            index = bisect.bisect_right(self._host_s, host_s)
            return self._simulated_s[max(index - 1, 0)] if self._simulated_s else 0.0

    def reset(self) -> None:
        """Reset the board (DTR)."""
        self.process.send_signal(signal.SIGUSR1)

    def unplug(self) -> None:
        """Pull the USB cable (``cable`` only): the host's port vanishes, the board runs on."""
        assert self.cable is not None, "started without cable=True"
        self.cable.unplug()

    def replug(self) -> None:
        """Plug it back in (``cable`` only): a new port at the link; USB power resets the board."""
        assert self.cable is not None, "started without cable=True"
        self.reset()
        self.cable.replug()

    def stop(self) -> int:
        """End the simulator; its exit status."""
        if self.cable is not None:
            self.cable.close()
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
        status = self.process.wait(10.0)
        self._thread.join(5.0)
        return status


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="fishtail-avr-board",
        description="The ROSArduinoBridge firmware in simavr on a pty (prints the device path), "
        "its motors the DC gear motor model. Build it first: make firmware.",
        epilog="Signals: SIGUSR1 resets the board (DTR); SIGINT, SIGTERM and SIGHUP end it.",
    )
    add = parser.add_argument
    add("--link", help="keep a symlink to the pty at this path (removed on exit)")
    add("--build-dir", type=Path, help="where make firmware put its output (build/firmware)")
    add("--counts-per-rev", type=int, default=64, help="encoder counts per motor turn")
    add(
        "--gear-ratio",
        type=float,
        help="motor turns per carrier turn (default: 30, or --motor's default ratio)",
    )
    add(
        "--motor",
        type=Path,
        help="the DC gear motor of this motor file (config/motors/; "
        "default: the suite's, the Pololu 37D 12 V)",
    )
    add(
        "--load",
        choices=SURROUNDINGS,
        default=NO_LOAD,
        help="what each motor turns: the tail of --config in air, in water held at rest, or "
        "towed at its swimming speed (the fish of --fish)",
    )
    add("--config", type=Path, help="--load's tail and link masses (config/oscillatory.yaml)")
    add("--fish", type=Path, help="--load's fish (config/fish.yaml)")
    add("--encoder-offset", type=int, default=0, help="initial encoder counts (test the wrap)")
    add("--fast", action="store_true", help="do not pace simulated time to wall time")
    return parser  # fmt: skip


def _motors(args: argparse.Namespace) -> list[DcChannelMotor]:
    """The two channels' motors the arguments describe (ValueError)."""
    if args.motor is not None:
        parameters = read_motor_file(args.motor).parameters(args.gear_ratio)
        scale = Scale(args.counts_per_rev, parameters.gear_ratio)
    else:
        scale = Scale(args.counts_per_rev, 30.0 if args.gear_ratio is None else args.gear_ratio)
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
    try:
        side = MotorSide(_motors(args))
        extra: list[str] = []
        if args.encoder_offset:
            extra = encoder_offset_pokes(firmware_variables(args.build_dir), args.encoder_offset)
        command = simulator_command(args.build_dir, args.link, args.fast, extra)
    except (ValueError, OSError, KeyError) as error:
        print(f"fishtail-avr-board: error: {error}", file=sys.stderr)
        return 2
    process = subprocess.Popen(
        command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, bufsize=1
    )
    assert process.stdin is not None and process.stdout is not None
    # The simulator ends on its own signal; forward ours, and finish when its output ends.
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, lambda *_: process.send_signal(signal.SIGTERM))
    signal.signal(signal.SIGUSR1, lambda *_: process.send_signal(signal.SIGUSR1))
    try:
        run_motor_side(side, process.stdout, process.stdin, lambda path: print(path, flush=True))
    except BrokenPipeError:
        process.terminate()
    except ValueError as error:
        print(f"fishtail-avr-board: error: {error}", file=sys.stderr)
        process.terminate()
    return process.wait()


if __name__ == "__main__":
    sys.exit(main())
