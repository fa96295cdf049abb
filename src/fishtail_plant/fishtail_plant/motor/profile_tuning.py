r"""The project firmware's profile controller settings (``k LEAD:KV:KA:KS:KQ``) for a motor.

The firmware follows a carrier speed profile with a feed-forward PWM computed from the law's
speed (KV, the back-EMF), its change (KA, the rotor's and the load's inertia), a constant (KS,
the Coulomb friction) and the speed squared (KQ, a drag such as the water's), and takes the law
LEAD ms ahead of the count (firmware/CHANGES.md, "The new commands"). :func:`feed_forward`
derives KV, KA, KS and KQ from the DC motor's model
(:class:`~fishtail_plant.motor.dc_motor.DcMotorParameters`, e.g. from a motor file's
:meth:`~fishtail_plant.motor.motor_file.MotorSpec.parameters`) and the load's mean figures over a
revolution (:func:`load_figures`); :func:`profile_tuning` puts them into ``k``'s argument.
Plain Python: the driver's parameter ``serial_profile_tuning`` takes the string, and
``fishtail-run --firmware`` computes it here. docs/firmware.md.

>>> from fishtail_plant.motor.board_units import Scale
>>> feed_forward(DcMotorParameters(), Scale(64, 30.0), 0.0, 0.0)   # the 37D 30:1, unloaded
(5955, 1224, 5, 0)
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from fishtail_plant.linkage_load.surroundings import NO_LOAD
from fishtail_plant.motor.board_units import Scale
from fishtail_plant.motor.dc_motor import DcMotorParameters
from fishtail_plant.values import tail_load_from_files

#: The lead the firmware's measurements use (docs/firmware.md): about half a 30 Hz frame plus
#: the motor's electrical lag.
DEFAULT_LEAD_MS = 8
#: Angles over a revolution at which the load's figures are averaged.
_SAMPLES = 72


def feed_forward(
    parameters: DcMotorParameters, scale: Scale, inertia_kg_m2: float, quadratic_n_m_s2: float
) -> tuple[int, int, int, int]:
    """``k``'s KV, KA, KS and KQ for a motor from its model and a load's mean figures.

    KV: the PWM whose voltage balances the back-EMF at 1 count/ms (Q8); KA: the PWM whose current
    accelerates the rotor and ``inertia_kg_m2`` (at the carrier) by 1 count/ms²; KS: the PWM whose
    current holds the Coulomb friction; KQ: the PWM whose current holds a load torque
    ``quadratic_n_m_s2`` ω² at 1 count/ms (Q8), through the gearbox.
    """
    p = parameters
    pwm_per_volt = 255.0 / p.supply_voltage_v
    rad_s = scale.rad_per_count * 1e3  # carrier rad/s at 1 count/ms
    kn = p.torque_constant_n_m_a * p.gear_ratio
    inertia = p.rotor_inertia_kg_m2 * p.gear_ratio**2 + inertia_kg_m2 / p.gearbox_efficiency
    accelerating = inertia * rad_s * 1e3 / kn  # current for 1 count/ms²
    friction = p.coulomb_friction_n_m / p.torque_constant_n_m_a
    load = quadratic_n_m_s2 * rad_s**2 / (kn * p.gearbox_efficiency)
    volts = p.resistance_ohm * pwm_per_volt
    return (
        round(kn * rad_s * pwm_per_volt * 256),
        round(accelerating * volts),
        round(friction * volts),
        round(load * volts * 256),
    )


def load_figures(
    surroundings: str, config: Path | None = None, fish: Path | None = None
) -> tuple[float, float]:
    """The tail's mean inertia [kg m²] and mean ω² coefficient [N m s²] over a revolution.

    The tail of ``config`` and ``fish`` (default: the workspace's or installed files) in
    ``surroundings``; none for ``none``.

    Raises:
        ValueError: a parameter file missing or refused.
    """
    if surroundings == NO_LOAD:
        return 0.0, 0.0
    tail = tail_load_from_files(surroundings, config, fish)
    angles = [2.0 * math.pi * i / _SAMPLES for i in range(_SAMPLES)]
    inertia = sum(tail.inertia(angle) for angle in angles) / len(angles)
    quadratic = sum(tail.torque(angle, 1.0) for angle in angles) / len(angles)
    return inertia, quadratic


def profile_tuning(
    surroundings: str,
    scale: Scale,
    parameters: DcMotorParameters | None = None,
    lead_ms: int = DEFAULT_LEAD_MS,
    config: Path | None = None,
    fish: Path | None = None,
) -> str:
    """``k``'s argument ``LEAD:KV:KA:KS:KQ`` for the motor turning the tail in ``surroundings``.

    ``parameters``: the motor (default: the 37D behind ``scale``'s gear ratio); ``scale``: its
    encoder and gearbox as the board counts them. The fields are within the firmware's ranges
    (0..255 for LEAD and KS, 0..32767 for the others), clamped where a motor would exceed them.

    Raises:
        ValueError: a parameter file missing or refused, or a lead outside 0..255 ms.
    """
    if not 0 <= lead_ms <= 255:
        raise ValueError(f"lead_ms must be in 0..255, got {lead_ms}")
    motor = parameters or dataclasses.replace(DcMotorParameters(), gear_ratio=scale.gear_ratio)
    kv, ka, ks, kq = feed_forward(motor, scale, *load_figures(surroundings, config, fish))
    fields = (lead_ms, min(max(kv, 0), 32767), min(max(ka, 0), 32767), min(max(ks, 0), 255),
              min(max(kq, 0), 32767))  # fmt: skip
    return ":".join(map(str, fields))
