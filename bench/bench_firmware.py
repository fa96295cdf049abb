"""The real firmware in simavr: the simulator's CPU, the command round trip beside the fake board.

Prints figures only. ``fishtail-avr-board`` (ROSArduinoBridge built for a Nano by ``make
firmware``, in simavr at 16 MHz paced to wall time, its motors the DC gear motor) is measured

* while the serial backend polls it at the driver's default rate (100 Hz) with the motor turning,
  and while nobody talks to it: the CPU of the simulator (C, libsimavr) and of its motor side
  (Python), and how far simulated time fell behind wall time;
* for the command round trip of ``m`` and ``e`` at 57600 baud, the method of bench_serial.py,
  beside ``fishtail-fake-board`` unpaced (a pty at memory speed) and ``--pace-baud`` (the line
  time added). The firmware's UART runs at 57600 baud in simulated time, so its figures include
  the line time, the firmware's own parsing and a millisecond of lockstep at most.

Then the carrier speed profile at the motor's full beat rate (docs/firmware.md), all in simulated
time (``fishtail_testkit.board_profile``, per simulated millisecond, so the figures do not depend
on the machine's load):

* the physics first (``fishtail_plant.motor.profile_reach``): the duty a profile asks of the
  default motor (Pololu 37D 30:1) turning the tail, so the deepest depth within PWM 255 at each
  beat and the fastest beat for depths 0.25, 0.45 and 0.5 (every phase, and the best one); and
  the firmware with ``o 255 255`` in water: the carrier's speed over a revolution at full duty;
* achieved depth (of the commanded), phase lag (rad, ms) and mean speed against beat frequency
  (0.5-4 Hz) and depth (0.25, 0.5), in air and in water: the host following the law through the
  stock firmware (30 Hz), the project's firmware with the law alone (version 1's loop, 30 Hz),
  and with its profile controller (``k``: lead and feed-forward) at 30 Hz; at 100 and 200 Hz
  depth 0.5 in water; and the AVR cycles of a PID frame of each, flash and RAM;
* the same firmware with a motor that can follow depth 0.5 at 3.75 Hz in water (STRONG_MOTOR,
  none of config/motors/), at 30, 100 and 200 Hz: what the firmware itself can do.

Skipped (one line, exit 0) where the AVR toolchain is missing. Run with ``make bench`` (or
``python bench/bench_firmware.py``; ``--profile-only`` for the second part alone, about 3 min of
simulated time, 5-10 min on a loaded machine; ``--no-profile`` for the first).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import re
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from bench_serial import percentile, round_trips, start_board
from fishtail_boards.avr_board import SET_POINT_OUTPUT, built_artifacts, firmware_variables
from fishtail_driver.protocol import encode_motor_speeds, encode_read_encoders
from fishtail_driver.serial_backend import SerialBackend
from fishtail_driver.serial_config import SerialConfig
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
from fishtail_plant.motor.dc_motor import DcMotorParameters
from fishtail_plant.motor.profile_reach import deepest_depth, fastest_mean
from fishtail_plant.values import tail_load_from_files
from fishtail_testkit.board_profile import (
    BoardRun,
    run_from_host,
    run_on_board,
    run_pwm,
    tuning_for,
)
from measure import ROOT, cpu_seconds

BAUD = 57600
POLL_RATE_HZ = 100.0  # the driver's serial_poll_rate_hz default
MEASURE_S = 6.0
#: 40 ticks per 33 ms frame of the Pololu 37D 30:1 with its 64-count encoder [rad/s].
SPEED_RAD_S = 40 * 2 * math.pi / (64 * 30) / 0.033


def build() -> str | None:
    """Build the firmware and the simulator; why not, or None."""
    done = subprocess.run([str(ROOT / "firmware" / "build.sh")], capture_output=True, text=True)
    if done.returncode != 0:
        return (done.stderr.strip().splitlines() or [f"exit {done.returncode}"])[0]
    return None if built_artifacts(ROOT / "build" / "firmware") else "nothing built"


def start_firmware(link: Path, stderr_path: Path) -> subprocess.Popen:
    """``fishtail-avr-board`` at ``link``, once its pty is there."""
    with open(stderr_path, "wb") as stderr:
        board = subprocess.Popen(
            [sys.executable, "-m", "fishtail_boards.avr_board", "--link", str(link),
             "--build-dir", str(ROOT / "build" / "firmware")],
            stdout=subprocess.PIPE, stderr=stderr, text=True, start_new_session=True,
        )  # fmt: skip
    assert board.stdout is not None
    board.stdout.readline()  # the pty path: the board is ready
    return board


def simulator_pid(board: subprocess.Popen) -> int:
    """The simulator's process: the motor side's child."""
    children = Path(f"/proc/{board.pid}/task/{board.pid}/children").read_text().split()
    return int(children[0])


def stop_firmware(board: subprocess.Popen, stderr_path: Path) -> str:
    """SIGTERM; the simulator's last line (simulated and wall time, how far behind)."""
    board.send_signal(signal.SIGTERM)
    board.wait(10)
    lines = re.findall(r"avr_board: .*behind", stderr_path.read_text(errors="replace"))
    return lines[-1] if lines else "(no report)"


