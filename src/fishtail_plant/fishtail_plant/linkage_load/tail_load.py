"""What the tail asks of the motor: the carrier's load torque and inertia for a motor model.

:class:`TailLoad` gives a DC motor model (:mod:`~fishtail_plant.motor.dc_motor`) its two load
callables, ``torque(phi, omega)`` and ``inertia(phi)``, for one tail in one of the
:data:`SURROUNDINGS` (``none``, ``air``, ``water_held``, ``water_swimming``: the fish towed at
the speed it would swim at). What each includes and the figures: docs/motor-load.md ("The load").

>>> from fishtail_kinematics.engine.geometry import OscillatoryGeometry
>>> from fishtail_plant.linkage_load.link_inertia import LinkInertia
>>> from fishtail_kinematics.engine.mechanisms import make_tail
>>> load = TailLoad(make_tail(OscillatoryGeometry()), LinkInertia(), FishParameters(), "air")
>>> load.torque(0.3, 0.0), load.inertia(0.3) > 0.0     # at rest, no torque; always some inertia
(0.0, True)
"""

from __future__ import annotations

import math

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_plant.errors import SwimInputError
from fishtail_plant.fish.figures import steady_surge_speed
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed
from fishtail_plant.linkage_load.carrier_load import CarrierLoad, CarrierLoadModel
from fishtail_plant.linkage_load.link_inertia import LinkInertia
from fishtail_plant.linkage_load.surroundings import SURROUNDINGS
from fishtail_plant.linkage_load.water import carrier_load_in_water, fin_added_inertia


def swimming_speed_per_carrier_speed(tail: Tail, fish: FishParameters) -> float:
    """U / omega [m/rad] of the fish's steady straight swimming (the cycle-average balance)."""
    drive = EngineTailDrive(tail, constant_carrier_speed(1.0))
    return float(np.ravel(steady_surge_speed(drive, fish, 2.0 * math.pi))[0])


class TailLoad:
    """The carrier's load for a motor model: ``torque(phi, omega)`` and ``inertia(phi)``.

    The load torque is exactly omega² c(phi) + omega |omega| d(phi): the links' inertia, Lighthill's
    force and the recoil are quadratic in the velocities, the fin plate's drag -k |w| w changes
    sign with them (d = 0 without the plate). A motor model asks for it thousands of times a
    simulated second, one angle at a time, too often for the engine; so c, d and J are solved
    once on :data:`TABLE_SIZE` angles and interpolated (docs/motor-load.md).
    """

    def __init__(
        self, tail: Tail, inertia: LinkInertia, fish: FishParameters, surroundings: str
    ) -> None:
        """Load of ``tail`` with links ``inertia`` on ``fish``, in ``surroundings``.

        Raises:
            SwimInputError: unknown ``surroundings``.
            NoSteadySpeedError: ``water_swimming`` with a fish that has no steady speed.
        """
        if surroundings not in SURROUNDINGS:
            raise SwimInputError(
                f"surroundings {surroundings!r} is not one of {', '.join(SURROUNDINGS)}"
            )
        self.surroundings = surroundings
        self.model = CarrierLoadModel(tail, inertia)
        self.fish = fish
        swimming = surroundings == "water_swimming"
        #: kappa = U / omega of the towed fish (0 unless swimming).
        self.speed_per_carrier_speed_m_rad = (
            swimming_speed_per_carrier_speed(tail, fish) if swimming else 0.0
        )
        angles = np.arange(TABLE_SIZE) * (2.0 * math.pi / TABLE_SIZE)
        #: Whether the torque has the plate's part that changes sign with omega.
        self._has_odd_part = surroundings.startswith("water") and fish.has_fin_drag
        per_speed_odd = np.zeros(TABLE_SIZE)
        if surroundings == "none":
            per_speed_squared = np.zeros(TABLE_SIZE)
            reduced = np.zeros(TABLE_SIZE)
        else:
            exact = self.exact(angles, 1.0)
            per_speed_squared = np.asarray(exact.torque_n_m, dtype=float)
            reduced = np.asarray(exact.reduced_inertia_kg_m2, dtype=float)
            if self._has_odd_part:
                # Turned backwards every velocity changes sign (the towed fish's too): the
                # quadratic terms stay, the plate's drag turns round. Half the sum and half the
                # difference of the two directions are c and d.
                backwards = np.asarray(self.exact(angles, -1.0).torque_n_m, dtype=float)
                per_speed_squared, per_speed_odd = (
                    0.5 * (per_speed_squared + backwards),
                    0.5 * (per_speed_squared - backwards),
                )
        # Plain lists: indexing them from Python is several times cheaper than numpy scalars.
        self._torque_table = _periodic_padding(per_speed_squared)
        self._odd_table = _periodic_padding(per_speed_odd)
        self._inertia_table = _periodic_padding(reduced)

    def exact(self, phi_rad: npt.ArrayLike, omega_rad_s: npt.ArrayLike) -> CarrierLoad:
        """The engine's load at (phi, omega), phi'' = 0, arrays or floats (what the table holds).

        In water J(phi) includes the fin plate's added mass, which moves with the tail: inertia,
        not load (the recoil's part in phi'').
        """
        if self.surroundings.startswith("water"):
            surge = self.speed_per_carrier_speed_m_rad * np.asarray(omega_rad_s, dtype=float)
            load = carrier_load_in_water(self.model, self.fish, phi_rad, omega_rad_s, 0.0, surge)
            added = fin_added_inertia(self.model.tail, self.fish, phi_rad)
            return load._replace(reduced_inertia_kg_m2=load.reduced_inertia_kg_m2 + added)
        return self.model.load(phi_rad, omega_rad_s)

    def torque(self, phi_rad: float, omega_rad_s: float) -> float:
        """The torque [N m] the carrier gives the load at phi, omega, apart from J(phi) phi''."""
        torque = omega_rad_s * omega_rad_s * _interpolate(self._torque_table, phi_rad)
        if self._has_odd_part:
            torque += omega_rad_s * abs(omega_rad_s) * _interpolate(self._odd_table, phi_rad)
        return torque

    def inertia(self, phi_rad: float) -> float:
        """The linkage's inertia reduced to the carrier, J(phi) [kg m²] (0 with no load)."""
        return _interpolate(self._inertia_table, phi_rad)


#: Angles per revolution of the load's table: cubic interpolation error ~ (2 pi / size)^4.
TABLE_SIZE = 4096
_STEPS_PER_RAD = TABLE_SIZE / (2.0 * math.pi)


def _periodic_padding(values: npt.NDArray[np.float64]) -> list[float]:
    # One value before and two after the revolution, so that any index i has i-1 .. i+2.
    return [float(values[-1]), *map(float, values), float(values[0]), float(values[1])]


def _interpolate(table: list[float], phi_rad: float) -> float:
    position = (phi_rad % (2.0 * math.pi)) * _STEPS_PER_RAD
    index = int(position)
    if index >= TABLE_SIZE:  # phi a rounding error below a whole turn
        index -= TABLE_SIZE
        position -= TABLE_SIZE
    t = position - index
    before, here, after, beyond = table[index : index + 4]
    # Catmull-Rom: the cubic through here and after with central-difference slopes.
    return here + 0.5 * t * (
        after - before + t * (2.0 * before - 5.0 * here + 4.0 * after - beyond
                              + t * (3.0 * (here - after) + beyond - before))
    )  # fmt: skip
