"""The torque and power the carrier must deliver: the links' inertia and a load on the tail.

The motor's load through the linkage, by virtual work: the reduced inertia J(phi), its slope
J'(phi) (from the engine's second-order kinematics, ``Tail.link_motion``; no mechanism is named
here) and the torque J phi_ddot + ½ J' phi_dot² minus the work of a force at the tip and a
moment on the last link. Arrays of angles are solved in the engine's blocks, with no Python
loop per sample. Derivation, assumptions and figures: docs/motor-load.md ("The load").

>>> from fishtail_kinematics.engine.geometry import OscillatoryGeometry
>>> from fishtail_kinematics.engine.mechanisms import OscillatoryTail
>>> tail = OscillatoryTail(OscillatoryGeometry())
>>> import dataclasses
>>> planet_only = dataclasses.replace(LinkInertia.massless(), planet_mass_kg=0.1)
>>> load = carrier_load(tail, planet_only, 0.3, motor_velocity=4.0, motor_acceleration=2.0)
>>> round(float(load.reduced_inertia_kg_m2), 12), round(float(load.torque_n_m), 12)  # m (R/2)²
(0.00025, 0.0005)
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.blocks import block_slices
from fishtail_kinematics.engine.errors import InvalidInputError
from fishtail_kinematics.engine.geometry import FloatArray, Real
from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_plant.linkage_load.link_inertia import LinkInertia


class ReducedInertia(NamedTuple):
    """The linkage's inertia and load ratios at carrier angles phi, shaped like the angles."""

    inertia_kg_m2: FloatArray  # J(phi)
    slope_kg_m2_per_rad: FloatArray  # J'(phi) = dJ/dphi
    tip_ratio_x_m: FloatArray  # dT_x/dphi, tail frame [m/rad]
    tip_ratio_y_m: FloatArray  # dT_y/dphi
    fin_ratio: FloatArray  # dtheta_last/dphi, the last link's (ST or VT) [rad/rad]


class CarrierLoad(NamedTuple):
    """Torque [N m] and power [W] the carrier delivers, and J(phi) [kg m^2]; broadcast shape."""

    torque_n_m: FloatArray  # inertial + external
    inertial_torque_n_m: FloatArray  # J phi_ddot + ½ J' phi_dot²
    external_torque_n_m: FloatArray  # -(F . dT/dphi + M dtheta_last/dphi)
    power_w: FloatArray  # torque x phi_dot
    reduced_inertia_kg_m2: FloatArray  # J(phi)


def finite_values(name: str, value: npt.ArrayLike) -> FloatArray:
    """``value`` as a float array.

    Raises:
        InvalidInputError: a non-finite value (naming ``name`` and the first bad index).
    """
    array = np.asarray(value, dtype=float)
    if not np.isfinite(array).all():
        bad = np.flatnonzero(~np.isfinite(array.ravel()))
        raise InvalidInputError(
            f"{bad.size} non-finite {name} value(s), the first at flat index {bad[0]}: "
            f"{array.ravel()[bad[0]]!r}"
        )
    return array