def cpu_while(board: subprocess.Popen, link: Path | None) -> tuple[float, float, float]:
    """CPU fractions of the simulator and the motor side over MEASURE_S, and the poll rate.

    With ``link`` the serial backend polls the board at POLL_RATE_HZ and turns the motor.
    """
    backend = None
    if link is not None:
        config = SerialConfig(port=str(link), baud=BAUD, poll_rate_hz=POLL_RATE_HZ,
                              counts_per_revolution=64, gear_ratio=30.0)  # fmt: skip
        backend = SerialBackend(config)
        backend.start()
        deadline = time.monotonic() + 10.0
        while backend.status()[0] != 0:
            if time.monotonic() > deadline:
                raise RuntimeError(f"backend did not connect: {backend.status()[1]}")
            time.sleep(0.01)
        backend.set_speed(SPEED_RAD_S)
        time.sleep(1.0)
    try:
        simulator = simulator_pid(board)
        polls = int(backend.status()[2].get("polls", "0")) if backend else 0
        start, sim0, side0 = time.monotonic(), cpu_seconds(simulator), cpu_seconds(board.pid)
        time.sleep(MEASURE_S)
        elapsed = time.monotonic() - start
        sim_cpu = (cpu_seconds(simulator) - sim0) / elapsed
        side_cpu = (cpu_seconds(board.pid) - side0) / elapsed
        rate = (int(backend.status()[2].get("polls", "0")) - polls) / elapsed if backend else 0.0
    finally:
        if backend is not None:
            backend.close()
    return sim_cpu, side_cpu, rate


def rtt_row(name: str, link: Path) -> str:
    """``m`` and ``e`` round trips (median, p99) against the board at ``link``."""
    m_times, _ = round_trips(link, BAUD, encode_motor_speeds(43, 0))
    e_times, _ = round_trips(link, BAUD, encode_read_encoders())
    m_ms = statistics.median(m_times) * 1e3, percentile(m_times, 0.99) * 1e3
    e_ms = statistics.median(e_times) * 1e3, percentile(e_times, 0.99) * 1e3
    return (f"{name:>26} | {m_ms[0]:>9.3f} {m_ms[1]:>7.3f} | {e_ms[0]:>9.3f} {e_ms[1]:>7.3f} "
            f"| {1 / statistics.median(e_times):>8.0f}")  # fmt: skip


