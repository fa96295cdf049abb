import argparse
import math

import pytest

from fishtail_common.command_line import (
    DURATION,
    OneLineErrorParser,
    add_parameter_flags,
    add_parameter_options,
    finite_number,
    spaced_range,
    value_list,
)
from fishtail_common.parameters import ParameterSpec

SPEED = ParameterSpec("speed", 4.0, "carrier speed", "rad/s", 0.0, exclusive_minimum=True)
STEPS = ParameterSpec("steps_per_beat", 32, "steps per beat", "", 4, 100_000)
MECHANISM = ParameterSpec("mechanism", "oscillatory", "tail", choices=("oscillatory", "undulatory"))
RADIUS = ParameterSpec("ring_radius_m", 0.05, "ring radius", "m", 0.001, 10.0)


def parser() -> OneLineErrorParser:
    result = OneLineErrorParser(prog="fishtail-demo")
    commands = result.add_subparsers(dest="command", required=True)
    run = commands.add_parser("run")
    add_parameter_options(run, [SPEED, STEPS])
    add_parameter_options(run, [MECHANISM], optional=True)
    add_parameter_flags(run.add_argument_group("geometry"), [RADIUS])
    return result


def test_options_have_the_specs_defaults_types_and_names():
    arguments = parser().parse_args(["run", "--steps-per-beat", "64", "--speed", "2"])
    assert (arguments.speed, arguments.steps_per_beat) == (2.0, 64)
    assert type(arguments.steps_per_beat) is int
    assert arguments.mechanism is None and arguments.ring_radius_m is None
    defaults = parser().parse_args(["run"])
    assert (defaults.speed, defaults.steps_per_beat) == (4.0, 32)


@pytest.mark.parametrize(
    ("argv", "words"),
    [
        (["--speed", "0"], "argument --speed: speed = 0.0 is outside (0.0, inf] rad/s"),
        (["--speed", "fast"], "argument --speed: not a number: 'fast'"),
        (["--speed", "inf"], "speed must be finite"),
        (["--steps-per-beat", "2"], "steps_per_beat = 2 is outside [4, 100000]"),
        (["--steps-per-beat", "4.5"], "not an integer: '4.5'"),
        (["--mechanism", "wiggly"], "mechanism must be one of oscillatory, undulatory"),
        (["--ring-radius-m", "x"], "argument --ring-radius-m: not a number: 'x'"),
    ],
)
def test_a_bad_value_is_one_line_with_the_specs_message_and_status_2(capsys, argv, words):
    with pytest.raises(SystemExit) as raised:
        parser().parse_args(["run", *argv])
    assert raised.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith("fishtail-demo: error: ") and err.count("\n") == 1, err
    assert words in err and err.endswith("(see fishtail-demo run --help)\n")


def test_override_flags_leave_the_range_to_the_command():
    # Merged with a parameter file and checked with it: one message for either source.
    assert math.isnan(parser().parse_args(["run", "--ring-radius-m", "nan"]).ring_radius_m)
    assert parser().parse_args(["run", "--ring-radius-m", "-1"]).ring_radius_m == -1.0


def test_help_gives_text_unit_range_and_default_once(capsys):
    with pytest.raises(SystemExit):
        parser().parse_args(["run", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--speed RAD/S carrier speed [rad/s] (> 0; default 4)" in text
    assert "--steps-per-beat N steps per beat (4 to 100000; default 32)" in text
    assert "--mechanism {oscillatory,undulatory} tail" in text
    assert "--ring-radius-m M ring radius [m] (0.001 to 10; default 0.05)" in text


def test_a_list_checks_each_item_by_the_spec():
    assert value_list(SPEED, "2, 4", 5) == [2.0, 4.0]
    for text, words in [
        ("2,-4", "speed = -4.0 is outside"),
        (",", "no carrier speed in ','"),
        ("1,2,3", "at most 2"),
    ]:
        with pytest.raises(argparse.ArgumentTypeError, match=words):
            value_list(SPEED, text, 2)


@pytest.mark.parametrize(
    ("text", "words"),
    [
        ("2:8", "expected first:last:count"),
        ("8:2:4", "last 2 must be above first 8"),
        ("2:2:4", "last 2 must be above first 2"),
        ("2:8:1", "steps_per_beat = 1 is outside"),
        ("0:8:4", "speed = 0.0 is outside"),
    ],
)
def test_a_range_checks_its_ends_count_and_order(text, words):
    assert spaced_range(SPEED, STEPS, "2:8:4") == (2.0, 8.0, 4)
    with pytest.raises(argparse.ArgumentTypeError, match=words):
        spaced_range(SPEED, STEPS, text)


def test_a_duration_is_optional_and_positive(capsys):
    parser = OneLineErrorParser(prog="fishtail-demo")
    add_parameter_options(parser, [DURATION], optional=True)
    assert parser.parse_args([]).duration is None
    assert parser.parse_args(["--duration", "0.5"]).duration == 0.5
    with pytest.raises(SystemExit):
        parser.parse_args(["--duration", "0"])
    assert "duration = 0.0 is outside (0.0, inf] s" in capsys.readouterr().err


def test_a_finite_number():
    assert finite_number("-2.5") == -2.5
    for text, words in [("nan", "not a finite number"), ("x", "not a number")]:
        with pytest.raises(argparse.ArgumentTypeError, match=words):
            finite_number(text)
