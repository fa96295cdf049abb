"""The project's firmware (firmware/fishtail.patch, docs/firmware.md) in simavr.

Its new commands against the stock firmware's answers, and the carrier speed profile it follows
on the board: per PID frame the target it set is the law at the count it read, and the DC motor
turning the tail in water follows it. Nothing is timed on the host's clock: the firmware's
variables, its frames' AVR cycles and the motor's angle are read per simulated millisecond.
"""

from __future__ import annotations

import dataclasses
import math
import os
import struct
import threading
import tty
from pathlib import Path

import pytest

from fishtail_boards.avr_board import (
    SET_POINT_ENCODER,
    SET_POINT_OUTPUT,
    SimulatedBoard,
    firmware_functions,
    firmware_variables,
)
from fishtail_boards.board_motors import DcChannelMotor
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
from fishtail_plant.motor.board_units import Scale
from fishtail_plant.motor.dc_motor import DcMotorParameters
from fishtail_plant.values import tail_load_from_files
from fishtail_testkit.board_profile import run_on_board, tuning_for
from fishtail_testkit.modulation_fit import FollowingResult, measure_following

#: The Pololu 37D 30:1 with its 64-count encoder: 1920 counts a carrier revolution.
SCALE = Scale(64, 30.0)
REVOLUTION = 64 * 30
DC_PARAMETERS = dataclasses.replace(DcMotorParameters(), gear_ratio=SCALE.gear_ratio)
CPU_HZ = 16_000_000
#: The profile's fastest point [encoder counts of the carrier].
PHASE_COUNTS = 500
PHASE_RAD = 2.0 * math.pi * PHASE_COUNTS / REVOLUTION
#: Longer than a command takes from the motor side's write to its run (20 bytes at 57600 baud).
COMMAND_US = 10_000
#: updatePID, as avr-nm names it (C++).
UPDATE_PID = "_Z9updatePIDv"


def board_in_water(build: Path, tmp_path: Path, **kwargs) -> SimulatedBoard:
    """The firmware of ``build`` with two DC motors, each turning the tail in water (towed)."""
    load = tail_load_from_files("water_swimming")
    motors = [DcChannelMotor(DC_PARAMETERS, SCALE, load.torque, load.inertia) for _ in range(2)]
    with open(tmp_path / "sim.stderr", "wb") as stderr:
        board = SimulatedBoard(motors, tmp_path / "board", build, stderr=stderr, **kwargs)
    assert board.ready.wait(30.0), "the simulator did not start"
    return board


def test_the_project_firmware_answers_the_capability_query(fishtail_build, raw_port, tmp_path):
    """``v`` names it and its PID rate; ``i`` sets the rate; bad arguments get ``ERR``."""
    board = board_in_water(fishtail_build, tmp_path)
    try:
        port = raw_port(board.link)
        assert port.ask("v") == "fishtail 1 pid_hz=30 pid_ms=33 profile=1"
        assert port.ask("b") == "57600"
        assert port.ask("e") == "0 0"
        assert port.ask("i 100") == "OK"
        assert port.ask("v") == "fishtail 1 pid_hz=100 pid_ms=10 profile=1"
        refused = ["i 0", "i 501", "f 64:500:0", "f 64:901:0:1920", "f -1:0:0:1920",
                   "f 64:0:0:0", "f 32768:0:0:1920", "f 64:0:0:65536"]  # fmt: skip
        assert [port.ask(command) for command in refused] == ["ERR"] * len(refused)
        assert port.ask("f 0:500:0:1920") == "OK"  # mean 0: a stop
        # Overlong arguments are cut to their buffers, no longer written past them.
        assert port.ask("f " + "7" * 40) == "ERR"
        assert port.ask("m 1 " + "9" * 40) == "OK"
        assert port.ask("b") == "57600"
        assert port.ask("q") == "Invalid Command"
    finally:
        board.stop()


def test_the_profile_controller_takes_its_settings(fishtail_build, raw_port, tmp_path):
    """``k LEAD:KV:KA:KS[:KQ]``: OK in range (KQ optional), ERR and nothing changed outside."""
    board = board_in_water(fishtail_build, tmp_path)
    try:
        port = raw_port(board.link)
        assert port.ask("k 8:5955:1889:5:690") == "OK"
        assert port.ask("k 8:5955:1889:5") == "OK"
        assert port.ask("k 0:0:0:0") == "OK"
        refused = ["k 8:5955:1889", "k 256:0:0:0", "k -1:0:0:0", "k 0:32768:0:0",
                   "k 0:0:32768:0", "k 0:0:0:256", "k 0:0:0:0:32768", "k 0:0:0:0:-1"]  # fmt: skip
        assert [port.ask(command) for command in refused] == ["ERR"] * len(refused)
        # The capability reply and f's fields are those of version 1.
        assert port.ask("v") == "fishtail 1 pid_hz=30 pid_ms=33 profile=1"
        assert port.ask("f 4055:500:500:1920") == "OK"
        assert port.ask("m 0 0") == "OK"
    finally:
        board.stop()


