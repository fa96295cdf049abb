"""``serial_profile_tuning``: the driver sends ``k`` to the project's firmware, on every board.

On the boards of ``either_board`` (the emulations of both firmwares and both firmwares in
simavr): the serial backend sends ``k`` after ``v`` at connect, again after a reconnect and after
a board reset, where the board follows the profile; on the stock firmware it sends none and says
so. With ``k`` (the 37D's feed-forward, here unloaded) the modulation's phase lag through the
driver is smaller than with the firmware's default loop. Times are the board's own
(``BoardUnderTest.clock_at``), so that nothing depends on the pace the host kept a simulator at.
And the fake board's emulation of ``k``'s controller is the firmware's, frame for frame.
"""

from __future__ import annotations

import math

import pytest

from fishtail_driver.protocol import ProfileTuning, parse_profile_tuning
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
from fishtail_plant.motor.board_units import Scale
from fishtail_plant.motor.profile_tuning import profile_tuning
from fishtail_testkit.modulation_fit import measure_following, speeds_from_angles

POLOLU = {"counts_per_revolution": 64, "gear_ratio": 30.0}
#: 1 Hz, depth 0.5, the fastest point at 2 rad.
PROFILE = CarrierSpeedProfile(2.0 * math.pi, 0.5, 2.0)
#: The 37D's k with the tail in water (docs/firmware.md).
IN_WATER = ProfileTuning(8, 5955, 1889, 5, 690)
#: Only bounds a failing wait: a simulator starved of CPU runs slower than wall time.
PATIENCE_S = 60.0
FAST = {"reconnect_min_s": 0.05, "reconnect_max_s": 0.2, "poll_rate_hz": 100.0}


def values(backend) -> dict[str, str]:
    """The backend's /diagnostics values."""
    return backend.status()[2]


def tunings(backend) -> int:
    """How many ``k`` the board acknowledged."""
    return int(values(backend).get("profile_tunings", "0") or 0)


def test_k_goes_out_at_connect_after_a_reconnect_and_after_a_reset(
    either_board, serial_backend, wait_until
):
    board = either_board()
    backend = serial_backend(board.link, profile_tuning=IN_WATER, **FAST, **POLOLU)
    wait_until(lambda: values(backend)["connected"] == "true", PATIENCE_S, "connected")
    wait_until(lambda: values(backend)["firmware"] != "not known yet (not connected)",
               PATIENCE_S, "v answered")  # fmt: skip
    if not board.project_firmware:
        # The stock firmware: no k (it would answer Invalid Command), and the reason shown.
        assert values(backend)["profile_tuning"] == "k 8:5955:1889:5:690 not sent (stock firmware)"
        assert tunings(backend) == 0
        if board.kind == "fake":
            assert not board.handle.commands("k")
        return
    acknowledged = "k 8:5955:1889:5:690 (acknowledged)"
    wait_until(lambda: tunings(backend) >= 1, PATIENCE_S, "k acknowledged at connect")
    assert values(backend)["profile_tuning"] == acknowledged
    assert backend.status()[0] == 0, backend.status()  # no fault
    # A reconnect (the cable pulled and put back: the board power-cycled) sends it again.
    board.unplug()
    wait_until(lambda: backend.status()[0] == 2, PATIENCE_S, "the link lost")
    board.replug()
    wait_until(lambda: tunings(backend) >= 2, PATIENCE_S, "k again after the reconnect")
    # A reset while connected (the carrier turned, so that the counts tell): again.
    backend.set_profile(PROFILE, PROFILE.mean_speed_rad_s)
    wait_until(lambda: values(backend)["acked_profile"].startswith("f "), PATIENCE_S, "an f")
    # Two revolutions: a fall of the count to 0 then is no motion, however late a poll.
    wait_until(lambda: int(values(backend)["continuous_counts"]) > 2 * 1920, PATIENCE_S, "turns")
    board.reset()
    wait_until(lambda: int(values(backend).get("board_resets", "0") or 0) >= 1,
               PATIENCE_S, "the reset noticed")  # fmt: skip
    wait_until(lambda: tunings(backend) >= 3, PATIENCE_S, "k again after the reset")
    assert values(backend)["profile_tuning"] == acknowledged
    if board.kind == "fake_fishtail":
        sent = board.handle.commands("k")
        assert sent == ["k 8:5955:1889:5:690"] * len(sent) and len(sent) >= 3, sent
        # k follows v at every connect, and precedes the f sent after the reset.
        log = board.handle.commands()
        assert all(log[i - 1] == "v" for i, command in enumerate(log[:4]) if command[0] == "k")


