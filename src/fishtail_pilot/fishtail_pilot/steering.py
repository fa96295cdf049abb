"""The pilot's steering parameters and the steering means they name, measured at start-up.

The tables themselves are :mod:`fishtail_pilot.steering_map` (both means of a tail, built from
the steady-turn batch in under a second); this module only picks the one the parameters ask
for. It imports the dynamics only when called, so that a command line can name the choices
without loading them. Plain Python: no rclpy.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

from fishtail_common.parameters import ParameterSpec, ParameterValue
from fishtail_plant.pivot_actuator import PIVOT_STROKE

if TYPE_CHECKING:
    from fishtail_kinematics.engine.mechanisms import Tail
    from fishtail_pilot.steering_map import SteeringChannel
    from fishtail_plant.fish.fish import FishParameters

MODULATION_STEERING = "modulation"
PIVOT_STEERING = "pivot"
STEERING = ParameterSpec(
    "steering", MODULATION_STEERING,
    "how the pilot turns the fish: modulation (the carrier's speed within each revolution, one "
    "motor) or pivot (the pivot actuator shifts S; the driver's pivot_actuator must be on)",
    choices=(MODULATION_STEERING, PIVOT_STEERING),
)  # fmt: skip
#: The pilot's steering parameters.
STEERING_PARAMETERS: tuple[ParameterSpec, ...] = (STEERING, PIVOT_STROKE)


def steering_from_values(
    values: Mapping[str, ParameterValue], tail: Tail, fish: FishParameters
) -> tuple[SteeringChannel, float]:
    """The means the parameters name, measured for ``tail`` and ``fish``, and U/f [m] straight.

    Raises:
        SwimInputError: the map's, e.g. a stroke it cannot tabulate.
        ValueError: a ``steering`` value that names no means.
    """
    from fishtail_pilot.steering_map import build_steering_map

    stroke = float(values.get(PIVOT_STROKE.name, PIVOT_STROKE.default))
    steering_map = build_steering_map(tail, fish, pivot_stroke_m=stroke)
    name = str(values.get(STEERING.name, STEERING.default))
    return steering_map.means(name), steering_map.straight_distance_per_beat_m