PROFILE_BEATS_HZ = (0.5, 1.0, 2.0, 3.0, 3.75, 4.0)
PROFILE_DEPTHS = (0.25, 0.5)
PROFILE_LOADS = ("air", "water_swimming")
#: The profile's fastest point: count 500 of 1920, as in the tests.
PHASE_RAD = 2.0 * math.pi * 500 / 1920
#: The profile controller's lead [ms] at each PID rate (about the loop's delay: half a frame and
#: the motor's electrical lag; measured at 1 Hz in water to leave a lag within a few ms).
LEAD_MS = {30: 8, 100: 8, 200: 8}
#: The gains (u Kp:Kd:Ki:Ko) the profile controller runs with at each rate: Kp the integrating
#: action, Kd the proportional one (per frame; doProfilePID); tried at 1 Hz, depth 0.5, in water
#: (docs/firmware.md). The law alone and the host keep the stock 20:12:0:50.
GAINS = {30: "40:24:0:50", 100: "60:80:0:50", 200: "80:160:0:50"}
SETTLE_S = 1.0


def physics() -> None:
    """What the default motor can reach at all: duty within PWM 255 over a revolution."""
    motor = DcMotorParameters()
    phases = [2.0 * math.pi * i / 12 for i in range(12)]
    print("\nThe default motor (Pololu 37D 12 V 30:1, DcMotorParameters()) following the law "
          "exactly: the duty it asks over a revolution "
          "(fishtail_plant.motor.profile_reach)")  # fmt: skip
    print(f"no-load carrier speed {motor.no_load_speed_rad_s:.2f} rad/s; depth 0.5 asks a peak "
          f"of {math.sqrt(3):.3f} x the mean")  # fmt: skip
    for load in PROFILE_LOADS:
        tail = tail_load_from_files(load)
        cells = []
        for beat in PROFILE_BEATS_HZ:
            omega = 2.0 * math.pi * beat
            depths = [deepest_depth(motor, omega, phase, tail.torque, tail.inertia, steps=45)
                      for phase in phases]  # fmt: skip
            at_phase = deepest_depth(motor, omega, PHASE_RAD, tail.torque, tail.inertia, steps=45)
            worst = None if None in depths else min(d for d in depths if d is not None)
            text = "none" if at_phase is None else f"{at_phase:.2f}"
            text += "/" + ("none" if worst is None else f"{worst:.2f}")
            cells.append(f"{beat:g} Hz {text}")
        print(f"  {load}: deepest depth within PWM 255 (at phase 500 / at every phase): "
              + ", ".join(cells))  # fmt: skip
        for depth in (0.0, 0.25, 0.45, 0.5):
            fastest = [fastest_mean(motor, depth, phase, tail.torque, tail.inertia)
                       for phase in phases]  # fmt: skip
            print(f"  {load}: depth {depth:.2f} within PWM 255 up to "
                  f"{min(fastest) / (2 * math.pi):.2f} Hz at every phase, "
                  f"{max(fastest) / (2 * math.pi):.2f} Hz at the best")  # fmt: skip


def full_duty(folder: Path) -> None:
    """The firmware's ``o 255 255`` in water: the carrier's speed over its revolutions."""
    profile = CarrierSpeedProfile(2.0 * math.pi * 3.75, 0.5, PHASE_RAD)
    done = run_pwm(ROOT / "build" / "firmware" / "fishtail", folder, 255, 4.0, "water_swimming")
    kept = done.kept(2.0)
    speeds = [record[3] for record in kept]
    turned = kept[-1][2] - kept[0][2]
    mean = turned / ((kept[-1][0] - kept[0][0]) * 1e-6)
    print(f"\nsimavr, o 255 255, in water (the last 2 s of 4): mean carrier speed {mean:.2f} "
          f"rad/s ({mean / (2 * math.pi):.2f} Hz), from {min(speeds):.2f} to "
          f"{max(speeds):.2f} rad/s (peak/mean {max(speeds) / mean:.2f}); 3.75 Hz asks a "
          f"mean of {2 * math.pi * 3.75:.2f} rad/s, depth 0.5 a peak of "
          f"{profile.peak_speed_rad_s:.2f}")  # fmt: skip