@pytest.mark.parametrize("reply", ["ERR", "Invalid Command"])
def test_a_board_that_refuses_k_keeps_its_default_loop(
    fake_board, serial_backend, wait_until, reply
):
    """ERR, or Invalid Command (the firmware's first version): shown, no fault, f still sent."""
    handle = fake_board(variant="joshnewans", motor="dc", firmware="fishtail", **POLOLU)
    firmware = handle.board.firmware
    answer = firmware._fishtail_command

    def without_k(cmd, *args):
        return f"{reply}\r\n".encode("ascii") if cmd == "k" else answer(cmd, *args)

    firmware._fishtail_command = without_k  # type: ignore[method-assign]
    backend = serial_backend(handle.link, profile_tuning=IN_WATER, **FAST, **POLOLU)
    refused = f"refused by the board: k 8:5955:1889:5:690 answered {reply!r}"
    wait_until(lambda: values(backend)["profile_tuning"].startswith(refused), PATIENCE_S, reply)
    backend.set_profile(PROFILE, PROFILE.mean_speed_rad_s)
    wait_until(lambda: handle.commands("f "), PATIENCE_S, "the f")
    assert tunings(backend) == 0 and backend.profile_on_board
    assert backend.status()[0] == 0, backend.status()  # an answer, not a fault of the link


def lag_through_the_driver(board, backend, wait_until) -> float:
    """The modulation's phase lag [rad] from the backend's samples, on the board's clock."""
    samples = []

    def collect() -> bool:
        while (sample := backend.read()) is not None:
            samples.append(sample)
        return bool(samples) and samples[-1].angle_rad - samples[0].angle_rad > 7 * 2 * math.pi

    backend.set_profile(PROFILE, PROFILE.mean_speed_rad_s)
    wait_until(collect, 4 * PATIENCE_S, "seven revolutions")
    backend.stop()
    start = samples[0].angle_rad + 2 * 2 * math.pi  # two revolutions to settle
    kept = [sample for sample in samples if sample.angle_rad >= start]
    times = [board.clock_at(sample.monotonic_s) for sample in kept]
    angles = [sample.angle_rad for sample in kept]
    result = measure_following(times, angles, speeds_from_angles(times, angles), PROFILE)
    assert len(result.revolutions) >= 3, result
    assert result.depth >= 0.3 and abs(result.mean_speed_rad_s / (2 * math.pi) - 1) < 0.1, result
    return result.phase_lag_rad


@pytest.mark.slow
def test_with_k_the_lag_through_the_driver_is_smaller(either_board, serial_backend, wait_until):
    """1 Hz, depth 0.5, unloaded: k takes most of the default loop's lag away.

    The default loop lags about 0.5 rad; k is the 37D's lead and feed-forward for no load.
    """
    first = either_board()
    if not first.project_firmware:
        pytest.skip("k is the project's firmware's; the stock one follows on the host")
    tuning = parse_profile_tuning(profile_tuning("none", Scale(64, 30.0)))
    lags = []
    for setting in (None, tuning):
        board = first if setting is None else either_board()  # one simulator at a time
        backend = serial_backend(board.link, profile_tuning=setting, **POLOLU)
        wait_until(lambda b=backend: values(b)["firmware"].endswith("(profile on board)"),
                   PATIENCE_S, "the profile on board")  # fmt: skip
        if setting is not None:
            wait_until(lambda b=backend: tunings(b) >= 1, PATIENCE_S, "k acknowledged")
        lags.append(lag_through_the_driver(board, backend, wait_until))
        backend.close()
        board.stop()
    default, tuned = lags
    print(f"{first.kind}: lag {default:.3f} rad with the default loop, {tuned:.3f} with k")
    assert tuned < default - 0.15, lags
    assert abs(tuned) < 0.4, lags


