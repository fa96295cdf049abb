r"""ROSArduinoBridge serial protocol: a pure codec (no rclpy, no I/O).

Encodes the firmware's commands (``e``, ``m``, ``r``, ``o``, ``u``, ``b``, and the project
firmware's ``v``, ``f``, ``i``, ``k``: firmware/CHANGES.md), splits the byte
stream into reply lines (:class:`LineFramer`) and parses replies, raising :class:`ReplyError`
with a countable ``kind`` and a precise ``reason`` for anything malformed; pure, so that it can be
fuzzed and tested without a port. Speeds in ticks per PID frame:
:class:`~fishtail_plant.motor.board_units.Scale`; a continuous angle from the counts:
:mod:`fishtail_driver.encoder_tracking`. The protocol: docs/serial.md
("The protocol in one table").

>>> encode_motor_speeds(68, 0)
b'm 68 0\r'
>>> parse_encoders(b"-12 2147483647")
(-12, 2147483647)
"""

from __future__ import annotations

import dataclasses
import re

from fishtail_plant.motor.board_units import (
    INT16_MAX,
    INT16_MIN,
    INT32_MAX,
    INT32_MIN,
    PWM_MAX,
)

#: The firmware's default baud rate.
DEFAULT_BAUD = 57600
#: The board stops the motors when no ``m``/``o`` came for strictly more than this [ms].
AUTO_STOP_INTERVAL_MS = 2000
#: Longest argument text sent (the smallest firmware argument buffer is 16 bytes incl. NUL).
MAX_ARGUMENT_CHARS = 15
#: Longest reply line accepted by default (``-2147483648 -2147483648`` is 23 characters).
MAX_REPLY_BYTES = 64
#: The project firmware's argument buffer (``argv1``) holds this many characters (32 incl. NUL).
MAX_PROFILE_ARGUMENT_CHARS = 31
#: ``f``'s MEAN is in 1/64 ticks per PID frame (Q6), at most 32767.
PROFILE_MEAN_SHIFT = 6
PROFILE_MEAN_MAX = 32767
#: ``f``'s DEPTH in thousandths, at most 900 (CarrierSpeedProfile's MAX_DEPTH 0.9).
PROFILE_DEPTH_UNIT = 1000
PROFILE_DEPTH_MAX = 900
#: ``f``'s REV (encoder counts per carrier revolution): 1..65535 (the angle is 16-bit).
PROFILE_REVOLUTION_MAX = 65535
#: ``i``'s PID rate range [Hz].
PID_RATE_MIN_HZ, PID_RATE_MAX_HZ = 1, 500

#: ``k``'s fields: LEAD [ms] and KS [PWM] 0..255, KV, KA and KQ 0..32767.
TUNING_LEAD_MAX_MS = 255
TUNING_GAIN_MAX = 32767
TUNING_FRICTION_MAX = 255

OK_REPLY = "OK"
#: The project firmware's refusal of ``f``, ``i`` or ``k`` arguments (nothing changed).
ERR_REPLY = "ERR"
INVALID_COMMAND_REPLY = "Invalid Command"

CHANNELS = ("left", "right")

_INTEGER = r"-?(?:0|[1-9][0-9]{0,9})"
_ENCODERS_RE = re.compile(rf"({_INTEGER}) ({_INTEGER})")
_BAUD_RE = re.compile(r" ?([1-9][0-9]{1,7})")
#: ``v``'s reply: "fishtail <version>" and key=value fields (unknown keys are for later versions).
_CAPABILITIES_RE = re.compile(r"fishtail ([1-9][0-9]{0,4})((?: [a-z_]{1,16}=[0-9]{1,6})*)")


class ReplyError(ValueError):
    """A reply that is not the expected one.

    Attributes:
        kind: one of :data:`REPLY_ERROR_KINDS`, for counting.
        reason: a human-readable explanation naming what was wrong.
        line: the offending bytes (may be truncated for display).
    """

    def __init__(self, kind: str, reason: str, line: bytes = b"") -> None:
        """Record the kind, reason and offending bytes."""
        super().__init__(f"{kind}: {reason}")
        self.kind = kind
        self.reason = reason
        self.line = bytes(line[:80])


#: Every ``ReplyError.kind``.
REPLY_ERROR_KINDS = (
    "empty",  # an empty line
    "binary",  # bytes outside printable ASCII
    "oversized",  # a line longer than the framer's limit
    "invalid_command",  # the board answered "Invalid Command"
    "unexpected",  # a well-formed reply to another command (replies out of step)
    "garbled",  # printable but not the expected format
    "out_of_range",  # a number outside the board's integer range
)


