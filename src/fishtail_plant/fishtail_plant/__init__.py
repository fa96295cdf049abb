"""The physical world the suite drives: the DC gear motor, the tail as its load, the fish in water.

numpy only (no rclpy, no plotting). Sub-packages: ``motor`` (the DC gear motor, the first-order
model, the board's speed loop and units), ``linkage_load`` (link inertia, the carrier's torque by
virtual work, the water on the fin), ``fish`` (body, forces, integrator and its compiled twin,
beat figures); beside them the pivot actuator and building all of it from parameter values.
Names load their module on first use: the motor models come without the fish dynamics (numba).
Equations: docs/motor-load.md, docs/swimming-dynamics.md.
"""

from typing import TYPE_CHECKING

from fishtail_common.package_front import lazy_exports

__all__ = [
    "CarrierLoadModel",
    "DcMotor",
    "DcMotorParameters",
    "EngineTailDrive",
    "FirmwareSpeedLoop",
    "FishParameters",
    "LinkInertia",
    "MotorParameters",
    "PidDrivenDcMotor",
    "PidGains",
    "PivotActuator",
    "PivotLimits",
    "PlantError",
    "Scale",
    "SimulatedMotor",
    "SwimError",
    "SwimFollower",
    "SwimModel",
    "TailLoad",
    "simulate",
    "steady_surge_speed",
    "steady_turn",
    "tail_load_from_values",
    "values_from_files",
]

_HOMES = {
    "fishtail_plant.errors": ("PlantError", "SwimError"),
    "fishtail_plant.fish.figures": ("steady_surge_speed",),
    "fishtail_plant.fish.fish": ("FishParameters",),
    "fishtail_plant.fish.follower": ("SwimFollower",),
    "fishtail_plant.fish.integrator": ("simulate",),
    "fishtail_plant.fish.model": ("SwimModel",),
    "fishtail_plant.fish.steady_turn": ("steady_turn",),
    "fishtail_plant.fish.tail_drive": ("EngineTailDrive",),
    "fishtail_plant.linkage_load.carrier_load": ("CarrierLoadModel",),
    "fishtail_plant.linkage_load.link_inertia": ("LinkInertia",),
    "fishtail_plant.linkage_load.tail_load": ("TailLoad",),
    "fishtail_plant.motor.board_units": ("Scale",),
    "fishtail_plant.motor.dc_motor": ("DcMotor", "DcMotorParameters"),
    "fishtail_plant.motor.first_order": ("MotorParameters", "SimulatedMotor"),
    "fishtail_plant.motor.pid_dc_motor": ("PidDrivenDcMotor",),
    "fishtail_plant.motor.speed_loop": ("FirmwareSpeedLoop", "PidGains"),
    "fishtail_plant.pivot_actuator": ("PivotActuator", "PivotLimits"),
    "fishtail_plant.values": ("tail_load_from_values", "values_from_files"),
}
__getattr__ = lazy_exports(__name__, __all__, _HOMES)

if TYPE_CHECKING:
    from fishtail_plant.errors import PlantError, SwimError
    from fishtail_plant.fish.figures import steady_surge_speed
    from fishtail_plant.fish.fish import FishParameters
    from fishtail_plant.fish.follower import SwimFollower
    from fishtail_plant.fish.integrator import simulate
    from fishtail_plant.fish.model import SwimModel
    from fishtail_plant.fish.steady_turn import steady_turn
    from fishtail_plant.fish.tail_drive import EngineTailDrive
    from fishtail_plant.linkage_load.carrier_load import CarrierLoadModel
    from fishtail_plant.linkage_load.link_inertia import LinkInertia
    from fishtail_plant.linkage_load.tail_load import TailLoad
    from fishtail_plant.motor.board_units import Scale
    from fishtail_plant.motor.dc_motor import DcMotor, DcMotorParameters
    from fishtail_plant.motor.first_order import MotorParameters, SimulatedMotor
    from fishtail_plant.motor.pid_dc_motor import PidDrivenDcMotor
    from fishtail_plant.motor.speed_loop import FirmwareSpeedLoop, PidGains
    from fishtail_plant.pivot_actuator import PivotActuator, PivotLimits
    from fishtail_plant.values import tail_load_from_values, values_from_files
