"""A population of linkages: the geometry's constraints and the tail drive of every design.

:class:`OscillatoryLinkages` holds mechanism 1's designs as one
:class:`~fishtail_kinematics.engine.drive_batch.OscillatoryBatch` and measures, over one stroke,
what the hull and the monitor ask of a linkage: that it assembles, its smallest transmission
angle, the room it takes at O, and how symmetric its swing is by the monitor's own statistics.
What each margin means: docs/design.md ("Constraints").
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.drive_batch import OscillatoryBatch
from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.fish.tail_drive import CarrierMotion, LinkageBatchDrive, TailDrive


class Stroke(NamedTuple):
    """What one revolution of each linkage shows, one element per design."""

    assembly_inner_m: FloatArray  # OS - |RS - PR|
    assembly_outer_m: FloatArray  # RS + PR - sqrt(OS² + R²)
    transmission_angle_rad: FloatArray  # the smallest over the stroke, in [0, pi/2]
    half_width_m: FloatArray  # how far from the body axis the drive reaches (ring gear, R)
    length_behind_o_m: FloatArray  # how far behind O the drive reaches (S, R)
    time_share_imbalance: FloatArray  # |share of the revolution with theta3 > 0 - 1/2|
    mean_angle_rad: FloatArray  # |mean theta3 over the carrier angle|
    tip_excursion_m: FloatArray  # peak to peak of the tip's y


def positive_share(values: FloatArray) -> FloatArray:
    """The share of a periodic sampled signal's period where it is > 0, per column.

    Linear between samples: each interval counts the part of it on the positive side, so that
    the share is resolved far below one sample (the monitor's WARN limit is 0.005 of a beat).
    """
    here, ahead = values, np.roll(values, -1, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        crossing = np.where(here > 0.0, here / (here - ahead), ahead / (ahead - here))
    part = np.where((here > 0.0) == (ahead > 0.0), (here > 0.0).astype(float), crossing)
    return np.asarray(part.mean(axis=0), dtype=float)


class OscillatoryLinkages:
    """Mechanism 1's designs, one linkage per element of the length arrays."""

    def __init__(self, designs: dict[str, FloatArray]) -> None:
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

    def stroke(self, samples: int) -> Stroke:
        """The stroke's figures from ``samples`` carrier angles over a revolution."""
        angles = (np.arange(samples) * (2.0 * math.pi / samples))[:, None]
        state = self.batch.solve(angles, 1.0)
        c = self.batch.constants
        # sin(theta1 + theta2) is the sine of the angle at R between PR and RS (docs/design.md).
        sine = np.abs(np.sin(state.theta1 + state.theta2)).min(axis=0)
        joint_x = c.pivot_offset_m + c.rocker_link_m * np.cos(state.theta2)
        joint_y = c.rocker_link_m * np.sin(state.theta2)
        inner, outer = self.batch.assembly_margins_m
        theta3 = np.asarray(state.theta3)
        return Stroke(
            inner, outer, np.arcsin(np.minimum(sine, 1.0)),
            np.maximum(c.ring_radius_m, np.abs(joint_y).max(axis=0)),
            np.maximum(c.pivot_offset_m, joint_x.max(axis=0)),
            np.abs(positive_share(theta3) - 0.5), np.abs(theta3.mean(axis=0)),
            np.ptp(np.asarray(state.tip_y), axis=0),
        )  # fmt: skip
