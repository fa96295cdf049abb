"""The project firmware's carrier speed profile in its own integers: ``fishtail_profile.h``.

With ``k`` (:meth:`CarrierProfileLaw.set_tuning`) the law is taken ahead of the count with a
feed-forward PWM per frame, and :meth:`CarrierProfileLaw.control` runs ``doProfilePID``
(``diff_controller.h``) instead of the stock loop, in the same integers and order.

The emulated board (:mod:`fishtail_boards.board_firmware`, ``firmware="fishtail"``) runs what the
patch's C runs, step for step: the command's conversion in the AVR's 32-bit ``double`` (a float)
with ``lround``, and at every PID frame the count's place in the revolution, a 16-bit angle, the
quarter sine table in Q14 with linear interpolation, one multiply, and the fraction of a tick
carried to the next frame. No float shortcut: the targets are the firmware's, bit for bit.
firmware/CHANGES.md ("The law and its arithmetic").

>>> law = CarrierProfileLaw()
>>> law.set_profile(b"4055:500:500:1920")
True
>>> law.scale, law.amplitude, law.phase, law.revolution
(4682, 2341, 500, 1920)
>>> [law.target(0, 500) for _ in range(4)]  # 7023/64 = 109.7 ticks: the fraction carried
[109, 110, 110, 109]
"""

from __future__ import annotations

import math

import numpy as np

from fishtail_driver.protocol import (
    PROFILE_DEPTH_MAX,
    PROFILE_DEPTH_UNIT,
    PROFILE_MEAN_MAX,
    PROFILE_MEAN_SHIFT,
    PROFILE_REVOLUTION_MAX,
    TUNING_FRICTION_MAX,
    TUNING_GAIN_MAX,
    TUNING_LEAD_MAX_MS,
)
from fishtail_plant.motor.board_units import PWM_MAX, wrap_int16, wrap_int32
from fishtail_plant.motor.speed_loop import FirmwareSpeedLoop, SetPoint, c_div

#: sin(k pi / 128) for k = 0..64 (a quarter turn), Q14: the patch's QUARTER_SINE.
QUARTER_SINE = (
    0, 402, 804, 1205, 1606, 2006, 2404, 2801, 3196, 3590, 3981,
    4370, 4756, 5139, 5520, 5897, 6270, 6639, 7005, 7366, 7723, 8076,
    8423, 8765, 9102, 9434, 9760, 10080, 10394, 10702, 11003, 11297, 11585,
    11866, 12140, 12406, 12665, 12916, 13160, 13395, 13623, 13842, 14053, 14256,
    14449, 14635, 14811, 14978, 15137, 15286, 15426, 15557, 15679, 15791, 15893,
    15986, 16069, 16143, 16207, 16261, 16305, 16340, 16364, 16379, 16384,
)  # fmt: skip
# The command's units and ranges: the driver's codec states them once.
SPEED_SHIFT = PROFILE_MEAN_SHIFT
DEPTH_UNIT = PROFILE_DEPTH_UNIT
MAX_DEPTH = PROFILE_DEPTH_MAX
MAX_MEAN = PROFILE_MEAN_MAX
MAX_REVOLUTION = PROFILE_REVOLUTION_MAX
#: ``k``'s ranges in its fields' order: LEAD, KV, KA, KS, KQ.
TUNING_LIMITS = (
    TUNING_LEAD_MAX_MS, TUNING_GAIN_MAX, TUNING_GAIN_MAX, TUNING_FRICTION_MAX, TUNING_GAIN_MAX
)  # fmt: skip
#: profileRetune's caps of the per-frame KA and KQ factors.
FACTOR_CAP = 262143
_U32 = 0xFFFFFFFF


def _atol(text: bytes) -> int:
    """avr-libc ``atol``: leading white space, a sign, digits; a 32-bit long (wraps)."""
    stripped = text.lstrip(b" \t\n\v\f\r")
    sign = 1
    if stripped[:1] in (b"+", b"-"):
        sign = -1 if stripped[:1] == b"-" else 1
        stripped = stripped[1:]
    digits = 0
    for byte in stripped:
        if not 0x30 <= byte <= 0x39:
            break
        digits = (digits * 10 + byte - 0x30) & 0xFFFFFFFF
    return wrap_int32(sign * digits)


