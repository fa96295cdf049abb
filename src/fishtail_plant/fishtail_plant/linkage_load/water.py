"""The water's force on the tail, for the carrier's load: Lighthill's force with the fish held.

The fish held by a guide, at rest or towed straight at a forward speed U, so that the motor's
load in water needs no free-body simulation: Lighthill's reactive force at the trailing edge
(:func:`~fishtail_plant.fish.formulas.tip_force`), turned into the tail frame as the force acting
on the tail. Angles, speeds and per-fish values broadcast together. Signs, the power it costs and
why it averages to zero held at rest: docs/motor-load.md ("The water's reaction").

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
    is U (0: held at rest).

    Raises:
        SwimInputError: a fin with chord (its recoil is not modelled), or a non-finite U.
        InvalidInputError: a non-finite carrier angle or speed (the engine's).
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

    Raises:
        SwimInputError: as :func:`water_force_on_tail`.
        InvalidInputError: a non-finite carrier angle, speed or acceleration.
    """
    water = water_force_on_tail(model.tail, fish, motor_angle, motor_velocity, surge_speed_m_s)
    return model.load(
        motor_angle, motor_velocity, motor_acceleration, water.force_x_n, water.force_y_n
    )
