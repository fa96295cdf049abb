"""The water's force on the tail, for the carrier's load: Lighthill's force with the fish held.

The fish is held by a guide: at rest (u = v = r = 0) or towed straight at a forward speed U
(u = U, v = r = 0), the "fish held or swimming" of docs/swimming-dynamics.md. Lighthill's
reactive force F_T (:func:`~fishtail_plant.fish.formulas.tip_force`, body frame) is the force of
the water on the fish, applied through the fin at the trailing edge T: it is the force the water
exerts on the tail, the reaction to the tail's push on the water. In the tail frame at O (x
backward, y left) a body-frame vector (a, b) is (-a, b), so the tail feels (-F_T,x, F_T,y) at T.
:class:`~fishtail_plant.linkage_load.carrier_load.CarrierLoadModel` takes exactly that force (the
external force acting on the tail) and charges the carrier -F . dT/dphi for it: the carrier's
power against the water is the tail power -F_T . (-Tx_dot, Ty_dot) of
:func:`~fishtail_plant.fish.figures.tail_power`. Swimming (U > 0) its mean is positive: the
tail works on the water. Held at rest its mean over a revolution is zero: the power is cubic in
the tail's velocities and a revolution is its own time reversal (the pose depends on phi only
through R cos(phi + psi)); for mechanism 1 it is zero at every instant, the fin turning about S.

Only the trailing-edge force: a fin with chord (``fin_chord_m`` > 0) adds a recoil at mid-chord
that is not modelled here, and such a fish is refused. The force acts at T, so it brings no moment
of its own about the last link.

Angles, speeds, the forward speed and the fish's per-fish values broadcast together (e.g. angles
of shape (K, 1) against N fish): no loop over angles or fish.

>>> import numpy as np
>>> from fishtail_kinematics.engine.geometry import OscillatoryGeometry
>>> from fishtail_kinematics.engine.mechanisms import OscillatoryTail
>>> tail = OscillatoryTail(OscillatoryGeometry())
>>> angles = np.linspace(0.0, 2 * np.pi, 64, endpoint=False)
>>> def power_on_tail(w):
...     return w.force_x_n * w.tip_velocity_x_m_s + w.force_y_n * w.tip_velocity_y_m_s
>>> swimming = water_force_on_tail(tail, FishParameters(), angles, 4.0, surge_speed_m_s=0.17)
>>> bool(power_on_tail(swimming).mean() < 0.0)   # the water resists: the carrier works on it
True
>>> at_rest = water_force_on_tail(tail, FishParameters(), angles, 4.0)
>>> abs(float(power_on_tail(at_rest).mean())) < 1e-15   # see docs/motor-load.md
True
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_plant.errors import SwimInputError
from fishtail_plant.fish import formulas
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.linkage_load.carrier_load import CarrierLoad, CarrierLoadModel


class WaterForce(NamedTuple):
    """The water's force on the tail at the tip T, tail frame (x back, y left); broadcast shape.

    The tip's velocity (tail frame, relative to the body) comes with it: the force's power on the
    tail is force . velocity, negative on average.
    """

    force_x_n: FloatArray
    force_y_n: FloatArray
    tip_velocity_x_m_s: FloatArray
    tip_velocity_y_m_s: FloatArray


def _check_no_chord(fish: FishParameters) -> None:
    chord = np.asarray(fish.fin_chord_m, dtype=float)
    if np.any(chord > 0.0):
        index = int(np.flatnonzero(chord.ravel() > 0.0)[0])
        where = f" (fish {index})" if chord.ndim else ""
        raise SwimInputError(
            f"fin_chord_m = {float(chord.ravel()[index])!r} m{where}: the fin's recoil is not in "
            "the carrier's load; use a fin without chord (fin_chord_m = 0)"
        )


def water_force_on_tail(
    tail: Tail,
    fish: FishParameters,
    motor_angle: npt.ArrayLike,
    motor_velocity: npt.ArrayLike,
    surge_speed_m_s: npt.ArrayLike = 0.0,
) -> WaterForce:
    """The water's force on the tail at T, the fish held at forward speed U (v = r = 0).

    ``motor_angle`` [rad] and ``motor_velocity`` [rad/s] are the carrier's; ``surge_speed_m_s``
    is U (0: held at rest). Raises :class:`SwimInputError` for a fin with chord.
    """
    _check_no_chord(fish)
    speed = np.asarray(surge_speed_m_s, dtype=float)
    if not np.isfinite(speed).all():
        raise SwimInputError(f"the forward speed must be finite, got {speed.ravel().tolist()}")
    state = tail.solve(np.asarray(motor_angle, dtype=float), np.asarray(motor_velocity, float))
    fin_angle = getattr(state, tail.fin_angle_field())
    held = np.zeros(())
    force_x, force_y, *_ = formulas.tip_force(
        fish.fin_added_mass_per_length_kg_m, fish.tail_origin_offset_m,
        state.tip_x, state.tip_y, state.tip_x_dot, state.tip_y_dot, fin_angle, speed, held, held,
    )  # fmt: skip
    shape = np.broadcast_shapes(np.shape(force_x), np.shape(force_y))
    return WaterForce(
        np.broadcast_to(-np.asarray(force_x, dtype=float), shape),
        np.broadcast_to(np.asarray(force_y, dtype=float), shape),
        np.broadcast_to(np.asarray(state.tip_x_dot, dtype=float), shape),
        np.broadcast_to(np.asarray(state.tip_y_dot, dtype=float), shape),
    )


def carrier_load_in_water(
    model: CarrierLoadModel,
    fish: FishParameters,
    motor_angle: npt.ArrayLike,
    motor_velocity: npt.ArrayLike,
    motor_acceleration: npt.ArrayLike = 0.0,
    surge_speed_m_s: npt.ArrayLike = 0.0,
) -> CarrierLoad:
    """The carrier's torque and power for the links' inertia and the water, the fish held.

    The external part is the water's (:func:`water_force_on_tail`), the inertial part the links'.
    """
    water = water_force_on_tail(model.tail, fish, motor_angle, motor_velocity, surge_speed_m_s)
    return model.load(
        motor_angle, motor_velocity, motor_acceleration, water.force_x_n, water.force_y_n
    )
