"""A population of linkages: the geometry's constraints and the tail drive of every design.

:class:`OscillatoryLinkages` holds mechanism 1's designs as one
:class:`~fishtail_kinematics.engine.drive_batch.OscillatoryBatch`; :class:`UndulatoryLinkages`
holds mechanism 2's as one :class:`~fishtail_design.undulatory_batch.UndulatoryBatch` (the
second loop followed design by design by a compiled kernel). Both measure, over one stroke,
what the hull and the monitor ask of a linkage: that it assembles, its smallest transmission
angle, the room it takes at O, and how symmetric its swing is by the monitor's own statistics.
:data:`LINKAGE_TYPES` gives the class of each mechanism. What each margin means: docs/design.md
("Constraints").
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import ClassVar, NamedTuple, Protocol

import numpy as np
import numpy.typing as npt

from fishtail_design.undulatory_batch import UndulatoryBatch
from fishtail_design.variables import LINKAGE_VARIABLES
from fishtail_kinematics.engine.drive_batch import OscillatoryBatch
from fishtail_kinematics.engine.geometry import OSCILLATORY, UNDULATORY
from fishtail_plant.fish.cycle_kernel import HeldCycles, held_cycles
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.tail_drive import (
    CarrierMotion,
    LinkageBatchDrive,
    TailAcceleration,
    TailDrive,
    TailSample,
)


class Stroke(NamedTuple):
    """What one revolution of each linkage shows, one element per design."""

    assembly_inner_m: FloatArray  # OS - |RS - PR|
    assembly_outer_m: FloatArray  # RS + PR - sqrt(OS² + R²)
    second_loop_m: FloatArray  # mechanism 2's loop A-U-V-W (UndulatoryLinkages); NaN: none
    transmission_angle_rad: FloatArray  # the smallest over the stroke, in [0, pi/2]
    half_width_m: FloatArray  # how far from the body axis the linkage reaches inside the hull
    length_behind_o_m: FloatArray  # how far behind O the drive reaches (S, R)
    time_share_imbalance: FloatArray  # |share of the revolution with theta3 > 0 - 1/2|
    mean_angle_rad: FloatArray  # |mean theta3 over the carrier angle|
    tip_excursion_m: FloatArray  # peak to peak of the tip's y


class Linkages(Protocol):
    """What the search asks of a population of one mechanism's linkages (one per design)."""

    #: Whether the mechanism has a second loop, whose margin ``second_loop`` then applies.
    has_second_loop: ClassVar[bool]
    size: int

    @property
    def assembles(self) -> npt.NDArray[np.bool_]:
        """Whether each linkage assembles over the whole stroke."""

    def drive(self, carrier: CarrierMotion) -> TailDrive:
        """Every linkage turned by ``carrier`` (its angles broadcast against the designs)."""

    def held_cycles(
        self, fish: FishParameters, carrier_speed_rad_s: FloatArray, samples: int
    ) -> HeldCycles | None:
        """Each linkage towed at its balance speed over a beat, compiled (None: use drive)."""

    def stroke(self, samples: int, hull_length_m: float = math.inf) -> Stroke:
        """The stroke's figures from ``samples`` carrier angles over a revolution.

        ``hull_length_m``: where the hull ends behind O (joints beyond it are in the water).
        """