# --------------------------------------------------------------------------------------------
# Encoding


def _check_int16(name: str, value: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"{name} must be an int, got {type(value).__name__}")
    if not INT16_MIN <= value <= INT16_MAX:
        raise ValueError(
            f"{name} = {value} is outside the board's 16-bit int range "
            f"[{INT16_MIN}, {INT16_MAX}] (atoi would wrap it)"
        )
    return value


def encode_read_encoders() -> bytes:
    """``e``: read both encoder counts."""
    return b"e\r"


def encode_reset_encoders() -> bytes:
    """``r``: zero both encoder counts (also resets the PID: the motors stop until the next m)."""
    return b"r\r"


def encode_get_baud() -> bytes:
    """``b``: ask for the baud rate (a harmless probe: does the board answer?)."""
    return b"b\r"


def encode_motor_speeds(left: int, right: int) -> bytes:
    """``m left right``: target speeds in encoder ticks per PID frame (16-bit ints).

    Raises:
        ValueError: a target that is not an integer in the 16-bit range.
    """
    _check_int16("left ticks per frame", left)
    _check_int16("right ticks per frame", right)
    return f"m {left} {right}\r".encode("ascii")


def encode_stop() -> bytes:
    """``m 0 0``: stop both motors and reset the PID."""
    return encode_motor_speeds(0, 0)


def encode_raw_pwm(left: int, right: int) -> bytes:
    """``o left right``: raw PWM in [-255, 255] (joshnewans fork; elsewhere Invalid Command).

    Raises:
        ValueError: a PWM that is not an integer in [-255, 255].
    """
    for name, value in (("left PWM", left), ("right PWM", right)):
        _check_int16(name, value)
        if abs(value) > PWM_MAX:
            raise ValueError(f"{name} = {value} is outside [-{PWM_MAX}, {PWM_MAX}]")
    return f"o {left} {right}\r".encode("ascii")


def encode_update_pid(kp: int, kd: int, ki: int, ko: int) -> bytes:
    """``u kp:kd:ki:ko``: PID gains (integers; the whole argument must fit the board's buffer).

    Raises:
        ValueError: a gain that is not a 16-bit integer, or an argument longer than the
            firmware's buffer.
    """
    for name, value in (("kp", kp), ("kd", kd), ("ki", ki), ("ko", ko)):
        _check_int16(name, value)
    argument = f"{kp}:{kd}:{ki}:{ko}"
    if len(argument) > MAX_ARGUMENT_CHARS:
        raise ValueError(
            f"PID argument {argument!r} is {len(argument)} characters; the firmware's argument "
            f"buffer holds {MAX_ARGUMENT_CHARS} (overflow is undefined behaviour on the board)"
        )
    return f"u {argument}\r".encode("ascii")


def encode_query_firmware() -> bytes:
    """``v``: which firmware is this (the project's answers its capabilities; stock: Invalid)."""
    return b"v\r"