class CarrierLoadModel:
    """A tail and its links' masses: the reduced inertia J(phi) and the carrier's load.

    Bodies whose mass and moment of inertia are both zero are skipped, so a massless linkage has
    J = J' = 0 exactly.
    """

    def __init__(self, tail: Tail, inertia: LinkInertia) -> None:
        """Keep ``tail`` (either mechanism) and the masses of its links.

        Raises:
            InvalidInertiaError: ``inertia`` has no values for one of the tail's links.
        """
        self.tail = tail
        self.inertia = inertia
        self._fin_rate_field = f"{tail.fin_angle_field()}_dot"
        self._weights = {link: inertia.mass_and_inertia(link) for link in tail.links}

    def _blocks(self, angle: FloatArray) -> Iterator[tuple[slice, _Block]]:
        """J, J' and the load ratios of a flat array of angles, a block at a time."""
        if angle.size == 1:
            # One angle (a simulator's step): the engine's float path, which costs a few us
            # where its array path's fixed cost is some 100 us.
            yield slice(0, 1), self._block(float(angle[0]))
            return
        # The engine's blocks (blocks.BLOCK_SAMPLES): each block's load is formed while the
        # engine's results for it are still in the cache.
        for block in block_slices(angle.size):
            yield block, self._block(angle[block])

    def _block(self, angle: Real) -> _Block:
        # Solved at unit carrier speed, the engine's rates are the velocity ratios.
        state = self.tail.solve(angle, 1.0)
        inertia: Real = 0.0
        slope: Real = 0.0
        for body in self.tail.link_motion(state):
            mass, moment = self._weights[body.link]
            if mass or moment:
                energy, change = body.reduced_inertia_terms(mass, moment)
                inertia = inertia + energy
                slope = slope + change
        ratios = (state.tip_x_dot, state.tip_y_dot, getattr(state, self._fin_rate_field))
        return _Block(inertia, slope, ratios)

    def reduced_inertia(self, motor_angle: npt.ArrayLike) -> ReducedInertia:
        """J(phi), J'(phi), dT/dphi and dtheta_last/dphi at carrier angles phi [rad].

        Raises:
            InvalidInputError: a non-finite angle (naming the first bad index).
        """
        angle = finite_values("carrier angle", motor_angle)
        columns = np.empty((5, angle.size))
        for block, values in self._blocks(angle.ravel()):
            columns[0, block] = values.inertia
            columns[1, block] = values.slope
            for row, ratio in enumerate(values.ratios, start=2):
                columns[row, block] = ratio
        return ReducedInertia(*columns.reshape(5, *angle.shape))

    def kinetic_energy(
        self, motor_angle: npt.ArrayLike, motor_velocity: npt.ArrayLike
    ) -> FloatArray:
        """T = ½ J(phi) phi_dot² [J] at carrier angles phi [rad] and speeds phi_dot [rad/s].

        Raises:
            InvalidInputError: a non-finite angle or speed.
        """
        speed = finite_values("carrier speed", motor_velocity)
        energy: FloatArray = 0.5 * self.reduced_inertia(motor_angle).inertia_kg_m2 * speed**2
        return energy

    def load(
        self,
        motor_angle: npt.ArrayLike,
        motor_velocity: npt.ArrayLike,
        motor_acceleration: npt.ArrayLike = 0.0,
        tip_force_x: npt.ArrayLike = 0.0,
        tip_force_y: npt.ArrayLike = 0.0,
        fin_moment: npt.ArrayLike = 0.0,
    ) -> CarrierLoad:
        """The carrier's torque and power at (phi, phi_dot, phi_ddot) [rad, rad/s, rad/s^2].

        ``tip_force_x``/``tip_force_y`` [N]: the external force acting on the tail at the tip T,
        in the tail frame (x back, y left); ``fin_moment`` [N m]: an external moment about the
        tail frame's z (positive turning from x towards y) on the last link. Every argument is a
        float or an array; they broadcast together and J is solved once per carrier angle.

        Raises:
            InvalidInputError: a non-finite argument (naming it and the first bad index).
        """
        angle = finite_values("carrier angle", motor_angle)
        inputs = _Inputs(
            finite_values("carrier speed", motor_velocity),
            finite_values("carrier acceleration", motor_acceleration),
            (
                finite_values("tip force x", tip_force_x),
                finite_values("tip force y", tip_force_y),
                finite_values("fin moment", fin_moment),
            ),
        )
        shape = np.broadcast_shapes(angle.shape, *(value.shape for value in inputs.arrays()))
        if shape != angle.shape:
            # The angles repeat along the other inputs' axes: J once per angle, then broadcast.
            reduced = self.reduced_inertia(angle)
            values = _Block(
                reduced.inertia_kg_m2,
                reduced.slope_kg_m2_per_rad,
                (reduced.tip_ratio_x_m, reduced.tip_ratio_y_m, reduced.fin_ratio),
            )
            return CarrierLoad(*(_full(part, shape) for part in _combine(values, inputs)))
        # Each block's load is formed while its arrays are in the cache.
        flat = inputs.flattened()
        columns = np.empty((5, angle.size))
        for block, values in self._blocks(angle.ravel()):
            for row, part in enumerate(_combine(values, flat.sliced(block))):
                columns[row, block] = part
        return CarrierLoad(*columns.reshape(5, *shape))


