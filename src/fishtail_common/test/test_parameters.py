import math

import pytest

from fishtail_common.parameters import ParameterSpec, ParameterValueError

RATE = ParameterSpec("publish_rate_hz", 200.0, "rate", "Hz", 1.0, 1000.0)
COUNTS = ParameterSpec("encoder_counts_per_revolution", 2048, "counts", "", 1)
BACKEND = ParameterSpec("backend", "sim", "motor backend", choices=("sim", "serial"))
JOINT = ParameterSpec("joint_name", "carrier_joint", "joint", non_empty=True)
FLAG = ParameterSpec("enabled", True, "on or off")


@pytest.mark.parametrize("value", [1.0, 1000.0, 1, 200.5])
def test_float_in_range_is_returned_as_float(value):
    assert RATE.check(value) == float(value)
    assert type(RATE.check(value)) is float


@pytest.mark.parametrize("value", [0.999, 1000.001, math.nan, math.inf, -math.inf])
def test_float_outside_range_or_not_finite_is_refused_with_the_name(value):
    with pytest.raises(ParameterValueError, match="publish_rate_hz"):
        RATE.check(value)


@pytest.mark.parametrize("value", ["200", None, True, [1.0]])
def test_float_of_the_wrong_type_is_refused(value):
    with pytest.raises(ParameterValueError, match="must be a number"):
        RATE.check(value)


def test_integer_parameter_keeps_integers_and_refuses_fractions():
    assert COUNTS.check(1920) == 1920
    assert type(COUNTS.check(1920.0)) is int
    with pytest.raises(ParameterValueError, match="whole number"):
        COUNTS.check(1.5)
    with pytest.raises(ParameterValueError, match=r"outside \[1, inf\]"):
        COUNTS.check(0)


def test_choices_and_non_empty_strings():
    assert BACKEND.check("serial") == "serial"
    with pytest.raises(ParameterValueError, match="one of sim, serial"):
        BACKEND.check("usb")
    assert JOINT.check("wheel") == "wheel"
    for empty in ("", "  "):
        with pytest.raises(ParameterValueError, match="joint_name must not be empty"):
            JOINT.check(empty)


def test_bool_parameter_refuses_numbers():
    assert FLAG.check(False) is False
    with pytest.raises(ParameterValueError, match="true or false"):
        FLAG.check(1)


def test_text_carries_the_unit():
    assert RATE.text == "rate [Hz]"
    assert BACKEND.text == "motor backend"


def test_not_finite_is_outside_a_range_and_refused_without_one():
    with pytest.raises(
        ParameterValueError, match=r"publish_rate_hz = nan is outside \[1.0, 1000.0\] Hz"
    ):
        RATE.check(math.nan)
    unbounded = ParameterSpec("offset", 0.0, "any offset")
    with pytest.raises(ParameterValueError, match="offset must be finite"):
        unbounded.check(math.inf)


def test_an_exclusive_minimum_refuses_the_minimum_itself():
    duration = ParameterSpec("duration", 60.0, "run time", "s", 0.0, exclusive_minimum=True)
    assert duration.check(1e-9) == 1e-9
    for value in (0.0, -1.0, math.nan):
        with pytest.raises(ParameterValueError, match=r"duration = .* is outside \(0.0, inf\] s"):
            duration.check(value)
