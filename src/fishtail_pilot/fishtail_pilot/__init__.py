"""The pilot: steering channels and their maps from the plant, the pilot law, the pilot node.

The law and the maps are plain Python (the node is :mod:`fishtail_pilot.node`); names load their
module on first use. How it steers: docs/steering.md.
"""

from typing import TYPE_CHECKING

from fishtail_common.package_front import lazy_exports

__all__ = [
    "Pilot",
    "PilotCommand",
    "PilotSettings",
    "SteeringChannel",
    "SteeringCommand",
    "SteeringMap",
    "build_steering_map",
    "steering_from_values",
]

_HOMES = {
    "fishtail_pilot.pilot": ("Pilot", "PilotCommand", "PilotSettings", "SteeringCommand"),
    "fishtail_pilot.steering": ("steering_from_values",),
    "fishtail_pilot.steering_map": ("SteeringChannel", "SteeringMap", "build_steering_map"),
}
__getattr__ = lazy_exports(__name__, __all__, _HOMES)

if TYPE_CHECKING:
    from fishtail_pilot.pilot import Pilot, PilotCommand, PilotSettings, SteeringCommand
    from fishtail_pilot.steering import steering_from_values
    from fishtail_pilot.steering_map import SteeringChannel, SteeringMap, build_steering_map