class _Block(NamedTuple):
    inertia: Real  # J; a float 0 when every body is massless
    slope: Real  # J'
    ratios: tuple[Real, Real, Real]  # dT_x/dphi, dT_y/dphi, dtheta_fin/dphi


class _Inputs(NamedTuple):
    """Carrier speed and acceleration, and the three loads: 0-d or shaped like the angles."""

    speed: FloatArray
    acceleration: FloatArray
    loads: tuple[FloatArray, FloatArray, FloatArray]

    def arrays(self) -> tuple[FloatArray, ...]:
        return (self.speed, self.acceleration, *self.loads)

    def flattened(self) -> _Inputs:
        def flat(value: FloatArray) -> FloatArray:
            return value if value.ndim == 0 else value.ravel()

        loads = self.loads
        return _Inputs(
            flat(self.speed),
            flat(self.acceleration),
            (flat(loads[0]), flat(loads[1]), flat(loads[2])),
        )

    def sliced(self, block: slice) -> _Inputs:
        def part(value: FloatArray) -> FloatArray:
            return value if value.ndim == 0 else value[block]

        loads = self.loads
        return _Inputs(
            part(self.speed),
            part(self.acceleration),
            (part(loads[0]), part(loads[1]), part(loads[2])),
        )


def _nonzero(value: FloatArray) -> bool:
    return bool(value.ndim or value != 0.0)


def _full(value: FloatArray, shape: tuple[int, ...]) -> FloatArray:
    """``value`` with the broadcast shape (a writable array of its own)."""
    if value.shape == shape:
        return value
    return np.broadcast_to(value, shape).copy()


def _combine(values: _Block, inputs: _Inputs) -> tuple[FloatArray, ...]:
    """Torque, inertial torque, external torque, power and J (broadcast, not yet full-shaped)."""
    speed = inputs.speed
    # Terms whose factor is a scalar zero (no acceleration, no load) are left out: on large
    # arrays each product costs as much as a block of the linkage's own arithmetic.
    inertial = values.slope * (0.5 * speed * speed)
    if _nonzero(inputs.acceleration):
        inertial = inertial + values.inertia * inputs.acceleration
    external: FloatArray = np.zeros(())
    for load, ratio in zip(inputs.loads, values.ratios, strict=True):
        if _nonzero(load):
            external = external - load * ratio
    torque = inertial + external
    parts = (torque, inertial, external, torque * speed, values.inertia)
    return tuple(np.asarray(part, dtype=float) for part in parts)


def carrier_load(
    tail: Tail,
    inertia: LinkInertia,
    motor_angle: npt.ArrayLike,
    motor_velocity: npt.ArrayLike,
    motor_acceleration: npt.ArrayLike = 0.0,
    tip_force_x: npt.ArrayLike = 0.0,
    tip_force_y: npt.ArrayLike = 0.0,
    fin_moment: npt.ArrayLike = 0.0,
) -> CarrierLoad:
    """The carrier's torque and power: :meth:`CarrierLoadModel.load` of ``tail`` and ``inertia``.

    Raises:
        InvalidInputError: a non-finite argument.
    """
    return CarrierLoadModel(tail, inertia).load(
        motor_angle, motor_velocity, motor_acceleration, tip_force_x, tip_force_y, fin_moment
    )
