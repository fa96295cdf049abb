"""The firmware's speed loop against hand-computed C integer arithmetic, frame by frame.

Each expected value is worked out from ``diff_controller.h`` in the comments: increment =
(Kp*error - Kd*(input - PrevInput) + ITerm) / Ko, the quotient truncated toward zero, output +=
increment, clamped to +-255, ITerm += Ki*error only when not clamped.
"""

from __future__ import annotations

import doctest

import pytest

from fishtail_plant.motor import speed_loop
from fishtail_plant.motor.board_units import Scale
from fishtail_plant.motor.speed_loop import FirmwareSpeedLoop, FrameTimer, PidGains, c_div


def running(target: int, gains: PidGains | None = None, counts: int = 0) -> FirmwareSpeedLoop:
    """One channel at ``counts``, after ``m target``."""
    loop = FirmwareSpeedLoop((counts,), gains)
    loop.command((target,), (counts,))
    return loop


def frames(loop: FirmwareSpeedLoop, deltas: list[int]) -> list[int]:
    """Run one frame per encoder increment; the PWM after each."""
    count = loop.set_points[0].encoder
    outputs = []
    for delta in deltas:
        count += delta
        outputs.append(loop.frame((count,))[0])
    return outputs


def test_doctests():
    result = doctest.testmod(speed_loop)
    assert result.failed == 0 and result.attempted >= 6


def test_c_division_truncates_toward_zero():
    assert [c_div(n, 50) for n in (-160, -280, -49, 49, 160)] == [-3, -5, 0, 0, 3]
    assert c_div(7, -2) == -3 and c_div(-7, -2) == 3


def test_default_gains_step_by_step():
    loop = running(40)
    # input 0: (20*40 - 12*(0-0)) / 50 = 800/50 = 16             -> 16
    # input 30: (20*10 - 12*(30-0)) / 50 = -160/50 = -3 (not -4) -> 13
    # input 45: (20*-5 - 12*(45-30)) / 50 = -280/50 = -5 (not -6) -> 8
    # input 40: (20*0 - 12*(40-45)) / 50 = 60/50 = 1             -> 9
    # input 40: 0/50                                             -> 9
    # input 38: (20*2 - 12*(38-40)) / 50 = 64/50 = 1             -> 10
    # input 38: (20*2 - 0) / 50 = 40/50 = 0: the dead band       -> 10
    assert frames(loop, [0, 30, 45, 40, 40, 38, 38]) == [16, 13, 8, 9, 9, 10, 10]
    point = loop.set_points[0]
    assert point.prev_input == 38 and point.output == 10 and point.iterm == 0


def test_clamp_freezes_the_integral_term():
    gains = PidGains(kp=20, kd=0, ki=5, ko=10)
    loop = running(100, gains)
    iterms = []
    outputs = []
    for delta in [0, 0, 0, 150, 150, 150]:
        outputs.append(frames(loop, [delta])[0])
        iterms.append(loop.set_points[0].iterm)
    # stalled, error 100: 2000/10 = 200 -> 200, not clamped: ITerm 5*100 = 500
    # (2000 + 500)/10 = 250 -> 450, clamped to 255: ITerm stays 500
    # again 250 -> 505 -> 255: ITerm 500
    # input 150, error -50: (-1000 + 500)/10 = -50 -> 205: ITerm 500 - 250 = 250
    # (-1000 + 250)/10 = -75 -> 130: ITerm 0
    # (-1000 + 0)/10 = -100 -> 30: ITerm -250
    assert outputs == [200, 255, 255, 205, 130, 30]
    assert iterms == [500, 500, 500, 250, 0, -250]


def test_an_output_of_exactly_255_counts_as_clamped():
    gains = PidGains(kp=1, kd=0, ki=1, ko=1)
    at_limit = running(255, gains)
    assert frames(at_limit, [0]) == [255] and at_limit.set_points[0].iterm == 0
    below = running(254, gains)
    assert frames(below, [0]) == [254] and below.set_points[0].iterm == 254
    assert frames(below, [0]) == [255] and below.set_points[0].iterm == 254  # 254 + 254 + 254


def test_negative_output_and_negative_clamp():
    loop = running(10)
    loop.set_points[0].output = -250
    # input 100, error -90: (-1800 - 1200)/50 = -60 -> -310, clamped to -255
    assert frames(loop, [100]) == [-255]


def test_the_encoder_delta_and_the_derivative_are_16_bit_ints():
    # A step of 40000 counts in one frame is input -25536 on the AVR.
    loop = running(10, PidGains(kp=1, kd=0, ki=0, ko=1000))
    frames(loop, [40000])
    assert loop.set_points[0].prev_input == -25536
    # Kd*(input - PrevInput) is int maths: 12*3000 = 36000 wraps to -29536, so the increment is
    # (0 - (-29536))/50 = +590: full forward PWM where the intended -720 would be full reverse.
    loop = running(10, PidGains(kp=0, kd=12, ki=0, ko=50))
    assert frames(loop, [3000]) == [255]


