"""The ROSArduinoBridge codec: encoding, framing, parsing (unit + fuzzing), units."""

from __future__ import annotations

import doctest

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fishtail_boards.board_firmware import Firmware, FirmwareConfig, atoi16
from fishtail_driver import protocol
from fishtail_driver.protocol import (
    REPLY_ERROR_KINDS,
    LineFramer,
    OversizedLine,
    ReplyError,
    channel_ticks,
    encode_get_baud,
    encode_motor_speeds,
    encode_raw_pwm,
    encode_read_encoders,
    encode_reset_encoders,
    encode_stop,
    encode_update_pid,
    parse_baud,
    parse_encoders,
    parse_ok,
)
from fishtail_plant.motor.board_units import (
    INT16_MAX,
    INT16_MIN,
    INT32_MAX,
    INT32_MIN,
)

int16 = st.integers(INT16_MIN, INT16_MAX)
int32 = st.integers(INT32_MIN, INT32_MAX)


def test_doctests():
    """The examples in the module documentation hold."""
    result = doctest.testmod(protocol)
    assert result.failed == 0 and result.attempted >= 2


# --- encoding ---------------------------------------------------------------------------------


def test_commands_are_cr_terminated_ascii():
    """Each command is its letter, space-separated integers and one CR."""
    assert encode_read_encoders() == b"e\r"
    assert encode_reset_encoders() == b"r\r"
    assert encode_get_baud() == b"b\r"
    assert encode_motor_speeds(12, -7) == b"m 12 -7\r"
    assert encode_stop() == b"m 0 0\r"
    assert encode_raw_pwm(-255, 100) == b"o -255 100\r"
    assert encode_update_pid(20, 12, 0, 50) == b"u 20:12:0:50\r"


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: encode_motor_speeds(32768, 0), "16-bit"),
        (lambda: encode_motor_speeds(0, -32769), "16-bit"),
        (lambda: encode_raw_pwm(256, 0), "-255, 255"),
        (lambda: encode_update_pid(-32768, -32768, -32768, -32768), "buffer"),
    ],
)
def test_unsendable_values_are_refused_with_the_reason(call, message):
    """Values the firmware would wrap or overflow never reach the wire."""
    with pytest.raises(ValueError, match=message):
        call()


def test_non_integers_are_refused():
    """Floats and bools are not sent (atoi would truncate 1.9 to 1)."""
    with pytest.raises(TypeError):
        encode_motor_speeds(1.9, 0)
    with pytest.raises(TypeError):
        encode_motor_speeds(True, 0)


def test_channel_ticks():
    """Only the tail's channel gets the speed."""
    assert channel_ticks("left", 5) == (5, 0)
    assert channel_ticks("right", 5) == (0, 5)
    with pytest.raises(ValueError, match="left"):
        channel_ticks("both", 5)


@given(int16, int16)
def test_motor_command_round_trips_through_the_firmware_parser(left, right):
    """What we encode is exactly what the firmware's byte parser and atoi make of it."""
    firmware = Firmware(FirmwareConfig(), 0.0, warn=lambda _: None)
    parsed = [firmware.feed_byte(byte) for byte in encode_motor_speeds(left, right)]
    command = parsed[-1]
    assert all(p is None for p in parsed[:-1]) and command is not None
    assert chr(command.cmd) == "m"
    assert (atoi16(command.argv1), atoi16(command.argv2)) == (left, right)


# --- framing ------------------------------------------------------------------------------------


def test_framer_splits_lines_across_chunks_and_strips_cr():
    """Lines end at LF; the CR before it goes; a line may arrive in pieces."""
    framer = LineFramer()
    assert framer.feed(b"12 3") == []
    assert framer.pending == b"12 3"
    assert framer.feed(b"4\r\nOK\r\n5") == [b"12 34", b"OK"]
    assert framer.feed(b"7\n") == [b"57"]  # a bare LF also ends a line


def test_framer_discards_an_oversized_line_once_and_recovers():
    """A babbling device cannot grow the buffer; the next good line gets through."""
    framer = LineFramer(max_line_bytes=10)
    out = framer.feed(b"x" * 25)
    assert out == [] and framer.pending == b""
    out = framer.feed(b"y" * 1000 + b"\r\nOK\r\n")
    assert len(out) == 2 and isinstance(out[0], OversizedLine) and out[0].length > 1000
    assert out[1] == b"OK"
    (line,) = framer.feed(b"0123456789A\r\n")
    assert line.length == 11 and line.head.startswith(b"0123456789A")


