"""Command lines: options generated from parameter specs, one-line usage errors.

An option is a :class:`~fishtail_common.parameters.ParameterSpec`, as a node's parameter is, so
that its flag, type, check, message and help (meaning, unit, range, default) are written once, in
the spec; lists and ``first:last:count`` ranges have typed helpers whose items a spec checks.

>>> steps = ParameterSpec("steps_per_beat", 32, "RK4 steps per tail beat", "", 4, 100_000)
>>> parser = OneLineErrorParser(prog="fishtail-demo")
>>> add_parameter_options(parser, [steps])
>>> parser.parse_args(["--steps-per-beat", "64"]).steps_per_beat
64
>>> parameter_help(steps)
'RK4 steps per tail beat (4 to 100000; default 32)'
>>> parse_value(steps, "2")
Traceback (most recent call last):
...
argparse.ArgumentTypeError: steps_per_beat = 2 is outside [4, 100000]
"""

from __future__ import annotations

import argparse
import functools
import math
from collections.abc import Iterable
from typing import NoReturn

from fishtail_common.parameters import ParameterSpec, ParameterValue, ParameterValueError

_BOOLEANS = {"true": True, "false": False}
#: ``--duration`` of the commands that otherwise run until stopped (add it with ``optional=True``).
DURATION = ParameterSpec(
    "duration", math.inf, "stop after this many seconds", "s", 0.0, exclusive_minimum=True
)


class UsageError(Exception):
    """Bad command-line input found after parsing: reported as one line, with exit status 2."""


class OneLineErrorParser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (the usage text stays behind --help)."""

    def error(self, message: str) -> NoReturn:
        """Print ``program: error: message (see <command> --help)`` and exit with status 2."""
        program = self.prog.split()[0]  # a subcommand's prog is "<program> <command>"
        self.exit(2, f"{program}: error: {message} (see {self.prog} --help)\n")


def flag_name(name: str) -> str:
    """The flag of a parameter's name: ``pivot_offset_m`` -> ``--pivot-offset-m``."""
    return "--" + name.replace("_", "-")


def _typed(spec: ParameterSpec, text: str) -> ParameterValue:
    """``text`` as the type of the spec's default, unchecked."""
    kind = type(spec.default)
    if kind is str:
        return text
    if kind is bool:
        if text.lower() not in _BOOLEANS:
            raise argparse.ArgumentTypeError(f"not true or false: {text!r}")
        return _BOOLEANS[text.lower()]
    try:
        return int(text) if kind is int else float(text)
    except ValueError:
        what = "an integer" if kind is int else "a number"
        raise argparse.ArgumentTypeError(f"not {what}: {text!r}") from None


def parse_value(spec: ParameterSpec, text: str) -> ParameterValue:
    """``text`` as a value of ``spec``: converted to its type and checked by it.

    Raises:
        argparse.ArgumentTypeError: with the spec's message (argparse reports it as a usage error).
    """
    try:
        return spec.check(_typed(spec, text))
    except ParameterValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def finite_number(text: str) -> float:
    """A finite float, for values without a spec (ranges are the specs').

    Raises:
        argparse.ArgumentTypeError: not a number, or not finite.

    >>> finite_number("0.5"), finite_number("-2")
    (0.5, -2.0)
    """
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"not a finite number: {text!r}")
    return value


def value_list(spec: ParameterSpec, text: str, most: int) -> list[float]:
    """Comma-separated numbers of ``spec``, one to ``most`` of them, each checked by it.

    Raises:
        argparse.ArgumentTypeError: no value, more than ``most``, or one the spec refuses.

    >>> value_list(ParameterSpec("speed", 4.0, "speed", "rad/s", 0.0), "2, 4,8", 10)
    [2.0, 4.0, 8.0]
    """
    values = [float(parse_value(spec, item.strip())) for item in text.split(",") if item.strip()]
    if not values:
        raise argparse.ArgumentTypeError(f"no {spec.description} in {text!r}")
    if len(values) > most:
        raise argparse.ArgumentTypeError(f"at most {most} values, got {len(values)}")
    return values