def test_m_0_0_stops_and_resets_and_the_next_m_starts_from_there():
    loop = running(40)
    frames(loop, [0, 30, 45])
    count = loop.set_points[0].encoder  # 75
    loop.command((0,), (count + 5,))
    assert loop.pwm == (0,) and not loop.moving
    point = loop.set_points[0]
    assert (point.target_ticks_per_frame, point.encoder, point.prev_enc) == (0, 80, 80)
    assert (point.output, point.prev_input, point.iterm) == (0, 0, 0)
    # Coasting on after the stop changes nothing (PrevInput is 0: no reset, PWM stays 0) ...
    assert frames(loop, [20, 10]) == [0, 0]
    assert point.prev_enc == 80 and point.encoder == 110
    # ... and the next m counts that coasting into its first frame: input 110 + 6 - 80 = 36,
    # (20*(40-36) - 12*(36-0))/50 = -352/50 = -7 (not -8): -7, a reverse PWM
    loop.command((40,), (110,))
    assert frames(loop, [6]) == [-7]


def test_the_coasting_reset_after_an_auto_stop():
    loop = running(40)
    frames(loop, [0, 30])  # output 13, PrevInput 30
    loop.auto_stop()
    assert loop.pwm == (0,) and not loop.moving
    point = loop.set_points[0]
    assert point.output == 13 and point.target_ticks_per_frame == 40  # not reset yet
    # The next frame sees PrevInput 30 != 0: reset at that frame's count.
    assert frames(loop, [25]) == [0]
    assert (point.output, point.prev_input, point.target_ticks_per_frame) == (0, 0, 0)
    assert point.prev_enc == 55
    assert frames(loop, [10]) == [0] and point.prev_enc == 55  # once: PrevInput is 0 now


def test_an_auto_stop_of_a_stalled_motor_keeps_the_old_output():
    loop = running(40)
    assert frames(loop, [0] * 20)[-1] == 255  # stalled: 16 per frame up to the clamp
    loop.auto_stop()
    assert frames(loop, [0, 0]) == [0, 0]
    assert loop.set_points[0].output == 255  # PrevInput 0: no reset
    loop.command((40,), (0,))
    assert frames(loop, [0]) == [255]  # full PWM at the first frame


def test_r_resets_the_loop_but_keeps_it_running():
    loop = running(40)
    frames(loop, [0, 30, 45])
    loop.reset_encoders()
    assert loop.moving and loop.set_points[0].target_ticks_per_frame == 0
    # counts 5 after the reset: input 5, error -5: (-100 - 60)/50 = -3 -> -3 (braking)
    assert loop.frame((5,)) == (-3,)


def test_raw_pwm_is_clamped_and_stops_the_loop():
    loop = running(40)
    frames(loop, [0])
    loop.raw_pwm((300,), (7,))
    assert loop.pwm == (255,) and not loop.moving
    assert loop.set_points[0].output == 0 and loop.set_points[0].prev_enc == 7
    assert frames(loop, [10]) == [255]  # a stopped loop leaves the PWM alone


def test_two_channels_are_independent_but_reset_together():
    loop = FirmwareSpeedLoop((0, 0))
    loop.command((40, 0), (0, 0))
    assert loop.frame((0, 0)) == (16, 0)
    assert loop.frame((30, 0)) == (13, 0)
    loop.auto_stop()
    loop.frame((30, 0))  # the left channel's PrevInput resets both
    assert [point.output for point in loop.set_points] == [0, 0]


def test_gains_refused_with_reasons():
    with pytest.raises(ValueError, match="ko must not be 0"):
        PidGains(ko=0)
    with pytest.raises(ValueError, match="kp = 40000 does not fit"):
        PidGains(kp=40000)
    with pytest.raises(ValueError, match="kd must be an integer"):
        PidGains(kd=1.5)
    with pytest.raises(ValueError, match="16-bit"):
        FirmwareSpeedLoop((0,)).command((40000,), (0,))
    with pytest.raises(ValueError, match="expected 1 encoder count"):
        FirmwareSpeedLoop((0,)).frame((0, 0))


def test_frames_fall_on_the_integer_millisecond_grid():
    frame_ms = Scale(64, 30.0, pid_rate_hz=30).frame_ms
    assert frame_ms == 33  # 1000 / 30 in integer maths
    timer = FrameTimer(frame_ms, start_s=10.0)
    assert list(timer.due(10.0339)) == []  # millis() > nextPID: one millisecond after the grid
    assert list(timer.due(10.1)) == pytest.approx([10.034, 10.067, 10.100])
    assert list(timer.due(10.1)) == []  # each frame once
    assert timer.next_s == pytest.approx(10.133)
    with pytest.raises(ValueError, match="frame_ms"):
        FrameTimer(0, 0.0)
