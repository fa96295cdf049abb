"""Parameter specifications: name, default, range or choices, unit and meaning, written once.

Nodes declare their ROS parameters from these (:func:`fishtail_common.ros.declare`, with a
descriptor carrying the range) and validate run-time changes with :meth:`ParameterSpec.check`;
command lines build their flags from the same specs. Plain Python.

>>> rate = ParameterSpec("publish_rate_hz", 200.0, "rate of motor/joint_state", "Hz", 1.0, 1000.0)
>>> rate.check(50.0)
50.0
>>> rate.check(0.0)
Traceback (most recent call last):
...
fishtail_common.parameters.ParameterValueError: publish_rate_hz = 0.0 is outside [1.0, 1000.0] Hz
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable

ParameterValue = bool | int | float | str


class ParameterValueError(ValueError):
    """A parameter value that its specification refuses; the message is the reason."""


@dataclasses.dataclass(frozen=True)
class ParameterSpec:
    """One parameter. Its type is the default's type (an int default makes an integer parameter).

    ``minimum``/``maximum`` bound numbers (inclusive), ``choices`` lists the allowed strings,
    ``non_empty`` refuses an empty string, ``read_only`` parameters are fixed at start-up.
    ``exclusive_minimum`` refuses the minimum itself, for quantities that must be above it (a
    duration > 0); a ROS descriptor cannot say so and shows the range closed.
    """

    name: str
    default: ParameterValue
    description: str
    unit: str = ""
    minimum: float | None = None
    maximum: float | None = None
    choices: tuple[str, ...] = ()
    non_empty: bool = False
    read_only: bool = False
    exclusive_minimum: bool = False

    @property
    def text(self) -> str:
        """The description with the unit, as a descriptor and --help show it."""
        return f"{self.description} [{self.unit}]" if self.unit else self.description

    def check(self, value: object) -> ParameterValue:
        """``value`` converted to the parameter's type.

        Raises:
            ParameterValueError: a value of the wrong type, out of range, not a choice or empty
                where it may not be; the message is the reason.
        """
        kind = type(self.default)
        if kind is bool:
            if not isinstance(value, bool):
                raise ParameterValueError(f"{self.name} must be true or false, got {value!r}")
            return value
        if kind is str:
            if not isinstance(value, str):
                raise ParameterValueError(f"{self.name} must be a string, got {value!r}")
            if self.choices and value not in self.choices:
                raise ParameterValueError(
                    f"{self.name} must be one of {', '.join(self.choices)}, got {value!r}"
                )
            if self.non_empty and not value.strip():
                raise ParameterValueError(f"{self.name} must not be empty")
            return value
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ParameterValueError(f"{self.name} must be a number, got {value!r}")
        number: int | float = int(value) if kind is int else float(value)
        if kind is int and number != value:
            raise ParameterValueError(f"{self.name} must be a whole number, got {value!r}")
        low = -math.inf if self.minimum is None else self.minimum
        high = math.inf if self.maximum is None else self.maximum  # inf prints as "inf"
        above_low = low < number if self.exclusive_minimum else low <= number
        if not (above_low and number <= high):  # NaN too: it compares false
            unit = f" {self.unit}" if self.unit else ""
            opening = "(" if self.exclusive_minimum else "["
            raise ParameterValueError(
                f"{self.name} = {number!r} is outside {opening}{low}, {high}]{unit}"
            )
        if not math.isfinite(number):  # an infinity where the range is open
            raise ParameterValueError(f"{self.name} must be finite, got {value!r}")
        return number


def read_only(specs: Iterable[ParameterSpec]) -> tuple[ParameterSpec, ...]:
    """``specs`` fixed at start-up: a node refuses run-time changes to them.

    >>> read_only([ParameterSpec("rate_hz", 1.0, "rate")])[0].read_only
    True
    """
    return tuple(dataclasses.replace(spec, read_only=True) for spec in specs)
