"""The project firmware's commands in the codec (``v``, ``f``, ``i``) and who follows a profile."""

from __future__ import annotations

import doctest
import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fishtail_driver import board_profile
from fishtail_driver.board_profile import ProfileFields, board_mode, board_revolution
from fishtail_driver.protocol import (
    BoardCapabilities,
    ReplyError,
    encode_pid_rate,
    encode_profile,
    encode_query_firmware,
    parse_capabilities,
)
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
from fishtail_plant.motor.board_units import Scale

POLOLU = Scale(64, 30.0)
FISHTAIL = BoardCapabilities(1, 30, 33, True)


def test_doctests():
    result = doctest.testmod(board_profile)
    assert result.attempted > 0 and result.failed == 0


def test_the_new_commands_encode_as_the_firmware_reads_them():
    assert encode_query_firmware() == b"v\r"
    assert encode_profile(1229, 500, 500, 1920) == b"f 1229:500:500:1920\r"
    assert encode_profile(32767, 900, 65534, 65535) == b"f 32767:900:65534:65535\r"
    assert encode_profile(0, 0, 0, 1) == b"f 0:0:0:1\r"
    assert encode_pid_rate(1) == b"i 1\r" and encode_pid_rate(500) == b"i 500\r"


@pytest.mark.parametrize(
    ("call", "words"),
    [
        (lambda: encode_profile(32768, 0, 0, 1920), "mean"),
        (lambda: encode_profile(-1, 0, 0, 1920), "mean"),
        (lambda: encode_profile(64, 901, 0, 1920), "depth"),
        (lambda: encode_profile(64, 0, 1920, 1920), "phase"),
        (lambda: encode_profile(64, 0, -1, 1920), "phase"),
        (lambda: encode_profile(64, 0, 0, 0), "revolution"),
        (lambda: encode_profile(64, 0, 0, 65536), "revolution"),
        (lambda: encode_pid_rate(0), "PID rate"),
        (lambda: encode_pid_rate(501), "PID rate"),
    ],
)
def test_values_the_firmware_would_answer_err_are_refused(call, words):
    with pytest.raises(ValueError, match=words):
        call()


@pytest.mark.parametrize("value", [1.5, math.nan, True, "64"])
def test_non_integer_fields_are_refused(value):
    with pytest.raises(TypeError):
        encode_profile(value, 0, 0, 1920)
    with pytest.raises(TypeError):
        encode_pid_rate(value)


def test_the_capability_reply_is_parsed_and_invalid_command_means_stock():
    assert parse_capabilities(b"fishtail 1 pid_hz=30 pid_ms=33 profile=1") == FISHTAIL
    assert parse_capabilities(b"fishtail 1 pid_hz=100 pid_ms=10 profile=1") == (
        BoardCapabilities(1, 100, 10, True)
    )
    # A later version may add fields (ignored) and say it has no profile.
    assert parse_capabilities(b"fishtail 2 pid_hz=500 pid_ms=2 profile=0 pivot=1") == (
        BoardCapabilities(2, 500, 2, False)
    )
    assert parse_capabilities(b"Invalid Command") is None
    assert FISHTAIL.describe() == "fishtail 1, PID 30 Hz (33 ms), profile"


@pytest.mark.parametrize(
    ("line", "kind", "words"),
    [
        (b"", "empty", "empty"),
        (b"fishtail 1 pid_hz=30 pid_ms=33 profile=1\x00", "binary", "0x00"),
        (b"fishtail 1 pid_hz=30 pid_ms=33", "garbled", "profile missing"),
        (b"fishtail 1 pid_hz=30 pid_hz=30 pid_ms=33 profile=1", "garbled", "twice"),
        (b"fishtail 1 pid_hz=30 pid_ms=30 profile=1", "garbled", "not 1000 / pid_hz"),
        (b"fishtail 1 pid_hz=0 pid_ms=33 profile=1", "out_of_range", "pid_hz=0"),
        (b"fishtail 1 pid_hz=501 pid_ms=1 profile=1", "out_of_range", "pid_hz=501"),
        (b"fishtail 1 pid_hz=30 pid_ms=33 profile=2", "out_of_range", "profile=2"),
        (b"fishtail 1 pid_hz=nan pid_ms=33 profile=1", "garbled", "capabilities"),
        (b"fishtail 1 pid_hz=inf pid_ms=33 profile=1", "garbled", "capabilities"),
        (b"fishtail 1 pid_hz=-30 pid_ms=33 profile=1", "garbled", "capabilities"),
        (b"fishtail 1 pid_hz=3e1 pid_ms=33 profile=1", "garbled", "capabilities"),
        (b"fishtail 0 pid_hz=30 pid_ms=33 profile=1", "garbled", "capabilities"),
        (b"fishtail NaN pid_hz=30 pid_ms=33 profile=1", "garbled", "capabilities"),
        (b"fishtail 1  pid_hz=30 pid_ms=33 profile=1", "garbled", "capabilities"),
        (b"fishtail 1 pid_hz=1234567 pid_ms=0 profile=1", "garbled", "capabilities"),
        (b"fishtai", "garbled", "capabilities"),
        (b"OK", "unexpected", "'OK'"),
        (b"12 34", "unexpected", "'12 34'"),
        (b" 57600", "unexpected", "57600"),
        (b"ERR", "garbled", "'ERR'"),
    ],
)
def test_garbled_capability_replies_are_reply_errors_with_a_reason(line, kind, words):
    with pytest.raises(ReplyError) as caught:
        parse_capabilities(line)
    assert caught.value.kind == kind and words in caught.value.reason, caught.value


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=80))
def test_fuzz_the_capability_parser_raises_only_reply_errors(data):
    try:
        result = parse_capabilities(data)
    except ReplyError:
        return
    assert result is None or 1 <= result.pid_rate_hz <= 500