def positive_share(values: FloatArray) -> FloatArray:
    """The share of a periodic sampled signal's period where it is > 0, per column.

    Linear between samples: each interval counts the part of it on the positive side, so that
    the share is resolved far below one sample (the monitor's WARN limit is 0.005 of a beat).
    NaN for a column with a NaN sample (a linkage without a pose).
    """
    here, ahead = values, np.roll(values, -1, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        crossing = np.where(here > 0.0, here / (here - ahead), ahead / (ahead - here))
    part = np.where((here > 0.0) == (ahead > 0.0), (here > 0.0).astype(float), crossing)
    share = part.mean(axis=0)
    return np.asarray(np.where(np.isnan(values).any(axis=0), np.nan, share), dtype=float)


def _revolution(samples: int) -> FloatArray:
    """``samples`` carrier angles over one revolution, from 0."""
    return np.arange(samples, dtype=np.float64) * (2.0 * math.pi / samples)


def drive_transmission_sine(theta1: FloatArray, theta2: FloatArray) -> FloatArray:
    """|sin| of the angle at R between PR and RS (docs/design.md): 1 best, 0 at the toggle."""
    return np.asarray(np.abs(np.sin(theta1 + theta2)), dtype=np.float64)


class OscillatoryLinkages:
    """Mechanism 1's designs, one linkage per element of the length arrays."""

    has_second_loop: ClassVar[bool] = False

    def __init__(self, designs: Mapping[str, FloatArray]) -> None:
        """The linkages of ``designs`` (the lengths of :data:`LINKAGE_VARIABLES`)."""
        self.batch = OscillatoryBatch(
            designs["ring_radius_m"], designs["crank_link_m"], designs["rocker_link_m"],
            designs["tail_link_m"], designs["pivot_offset_m"],
        )  # fmt: skip
        self.size = self.batch.size

    @property
    def assembles(self) -> npt.NDArray[np.bool_]:
        """Whether each linkage assembles over the whole stroke."""
        return np.asarray(self.batch.assembles, dtype=bool)

    def drive(self, carrier: CarrierMotion) -> TailDrive:
        """Every linkage turned by ``carrier`` (its angles broadcast against the designs)."""
        return LinkageBatchDrive(self.batch, carrier)

    def held_cycles(
        self, fish: FishParameters, carrier_speed_rad_s: FloatArray, samples: int
    ) -> HeldCycles | None:
        """Each linkage towed at its balance speed over a beat by the compiled cycle kernel."""
        return held_cycles(self.batch, fish, carrier_speed_rad_s, samples)

    def stroke(self, samples: int, hull_length_m: float = math.inf) -> Stroke:
        """The stroke's figures from ``samples`` carrier angles over a revolution.

        The drive lies inside the hull whatever its length: ``hull_length_m`` is not used.
        """
        state = self.batch.solve(_revolution(samples)[:, None], 1.0)
        c = self.batch.constants
        theta1, theta2 = np.asarray(state.theta1), np.asarray(state.theta2)
        sine = drive_transmission_sine(theta1, theta2).min(axis=0)
        joint_x = c.pivot_offset_m + c.rocker_link_m * np.cos(state.theta2)
        joint_y = c.rocker_link_m * np.sin(state.theta2)
        inner, outer = self.batch.assembly_margins_m
        theta3 = np.asarray(state.theta3)
        return Stroke(
            inner, outer, np.full(self.size, np.nan), np.arcsin(np.minimum(sine, 1.0)),
            np.maximum(c.ring_radius_m, np.abs(joint_y).max(axis=0)),
            np.maximum(c.pivot_offset_m, joint_x.max(axis=0)),
            np.abs(positive_share(theta3) - 0.5), np.abs(theta3.mean(axis=0)),
            np.ptp(np.asarray(state.tip_y), axis=0),
        )  # fmt: skip


def loop_transmission_sine(
    theta4: FloatArray, theta5: FloatArray, pin_distance_m: FloatArray, slotted_link_m: FloatArray
) -> FloatArray:
    """|sin| of mechanism 2's second-loop transmission angle (docs/design.md): 1 best, 0 toggle.

    The slotted link AV can push the fin link at V only across the path V follows on AV when the
    slider A moves with SW held (frictionless slide and slot), d V / d AS =
    (-1 + AV sin²θ4 / AU, -AV sin θ4 cos θ4 / AU); the angle between that force and VW is the
    transmission angle, whose sine is |e(θ5) · dV/dAS| / |dV/dAS|. It is 0 exactly where the
    engine's Newton slope in AS vanishes (the toggle pose).
    """
    sin4, cos4 = np.sin(theta4), np.cos(theta4)
    lever = slotted_link_m * sin4 / pin_distance_m
    path_x = lever * sin4 - 1.0
    path_y = -lever * cos4
    along = np.abs(np.cos(theta5) * path_x + np.sin(theta5) * path_y)
    return np.asarray(along / np.hypot(path_x, path_y), dtype=float)


class _Remembered:
    """A drive that answers the times it was last asked from memory.

    The search asks a population's drive the same times again and again (the balance, then the
    load at the same samples; the turning figure's bisection varies the yaw rate at fixed tail
    motion); each repeat would cost a mechanism-2 population a Newton solve of its second loop.
    The remembered arrays are read-only.
    """

    def __init__(self, drive: TailDrive) -> None:
        self.drive = drive
        self._sample: tuple[FloatArray, TailSample] | None = None
        self._acceleration: tuple[FloatArray, TailAcceleration] | None = None

    def sample(self, time_s: npt.ArrayLike) -> TailSample:
        """The drive's sample at ``time_s``, from memory when the times are the last ones."""
        times = np.asarray(time_s, dtype=float)
        if self._sample is None or not _same(self._sample[0], times):
            self._sample = (times.copy(), TailSample(*_frozen(self.drive.sample(times))))
        return self._sample[1]

    def acceleration(self, time_s: npt.ArrayLike) -> TailAcceleration:
        """The drive's accelerations at ``time_s``, from memory when the times are the last ones."""
        times = np.asarray(time_s, dtype=float)
        if self._acceleration is None or not _same(self._acceleration[0], times):
            values = TailAcceleration(*_frozen(self.drive.acceleration(times)))
            self._acceleration = (times.copy(), values)
        return self._acceleration[1]


def _same(remembered: FloatArray, times: FloatArray) -> bool:
    # NaN times (the carrier of a design without a speed) are the same times.
    same = np.array_equal(remembered, times, equal_nan=True)
    return remembered.shape == times.shape and bool(same)


def _frozen(values: tuple[FloatArray, ...]) -> list[FloatArray]:
    arrays = []
    for value in values:
        array = np.array(value, dtype=float)
        array.setflags(write=False)
        arrays.append(array)
    return arrays


class UndulatoryLinkages:
    """Mechanism 2's designs, one linkage per element of the length arrays.

    The drive is mechanism 1's batch (SW its tail link); the second loop is followed design by
    design by the compiled kernel (:class:`~fishtail_design.undulatory_batch.UndulatoryBatch`),
    each pose the engine's to its tolerance. A design the engine would refuse does not
    assemble: NaN poses, its reason in ``refusals``.
    """

    has_second_loop: ClassVar[bool] = True

    def __init__(self, designs: Mapping[str, FloatArray]) -> None:
        """The linkages of ``designs`` (the lengths of :data:`LINKAGE_VARIABLES`)."""
        self.batch = UndulatoryBatch(
            {name: designs[name] for name in LINKAGE_VARIABLES[UNDULATORY]}
        )
        self.size = self.batch.size
        self.lengths = self.batch.lengths
        self.loop_conditions_m = self.batch.loop_conditions_m
        #: The engine's reason for refusing each design, None where it builds the tail.
        self.refusals: list[str | None] = self.batch.refusals

    @property
    def assembles(self) -> npt.NDArray[np.bool_]:
        """Whether each linkage assembles (both loops over the whole stroke)."""
        return np.asarray(self.batch.assembles, dtype=bool)

    def drive(self, carrier: CarrierMotion) -> TailDrive:
        """Every linkage turned by its column of ``carrier``; NaN for one that does not assemble."""
        return _Remembered(LinkageBatchDrive(self.batch, carrier))

    def held_cycles(
        self, fish: FishParameters, carrier_speed_rad_s: FloatArray, samples: int
    ) -> HeldCycles | None:
        """Each linkage towed at its balance speed over a beat by the compiled loop kernel."""
        return self.batch.held_cycles(fish, carrier_speed_rad_s, samples)

    def stroke(self, samples: int, hull_length_m: float = math.inf) -> Stroke:
        """The stroke's figures from ``samples`` carrier angles over a revolution.

        The transmission angle is the smaller of the drive's (at R) and the second loop's (at
        V); the hull's room counts the ring gear, the drive's joint R and S over their whole
        travel, and the second loop's joints U, A, V, W against the width while they lie within
        ``hull_length_m`` behind O (beyond it they are the tail, in the water, as the fin is).
        """
        columns = _stroke_columns(self.batch, samples)
        with np.errstate(invalid="ignore"):
            figures = _stroke_figures(columns, self.lengths, hull_length_m)
        conditions = self.loop_conditions_m.min(axis=0)
        # A failed condition is its own margin; else the engine's stroke says, where it built the
        # tail; where it refused the loop over the swing no distance is known (NaN: unmet).
        figures["second_loop_m"] = np.where(
            conditions < 0.0, conditions, np.minimum(conditions, figures["second_loop_m"])
        )
        inner, outer = self.batch.drive.assembly_margins_m
        return Stroke(inner, outer, **figures)


def _stroke_columns(batch: UndulatoryBatch, samples: int) -> dict[str, FloatArray]:
    """The population's stroke, (samples, N): the state's angles and the joints the hull holds.

    The joints as the engine's ``link_points`` places them (undulatory_points): R = P + PR
    (cos theta1, -sin theta1), U = S + SU e(theta3), A = (OS - AS, 0), V = A + AV e(theta4),
    W = S + SW e(theta3). NaN throughout for a design without a pose at every sample.
    """
    c = batch.stroke_states(samples)
    g = batch.lengths
    pivot = g["pivot_offset_m"]
    theta1, theta3, theta4 = c["theta1"], c["theta3"], c["theta4"]
    c["joint_r_x"] = g["crank_link_m"] * np.cos(theta1)
    c["joint_r_y"] = c["slider_position"] - g["crank_link_m"] * np.sin(theta1)
    cos3, sin3 = np.cos(theta3), np.sin(theta3)
    c["pin_u_x"], c["pin_u_y"] = pivot + g["pin_offset_m"] * cos3, g["pin_offset_m"] * sin3
    c["slider_a_x"] = pivot - c["slider_a_distance"]
    c["slider_a_y"] = np.zeros_like(theta3)
    c["joint_v_x"] = c["slider_a_x"] + g["slotted_link_m"] * np.cos(theta4)
    c["joint_v_y"] = g["slotted_link_m"] * np.sin(theta4)
    c["joint_w_x"], c["joint_w_y"] = pivot + g["swing_arm_m"] * cos3, g["swing_arm_m"] * sin3
    return c


def _stroke_figures(
    c: Mapping[str, FloatArray], lengths: Mapping[str, FloatArray], hull_length_m: float
) -> dict[str, FloatArray]:
    """Mechanism 2's stroke figures from the stacked strokes (samples, designs)."""
    drive = drive_transmission_sine(c["theta1"], c["theta2"]).min(axis=0)
    loop = loop_transmission_sine(
        c["theta4"], c["theta5"], c["pin_u_distance"], lengths["slotted_link_m"]
    ).min(axis=0)
    reach = np.maximum(lengths["ring_radius_m"], np.abs(c["joint_r_y"]).max(axis=0))
    for joint in ("pin_u", "slider_a", "joint_v", "joint_w"):
        inside = c[f"{joint}_x"] <= hull_length_m
        reach = np.maximum(reach, np.where(inside, np.abs(c[f"{joint}_y"]), 0.0).max(axis=0))
    length = np.maximum(lengths["pivot_offset_m"], c["joint_r_x"].max(axis=0))
    length = np.maximum(length, c["slider_a_x"].max(axis=0))
    pin = c["pin_u_distance"]
    slot = np.minimum(pin, lengths["slotted_link_m"] - pin).min(axis=0)
    theta3 = c["theta3"]
    return {
        "second_loop_m": np.minimum(slot, c["slider_a_distance"].min(axis=0)),
        "transmission_angle_rad": np.arcsin(np.minimum(np.minimum(drive, loop), 1.0)),
        "half_width_m": reach,
        "length_behind_o_m": length,
        "time_share_imbalance": np.abs(positive_share(theta3) - 0.5),
        "mean_angle_rad": np.abs(theta3.mean(axis=0)),
        "tip_excursion_m": np.ptp(c["tip_y"], axis=0),
    }


#: The linkages of each mechanism's designs.
LINKAGE_TYPES: dict[str, Callable[[Mapping[str, FloatArray]], Linkages]] = {
    OSCILLATORY: OscillatoryLinkages,
    UNDULATORY: UndulatoryLinkages,
}
