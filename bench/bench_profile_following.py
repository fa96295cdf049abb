"""How well the carrier follows a speed profile: achieved depth and phase lag against beat rate.

The driver commands the speed of a once-per-revolution profile at every carrier angle it reads
(docs/serial.md, "Speed profiles"); the motor lags, so the modulation comes out shallower and
later than commanded. For each source, beat frequency f (mean speed Omega = 2 pi f) and commanded
depth, this runs the profile (fastest at phi_0 = 1 rad) for SETTLE_REVOLUTIONS, then measures
the whole revolutions after them (at least MEASURE_REVOLUTIONS) with
fishtail_testkit.modulation_fit: per revolution a fit of speed ~ a0 + a1 cos phi + b1 sin phi over
the angle, the achieved depth and phase lag averaged over the revolutions, their spreads (largest
minus smallest), the lag as a time at the mean speed, the achieved mean speed over the commanded
one, and the revolutions fitted and left out (a gap in the samples). The sources:

* ``first_order``: the sim's default speed lag (0.15 s), in simulated time at 200 samples/s;
* ``dc``: the sim's DC motor (Pololu 37D 30:1, 64-count encoder) under the firmware's exact
  integer PID at 30.3 Hz, unloaded, in simulated time at 200 samples/s;
* ``dc water``: the same turning the tail of config/oscillatory.yaml in water, the fish towed at
  its swimming speed (``motor_load: water_swimming``);
* ``serial``: ``fishtail-fake-board --motor dc --load water_swimming --pace-baud`` as its own
  process (the same motor and load behind the emulated firmware, bytes paced at 57600 baud), and
  in this process the serial backend polled at 100 Hz with a loop that does what the node does at
  each of its 200 Hz publish ticks (read the newest sample, command the profile's speed at its
  angle); real time, speeds from the encoder angles (central differences).

max_speed_rad_s is 45 here (above every peak of the table and the motor's 36.7 rad/s at no load),
so that the motor's own limits show; rows marked ``*`` peak above the driver's default
max_speed_rad_s of 20, which the node would refuse. Prints a table (the one in docs/serial.md)
and writes bench/out/bench_profile_following.json. About 110 s, most of it the serial rows in
real time: ``python bench/bench_profile_following.py`` (``--no-serial``: the simulations only,
5 s).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from fishtail_common.parameters import ParameterValue
from fishtail_driver.parameters import DC_MOTOR_ENCODER, DRIVER_PARAMETERS, make_sim_motor
from fishtail_driver.profile_command import CarrierCommand
from fishtail_driver.serial_backend import SerialBackend
from fishtail_driver.serial_config import SerialConfig
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
from fishtail_plant.values import tail_load_from_files
from fishtail_testkit.modulation_fit import (
    FollowingResult,
    Recording,
    follow_simulated,
    measure_following,
    speeds_from_angles,
)
from measure import OUT

BEATS_HZ = (0.5, 1.0, 2.0, 3.0, 4.0)
DEPTHS = (0.1, 0.25, 0.5)
PHASE_RAD = 1.0
SETTLE_REVOLUTIONS = 2
MEASURE_REVOLUTIONS = 4
SAMPLE_RATE_HZ = 200.0  # the node's default publish rate
POLL_RATE_HZ = 100.0  # the serial backend's default
MAX_SPEED_RAD_S = 45.0
DEFAULT_MAX_SPEED_RAD_S = 20.0
#: A label and what runs a profile and records the carrier.
Source = tuple[str, Callable[[CarrierSpeedProfile], Recording]]


def driver_values(**changes: ParameterValue) -> dict[str, ParameterValue]:
    """The driver's parameters at their defaults, the bench's speed limit, and ``changes``."""
    values = {spec.name: spec.default for spec in DRIVER_PARAMETERS}
    return {**values, "max_speed_rad_s": MAX_SPEED_RAD_S, **changes}


def simulated(
    label: str, changes: dict[str, ParameterValue] | None = None, water: bool = False
) -> Source:
    """A source: the simulated backend's motor of ``changes``, run in simulated time."""
    load = tail_load_from_files("water_swimming") if water else None

    def run(profile: CarrierSpeedProfile) -> Recording:
        values = driver_values(**(changes or {}))
        if load is None:
            motor = make_sim_motor(values)
        else:
            motor = make_sim_motor(values, load.torque, load.inertia)
        revolutions = SETTLE_REVOLUTIONS + MEASURE_REVOLUTIONS + 1
        duration_s = revolutions * 2.0 * math.pi / profile.mean_speed_rad_s
        # A slower motor turns fewer revolutions in that time: give it a margin.
        return follow_simulated(motor, profile, SAMPLE_RATE_HZ, 1.5 * duration_s)

    return label, run