@pytest.mark.parametrize("command", ["v", "f 64:500:0:1920", "i 100", "k 8:5955:1889:5:690"])
def test_the_stock_firmware_answers_the_new_commands_invalid(
    firmware_build, raw_port, tmp_path, command
):
    """What tells the two firmwares apart: the stock one knows none of the new letters."""
    board = board_in_water(firmware_build, tmp_path)
    try:
        assert raw_port(board.link).ask(command) == "Invalid Command"
    finally:
        board.stop()


@dataclasses.dataclass
class ProfileRun:
    """Per simulated millisecond: time [us], the watched variables, the motor's angle and speed."""

    records: list[tuple[int, tuple[int, ...], float, float]]
    #: The simulated time [us] the profile was sent and the one the m that ended it was.
    started_us: int
    ended_us: int

    def frames(self) -> list[tuple[int, float, int, int]]:
        """Each PID frame after the profile's start: time [us], target, count, frame cycles."""
        found = []
        for before, after in zip(self.records, self.records[1:], strict=False):
            # The f takes a few milliseconds through the UART: a frame then still ran without it.
            if after[1][0] != before[1][0] and after[0] > self.started_us + COMMAND_US:
                target = struct.unpack("<f", after[1][1].to_bytes(4, "little"))[0]
                count = after[1][2] - (1 << 32) if after[1][2] >= 1 << 31 else after[1][2]
                found.append((after[0], target, count, after[1][3]))
        return found

    def following(self, profile: CarrierSpeedProfile, settle_s: float) -> FollowingResult:
        """The modulation the motor achieved, from ``settle_s`` after the start to the end."""
        kept = [record for record in self.records
                if self.started_us + settle_s * 1e6 <= record[0] < self.ended_us]  # fmt: skip
        times = [record[0] * 1e-6 for record in kept]
        return measure_following(
            times, [record[2] for record in kept], [record[3] for record in kept], profile
        )