def _lround(value: float) -> int:
    """C ``lround``: to nearest, halves away from zero."""
    return int(math.copysign(math.floor(abs(value) + 0.5), value))


def sine_q14(angle: int) -> int:
    """``sineQ14``: sin of a 16-bit angle (65536 a turn), Q14."""
    angle &= 0xFFFF
    x = angle & 0x3FFF
    quadrant = angle >> 14
    if quadrant & 1:
        x = 0x4000 - x
    index, fraction = x >> 8, x & 0xFF
    sine = QUARTER_SINE[index]
    if fraction:
        sine = wrap_int16(sine + (((QUARTER_SINE[index + 1] - sine) * fraction) >> 8))
    return -sine if quadrant & 2 else sine


class CarrierProfileLaw:
    """The ``CarrierProfile`` struct and its functions (``setProfile``, ``profileTarget``)."""

    def __init__(self) -> None:
        """Off, as at power-on (the struct is zeroed)."""
        self.scale = 0
        self.amplitude = 0
        self.phase = 0
        self.revolution = 0
        self.carry = [0, 0]
        self.on = False
        # The profile controller (k): as commanded, its per-frame factors, this frame's
        # feed-forward and the integral (PWM * Ko), per channel.
        self.lead_ms = self.kv = self.ka = self.ks = self.kq = 0
        self.lead_k = self.kv_k = self.ka_k = self.kq_k = 0
        self.tuned = False
        self.ff = [0, 0]
        self.integral = [0, 0]

    def set_profile(self, text: bytes) -> bool:
        """``setProfile``: "MEAN:DEPTH:PHASE:REV" into the profile; False (unchanged) if refused.

        Fields split at colons as ``strtok_r`` does (empty ones vanish; a fifth is ignored).
        """
        fields = [_atol(token) for token in text.split(b":") if token][:4]
        if len(fields) != 4:
            return False
        mean, depth, phase, revolution = fields
        if not (0 <= mean <= MAX_MEAN and 0 <= depth <= MAX_DEPTH and 1 <= revolution):
            return False
        if revolution > MAX_REVOLUTION:
            return False
        # avr-gcc's double is a 32-bit float.
        depth_f = np.float32(depth) / np.float32(DEPTH_UNIT)
        scale_f = np.float32(mean) / np.sqrt(np.float32(1.0) - depth_f * depth_f)
        self.scale = _lround(float(scale_f))
        self.amplitude = _lround(float(np.float32(scale_f * depth_f)))
        self.revolution = revolution
        self.phase = int(math.fmod(phase, revolution))  # C's %: the sign of the dividend
        if self.phase < 0:
            self.phase += revolution
        if not self.on:
            self.carry = [0, 0]
            self.integral = [0, 0]
        self.on = True
        return True

    def set_tuning(self, text: bytes, interval_ms: int) -> bool:
        """``setProfileTuning``: "LEAD:KV:KA:KS[:KQ]"; False (unchanged) if a field is refused.

        Fields split at colons as ``strtok_r`` does (empty ones vanish; a sixth is ignored).
        """
        fields = [_atol(token) for token in text.split(b":") if token][:5]
        if len(fields) < 4:
            return False
        fields += [0] * (5 - len(fields))
        if not all(0 <= value <= top for value, top in zip(fields, TUNING_LIMITS, strict=True)):
            return False
        self.lead_ms, self.kv, self.ka, self.ks, self.kq = fields
        self.retune(interval_ms)
        return True

    def retune(self, interval_ms: int) -> None:
        """``profileRetune``: the per-frame factors at frames of ``interval_ms``."""
        frame = interval_ms if interval_ms > 0 else 1
        self.lead_k = self.lead_ms * 1024 // frame
        self.kv_k = self.kv * 4 // frame
        self.ka_k = min(self.ka * 1024 // (frame * frame), FACTOR_CAP)
        self.kq_k = min(self.kq * 256 // (frame * frame), FACTOR_CAP)
        self.tuned = bool(self.lead_ms or self.kv or self.ka or self.ks or self.kq)

    def law(self, count: int) -> int:
        """``profileLaw``: the law's speed at ``count`` [1/64 ticks per frame]."""
        offset = wrap_int32(count - self.phase)
        in_turn = int(math.fmod(offset, self.revolution))
        if in_turn < 0:
            in_turn += self.revolution
        angle = ((in_turn << 16) // self.revolution) & 0xFFFF
        cosine = sine_q14(angle + 0x4000)
        return wrap_int32(self.scale + ((self.amplitude * cosine) >> 14))

    def _speed_ahead(self, channel: int, count: int, frame_input: int) -> int:
        """The tuned ``profileTarget``'s law ahead of the count, and the frame's feed-forward."""
        moving = min(frame_input if frame_input > 0 else 0, 2047)
        ahead = (moving * self.lead_k & _U32) >> 10
        speed = self.law(wrap_int32(count + ahead))
        change = wrap_int32(self.law(wrap_int32(count + ahead + (speed >> SPEED_SHIFT))) - speed)
        change = max(-8191, min(change, 8191))
        ff = wrap_int32(((((speed & _U32) >> 4) * self.kv_k) & _U32) >> 12)
        ff = wrap_int32(ff + (wrap_int32(change * self.ka_k) >> 16))
        if self.kq_k:
            quarter = speed >> 4  # in 1/4 ticks per frame
            square = min(wrap_int32(quarter * quarter) >> 8, 8191)
            ff = wrap_int32(ff + (wrap_int32(square * self.kq_k) >> 12))
        self.ff[channel] = wrap_int32(ff + self.ks)
        return speed

    def control(self, loop: FirmwareSpeedLoop, counts: tuple[int, ...]) -> tuple[int, ...]:
        """``updatePID``'s tuned branch: ``doProfilePID`` right then left, then the PWM."""
        for point, count in zip(loop.set_points, counts, strict=True):
            point.encoder = count
        for channel in reversed(range(len(loop.set_points))):
            self._do_profile_pid(loop, loop.set_points[channel], channel)
        loop.pwm = tuple(max(-PWM_MAX, min(PWM_MAX, point.output)) for point in loop.set_points)
        return loop.pwm

    def _do_profile_pid(self, loop: FirmwareSpeedLoop, point: SetPoint, channel: int) -> None:
        """``doProfilePID``: the feed-forward plus Kd e / Ko and the integral of Kp e / Ko."""
        kp, kd, ko = loop.gains.kp, loop.gains.kd, loop.gains.ko
        frame_input = wrap_int16(point.encoder - point.prev_enc)
        error = point.target_ticks_per_frame - frame_input
        integral = wrap_int32(self.integral[channel] + wrap_int32(kp * error))
        limit = wrap_int32(PWM_MAX * ko)
        if integral > limit:
            integral = limit
        elif integral < -limit:
            integral = -limit
        action = c_div(wrap_int32(wrap_int32(kd * error) + integral), ko)
        output = wrap_int32(self.ff[channel] + action)
        if output >= PWM_MAX:
            output = PWM_MAX
            if error > 0:
                integral = self.integral[channel]
        elif output <= -PWM_MAX:
            output = -PWM_MAX
            if error < 0:
                integral = self.integral[channel]
        self.integral[channel] = integral
        point.prev_enc = point.encoder
        point.output = output
        point.prev_input = frame_input

    def target(self, channel: int, count: int, frame_input: int = 0) -> int:
        """``profileTarget``: the channel's ticks for the next frame at its encoder ``count``.

        ``frame_input``: the ticks of the last frame (``Encoder - PrevEnc``), which the tuned
        law's lead multiplies.
        """
        if self.tuned:
            speed = self._speed_ahead(channel, count, wrap_int16(frame_input))
        else:
            speed = self.law(count)
        total = speed + self.carry[channel]
        ticks = total >> SPEED_SHIFT
        self.carry[channel] = total - (ticks << SPEED_SHIFT)
        return wrap_int16(ticks)