def test_who_follows_the_profile():
    on_board = board_mode(FISHTAIL, True, POLOLU)
    assert on_board.on_board and on_board.firmware == "fishtail 1 (profile on board)"
    stock = board_mode(None, True, POLOLU)
    assert not stock.on_board
    assert stock.firmware == "stock ROSArduinoBridge (profile on host)"
    failed = board_mode("timeouts: no reply to 'v' within 0.1 s", True, POLOLU)
    assert not failed.on_board and "'v' failed (timeouts" in failed.firmware
    assert "profile_on_board is false" in board_mode(FISHTAIL, False, POLOLU).firmware
    no_profile = BoardCapabilities(2, 30, 33, False)
    assert not board_mode(no_profile, True, POLOLU).on_board
    # The board takes a whole number of counts per carrier turn, at most 65535.
    assert board_revolution(POLOLU) == 1920
    assert "not a whole number" in str(board_revolution(Scale(64, 30.01)))
    assert "over 65535" in str(board_revolution(Scale(2048, 50.0)))
    assert not board_mode(FISHTAIL, True, Scale(64, 30.01)).on_board


def test_the_profile_becomes_fs_fields_with_the_phase_at_the_boards_count():
    mode = board_mode(FISHTAIL, True, POLOLU)
    # 1 Hz at 30 Hz: round(1920 x 0.033 x 64) = 4055 (docs/firmware.md).
    fields = mode.fields(CarrierSpeedProfile(2 * math.pi, 0.5, 0.0), zero_count=0)
    assert fields == ProfileFields(4055, 500, 0, 1920)
    # The fastest point a quarter turn on, the board's count 1000 at the driver's angle 0.
    fields = mode.fields(CarrierSpeedProfile(2 * math.pi, 0.25, math.pi / 2), zero_count=1000)
    assert fields == ProfileFields(4055, 250, 1480, 1920)
    # Negative counts and phases wrap into [0, revolution).
    fields = mode.fields(CarrierSpeedProfile(2 * math.pi, 0.5, -math.pi), zero_count=-5)
    assert fields is not None and fields.phase_counts == (-5 - 960) % 1920
    # At 100 Hz (10 ms frames), the board's frame is used: 1229 (docs/firmware.md).
    fast = board_mode(BoardCapabilities(1, 100, 10, True), True, POLOLU)
    fields = fast.fields(CarrierSpeedProfile(2 * math.pi, 0.5, 0.0), 0)
    assert fields is not None and fields.mean_q6 == 1229
    # A stop is m 0 0, not f; too fast for MEAN's 16 bits: the host follows it.
    assert mode.fields(CarrierSpeedProfile(0.0), 0) is None
    assert not mode.follows(CarrierSpeedProfile(0.0))
    big = board_mode(FISHTAIL, True, Scale(2048, 30.0))
    too_fast = CarrierSpeedProfile(20.0, 0.5)
    assert big.fields(too_fast, 0) is None and not big.follows(too_fast)
    assert "exceeds f's 32767/64" in big.overflow_reason(too_fast)
    assert not board_mode(None, True, POLOLU).follows(CarrierSpeedProfile(6.0))


@settings(max_examples=200, deadline=None)
@given(
    st.floats(0.0, 20.0),
    st.floats(0.0, 0.9),
    st.floats(-100.0, 100.0),
    st.integers(-(2**31), 2**31 - 1),
)
def test_every_profile_the_driver_accepts_encodes(mean, depth, phase, zero):
    mode = board_mode(FISHTAIL, True, POLOLU)
    fields = mode.fields(CarrierSpeedProfile(mean, depth, phase), zero)
    if fields is not None:
        assert fields.encode().startswith(b"f ")