def run_profile(
    build: Path, tmp_path: Path, rate_hz: int, profile: CarrierSpeedProfile, run_s: float
) -> ProfileRun:
    """``profile`` on the project's firmware at ``rate_hz`` for ``run_s`` (simulated), then m 40 40.

    The commands are written from the motor side just after an exchange, so that each runs in a
    known millisecond; ``f`` is sent again every second against the firmware's auto-stop.
    """
    variables = firmware_variables(build)
    entry = firmware_functions(build)[UPDATE_PID]
    left = variables["leftPID"][0]
    watched = [variables["nextPID"][0], left, left + SET_POINT_ENCODER]
    extra = [arg for address in watched for arg in ("--watch", f"{address:#x}:4")]
    extra += ["--time-function", f"{entry:#x}"]
    interval_s = (1000 // rate_hz) * 1e-3
    mean_q6 = round(profile.mean_speed_rad_s / SCALE.rad_per_count * interval_s * 64)
    command = f"f {mean_q6}:{round(profile.depth * 1000)}:{PHASE_COUNTS}:{REVOLUTION}\r"
    records: list[tuple[int, tuple[int, ...], float, float]] = []
    script = [f"i {rate_hz}\r", command]
    marks: dict[str, int] = {}
    port_fd: list[int] = []
    holder: list[SimulatedBoard] = []
    finished = threading.Event()

    def observe(now_us: int, pwm: tuple[int, int], watched: tuple[int, ...]) -> None:
        if not (port_fd and holder):
            return
        motor = holder[0].side.motors[0].motor
        records.append((now_us, watched, motor.angle_rad, motor.speed_rad_s))
        if script:
            text = script.pop(0)
            os.write(port_fd[0], text.encode("ascii"))
            if text == command:
                marks["started"] = now_us
        elif "ended" not in marks and now_us - marks["started"] >= run_s * 1e6:
            os.write(port_fd[0], b"m 40 40\r")
            marks["ended"] = now_us
        elif "ended" not in marks and (now_us - marks["started"]) % 1_000_000 < 1000:
            os.write(port_fd[0], command.encode("ascii"))
        elif "ended" in marks and now_us - marks["ended"] >= 300_000:
            finished.set()

    board = board_in_water(build, tmp_path, extra=extra, observer=observe)
    try:
        port_fd.append(os.open(board.link, os.O_RDWR | os.O_NOCTTY))
        tty.setraw(port_fd[0])
        holder.append(board)
        assert finished.wait(60.0 + 20.0 * run_s), "the profile run did not finish"
    finally:
        board.stop()
        if port_fd:
            os.close(port_fd[0])
    return ProfileRun(records, marks["started"], marks["ended"])


def law_ticks(profile_q6: int, depth: float, count: int) -> float:
    """The profile's speed at ``count`` [ticks per frame], exactly (floating point)."""
    angle = 2.0 * math.pi * (count - PHASE_COUNTS) / REVOLUTION
    return profile_q6 / 64.0 * (1.0 + depth * math.cos(angle)) / math.sqrt(1.0 - depth**2)


def test_the_profile_sets_the_law_each_frame_and_the_motor_follows_it_in_water(
    fishtail_build, tmp_path
):
    """1 Hz, depth 0.5, 30 Hz PID, in water: the targets are the law, the motor keeps the depth.

    Frame by frame the integer target is the law at the count the frame read, within a tick, and
    their sum stays within the carried tick and the Q6 rounding of the law's; the carrier's speed
    keeps at least 0.8 of the depth (measured: 1.04, lag 0.99 rad); m 40 40 ends the profile; a
    frame takes a few thousand AVR cycles (measured: about 6200-7000 with the encoders'
    interrupts), far within even a 5 ms frame.
    """
    profile = CarrierSpeedProfile(2.0 * math.pi, 0.5, PHASE_RAD)
    run = run_profile(fishtail_build, tmp_path, 30, profile, 9.0)
    frames = run.frames()
    mean_q6 = round(profile.mean_speed_rad_s / SCALE.rad_per_count * 0.033 * 64)
    during = [frame for frame in frames if frame[0] <= run.ended_us]
    assert len(during) >= 9.0 * 30 - 3
    drift, largest = 0.0, 0.0
    for _, target, count, _ in during:
        exact = law_ticks(mean_q6, profile.depth, count)
        assert abs(target - exact) < 1.01, (target, exact, count)
        drift += target - exact
        largest = max(largest, abs(drift))
    # Besides the carried fraction, the Q6 rounding of the speed and amplitude: 1/64 a frame.
    assert largest < 1.0 + len(during) / 64, (
        f"the targets drift from the law by {largest:.2f} ticks"
    )
    after = [frame for frame in frames if frame[0] > run.ended_us + COMMAND_US]
    assert after and all(target == 40.0 for _, target, _, _ in after)

    result = run.following(profile, settle_s=1.5)
    ratio = result.mean_speed_rad_s / profile.mean_speed_rad_s
    print(f"1 Hz depth 0.5 in water, 30 Hz PID: depth {result.depth:.3f}, lag "
          f"{result.phase_lag_rad:.2f} rad, mean ratio {ratio:.3f}")  # fmt: skip
    assert result.depth_ratio >= 0.8, result
    assert 0.97 <= ratio <= 1.06, result
    cycles = [frame[3] for frame in during[1:]]
    assert max(cycles) < 0.25 * CPU_HZ * 0.005, f"a frame took {max(cycles)} cycles"


#: The tail at 3.75 Hz, depth 0.5, in water (its peak speed, 40.8 rad/s, is beyond the motor):
#: (PID rate, the least achieved depth, the least mean ratio) the test holds it to. Measured:
#: depth 0.073 and 0.064, mean ratio 0.84 and 0.85, the PWM at 255 through the fast half-stroke.
RATES_AT_3_75_HZ = [(30, 0.05, 0.8), (100, 0.05, 0.8)]


@pytest.mark.parametrize(("rate_hz", "least_depth", "least_mean_ratio"), RATES_AT_3_75_HZ)
def test_what_the_profile_keeps_at_3_75_hz_in_water(
    fishtail_build, tmp_path, rate_hz, least_depth, least_mean_ratio
):
    """The fast beat: what the board's loop gets out of the motor at two PID rates (reported)."""
    profile = CarrierSpeedProfile(3.75 * 2.0 * math.pi, 0.5, PHASE_RAD)
    run = run_profile(fishtail_build, tmp_path, rate_hz, profile, 3.5)
    result = run.following(profile, settle_s=0.8)
    ratio = result.mean_speed_rad_s / profile.mean_speed_rad_s
    cycles = [frame[3] for frame in run.frames() if frame[0] <= run.ended_us][1:]
    print(f"3.75 Hz depth 0.5 in water, {rate_hz} Hz PID: depth {result.depth:.3f}, lag "
          f"{result.phase_lag_rad:.2f} rad, mean ratio {ratio:.3f}, frame cycles "
          f"{min(cycles)}-{max(cycles)}")  # fmt: skip
    assert result.depth >= least_depth and ratio >= least_mean_ratio, result
    assert max(cycles) < 0.25 * CPU_HZ * (1000 // rate_hz) * 1e-3


#: The profile controller's gains (u Kp:Kd:Ki:Ko) at each PID rate (bench_firmware.py's).
TUNED_GAINS = {30: "40:24:0:50", 100: "60:80:0:50", 200: "80:160:0:50"}
#: A motor that can follow depth 0.5 at 3.75 Hz in water (none of config/motors/ can): 24 V,
#: 20 N m stall and 80 rad/s at no load at the carrier, 30:1, a 400 W class motor; at most 0.97
#: of its supply over the revolution (fishtail_plant.motor.profile_reach).
STRONG_MOTOR = DcMotorParameters.from_stall_and_no_load(
    supply_voltage_v=24.0, stall_torque_n_m=20.0, no_load_speed_rad_s=80.0, gear_ratio=30.0,
    gearbox_efficiency=0.76, rotor_inertia_kg_m2=2e-5,
)  # fmt: skip


def tuned_run(build: Path, folder: Path, profile: CarrierSpeedProfile, rate_hz: int, run_s: float,
              parameters: DcMotorParameters | None = None):  # fmt: skip
    """``profile`` in water under the profile controller (lead 8 ms, the motor's feed-forward)."""
    output = firmware_variables(build)["leftPID"][0] + SET_POINT_OUTPUT
    tuning = tuning_for("water_swimming", 8, parameters)
    run = run_on_board(build, folder, profile, rate_hz, run_s, tuning=tuning,
                       gains=TUNED_GAINS[rate_hz], parameters=parameters, watch=[output],
                       time_frames=True)  # fmt: skip
    result = run.following(profile, settle_s=1.0)
    lag_ms = 1e3 * result.phase_lag_rad / profile.mean_speed_rad_s
    cycles = sorted({record[1][-1] for record in run.kept(1.0)})
    ratio = result.mean_speed_rad_s / profile.mean_speed_rad_s
    print(f"{profile.mean_speed_rad_s / (2 * math.pi):g} Hz depth {profile.depth} in water, "
          f"{rate_hz} Hz PID, k {tuning}: depth ratio {result.depth_ratio:.3f}, lag "
          f"{lag_ms:+.1f} ms, mean ratio {ratio:.3f}, PWM at 255 {run.saturated(1.0):.2f}, "
          f"frame cycles {cycles[0]}-{cycles[-1]}")  # fmt: skip
    assert cycles[-1] < 0.25 * CPU_HZ * (1000 // rate_hz) * 1e-3
    return run, result, lag_ms, ratio


@pytest.mark.parametrize("rate_hz", [30, 200])
def test_lead_and_feed_forward_cancel_the_lag_where_the_motor_can_follow(
    fishtail_build, tmp_path, rate_hz
):
    """1 Hz, depth 0.5, in water, the default motor, tuned: the project's target holds.

    There the exact law needs at most 0.9 of the supply (fishtail_plant.motor.profile_reach), so
    the motor is not saturated: the profile controller keeps at least 0.9 of the depth with the
    fastest point within 20 ms (measured 0.97 and 0.99 of it, 2 ms; version 1's loop: 1.04 of
    it but 157 ms late), and a frame stays within a quarter of its interval.
    """
    profile = CarrierSpeedProfile(2.0 * math.pi, 0.5, PHASE_RAD)
    run, result, lag_ms, _ = tuned_run(fishtail_build, tmp_path, profile, rate_hz, 4.0)
    assert 0.9 <= result.depth_ratio <= 1.1, result
    assert abs(lag_ms) <= 20.0, result
    assert run.saturated(1.0) == 0.0


def test_at_3_75_hz_the_default_motor_not_the_loop_is_the_limit(fishtail_build, tmp_path):
    """3.75 Hz, depth 0.5, in water, tuned: the PWM sits at 255 and the mean falls short.

    The revolution the profile asks (267 ms) is shorter than the default motor's at full duty
    in water (297 ms, 21.1 rad/s: bench_firmware.py's o 255 255), so no controller reaches it;
    the tuned loop drives the motor at its limit for most of the turn.
    """
    profile = CarrierSpeedProfile(3.75 * 2.0 * math.pi, 0.5, PHASE_RAD)
    run, _, _, ratio = tuned_run(fishtail_build, tmp_path, profile, 100, 3.0)
    assert run.saturated(1.0) >= 0.5
    assert ratio < 0.92


def test_with_a_motor_that_can_the_firmware_meets_the_target_at_3_75_hz(fishtail_build, tmp_path):
    """3.75 Hz, depth 0.5, in water, STRONG_MOTOR, 200 Hz: 0.9 of the depth within 20 ms."""
    profile = CarrierSpeedProfile(3.75 * 2.0 * math.pi, 0.5, PHASE_RAD)
    run, result, lag_ms, ratio = tuned_run(
        fishtail_build, tmp_path, profile, 200, 3.0, STRONG_MOTOR
    )
    assert 0.9 <= result.depth_ratio <= 1.15, result
    assert abs(lag_ms) <= 20.0, result
    assert 0.97 <= ratio <= 1.03, result
    assert run.saturated(1.0) < 0.05