# --- parsing ------------------------------------------------------------------------------------


def test_parse_valid_replies():
    """The replies the firmware sends, including both forms of the baud reply."""
    assert parse_encoders(b"0 0") == (0, 0)
    assert parse_encoders(b"-2147483648 2147483647") == (INT32_MIN, INT32_MAX)
    parse_ok(b"OK")
    assert parse_baud(b" 57600") == 57600
    assert parse_baud(b"57600") == 57600
    assert parse_baud(b"1000000") == 1000000


@pytest.mark.parametrize(
    ("parser", "line", "kind", "words"),
    [
        (parse_encoders, b"", "empty", "empty"),
        (parse_encoders, b"12 \x0034", "binary", "0x00 at offset 3"),
        (parse_encoders, b"12 3\xff", "binary", "0xff"),
        (parse_encoders, b"Invalid Command", "invalid_command", "Invalid Command"),
        (parse_encoders, b"OK", "unexpected", "out of step"),
        (parse_encoders, b"12", "garbled", "1 space-separated fields"),
        (parse_encoders, b"1 2 3", "garbled", "3 space-separated"),
        (parse_encoders, b"1  2", "garbled", "3 space-separated"),
        (parse_encoders, b"1 x2", "garbled", "not a decimal integer"),
        (parse_encoders, b"+1 2", "garbled", "not a decimal integer"),
        (parse_encoders, b"01 2", "garbled", "not a decimal integer"),
        (parse_encoders, b"1_0 2", "garbled", "not a decimal integer"),
        (parse_encoders, b"2147483648 0", "out_of_range", "left count 2147483648"),
        (parse_encoders, b"0 -2147483649", "out_of_range", "right count"),
        (parse_ok, b"12 34", "unexpected", "out of step"),
        (parse_ok, b" 57600", "unexpected", "out of step"),
        (parse_ok, b"OK!", "garbled", "'OK!'"),
        (parse_ok, b"Invalid Command", "invalid_command", "'OK' was expected"),
        (parse_baud, b"OK", "unexpected", "baud rate"),
        (parse_baud, b"5760O", "garbled", "baud rate"),
        (parse_baud, b"  57600", "garbled", "baud rate"),
    ],
)
def test_malformed_replies_are_rejected_with_a_precise_reason(parser, line, kind, words):
    """Each malformed reply raises ReplyError naming its kind and what was wrong."""
    with pytest.raises(ReplyError) as caught:
        parser(line)
    assert caught.value.kind == kind
    assert words in caught.value.reason


@settings(max_examples=400, deadline=None)
@given(st.binary(max_size=200))
def test_fuzz_parsers_raise_only_reply_errors(data):
    """Arbitrary bytes: every parser returns a well-typed value or raises ReplyError."""
    for parser in (parse_encoders, parse_ok, parse_baud):
        try:
            value = parser(data)
        except ReplyError as error:
            assert error.kind in REPLY_ERROR_KINDS
            assert error.reason
            continue
        if parser is parse_encoders:
            left, right = value
            assert INT32_MIN <= left <= INT32_MAX and INT32_MIN <= right <= INT32_MAX
        elif parser is parse_baud:
            assert isinstance(value, int) and value > 0


@settings(max_examples=300, deadline=None)
@given(st.lists(st.binary(max_size=80), max_size=12), st.integers(8, 64))
def test_fuzz_framer_then_parsers(chunks, limit):
    """Arbitrary chunked bytes through the framer and the parsers: never another exception."""
    framer = LineFramer(max_line_bytes=limit)
    for chunk in chunks:
        for line in framer.feed(chunk):
            if isinstance(line, OversizedLine):
                assert line.length > limit
                continue
            assert len(line) <= limit and b"\n" not in line
            for parser in (parse_encoders, parse_ok, parse_baud):
                try:
                    parser(line)
                except ReplyError:
                    pass
    assert len(framer.pending) <= limit + 1


@given(int32, int32)
def test_encoder_replies_round_trip(left, right):
    """Whatever the board prints for two counts parses back to them."""
    assert parse_encoders(f"{left} {right}".encode()) == (left, right)


# --- units --------------------------------------------------------------------------------------


def test_the_firmwares_atoi_wraps_to_an_avr_int():
    assert atoi16(b"40000") == -25536
    assert atoi16(b"1.9") == 1 and atoi16(b"junk") == 0 and atoi16(b"\n-12x") == -12
