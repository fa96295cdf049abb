"""The project firmware's carrier speed profile in its own integers: ``fishtail_profile.h``.

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

from fishtail_plant.motor.board_units import wrap_int16, wrap_int32

#: sin(k pi / 128) for k = 0..64 (a quarter turn), Q14: the patch's QUARTER_SINE.
QUARTER_SINE = (
    0, 402, 804, 1205, 1606, 2006, 2404, 2801, 3196, 3590, 3981,
    4370, 4756, 5139, 5520, 5897, 6270, 6639, 7005, 7366, 7723, 8076,
    8423, 8765, 9102, 9434, 9760, 10080, 10394, 10702, 11003, 11297, 11585,
    11866, 12140, 12406, 12665, 12916, 13160, 13395, 13623, 13842, 14053, 14256,
    14449, 14635, 14811, 14978, 15137, 15286, 15426, 15557, 15679, 15791, 15893,
    15986, 16069, 16143, 16207, 16261, 16305, 16340, 16364, 16379, 16384,
)  # fmt: skip
SPEED_SHIFT = 6
DEPTH_UNIT = 1000
MAX_DEPTH = 900
MAX_MEAN = 32767
MAX_REVOLUTION = 65535


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
        self.on = True
        return True

    def target(self, channel: int, count: int) -> int:
        """``profileTarget``: the channel's ticks for the next frame at its encoder ``count``."""
        offset = wrap_int32(count - self.phase)
        in_turn = int(math.fmod(offset, self.revolution))
        if in_turn < 0:
            in_turn += self.revolution
        angle = ((in_turn << 16) // self.revolution) & 0xFFFF
        cosine = sine_q14(angle + 0x4000)
        speed = self.scale + ((self.amplitude * cosine) >> 14)
        total = speed + self.carry[channel]
        ticks = total >> SPEED_SHIFT
        self.carry[channel] = total - (ticks << SPEED_SHIFT)
        return wrap_int16(ticks)
