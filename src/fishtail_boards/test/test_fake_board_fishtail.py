"""The emulation of the project's firmware: ``v``, ``f`` (the integer law), ``i``, ``k``.

The stock firmware's answers are unchanged.

The same answers as the firmware in simavr (test_fishtail_firmware.py), and at every PID frame
the targets of fishtail_profile.h's integer law, which stay within its rounding of the float law
(:class:`~fishtail_kinematics.engine.carrier_profile.CarrierSpeedProfile`) and average to it.
"""

from __future__ import annotations

import doctest
import math

import pytest

from fishtail_boards import board_profile_law
from fishtail_boards.board_firmware import Firmware, FirmwareConfig
from fishtail_boards.board_profile_law import CarrierProfileLaw, sine_q14
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile

POLOLU = {"counts_per_revolution": 64, "gear_ratio": 30.0, "motor": "dc"}


def firmware(kind: str = "fishtail", **config) -> Firmware:
    """A board with the DC motor, powered on at t = 0."""
    return Firmware(FirmwareConfig(firmware=kind, **{**POLOLU, **config}), 0.0, warn=print)


def ask(board: Firmware, command: str, now: float = 0.0) -> str:
    """One command's reply, without CR LF."""
    for byte in command.encode("ascii") + b"\r":
        parsed = board.feed_byte(byte)
        if parsed is not None:
            return board.execute(parsed, now).decode("ascii").strip()
    raise AssertionError("no CR")


def test_doctests():
    result = doctest.testmod(board_profile_law)
    assert result.attempted > 0 and result.failed == 0


def test_the_emulation_answers_as_the_project_firmware_in_simavr():
    board = firmware()
    assert ask(board, "v") == "fishtail 1 pid_hz=30 pid_ms=33 profile=1"
    assert ask(board, "i 100") == "OK"
    assert ask(board, "v") == "fishtail 1 pid_hz=100 pid_ms=10 profile=1"
    refused = ["i 0", "i 501", "f 64:500:0", "f 64:901:0:1920", "f -1:0:0:1920",
               "f 64:0:0:0", "f 32768:0:0:1920", "f 64:0:0:65536", "f " + "7" * 40]  # fmt: skip
    assert [ask(board, command) for command in refused] == ["ERR"] * len(refused)
    assert ask(board, "f 0:500:0:1920") == "OK"
    assert ask(board, "b") == "57600" and ask(board, "q") == "Invalid Command"
    board.power_on(1.0)  # a reset: the build's PID rate again
    assert ask(board, "v", 1.0) == "fishtail 1 pid_hz=30 pid_ms=33 profile=1"


@pytest.mark.parametrize("command", ["v", "f 64:500:0:1920", "i 100", "k 8:5955:1889:5:690"])
def test_the_stock_emulation_answers_the_new_commands_invalid(command):
    assert ask(firmware("stock"), command) == "Invalid Command"


def test_the_quarter_sine_table_is_within_2e4_of_the_sine():
    worst = max(abs(sine_q14(angle) / 16384 - math.sin(angle * math.tau / 65536))
                for angle in range(0, 65536, 7))  # fmt: skip
    # Q14 steps, linear interpolation over pi/128 and the truncating shift: 1.44e-4 at most.
    assert worst < 2e-4


def test_each_frame_sets_the_law_at_its_count_and_the_targets_average_to_it():
    board = firmware()
    assert ask(board, "f 4055:500:500:1920") == "OK"
    law = CarrierSpeedProfile(4055 / 64, 0.5, 2 * math.pi * 500 / 1920)  # ticks per frame
    targets, exact = [], []
    for step in range(1, 300):
        now = step * 0.033 + 0.0015
        if step % 30 == 0:  # within the auto-stop; the same profile again goes on as it was
            assert ask(board, "f 4055:500:500:1920", now - 0.0003) == "OK"
        board.advance(now)
        when, counts, _ = board.frames[-1]
        if when > 0.04:  # the frames after the f
            targets.append(board.targets[0])
            exact.append(law.speed_at(2 * math.pi * counts[0] / 1920))
            assert board.targets[1] == board.targets[0]  # the same law on the other channel
    assert all(abs(t - e) <= 1.02 for t, e in zip(targets, exact, strict=True))
    # Within the carried fraction (a tick) and the Q6 rounding of scale, amplitude and their
    # product (at most 1.5/64 a frame; about 0.011 here).
    assert abs(sum(targets) - sum(exact)) <= 1 + len(targets) * 1.5 / 64
    assert max(exact) > 1.5 * min(exact)  # it turned through the modulation
    # m ends the profile: its target stays.
    assert ask(board, "m 40 40", 10.0) == "OK"
    board.advance(10.2)
    assert board.targets == [40, 40] and not board.profile.on


