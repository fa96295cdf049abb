"""The pilot's steering means: a measured table of yaw per beat against the actuator's input.

Every force on the fish is quadratic in velocity, so its steady yaw per beat r̄/f (and distance per
beat Ū/f) depends on the geometry and the steering input only, not on the beat frequency: one
table per means, measured by :mod:`fishtail_swim.dynamics.steady_turn` when the pilot starts,
serves every speed. The table is inverted by linear interpolation over its monotone stretch.

* :class:`ModulationSteering`: one motor. The input is a signed depth: a positive one modulates the
  carrier with the phase that turns the fish most to the left, a negative one with the phase that
  turns it most to the right.
* :class:`PivotSteering`: the pivot actuator. The input is the shift of S along the body axis; the
  carrier runs at constant speed.

Plain Python: no rclpy. The builder imports the dynamics only when called, so that a command
line can name the choices without loading them.

>>> table = PivotSteering(shifts_m=[-0.03, 0.0, 0.03], yaw_per_beat_rad=[0.02, 0.0, -0.02])
>>> table.yaw_per_beat_range_rad
(-0.02, 0.02)
>>> command = table.command(0.01)
>>> round(command.pivot_shift_m, 6), command.yaw_per_beat_rad
(-0.015, 0.01)
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING

import numpy as np
import numpy.typing as npt

from fishtail_common.parameters import ParameterSpec, ParameterValue
from fishtail_swim.pilot import SteeringCommand

if TYPE_CHECKING:
    from fishtail_kinematics.engine.mechanisms import Tail
    from fishtail_swim.dynamics.fish import FishParameters

MODULATION_STEERING = "modulation"
PIVOT_STEERING = "pivot"
STEERING = ParameterSpec(
    "steering", MODULATION_STEERING,
    "how the pilot turns the fish: modulation (the carrier's speed within each revolution, one "
    "motor) or pivot (the pivot actuator shifts S; the driver's pivot_actuator must be on)",
    choices=(MODULATION_STEERING, PIVOT_STEERING),
)  # fmt: skip
PIVOT_STROKE = ParameterSpec(
    "pivot_stroke_m", 0.03,
    "the pivot actuator's reach each way from the design position of S (as the driver's)",
    "m", 0.0, 0.5,
)  # fmt: skip
#: The pilot's steering parameters.
STEERING_PARAMETERS: tuple[ParameterSpec, ...] = (STEERING, PIVOT_STROKE)


class SteeringTable:
    """A measured table: actuator input -> yaw per beat, inverted over its monotone stretch."""

    name = "table"

    def __init__(self, inputs: npt.ArrayLike, yaw_per_beat_rad: npt.ArrayLike) -> None:
        """Keep the table (inputs increasing); the stretch where the yaw is monotone is used."""
        inputs_array = np.asarray(inputs, dtype=float)
        yaw = np.asarray(yaw_per_beat_rad, dtype=float)
        if inputs_array.shape != yaw.shape or inputs_array.size < 2:
            raise ValueError("a steering table needs two or more inputs, each with its yaw")
        if not (np.all(np.isfinite(inputs_array)) and np.all(np.isfinite(yaw))):
            raise ValueError("a steering table's values must be finite")
        if np.any(np.diff(inputs_array) <= 0.0):
            raise ValueError("a steering table's inputs must increase")
        # Inverting needs a monotone yaw: keep the stretch between the extremes of the yaw, where
        # it is (the measured tables are; a deeper input past an extreme gains nothing).
        low, high = int(np.argmin(yaw)), int(np.argmax(yaw))
        first, last = min(low, high), max(low, high)
        stretch = slice(first, last + 1)
        inputs_array, yaw = inputs_array[stretch], yaw[stretch]
        if yaw[0] > yaw[-1]:
            inputs_array, yaw = inputs_array[::-1], yaw[::-1]
        if np.any(np.diff(yaw) <= 0.0):
            raise ValueError("a steering table's yaw is not monotone between its extremes")
        self.inputs = inputs_array
        self.yaw_per_beat = yaw

    @property
    def yaw_per_beat_range_rad(self) -> tuple[float, float]:
        """The most rightward (negative) and most leftward (positive) yaw per beat."""
        return float(self.yaw_per_beat[0]), float(self.yaw_per_beat[-1])

    def input_for(self, yaw_per_beat_rad: float) -> tuple[float, float]:
        """The input giving ``yaw_per_beat_rad``, and the yaw it gives (the range's end beyond)."""
        low, high = self.yaw_per_beat_range_rad
        achieved = min(max(yaw_per_beat_rad, low), high)
        return float(np.interp(achieved, self.yaw_per_beat, self.inputs)), achieved


class ModulationSteering(SteeringTable):
    """One motor: a signed depth, the sign choosing the leftward or the rightward phase."""

    name = MODULATION_STEERING

    def __init__(
        self,
        signed_depths: npt.ArrayLike,
        yaw_per_beat_rad: npt.ArrayLike,
        left_phase_rad: float,
        right_phase_rad: float,
    ) -> None:
        """The table over signed depths; the phases of the strongest turns each way."""
        super().__init__(signed_depths, yaw_per_beat_rad)
        self.left_phase_rad = left_phase_rad
        self.right_phase_rad = right_phase_rad

    def command(self, yaw_per_beat_rad: float) -> SteeringCommand:
        """The depth and phase for ``yaw_per_beat_rad``; no pivot."""
        signed_depth, achieved = self.input_for(yaw_per_beat_rad)
        phase = self.left_phase_rad if signed_depth >= 0.0 else self.right_phase_rad
        return SteeringCommand(abs(signed_depth), phase, None, achieved)


class PivotSteering(SteeringTable):
    """The pivot actuator: the shift of S, at constant carrier speed."""

    name = PIVOT_STEERING

    def __init__(self, shifts_m: npt.ArrayLike, yaw_per_beat_rad: npt.ArrayLike) -> None:
        """The table over pivot shifts [m]."""
        super().__init__(shifts_m, yaw_per_beat_rad)

    def command(self, yaw_per_beat_rad: float) -> SteeringCommand:
        """The shift for ``yaw_per_beat_rad``; the carrier unmodulated."""
        shift, achieved = self.input_for(yaw_per_beat_rad)
        return SteeringCommand(0.0, 0.0, shift, achieved)


#: The carrier speed the tables are measured at: any serves (r/f and U/f do not depend on it);
#: 2 pi rad/s is one beat a second.
MAP_CARRIER_SPEED_RAD_S = 2.0 * np.pi
#: The phase scan that finds the strongest phases each way, at this depth.
PHASE_SCAN_COUNT = 12
PHASE_SCAN_DEPTH = 0.5
#: The depths of the table each way (with depth 0 between them).
TABLE_DEPTHS = (0.15, 0.3, 0.45, 0.6, 0.75, 0.9)
#: The pivot table's shifts, across the stroke.
PIVOT_TABLE_POINTS = 9


def modulation_steering(tail: Tail, fish: FishParameters) -> tuple[ModulationSteering, float]:
    """One-motor steering measured for ``tail`` and ``fish``, and U/f [m] unmodulated.

    Two batches of the steady-turn simulation: a phase scan at :data:`PHASE_SCAN_DEPTH`, then
    every table depth at the strongest phase each way, with depth 0.
    """
    from fishtail_swim.dynamics.steady_turn import modulation_turns, strongest_phases

    phases = np.arange(PHASE_SCAN_COUNT) * (2.0 * np.pi / PHASE_SCAN_COUNT)
    scan = modulation_turns(tail, fish, MAP_CARRIER_SPEED_RAD_S, PHASE_SCAN_DEPTH, phases)
    strongest = strongest_phases(phases, scan.yaw_per_beat_rad)
    depths = np.asarray(TABLE_DEPTHS)
    batch_depths = np.concatenate([depths[::-1], [0.0], depths])
    batch_phases = np.concatenate(
        [np.full(depths.size, strongest.right_rad), [0.0], np.full(depths.size, strongest.left_rad)]
    )
    turns = modulation_turns(tail, fish, MAP_CARRIER_SPEED_RAD_S, batch_depths, batch_phases)
    signed_depths = np.concatenate([-depths[::-1], [0.0], depths])
    steering = ModulationSteering(
        signed_depths, turns.yaw_per_beat_rad, strongest.left_rad, strongest.right_rad
    )
    return steering, float(turns.distance_per_beat_m[depths.size])


def pivot_steering(
    tail: Tail, fish: FishParameters, stroke_m: float
) -> tuple[PivotSteering, float]:
    """Pivot-shift steering across ``stroke_m`` each way (within the shifts the linkage allows)."""
    from fishtail_swim.dynamics.steady_turn import pivot_shift_turns

    low, high = tail.pivot_shift_range()
    # The range is open: keep a millimetre off its ends.
    reach_low, reach_high = max(-stroke_m, low + 1e-3), min(stroke_m, high - 1e-3)
    if not reach_low < 0.0 < reach_high:
        raise ValueError(
            f"pivot_stroke_m = {stroke_m:g} m: the linkage assembles for shifts in "
            f"({low:.4g}, {high:.4g}) m only"
        )
    shifts = np.unique(
        np.concatenate([np.linspace(reach_low, reach_high, PIVOT_TABLE_POINTS), [0.0]])
    )
    turns = pivot_shift_turns(tail, fish, MAP_CARRIER_SPEED_RAD_S, shifts)
    neutral = int(np.flatnonzero(shifts == 0.0)[0])
    return PivotSteering(shifts, turns.yaw_per_beat_rad), float(turns.distance_per_beat_m[neutral])


def steering_from_values(
    values: Mapping[str, ParameterValue], tail: Tail, fish: FishParameters
) -> tuple[SteeringTable, float]:
    """The steering means the parameters name, measured for ``tail`` and ``fish``; and U/f [m]."""
    if values.get(STEERING.name, STEERING.default) == PIVOT_STEERING:
        stroke = float(values.get(PIVOT_STROKE.name, PIVOT_STROKE.default))
        return pivot_steering(tail, fish, stroke)
    return modulation_steering(tail, fish)
