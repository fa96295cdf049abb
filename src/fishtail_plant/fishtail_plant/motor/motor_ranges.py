"""The range of a small fish's DC gear motor, written once for the motor options and motor files.

Each of :class:`~fishtail_plant.motor.dc_motor.DcMotorParameters`' fields, and the two datasheet
figures at the gearbox output, has a range that spans small gear motors with a wide margin and
keeps the motor sizing's figures physical (``fishtail-swim motor``'s options and the motor files
of :mod:`fishtail_plant.motor.motor_file` are both checked against it). Docs:
docs/motor-load.md ("Choosing a motor", "Motor files and the catalogue").

>>> check_motor_ranges(DcMotorParameters(resistance_ohm=1e-3))
Traceback (most recent call last):
...
fishtail_common.parameters.ParameterValueError: resistance_ohm = 0.001 is outside [0.01, 1000.0] ohm
"""

from __future__ import annotations

import dataclasses
import math

from fishtail_common.parameters import ParameterSpec
from fishtail_plant.motor.dc_motor import DcMotorParameters

#: DcMotorParameters' fields: what they are, their unit and their range. The ranges span small
#: gear motors with a wide margin, and keep the full-duty run's step (0.1 of the mechanical time
#: constant) and the quasi-static figures physical: a supply within the 60 V of extra-low
#: voltage; up to the largest gearhead reductions; a winding from a large 12 V motor's 0.01 ohm
#: to a micro motor's 1000; k from 1e-4 (a tiny fast motor) to 1 N m/A; a rotor from a micro
#: motor's 1e-10 kg m^2 to a flywheel's 1e-2.
MOTOR_FIELDS: dict[str, tuple[str, str, float, float]] = {
    "supply_voltage_v": ("supply voltage, the armature's at PWM 255", "V", 1.0, 60.0),
    "gear_ratio": ("motor turns per carrier turn", "", 1.0, 10_000.0),
    "gearbox_efficiency": ("gearbox efficiency, (0, 1]", "", 0.01, 1.0),
    "resistance_ohm": ("armature resistance", "ohm", 0.01, 1000.0),
    "torque_constant_n_m_a": ("torque constant = back-EMF constant", "N m/A", 1e-4, 1.0),
    "rotor_inertia_kg_m2": ("rotor inertia at the motor shaft", "kg m^2", 1e-10, 1e-2),
    "viscous_friction_n_m_s": ("viscous friction at the motor shaft", "N m s/rad", 0.0, 1e-2),
    "coulomb_friction_n_m": ("Coulomb (breakaway) friction at the motor shaft", "N m", 0.0, 1.0),
}

#: The datasheet figures at the carrier: a small fish's tail needs about 0.01 to 1 N m at 0.5 to
#: 5 Hz, 3 to 31 rad/s (docs/motor-load.md); these ranges hold any gear motor that could turn it
#: with a wide margin (a hundred times the torque, thirty times the speed).
STALL_TORQUE = ParameterSpec(
    "stall_torque_n_m", 1.0, "stall torque at the gearbox output", "N m", 1e-3, 100.0
)
NO_LOAD_SPEED = ParameterSpec(
    "no_load_speed_rad_s", 30.0, "no-load speed of the gearbox output", "rad/s", 0.5, 1000.0
)
#: One revolution per minute in rad/s.
RPM = 2.0 * math.pi / 60.0


def _defaults() -> dict[str, float]:
    fields = dataclasses.fields(DcMotorParameters)
    return {field.name: field.default for field in fields if isinstance(field.default, float)}


def motor_parameter_specs() -> tuple[ParameterSpec, ...]:
    """:data:`MOTOR_FIELDS` as specs, each default DcMotorParameters' (the default motor's)."""
    defaults = _defaults()
    return tuple(
        ParameterSpec(name, defaults[name], text, unit, low, high)
        for name, (text, unit, low, high) in MOTOR_FIELDS.items()
    )


def check_motor_ranges(parameters: DcMotorParameters) -> DcMotorParameters:
    """``parameters`` if every field of :data:`MOTOR_FIELDS` is within its range.

    Raises:
        ParameterValueError: the first field outside its range, named with its value and range.
    """
    for spec in motor_parameter_specs():
        spec.check(getattr(parameters, spec.name))
    return parameters