def test_a_profile_ends_with_the_auto_stop_mean_0_stops_and_i_stops():
    board = firmware()
    assert ask(board, "f 4055:0:0:1920") == "OK" and board.moving
    board.advance(1.0)
    assert board.targets[0] in (63, 64)  # 4055 / 64 = 63.4 ticks per frame
    board.advance(2.1)  # no command for over 2 s
    assert not board.profile.on and not board.moving
    assert ask(board, "f 4055:0:0:1920", 3.0) == "OK"
    assert ask(board, "f 0:0:0:1920", 3.1) == "OK"
    assert not board.moving and board.loop.pwm == (0, 0) and not board.profile.on
    assert ask(board, "f 4055:0:0:1920", 3.2) == "OK"
    assert ask(board, "i 100", 3.3) == "OK"
    assert not board.moving and not board.profile.on and board.timer.frame_ms == 10


def test_setprofile_converts_in_the_avrs_float_and_keeps_the_carry_while_on():
    law = CarrierProfileLaw()
    assert law.set_profile(b"1229:900:-5:1920")
    assert (law.scale, law.amplitude, law.phase) == (2820, 2538, 1915)
    law.carry = [17, 3]
    assert law.set_profile(b"1229:500:0:1920::") and law.carry == [17, 3]  # still on
    assert not law.set_profile(b"1229:500::") and law.scale == round(1229 / math.sqrt(0.75))


def test_k_is_taken_and_refused_as_the_firmware_does():
    """The same answers as test_fishtail_firmware.py's; a refused k changes nothing."""
    board = firmware()
    assert ask(board, "k 8:5955:1889:5:690") == "OK"
    law = board.profile
    assert (law.lead_ms, law.kv, law.ka, law.ks, law.kq, law.tuned) == (8, 5955, 1889, 5, 690, True)
    # profileRetune at 33 ms frames: 8 * 1024 / 33, kv * 4 / 33, ka * 1024 / 33², kq * 256 / 33².
    assert (law.lead_k, law.kv_k, law.ka_k, law.kq_k) == (248, 721, 1776, 162)
    refused = ["k 8:5955:1889", "k 256:0:0:0", "k -1:0:0:0", "k 0:32768:0:0",
               "k 0:0:32768:0", "k 0:0:0:256", "k 0:0:0:0:32768", "k 0:0:0:0:-1"]  # fmt: skip
    assert [ask(board, command) for command in refused] == ["ERR"] * len(refused)
    assert (law.lead_ms, law.kv, law.kq) == (8, 5955, 690)
    assert ask(board, "k 8:5955:1889:5") == "OK" and law.kq == 0  # KQ optional
    assert ask(board, "i 100") == "OK" and (law.lead_k, law.kv_k) == (819, 2382)  # kept, retuned
    assert ask(board, "k 0:0:0:0") == "OK" and not law.tuned  # version 1's loop
    assert ask(board, "v") == "fishtail 1 pid_hz=100 pid_ms=10 profile=1"
    board.power_on(1.0)  # a reset: k's defaults again
    assert not board.profile.tuned and board.profile.kv == 0


def run_in_water(tuning: str | None, run_s: float = 7.0):
    """1 Hz, depth 0.5, fastest at count 500, the tail in water, at 30 Hz: per ms, board time."""
    from fishtail_plant.values import tail_load_from_files

    tail = tail_load_from_files("water_swimming")
    board = firmware(variant="joshnewans", load=tail.torque, load_inertia=tail.inertia)
    if tuning is not None:
        assert ask(board, f"k {tuning}") == "OK"
    command = "f 4055:500:500:1920"
    assert ask(board, command) == "OK"
    times, angles = [], []
    for ms in range(1, round(run_s * 1000)):
        now = ms * 1e-3
        if ms % 1000 == 0:
            assert ask(board, command, now) == "OK"  # against the auto-stop
        board.advance(now)
        times.append(now)
        angles.append(board.motors[0].encoder_counts() * 2.0 * math.pi / 1920)
    return board, times, angles


def test_with_k_the_emulated_controller_removes_the_lag_in_water():
    """Version 1's loop runs about 1 rad late at 1 Hz in water; k brings the lag near 0.

    k's lead and feed-forward are the 37D's in water, from its model (docs/firmware.md: +158 ms
    and +2 ms on the firmware in simavr), keeping the depth and the mean; the PWM in range.
    """
    from fishtail_plant.motor.board_units import Scale
    from fishtail_plant.motor.profile_tuning import profile_tuning
    from fishtail_testkit.modulation_fit import measure_following, speeds_from_angles

    profile = CarrierSpeedProfile(2.0 * math.pi, 0.5, 2.0 * math.pi * 500 / 1920)
    results = {}
    for name, tuning in (("law", None), ("k", profile_tuning("water_swimming", Scale(64, 30.0)))):
        board, times, angles = run_in_water(tuning)
        kept = [i for i, t in enumerate(times) if t >= 2.0]
        times, angles = [times[i] for i in kept], [angles[i] for i in kept]
        results[name] = measure_following(times, angles, speeds_from_angles(times, angles), profile)
        assert all(abs(pwm) <= 255 for _, _, frame in board.frames for pwm in frame)
    law, tuned = results["law"], results["k"]
    assert 0.7 <= law.phase_lag_rad <= 1.3, law  # measured 0.98
    assert abs(tuned.phase_lag_rad) <= 0.25, tuned  # measured -0.00
    assert tuned.depth_ratio >= 0.8 and abs(tuned.mean_speed_rad_s / (2 * math.pi) - 1) < 0.05