#: ``CarrierProfile``'s ff[0] and integral[0] (fishtail_profile.h; avr-gcc packs the struct: 4 x
#: long, carry[2], on, 5 x int, 4 x long, tuned, then ff[2] and integral[2]: 68 bytes).
PROFILE_FF, PROFILE_INTEGRAL, PROFILE_SIZE = 52, 60, 68


def signed(value: int) -> int:
    """A watched 4-byte value as a signed long."""
    return value - (1 << 32) if value >= 1 << 31 else value


def test_the_emulated_controller_is_the_firmware_s_frame_for_frame(fishtail_build, tmp_path):
    """With k, in water, at 30 Hz: the emulation's controller is the firmware's, frame for frame.

    From the counts the firmware read, the emulation's target, feed-forward, integral and PWM
    are the firmware's at every frame (its variables read per simulated millisecond).
    """
    import struct

    from fishtail_boards.avr_board import (
        SET_POINT_ENCODER,
        SET_POINT_OUTPUT,
        SET_POINT_PREV_ENC,
        firmware_variables,
    )
    from fishtail_boards.board_profile_law import CarrierProfileLaw
    from fishtail_plant.motor.speed_loop import FirmwareSpeedLoop
    from fishtail_testkit.board_profile import SCALE, profile_command, run_on_board

    variables = firmware_variables(fishtail_build)
    assert variables["profile"][1] == PROFILE_SIZE, variables["profile"]
    left, profile_at = variables["leftPID"][0], variables["profile"][0]
    set_point = [left + offset for offset in (0, SET_POINT_ENCODER, SET_POINT_PREV_ENC,
                                              SET_POINT_OUTPUT)]  # fmt: skip
    watch = [variables["nextPID"][0], *set_point, profile_at + PROFILE_FF,
             profile_at + PROFILE_INTEGRAL]  # fmt: skip
    tuning = profile_tuning("water_swimming", SCALE)
    run = run_on_board(fishtail_build, tmp_path, PROFILE, 30, 4.0, tuning=tuning, watch=watch)
    frames = []
    for before, after in zip(run.records, run.records[1:], strict=False):
        if after[1][0] != before[1][0] and after[0] < run.ended_us:
            frames.append((before[1], after[1]))
    first = next(i for i, (_, after) in enumerate(frames) if signed(after[5]) != 0)
    law = CarrierProfileLaw()
    assert law.set_profile(profile_command(PROFILE, SCALE, 30)[2:].encode("ascii"))
    assert law.set_tuning(tuning.encode("ascii"), 33)
    loop = FirmwareSpeedLoop((0,))
    loop.moving = True
    loop.set_points[0].prev_enc = signed(frames[first][0][3])  # PrevEnc before the profile
    compared = 0
    for _, after in frames[first:]:
        count = signed(after[2])
        point = loop.set_points[0]
        point.target_ticks_per_frame = law.target(0, count, count - point.prev_enc)
        (pwm,) = law.control(loop, (count,))
        target = struct.unpack("<f", after[1].to_bytes(4, "little"))[0]
        firmware = (target, signed(after[5]), signed(after[6]), signed(after[4]))
        emulated = (float(point.target_ticks_per_frame), law.ff[0], law.integral[0], pwm)
        assert emulated == firmware, (compared, count, emulated, firmware)
        compared += 1
    assert compared >= 3.5 * 30, compared
    # The loop did work: the PWM moved over a wide range, the integral was used.
    outputs = [signed(after[4]) for _, after in frames[first:]]
    assert max(outputs) - min(outputs) > 50 and any(signed(a[6]) != 0 for _, a in frames[first:])
