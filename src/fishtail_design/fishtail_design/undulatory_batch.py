"""Many mechanism-2 linkages at once: the drive as one batch, the second loop design by design.

The engine's :class:`~fishtail_kinematics.engine.undulatory_tail.UndulatoryTail` proves the
loop's branch by a continuation sweep and fits its Newton seed to it, some 9 ms a design.
:class:`UndulatoryBatch` asks the compiled kernel (:func:`~fishtail_plant.fish.loop_kernel.
follow_branches`) to follow each design's branch from the straight pose over its swing and a
beat instead, and seeds every later solve from that beat: the nearest sample's AS, then the
engine's Newton closure (:mod:`~fishtail_kinematics.engine.loop_pose`) to the engine's tolerance,
so that every pose is the engine's to ~1e-13 m. A design the engine would refuse keeps its
column, NaN, with the engine's reason. docs/design.md ("Mechanism 2").
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.drive_batch import OscillatoryBatch
from fishtail_kinematics.engine.geometry import UndulatoryState
from fishtail_kinematics.engine.loop_pose import (
    LOOP_NEWTON_STEPS,
    loop_rates,
    loop_residual_and_slope,
    loop_tip,
    residual_tolerance,
)
from fishtail_plant.fish import cycle_kernel, loop_kernel
from fishtail_plant.fish.cycle_kernel import FISH_COLUMNS, HeldCycles
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.loop_kernel import STROKE_FIELDS
from fishtail_plant.fish.tail_drive import constant_carrier_speed

#: Carrier angles over a revolution at which each design's branch is followed and kept: the
#: seeds of every later solve (the engine's tail is likewise solved at 128 angles when built).
BRANCH_SAMPLES = 128
#: Why the engine refuses a design whose branch the kernel could not follow.
_BRANCH_REFUSALS = {
    loop_kernel.TOGGLE: "AssemblyError: mechanism 2 reaches a toggle pose: the linkage locks",
    loop_kernel.PIN_OUT_OF_SLOT: "AssemblyError: pin U leaves the slot of AV",
    loop_kernel.SLIDER_PAST_S: "AssemblyError: slider A passes S",
    loop_kernel.OPEN: "SolverError: mechanism 2 loop does not close",
}


def second_loop_conditions(designs: Mapping[str, FloatArray]) -> FloatArray:
    """Mechanism 2's loop conditions that need no swing, as signed lengths [m], shape (3, N).

    > 0 where each holds: the pin U on SW short of W's joint, SW - VW - SU (the engine's
    ``0 < SU < SW - VW``); W between V and T, VT - VW; the slider A behind S in the straight
    pose, AS = AV + VW - SW.
    """
    sw, vw = designs["swing_arm_m"], designs["fin_joint_offset_m"]
    return np.array([
        sw - vw - designs["pin_offset_m"],
        designs["fin_link_m"] - vw,
        designs["slotted_link_m"] + vw - sw,
    ])  # fmt: skip


def _refusal(conditions: FloatArray, pin: float, drive: bool, status: int) -> str | None:
    """The engine's reason for refusing one design (its checks in the engine's order)."""
    if not (pin > 0.0 and conditions[0] > 0.0):
        return "PinOffsetError: 0 < SU < SW - VW fails"
    if not conditions[1] > 0.0:
        return "InvalidLengthError: VW < VT fails"
    if not drive:
        return "AssemblyError: the drive cannot assemble over the stroke"
    if not conditions[2] > 0.0:
        return "AssemblyError: AV + VW > SW fails: the straight pose puts A not behind S"
    return _BRANCH_REFUSALS.get(status)


class UndulatoryBatch:
    """Mechanism 2 for N designs: the lengths of ``designs`` as arrays of shape (N,).

    Attributes: ``drive`` (the mechanism-1 batch, SW its tail link), ``lengths``,
    ``loop_conditions_m`` (:func:`second_loop_conditions`), ``assembles`` (N,), ``refusals``
    (the engine's reason per design, None where it builds the tail), ``stroke`` (the
    :data:`~fishtail_plant.fish.loop_kernel.STROKE_FIELDS` at the branch's samples,
    (fields, BRANCH_SAMPLES, N), NaN where a design does not assemble) and ``slider`` (AS there).
    """

    def __init__(self, designs: Mapping[str, FloatArray]) -> None:
        """Follow each design's branch (compiled where numba is there)."""
        self.drive = OscillatoryBatch(
            designs["ring_radius_m"], designs["crank_link_m"], designs["rocker_link_m"],
            designs["swing_arm_m"], designs["pivot_offset_m"],
        )  # fmt: skip
        self.size = count = self.drive.size
        self.lengths = {
            name: np.broadcast_to(np.asarray(value, dtype=float), (count,))
            for name, value in designs.items()
        }
        g = self.lengths
        self.loop_conditions_m = second_loop_conditions(g)
        pin = g["pin_offset_m"]
        drives = np.asarray(self.drive.assembles, dtype=bool)
        active = drives & (self.loop_conditions_m > 0.0).all(axis=0) & (pin > 0.0)
        self.drive_table = loop_kernel.drive_table(self.drive)
        self.loop_table = loop_kernel.loop_table(
            self.drive, pin, g["slotted_link_m"], g["fin_link_m"], g["fin_joint_offset_m"]
        )
        self.tolerance = np.asarray(residual_tolerance(g["fin_joint_offset_m"]))
        status, self.stroke = loop_kernel.follow_branches(
            self.drive_table, self.loop_table, active, BRANCH_SAMPLES
        )
        self.slider = self.stroke[STROKE_FIELDS.index("slider_a_distance")]
        self.assembles = status == loop_kernel.FOLLOWED
        self.refusals = [
            _refusal(self.loop_conditions_m[:, i], float(pin[i]), bool(drive), int(code))
            for i, (drive, code) in enumerate(zip(drives, status, strict=True))
        ]

    def stroke_states(self, samples: int) -> dict[str, FloatArray]:
        """The stroke's state fields at ``samples`` carrier angles over a revolution, (samples, N).

        :data:`~fishtail_plant.fish.loop_kernel.STROKE_FIELDS` at ``k 2 pi / samples``, unit
        speed: the branch's own where it has that many samples, else :meth:`solve`'s. NaN
        throughout for a design without a pose at every sample.
        """
        if samples == BRANCH_SAMPLES:
            return dict(zip(STROKE_FIELDS, self.stroke, strict=True))
        angles = np.arange(samples, dtype=np.float64) * (2.0 * math.pi / samples)
        state = self.solve(angles[:, None], 1.0)
        states = {name: np.array(getattr(state, name), dtype=float) for name in STROKE_FIELDS}
        missing = np.isnan(states["slider_a_distance"]).any(axis=0)
        for values in states.values():
            values[:, missing] = np.nan
        return states

    @staticmethod
    def fin_angle_field() -> str:
        """The state field of the fin link's angle to the body axis."""
        return "theta5"

    def solve(self, motor_angle: npt.ArrayLike, motor_velocity: npt.ArrayLike) -> UndulatoryState:
        """Every design at carrier angles and speeds broadcasting against (N,).

        Each sample's loop is closed from the AS of the branch's sample nearest its carrier
        angle, by the engine's Newton step to its tolerance, each sample stopping on its own
        (its result does not depend on its batch). A design whose loop does not close at one of
        the samples (next to a toggle pose), or that does not assemble, is NaN throughout.
        """
        d, cos3, sin3 = self.drive.solve_with_tail_trig(motor_angle, motor_velocity)
        shape = np.shape(d.theta3)
        g = self.lengths
        su, sw, av, vw = (g[name] for name in ("pin_offset_m", "swing_arm_m", "slotted_link_m",
                                               "fin_joint_offset_m"))  # fmt: skip
        angle = np.broadcast_to(np.asarray(motor_angle, dtype=float), shape)
        with np.errstate(invalid="ignore"):
            turns = np.remainder(angle, 2.0 * math.pi) * (BRANCH_SAMPLES / (2.0 * math.pi))
            nearest = np.rint(turns)
        index = np.where(np.isfinite(nearest), nearest, 0.0).astype(np.intp) % BRANCH_SAMPLES
        a = np.take_along_axis(self.slider, index.reshape(-1, self.size), axis=0).reshape(shape)
        seeded = np.isfinite(a)
        with np.errstate(invalid="ignore", divide="ignore"):
            residual, slope = loop_residual_and_slope(a, cos3, sin3, su, sw, av, vw)
            step = residual / slope
            for _ in range(LOOP_NEWTON_STEPS):
                a = a - step
                residual, slope = loop_residual_and_slope(a, cos3, sin3, su, sw, av, vw)
                open_loop = ~(np.abs(residual) < self.tolerance) & seeded
                if not open_loop.any():
                    break
                step = np.divide(residual, slope, out=np.zeros(shape), where=open_loop)
            open_loop = ~(np.abs(residual) < self.tolerance)
            failed = open_loop.reshape(-1, self.size).any(axis=0)
            a = np.where(failed, np.nan, a)
            dx = a + su * cos3
            dy = su * sin3
            au = np.sqrt(dx * dx + dy * dy)
            cos4, sin4 = dx / au, dy / au
            cos5 = (sw * cos3 + a - av * cos4) / vw
            sin5 = (sw * sin3 - av * sin4) / vw
            t3_dot = d.fin_angle_dot
            theta4_dot, au_rate, slider_rate, theta5_dot = loop_rates(
                t3_dot, cos3, sin3, cos4, sin4, cos5, sin5, au, su, sw, av, vw
            )
            tip_x, tip_y, tip_x_dot, tip_y_dot = loop_tip(
                g["pivot_offset_m"], sw, g["fin_link_m"] - vw, cos3, sin3, cos5, sin5, t3_dot,
                theta5_dot,
            )  # fmt: skip
            theta4, theta5 = np.arctan2(sin4, cos4), np.arctan2(sin5, cos5)
        return UndulatoryState(
            d.motor_angle, d.motor_velocity, d.slider_position, d.slider_velocity,
            d.theta1, d.theta1_dot, d.theta2, d.theta2_dot, d.theta3, d.theta3_dot,
            tip_x, tip_y, tip_x_dot, tip_y_dot,
            theta4, theta4_dot, au, au_rate, a, slider_rate, theta5, theta5_dot,
            theta5, theta5_dot,
        )  # fmt: skip

    def held_cycles(
        self, fish: FishParameters, carrier_speed_rad_s: FloatArray, samples: int
    ) -> HeldCycles | None:
        """Each design towed at its balance speed over a beat, compiled (None without numba).

        What :func:`~fishtail_plant.fish.figures.steady_surge_speed` and
        :func:`~fishtail_plant.fish.figures.held_tail` give on this batch's drive.

        Raises:
            SwimParameterError: a carrier speed that is not finite (as the carrier refuses it).
        """
        count = self.size
        speed = np.array(np.broadcast_to(np.asarray(carrier_speed_rad_s, dtype=float), count))
        constant_carrier_speed(speed)  # refuses what the numpy path refuses
        table = cycle_kernel.design_table([getattr(fish, name) for name in FISH_COLUMNS], count)
        has_chord = bool(np.any(np.asarray(fish.fin_chord_m) > 0.0))
        return loop_kernel.held_loop_cycles(
            self.drive_table, self.loop_table, self.slider, table, speed, fish.has_fin_drag,
            has_chord, samples,
        )  # fmt: skip