#: A motor that can follow depth 0.5 at 3.75 Hz in water (none in config/motors/ can): 24 V, 20 N m
#: stall and 80 rad/s at no load at the carrier behind 30:1, a 400 W class motor (the 37D 30:1
#: gives 1.37 N m and 34.6 rad/s at 12 V, 12 W at most), its rotor 2e-5 kg m².
STRONG_MOTOR = DcMotorParameters.from_stall_and_no_load(
    supply_voltage_v=24.0, stall_torque_n_m=20.0, no_load_speed_rad_s=80.0, gear_ratio=30.0,
    gearbox_efficiency=0.76, rotor_inertia_kg_m2=2e-5,
)  # fmt: skip


@dataclasses.dataclass
class ProfileSource:
    """One way to follow the profile: a label, the PID rate, on the board or from the host."""

    label: str
    rate_hz: int
    tuned: bool
    host: bool = False
    motor: DcMotorParameters | None = None


def profile_row(source: ProfileSource, beat: float, depth: float, load: str, folder: Path) -> str:
    """One table row: achieved depth and its ratio, lag, mean ratio, saturation, frame cycles."""
    profile = CarrierSpeedProfile(2.0 * math.pi * beat, depth, PHASE_RAD)
    run_s = SETTLE_S + max(3.0 / beat, 1.0)
    run: BoardRun
    if source.host:
        run = run_from_host(ROOT / "build" / "firmware", folder, profile, run_s, load)
    else:
        build_dir = ROOT / "build" / "firmware" / "fishtail"
        lead = LEAD_MS[source.rate_hz]
        tuning = tuning_for(load, lead, source.motor) if source.tuned else None
        output = firmware_variables(build_dir)["leftPID"][0] + SET_POINT_OUTPUT
        gains = GAINS[source.rate_hz] if source.tuned else None
        run = run_on_board(build_dir, folder, profile, source.rate_hz, run_s, load, tuning,
                           gains, source.motor, watch=[output], time_frames=True)  # fmt: skip
    result = run.following(profile, SETTLE_S)
    lag_ms = 1e3 * result.phase_lag_rad / profile.mean_speed_rad_s
    cycles = ""
    if not source.host:
        # The last watched value is updatePID's cycles, refreshed at each frame.
        values = sorted({record[1][-1] for record in run.kept(SETTLE_S)})
        cycles = f"{values[0]}-{values[-1]}" if values else ""
    return (f"| {source.label:<16} | {beat:>4g} | {depth:.2f} | {load[:5]:<5} "
            f"| {result.depth:.3f} | {result.depth_ratio:.2f} | {result.phase_lag_rad:+.2f} "
            f"| {lag_ms:+5.0f} | {result.mean_speed_rad_s / profile.mean_speed_rad_s:.2f} "
            f"| {run.saturated(SETTLE_S):.2f} | {cycles} |")  # fmt: skip