def _check_range(name: str, value: int, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise TypeError(f"{name} must be an int, got {type(value).__name__}")
    if not low <= value <= high:
        raise ValueError(f"{name} = {value} is outside [{low}, {high}]")
    return value


def encode_profile(mean_q6: int, depth_milli: int, phase_counts: int, revolution: int) -> bytes:
    """``f MEAN:DEPTH:PHASE:REV``: the board follows this carrier speed profile itself.

    ``mean_q6`` in 1/64 ticks per PID frame, ``depth_milli`` in thousandths, ``phase_counts`` the
    fastest point's encoder count in [0, revolution), ``revolution`` counts per carrier turn.

    Raises:
        ValueError: a field outside the firmware's range (it would answer ERR).
        TypeError: a field that is not an int.
    """
    _check_range("revolution", revolution, 1, PROFILE_REVOLUTION_MAX)
    _check_range("mean (1/64 ticks per frame)", mean_q6, 0, PROFILE_MEAN_MAX)
    _check_range("depth (thousandths)", depth_milli, 0, PROFILE_DEPTH_MAX)
    _check_range("phase (counts)", phase_counts, 0, revolution - 1)
    argument = f"{mean_q6}:{depth_milli}:{phase_counts}:{revolution}"
    assert len(argument) <= MAX_PROFILE_ARGUMENT_CHARS  # 21 at most
    return f"f {argument}\r".encode("ascii")


def encode_pid_rate(rate_hz: int) -> bytes:
    """``i HZ``: the project's firmware runs its PID at this rate (and stops the motors).

    Raises:
        ValueError: a rate outside [1, 500] Hz.
        TypeError: a rate that is not an int.
    """
    _check_range("PID rate (Hz)", rate_hz, PID_RATE_MIN_HZ, PID_RATE_MAX_HZ)
    return f"i {rate_hz}\r".encode("ascii")


@dataclasses.dataclass(frozen=True)
class ProfileTuning:
    """``k LEAD:KV:KA:KS[:KQ]``: how the project's firmware follows a profile.

    The law taken ``lead_ms`` ahead of the count, and a feed-forward PWM from the law's speed
    (``kv``, PWM per count/ms in 1/256), its change (``ka``, PWM per count/ms²), a constant
    (``ks``, PWM) and its square (``kq``, PWM per (count/ms)² in 1/256; None: not sent, which the
    firmware reads as 0). All 0 is the firmware's default loop.

    Raises:
        ValueError: a field outside the firmware's range (it would answer ERR).
        TypeError: a field that is not an int.
    """

    lead_ms: int
    kv: int
    ka: int
    ks: int
    kq: int | None = None

    def __post_init__(self) -> None:
        """The firmware's ranges (``setProfileTuning``)."""
        _check_range("LEAD (ms)", self.lead_ms, 0, TUNING_LEAD_MAX_MS)
        _check_range("KV", self.kv, 0, TUNING_GAIN_MAX)
        _check_range("KA", self.ka, 0, TUNING_GAIN_MAX)
        _check_range("KS", self.ks, 0, TUNING_FRICTION_MAX)
        if self.kq is not None:
            _check_range("KQ", self.kq, 0, TUNING_GAIN_MAX)

    @property
    def argument(self) -> str:
        """``LEAD:KV:KA:KS[:KQ]``."""
        fields: tuple[int, ...] = (self.lead_ms, self.kv, self.ka, self.ks)
        fields += () if self.kq is None else (self.kq,)
        return ":".join(map(str, fields))

    def encode(self) -> bytes:
        """The command's bytes (25 characters of argument at most: within ``argv1``)."""
        argument = self.argument
        assert len(argument) <= MAX_PROFILE_ARGUMENT_CHARS
        return f"k {argument}\r".encode("ascii")


_TUNING_RE = re.compile(r"(?:0|[1-9][0-9]{0,5})(?::(?:0|[1-9][0-9]{0,5})){3,4}")


def parse_profile_tuning(text: str) -> ProfileTuning | None:
    """``LEAD:KV:KA:KS[:KQ]`` (a parameter's value) as a :class:`ProfileTuning`; "" is None.

    Stricter than the firmware's ``atol`` and ``strtok_r``: four or five decimal integers
    without signs or spaces, colons between them (the firmware skips empty fields and ignores a
    sixth, which would shift or drop a field unnoticed).

    Raises:
        ValueError: anything else, or a field outside the firmware's range, with the reason.
    """
    stripped = text.strip()
    if not stripped:
        return None
    if _TUNING_RE.fullmatch(stripped) is None:
        raise ValueError(
            f"{text!r} is not LEAD:KV:KA:KS[:KQ] (four or five non-negative integers joined by "
            "colons, e.g. 8:5955:1889:5:690)"
        )
    fields = [int(field) for field in stripped.split(":")]
    return ProfileTuning(*fields)


def encode_profile_tuning(lead_ms: int, kv: int, ka: int, ks: int, kq: int | None = None) -> bytes:
    """``k LEAD:KV:KA:KS[:KQ]`` (see :class:`ProfileTuning`).

    Raises:
        ValueError: a field outside the firmware's range (it would answer ERR).
        TypeError: a field that is not an int.
    """
    return ProfileTuning(lead_ms, kv, ka, ks, kq).encode()


def channel_ticks(channel: str, ticks: int) -> tuple[int, int]:
    """(left, right) ticks for driving only ``channel`` ("left" or "right").

    Raises:
        ValueError: another channel name.
    """
    if channel == "left":
        return ticks, 0
    if channel == "right":
        return 0, ticks
    raise ValueError(f"channel must be 'left' or 'right', got {channel!r}")


# --------------------------------------------------------------------------------------------
# Framing and parsing


@dataclasses.dataclass(frozen=True)
class OversizedLine:
    """Marker returned by :class:`LineFramer` for a line longer than its limit (discarded)."""

    length: int
    head: bytes


class LineFramer:
    """Split a byte stream into reply lines (terminated by LF, a trailing CR stripped).

    A line longer than ``max_line_bytes`` is discarded and reported once as an
    :class:`OversizedLine` (with its first bytes), so that a babbling device cannot grow the
    buffer without bound.
    """

    def __init__(self, max_line_bytes: int = MAX_REPLY_BYTES) -> None:
        """Create an empty framer.

        Raises:
            ValueError: ``max_line_bytes`` < 1.
        """
        if max_line_bytes < 1:
            raise ValueError(f"max_line_bytes must be >= 1, got {max_line_bytes}")
        self.max_line_bytes = max_line_bytes
        self._buffer = bytearray()
        self._discarding = 0  # bytes dropped so far from an oversized line (0: not discarding)
        self._head = b""
        self._ends_cr = False  # the last byte before the coming LF is a CR

    @property
    def pending(self) -> bytes:
        """Bytes of an incomplete line received so far."""
        return bytes(self._buffer)

    def clear(self) -> None:
        """Forget everything buffered (after a resynchronisation)."""
        self._buffer.clear()
        self._discarding = 0
        self._head = b""

    def feed(self, data: bytes) -> list[bytes | OversizedLine]:
        """Add received bytes; return the lines they complete, in order."""
        out: list[bytes | OversizedLine] = []
        start = 0
        while start < len(data):
            end = data.find(b"\n", start)
            chunk = data[start:] if end < 0 else data[start:end]
            if chunk:
                self._ends_cr = chunk.endswith(b"\r")
            if self._discarding:
                self._discarding += len(chunk)
            else:
                self._buffer += chunk
                if len(self._buffer) > self.max_line_bytes + 1:  # +1: the CR before the LF
                    self._discarding = len(self._buffer)
                    self._head = bytes(self._buffer[:24])
                    self._buffer.clear()
            if end < 0:
                break
            if self._discarding:
                out.append(OversizedLine(self._discarding - self._ends_cr, self._head))
                self._discarding = 0
                self._head = b""
            else:
                line = bytes(self._buffer)
                self._buffer.clear()
                if line.endswith(b"\r"):
                    line = line[:-1]
                if len(line) > self.max_line_bytes:
                    out.append(OversizedLine(len(line), line[:24]))
                else:
                    out.append(line)
            start = end + 1
        return out


def _text(line: bytes) -> str:
    """Printable-ASCII text of a line, or a ReplyError naming the first bad byte."""
    if not line:
        raise ReplyError("empty", "empty reply line", line)
    for index, byte in enumerate(line):
        if not 0x20 <= byte <= 0x7E:
            raise ReplyError(
                "binary",
                f"non-printable byte 0x{byte:02x} at offset {index} in {bytes(line[:40])!r}",
                line,
            )
    return line.decode("ascii")


def _common_rejections(text: str, line: bytes, expected: str) -> None:
    if text == INVALID_COMMAND_REPLY:
        raise ReplyError(
            "invalid_command", f"the board answered 'Invalid Command' where {expected}", line
        )


def parse_encoders(line: bytes) -> tuple[int, int]:
    """Parse the reply to ``e``: two signed 32-bit integers separated by one space.

    Raises:
        ReplyError: anything else, its ``kind`` saying what (``garbled``, ``binary``,
            ``out_of_range``, ``unexpected``, ``invalid_command``, ...).
    """
    expected = "encoder counts '<left> <right>' were expected"
    text = _text(line)
    _common_rejections(text, line, expected)
    if text == OK_REPLY:
        raise ReplyError("unexpected", f"got 'OK' where {expected} (replies out of step)", line)
    match = _ENCODERS_RE.fullmatch(text)
    if match is None:
        fields = text.split(" ")
        if len(fields) != 2:
            detail = f"{len(fields)} space-separated fields"
        else:
            detail = "a field that is not a decimal integer"
        raise ReplyError("garbled", f"{text[:40]!r} has {detail}; {expected}", line)
    left, right = int(match.group(1)), int(match.group(2))
    for name, value in (("left", left), ("right", right)):
        if not INT32_MIN <= value <= INT32_MAX:
            raise ReplyError(
                "out_of_range", f"{name} count {value} is outside the signed 32-bit range", line
            )
    return left, right


def parse_ok(line: bytes) -> None:
    """Parse the reply to ``m``, ``r``, ``o`` or ``u``: exactly ``OK``.

    Raises:
        ReplyError: anything else (``unexpected`` for another command's reply).
    """
    expected = "'OK' was expected"
    text = _text(line)
    _common_rejections(text, line, expected)
    if text == OK_REPLY:
        return
    if _ENCODERS_RE.fullmatch(text) or _BAUD_RE.fullmatch(text):
        raise ReplyError("unexpected", f"got {text!r} where {expected} (replies out of step)", line)
    raise ReplyError("garbled", f"got {text[:40]!r} where {expected}", line)


def parse_accepted(line: bytes) -> bool:
    """Parse the reply to ``f``, ``i`` or ``k``: True for ``OK``, False for ``ERR`` (refused).

    Raises:
        ReplyError: ``invalid_command`` (a firmware without the command: the stock one, or
            version 1's for ``k``), or anything else (``unexpected`` for another command's reply).
    """
    expected = "'OK' or 'ERR' was expected"
    text = _text(line)
    _common_rejections(text, line, expected)
    if text in (OK_REPLY, ERR_REPLY):
        return text == OK_REPLY
    if _ENCODERS_RE.fullmatch(text) or _BAUD_RE.fullmatch(text):
        raise ReplyError("unexpected", f"got {text!r} where {expected} (replies out of step)", line)
    raise ReplyError("garbled", f"got {text[:40]!r} where {expected}", line)


def parse_baud(line: bytes) -> int:
    """Parse the reply to ``b``: the baud rate, with or without a leading space.

    Raises:
        ReplyError: anything else (``unexpected`` for another command's reply).
    """
    expected = "a baud rate was expected"
    text = _text(line)
    _common_rejections(text, line, expected)
    match = _BAUD_RE.fullmatch(text)
    if match is None:
        kind = "unexpected" if text == OK_REPLY or _ENCODERS_RE.fullmatch(text) else "garbled"
        raise ReplyError(kind, f"got {text[:40]!r} where {expected}", line)
    return int(match.group(1))


@dataclasses.dataclass(frozen=True)
class BoardCapabilities:
    """What the project's firmware said to ``v``: its version, PID rate and frame, profile."""

    version: int
    pid_rate_hz: int
    #: The PID frame in whole milliseconds (``1000 / pid_rate_hz`` in integers).
    pid_frame_ms: int
    #: Whether it follows a carrier speed profile (``f``).
    profile: bool

    def describe(self) -> str:
        """E.g. ``fishtail 1, PID 30 Hz (33 ms), profile``."""
        profile = "profile" if self.profile else "no profile"
        rate = f"PID {self.pid_rate_hz} Hz ({self.pid_frame_ms} ms)"
        return f"fishtail {self.version}, {rate}, {profile}"


def parse_capabilities(line: bytes) -> BoardCapabilities | None:
    """Parse the reply to ``v``: the project firmware's capabilities, None for stock firmware.

    ``fishtail 1 pid_hz=30 pid_ms=33 profile=1``; fields this version does not know are ignored
    (a later firmware may add some). The stock firmware answers ``Invalid Command``: None.

    Raises:
        ReplyError: anything else: ``garbled`` (not the format, a field missing or twice, a frame
            that does not match the rate), ``out_of_range`` (a rate outside 1..500 Hz, a flag
            not 0/1), ``unexpected`` (another command's reply), ``binary``, ``empty``.
    """
    expected = "the firmware's capabilities 'fishtail <version> pid_hz=.. pid_ms=.. profile=..'"
    text = _text(line)
    if text == INVALID_COMMAND_REPLY:
        return None
    match = _CAPABILITIES_RE.fullmatch(text)
    if match is None:
        stray = text == OK_REPLY or _ENCODERS_RE.fullmatch(text) or _BAUD_RE.fullmatch(text)
        kind = "unexpected" if stray else "garbled"
        raise ReplyError(kind, f"got {text[:40]!r} where {expected} was expected", line)
    fields: dict[str, int] = {}
    for item in match.group(2).split():
        key, value = item.split("=")
        if key in fields:
            raise ReplyError("garbled", f"{key} twice in {text[:60]!r}", line)
        fields[key] = int(value)
    missing = [key for key in ("pid_hz", "pid_ms", "profile") if key not in fields]
    if missing:
        raise ReplyError("garbled", f"{', '.join(missing)} missing from {text[:60]!r}", line)
    rate, frame, profile = fields["pid_hz"], fields["pid_ms"], fields["profile"]
    if not PID_RATE_MIN_HZ <= rate <= PID_RATE_MAX_HZ:
        raise ReplyError(
            "out_of_range",
            f"pid_hz={rate} is outside [{PID_RATE_MIN_HZ}, {PID_RATE_MAX_HZ}]",
            line,
        )
    if frame != 1000 // rate:
        raise ReplyError(
            "garbled", f"pid_ms={frame} is not 1000 / pid_hz={rate} ({1000 // rate})", line
        )
    if profile not in (0, 1):
        raise ReplyError("out_of_range", f"profile={profile} is neither 0 nor 1", line)
    return BoardCapabilities(int(match.group(1)), rate, frame, bool(profile))
