"""Named errors of the plant; each message says what failed and by how much.

>>> raise SwimParameterError("fin_span_m", -0.1, 0.001, 5.0, "m")
Traceback (most recent call last):
...
fishtail_plant.errors.SwimParameterError: fin_span_m = -0.1 is outside [0.001, 5.0] m
"""

from __future__ import annotations

from fishtail_common.parameters import ParameterValueError


class PlantError(ValueError):
    """Base class of every error the plant raises for bad input."""


class InvalidInertiaError(PlantError, ParameterValueError):
    """A link's mass or moment of inertia is non-finite or negative, or names no link."""


class SwimError(PlantError):
    """Base class of every error the fish dynamics raise for bad input."""


class FishParameterError(SwimError, ParameterValueError):
    """A parameter that is unknown, not a number, or whose per-fish arrays do not broadcast.

    Also a :class:`~fishtail_common.parameters.ParameterValueError`, so that code handling the
    suite's parameter refusals handles these too.
    """


class FishConfigError(FishParameterError):
    """A fish parameter file that cannot be read or holds a refused value."""


class SwimParameterError(FishParameterError):
    """A fish or tail parameter is non-finite or outside its range (a name, value and range)."""

    def __init__(
        self,
        name: str,
        value: float,
        minimum: float,
        maximum: float,
        unit: str = "",
        fish_index: int | None = None,
    ) -> None:
        """Keep the offending ``name``, ``value`` and range; ``fish_index`` in a batch."""
        self.name = name
        self.value = value
        self.minimum = minimum
        self.maximum = maximum
        self.fish_index = fish_index
        where = "" if fish_index is None else f" (fish {fish_index})"
        unit_text = f" {unit}" if unit else ""
        super().__init__(
            f"{name} = {value!r} is outside [{minimum}, {maximum}]{unit_text}{where}"
        )


class SwimInputError(SwimError):
    """A state, time step, duration or batch shape given to the dynamics is unusable."""


class BeatAlignmentError(SwimError):
    """Beat figures need whole beats on the recorded samples, and enough of them."""


class NoSteadySpeedError(SwimError):
    """The cycle-mean thrust never balances the drag at a positive speed."""


class MotorSpecError(PlantError):
    """A motor specification that is incomplete or inconsistent, or a gear ratio it does not offer.

    The message names the key (``motor.resistance_ohm``, ``gearbox.ratios[2].efficiency``) and
    what is wrong with it, in one line.
    """


class MotorFileError(MotorSpecError):
    """A motor file that cannot be read or holds a refused value; the message names the file."""