class SerialSource:
    """The fake board as a process, the serial backend and the node's follow loop, in real time."""

    def __init__(self, directory: Path) -> None:
        """Start the board (``--motor dc --load water_swimming``) and connect to it."""
        link = directory / "board"
        argv = [sys.executable, "-m", "fishtail_boards.fake_board", "--link", str(link),
                "--motor", "dc", "--load", "water_swimming", "--pace-baud",
                "--counts-per-rev", str(DC_MOTOR_ENCODER["encoder_counts_per_revolution"]),
                "--gear-ratio", str(DC_MOTOR_ENCODER["gear_ratio"]),
                "--max-speed", str(MAX_SPEED_RAD_S)]  # fmt: skip
        self.board = subprocess.Popen(argv, stdout=subprocess.PIPE, text=True)
        assert self.board.stdout is not None
        self.board.stdout.readline()  # the pty's path: the board is up
        self.backend = SerialBackend(
            SerialConfig(
                port=str(link),
                counts_per_revolution=int(DC_MOTOR_ENCODER["encoder_counts_per_revolution"]),
                gear_ratio=float(DC_MOTOR_ENCODER["gear_ratio"]),
                poll_rate_hz=POLL_RATE_HZ,
                max_speed_rad_s=MAX_SPEED_RAD_S,
            )
        )
        self.backend.start()
        deadline = time.monotonic() + 10.0
        while self.backend.status()[0] != 0:
            if time.monotonic() > deadline:
                raise RuntimeError(f"the fake board did not answer: {self.backend.status()[1]}")
            time.sleep(0.05)

    def run(self, profile: CarrierSpeedProfile) -> Recording:
        """Follow ``profile`` as the node does until enough revolutions, then stop the motor."""
        command = CarrierCommand(MAX_SPEED_RAD_S)
        command.set_profile(profile.mean_speed_rad_s, profile.depth, profile.phase_rad)
        times: list[float] = []
        angles: list[float] = []
        period_s = 1.0 / SAMPLE_RATE_HZ
        wanted_rad = (SETTLE_REVOLUTIONS + MEASURE_REVOLUTIONS + 1) * 2.0 * math.pi
        self.backend.set_speed(command.commanded_speed_rad_s)
        tick = time.monotonic()
        while not angles or angles[-1] - angles[0] < wanted_rad:
            tick += period_s
            time.sleep(max(tick - time.monotonic(), 0.0))
            sample = self.backend.read()
            if sample is None:
                continue
            times.append(sample.monotonic_s)
            angles.append(sample.angle_rad)
            speed = command.follow(sample.angle_rad)
            if speed is not None:
                self.backend.set_speed(speed)
        self.backend.stop()
        time.sleep(1.0)  # the carrier coasts to rest before the next profile
        return Recording(np.array(times), np.array(angles), speeds_from_angles(times, angles))

    def close(self) -> None:
        """Stop the motor, close the port, end the board."""
        self.backend.close()
        self.board.terminate()
        self.board.wait(5.0)


def row(label: str, profile: CarrierSpeedProfile, result: FollowingResult) -> dict[str, Any]:
    """One line of the table, as a dict."""
    return {
        "source": label,
        "beat_hz": profile.mean_speed_rad_s / (2.0 * math.pi),
        "depth": profile.depth,
        "peak_rad_s": profile.peak_speed_rad_s,
        "achieved_depth": result.depth,
        "depth_ratio": result.depth_ratio,
        "phase_lag_rad": result.phase_lag_rad,
        "lag_ms": 1e3 * result.phase_lag_rad / profile.mean_speed_rad_s,
        "mean_ratio": result.mean_speed_rad_s / profile.mean_speed_rad_s,
        "depth_spread": result.depth_spread,
        "phase_lag_spread_rad": result.phase_lag_spread_rad,
        "revolutions": len(result.revolutions),
        "left_out": result.left_out,
    }


def print_row(line: dict[str, Any]) -> None:
    """A markdown table row; the spreads are largest minus smallest over the revolutions."""
    mark = "*" if float(line["peak_rad_s"]) > DEFAULT_MAX_SPEED_RAD_S else " "
    print(
        f"| {line['source']:<11} | {line['beat_hz']:>3.1f} | {line['depth']:.2f}{mark} "
        f"| {line['achieved_depth']:.3f} ({line['depth_spread']:.3f}) "
        f"| {line['depth_ratio']:.2f} | {line['phase_lag_rad']:+.2f} "
        f"({line['phase_lag_spread_rad']:.2f}) | {line['lag_ms']:>3.0f} "
        f"| {line['mean_ratio']:.2f} | {line['revolutions']} | {line['left_out']} |",
        flush=True,
    )


def main() -> int:
    """Run every source at every beat and depth; print the table, write the JSON."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-serial", action="store_true", help="the simulations only")
    args = parser.parse_args()
    sources: list[Source] = [
        simulated("first_order"),
        simulated("dc", {"motor_model": "dc", **DC_MOTOR_ENCODER}),
        simulated("dc water", {"motor_model": "dc", **DC_MOTOR_ENCODER}, water=True),
    ]
    print(
        "| source | beat Hz | depth | achieved (spread) | ratio | lag rad (spread) | lag ms "
        "| mean ratio | revs | left out |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    lines = []
    with tempfile.TemporaryDirectory(prefix="fishtail-profile-") as directory:
        serial = None if args.no_serial else SerialSource(Path(directory))
        if serial is not None:
            sources.append(("serial", serial.run))
        try:
            for label, run in sources:
                for beat_hz in BEATS_HZ:
                    for depth in DEPTHS:
                        profile = CarrierSpeedProfile(2.0 * math.pi * beat_hz, depth, PHASE_RAD)
                        recording = run(profile)
                        result = measure_following(
                            recording.times_s,
                            recording.angles_rad,
                            recording.speeds_rad_s,
                            profile,
                            SETTLE_REVOLUTIONS,
                        )
                        lines.append(row(label, profile, result))
                        print_row(lines[-1])
        finally:
            if serial is not None:
                serial.close()
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "bench_profile_following.json").write_text(json.dumps(lines, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