def spaced_range(
    value: ParameterSpec, count: ParameterSpec, text: str, form: str = "FIRST:LAST:COUNT"
) -> tuple[float, float, int]:
    """The ends and the count of ``first:last:count``, evenly spaced values.

    ``value`` checks the ends and ``count`` the count; the last must be above the first unless
    the count is 1. ``form`` names the three parts in the messages.

    Raises:
        argparse.ArgumentTypeError: not three parts, a part the specs refuse, or ends out of
            order.

    >>> shifts = ParameterSpec("pivot_shift_m", 0.0, "pivot shift", "m")
    >>> points = ParameterSpec("count", 5, "how many", "", 2, 1000)
    >>> spaced_range(shifts, points, "-0.02:0.02:5", "LOW:HIGH:COUNT")
    (-0.02, 0.02, 5)
    >>> spaced_range(shifts, points, "0.02:-0.02:5", "LOW:HIGH:COUNT")
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: high -0.02 must be above low 0.02
    """
    parts = text.split(":")
    if len(parts) != 3:
        raise argparse.ArgumentTypeError(f"expected {form.lower()}, got {text!r}")
    first, last = (float(parse_value(value, part)) for part in parts[:2])
    number = int(parse_value(count, parts[2]))
    if last < first or (last == first and number > 1):
        first_name, last_name, _ = form.lower().split(":")
        raise argparse.ArgumentTypeError(
            f"{last_name} {last:g} must be above {first_name} {first:g}"
        )
    return first, last, number


def _shown(value: ParameterValue) -> str:
    """A value as the help shows it: whole numbers in full, others to 6 digits."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, float) and not value.is_integer():
        return f"{value:.6g}"
    return str(int(value)) if isinstance(value, float) else str(value)


def _bounds(spec: ParameterSpec) -> str:
    """The range in words: ``4 to 100000``, ``> 0``, ``> 0, <= 50``; empty without one."""
    low, high = spec.minimum, spec.maximum
    if low is not None and high is not None and not spec.exclusive_minimum:
        return f"{_shown(low)} to {_shown(high)}"
    parts = [] if low is None else [f"{'>' if spec.exclusive_minimum else '>='} {_shown(low)}"]
    return ", ".join(parts + ([] if high is None else [f"<= {_shown(high)}"]))


def parameter_help(spec: ParameterSpec, with_default: bool = True) -> str:
    """The help of a spec's flag: its text (with the unit), then its range and default.

    >>> fps = ParameterSpec("fps", 24.0, "frames", "1/s", 0.0, 50.0, exclusive_minimum=True)
    >>> parameter_help(fps), parameter_help(fps, with_default=False)
    ('frames [1/s] (> 0, <= 50; default 24)', 'frames [1/s] (> 0, <= 50)')
    """
    bounds = _bounds(spec)
    notes = [bounds] if bounds else []
    if with_default:
        notes.append(f"default {_shown(spec.default)}")
    text = f"{spec.text} ({'; '.join(notes)})" if notes else spec.text
    return text.replace("%", "%%")  # argparse formats help with %


def _metavar(spec: ParameterSpec) -> str:
    if spec.choices:
        return "{" + ",".join(spec.choices) + "}"
    if spec.unit:
        return spec.unit.upper().replace(" ", "_")
    return {int: "N", float: "X", bool: "BOOL"}.get(type(spec.default), "TEXT")


def add_parameter_options(
    parser: argparse._ActionsContainer, specs: Iterable[ParameterSpec], optional: bool = False
) -> None:
    """One option per spec (dest: its name), its value checked by the spec as it is parsed.

    Args:
        parser: a parser or an argument group.
        specs: the options' specs.
        optional: the value is None when the flag is not given (the command decides what that
            means, such as a mode that needs no value), and the help names no default; otherwise
            it is the spec's default.
    """
    for spec in specs:
        parser.add_argument(
            flag_name(spec.name),
            dest=spec.name,
            type=functools.partial(parse_value, spec),
            default=None if optional else spec.default,
            metavar=_metavar(spec),
            help=parameter_help(spec, with_default=not optional),
        )


def add_parameter_flags(group: argparse._ActionsContainer, specs: Iterable[ParameterSpec]) -> None:
    """One flag per spec that overrides a value read from elsewhere (a parameter file).

    The value is None when the flag is not given, and is only converted to the spec's type here:
    the command merges it with the file's values and checks them together, so that a bad value
    has one message whichever of the two it came from. The help names the spec's default.
    """
    for spec in specs:
        group.add_argument(
            flag_name(spec.name),
            dest=spec.name,
            type=functools.partial(_typed, spec),
            metavar=_metavar(spec),
            help=parameter_help(spec),
        )