def test_k_encodes_within_the_firmware_s_ranges_and_refuses_what_it_would_answer_err():
    from fishtail_driver.protocol import ProfileTuning, encode_profile_tuning

    assert encode_profile_tuning(8, 5955, 1889, 5, 690) == b"k 8:5955:1889:5:690\r"
    assert encode_profile_tuning(8, 5955, 1889, 5) == b"k 8:5955:1889:5\r"  # KQ left out
    assert encode_profile_tuning(0, 0, 0, 0, 0) == b"k 0:0:0:0:0\r"  # the default loop
    largest = encode_profile_tuning(255, 32767, 32767, 255, 32767)
    assert largest == b"k 255:32767:32767:255:32767\r" and len(largest) - 3 <= 31  # argv1
    refused = ((256, 0, 0, 0), (-1, 0, 0, 0), (0, 32768, 0, 0), (0, 0, 32768, 0),
               (0, 0, 0, 256), (0, 0, 0, -1), (0, 0, 0, 0, 32768), (0, 0, 0, 0, -1))  # fmt: skip
    for fields in refused:
        with pytest.raises(ValueError, match="outside"):
            encode_profile_tuning(*fields)
    with pytest.raises(TypeError):
        ProfileTuning(8, 5955.0, 1889, 5)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    "text",
    ["8:5955:1889", "8::5955:1889:5", "8:5955:1889:5:690:1", "-8:5955:1889:5", "+8:1:1:1",
     "8 :5955:1889:5", "8:5955:1889:5:", "a:b:c:d", "0x8:1:1:1", "08:1:1:1", "8;1;1;1",
     "256:1:1:1", "8:99999:1:1", "1:2:3:256", "1:2:3:4:1000000"],
)  # fmt: skip
def test_a_malformed_tuning_parameter_is_refused_with_the_reason(text):
    from fishtail_driver.protocol import parse_profile_tuning

    with pytest.raises(ValueError, match=r"LEAD:KV:KA:KS|outside"):
        parse_profile_tuning(text)


def test_a_tuning_parameter_reads_as_the_firmware_s_fields():
    from fishtail_driver.protocol import ProfileTuning, parse_profile_tuning

    assert parse_profile_tuning("") is None and parse_profile_tuning("  ") is None
    assert parse_profile_tuning("8:5955:1889:5:690") == ProfileTuning(8, 5955, 1889, 5, 690)
    assert parse_profile_tuning(" 8:5955:1889:5 ") == ProfileTuning(8, 5955, 1889, 5)
    assert parse_profile_tuning("0:0:0:0").argument == "0:0:0:0"


def test_ok_err_and_invalid_command_answer_k():
    from fishtail_driver.protocol import parse_accepted

    assert parse_accepted(b"OK") is True
    assert parse_accepted(b"ERR") is False
    with pytest.raises(ReplyError) as invalid:
        parse_accepted(b"Invalid Command")
    assert invalid.value.kind == "invalid_command"
    for line, kind in ((b"12 13", "unexpected"), (b"57600", "unexpected"), (b"OKAY", "garbled"),
                       (b"", "empty"), (b"O\x00K", "binary")):  # fmt: skip
        with pytest.raises(ReplyError) as error:
            parse_accepted(line)
        assert error.value.kind == kind, line


def test_the_tuning_goes_out_where_the_board_follows_the_profile_and_its_answer_is_noted():
    from fishtail_driver.board_profile import TUNING_NOT_SET, tune_board
    from fishtail_driver.protocol import ProfileTuning
    from fishtail_driver.serial_link import Answered, Failed

    tuning = ProfileTuning(8, 5955, 1889, 5, 690)
    sent: list[bytes] = []

    def answering(line: bytes):
        def exchange(payload, parse):
            sent.append(payload)
            return Answered(parse(line), 0.0, 0.0)

        return exchange

    on_board = board_mode(FISHTAIL, True, POLOLU)
    acked = tune_board(on_board, tuning, answering(b"OK"))
    assert acked.tuning == "k 8:5955:1889:5:690 (acknowledged)" and acked.on_board
    assert sent == [b"k 8:5955:1889:5:690\r"]
    for line in (b"ERR", b"Invalid Command"):
        refused = tune_board(on_board, tuning, answering(line))
        assert refused.tuning.startswith("refused by the board: k 8:5955:1889:5:690 answered")
        assert line.decode() in refused.tuning and refused.on_board  # f still goes out
    lost = tune_board(on_board, tuning, lambda payload, parse: Failed("timeouts", "no reply"))
    assert lost.tuning.startswith("not acknowledged: k 8:") and "timeouts" in lost.tuning
    sent.clear()
    # Not sent: none set, the stock firmware, the host following, v failed.
    assert tune_board(on_board, None, answering(b"OK")).tuning == TUNING_NOT_SET
    stock = tune_board(board_mode(None, True, POLOLU), tuning, answering(b"OK"))
    assert stock.tuning == "k 8:5955:1889:5:690 not sent (stock firmware)"
    host = tune_board(board_mode(FISHTAIL, False, POLOLU), tuning, answering(b"OK"))
    assert host.tuning == "k 8:5955:1889:5:690 not sent (profile on host)"
    unknown = tune_board(board_mode("timeouts: no reply", True, POLOLU), tuning, answering(b"OK"))
    assert unknown.tuning.endswith("not sent (firmware unknown)")
    assert sent == []