def profiles(folder: Path) -> None:
    """The profile table: every source, beat, depth and load."""
    physics()
    full_duty(folder / "full")
    for name, path in (("stock", ROOT / "build" / "firmware"),
                       ("project", ROOT / "build" / "firmware" / "fishtail")):  # fmt: skip
        done = subprocess.run(["avr-size", str(path / "ROSArduinoBridge.elf")],
                              capture_output=True, text=True)  # fmt: skip
        text, data, bss = (int(field) for field in done.stdout.splitlines()[-1].split()[:3])
        print(f"{name} firmware: flash {text + data} B, RAM {data + bss} B")
    print("\n| source | beat Hz | depth | load | achieved | ratio | lag rad | lag ms | mean ratio "
          "| PWM at 255 | frame cycles |")  # fmt: skip
    print("|---|---|---|---|---|---|---|---|---|---|---|", flush=True)
    host = ProfileSource("host, stock 30", 30, False, True)
    law = ProfileSource("board law, 30", 30, False)
    tuned = [ProfileSource(f"board k, {rate}", rate, True) for rate in (30, 100, 200)]
    # In water every beat and depth; the faster rates at depth 0.5; in air a few rows.
    plan = [("water_swimming", depth, beat,
             [host, law, tuned[0], *(tuned[1:] if depth == 0.5 else [])])
            for depth in PROFILE_DEPTHS for beat in PROFILE_BEATS_HZ]  # fmt: skip
    plan += [("air", 0.5, beat, [host, tuned[0]]) for beat in (1.0, 2.0, 3.75)]
    # The firmware with a motor that can (STRONG_MOTOR), at the target's beat.
    strong = [ProfileSource(f"strong k, {rate}", rate, True, motor=STRONG_MOTOR)
              for rate in (30, 100, 200)]  # fmt: skip
    plan += [("water_swimming", 0.5, 3.75, strong)]
    index = 0
    for load, depth, beat, sources in plan:
        for source in sources:
            index += 1
            run_folder = folder / f"run{index}"
            run_folder.mkdir()
            print(profile_row(source, beat, depth, load, run_folder), flush=True)
    print("achieved: the first harmonic's depth; lag: of the fastest point (+: later); PWM at 255: "
          "share of the milliseconds the left PWM was at +-255; frame cycles: updatePID's, "
          "interrupts included.")  # fmt: skip


def main() -> int:
    """Measure and print."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--profile-only", action="store_true", help="the profile part alone")
    parser.add_argument("--no-profile", action="store_true", help="without the profile part")
    args = parser.parse_args()
    print(__doc__.split("\n\n")[0])
    reason = build()
    if reason is not None:
        print(f"skipped: firmware in simavr: {reason}")
        return 0
    if not args.no_profile:
        with tempfile.TemporaryDirectory(prefix="fishtail-bench-") as directory:
            (Path(directory) / "full").mkdir()
            profiles(Path(directory))
    if args.profile_only:
        return 0
    print(f"{os.cpu_count()} CPUs, other work may be running; CPU in % of one core\n")
    with tempfile.TemporaryDirectory(prefix="fishtail-bench-") as directory:
        folder = Path(directory)
        for label, polled in (("idle (no host)", False), (f"polled {POLL_RATE_HZ:g} Hz", True)):
            link, stderr = folder / f"tty{int(polled)}", folder / f"board{int(polled)}.stderr"
            board = start_firmware(link, stderr)
            try:
                sim_cpu, side_cpu, rate = cpu_while(board, link if polled else None)
            finally:
                report = stop_firmware(board, stderr)
            achieved = f", {rate:.1f} polls/s achieved" if polled else ""
            print(f"{label:>16}: simulator {sim_cpu * 100:5.1f} %, motor side "
                  f"{side_cpu * 100:5.1f} %{achieved}; {report}")  # fmt: skip

        header = (f"{'board at 57600 baud':>26} | {'m rtt med':>9} {'p99':>7} | "
                  f"{'e rtt med':>9} {'p99':>7} | {'e/s max':>8}")  # fmt: skip
        print(f"\n{header}\n{'-' * len(header)}")
        for name, paced in (("fake board, pty", False), ("fake board, --pace-baud", True)):
            link = folder / f"fake{int(paced)}"
            fake = start_board(link, BAUD, paced)
            try:
                print(rtt_row(name, link))
            finally:
                fake.terminate()
                fake.wait(5)
        link, stderr = folder / "ttyrtt", folder / "rtt.stderr"
        board = start_firmware(link, stderr)
        try:
            print(rtt_row("firmware in simavr", link))
        finally:
            report = stop_firmware(board, stderr)
        print(f"{'':>26}   ({report})")
    print("\nround trips in ms; e/s max: 1 / median e round trip.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
