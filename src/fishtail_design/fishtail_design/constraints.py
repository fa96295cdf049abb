"""The constraints of a design, each a name and a signed margin (>= 0: met).

Margins are in the constraint's own unit (metres, degrees, amperes, ...), as a builder reads
them in ``front.csv``; the optimiser sees each divided by its scale, so that no unit outweighs
another in the total violation. A design with any negative margin is infeasible and never
enters a front. What each constraint asks: docs/design.md ("Constraints").
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import NamedTuple

import numpy as np

from fishtail_design.linkages import Stroke
from fishtail_design.performance import Performance
from fishtail_kinematics.engine.symmetry import SymmetryTolerances
from fishtail_plant.fish.fish import FloatArray

_ROUNDING = 1e-9
#: A builder's optional band: (low, high), either may be None.
Band = tuple[float | None, float | None]


@dataclasses.dataclass(frozen=True)
class Limits:
    """What a design must meet besides assembling.

    The hull's room at O (a box: its width at O, a length behind O), the smallest transmission
    angle, the monitor's WARN tolerances for the swing's symmetry, the motor's and its driver's
    current ratings, and optional bands on the tip's excursion, the beat frequency and the
    Strouhal number.
    """

    hull_width_at_o_m: float
    length_behind_o_m: float
    min_transmission_angle_deg: float = 30.0
    symmetry: SymmetryTolerances = SymmetryTolerances()
    motor_continuous_current_a: float = math.inf
    motor_peak_current_a: float = math.inf
    driver_continuous_current_a: float = math.inf
    driver_peak_current_a: float = math.inf
    tip_excursion_m: Band = (None, None)
    beat_frequency_hz: Band = (None, None)
    strouhal_number: Band = (None, None)


class Constraint(NamedTuple):
    """A constraint's name, the unit of its margin and the scale the optimiser divides it by."""

    name: str
    unit: str
    scale: float


def _band_margins(name: str, unit: str, values: FloatArray, band: Band, scale: float
                  ) -> dict[Constraint, FloatArray]:  # fmt: skip
    margins = {}
    low, high = band
    if low is not None:
        margins[Constraint(f"{name}_min", unit, scale)] = values - low
    if high is not None:
        margins[Constraint(f"{name}_max", unit, scale)] = high - values
    return margins


def margins(
    stroke: Stroke, figures: Performance, limits: Limits, second_loop: bool = False
) -> dict[Constraint, FloatArray]:
    """Every constraint's margin for every design (NaN figures count as unmet).

    ``second_loop``: the mechanism has one (mechanism 2), and its margin ``second_loop``
    applies: the smallest of its signed lengths (the pin U short of W's joint, W between V and
    T, the slider A behind S, U inside AV's slot over the stroke); unmet without a distance
    where the engine refused the loop during its sweep or the drive gives it no swing.
    """
    length = max(limits.hull_width_at_o_m, limits.length_behind_o_m)
    tolerances = limits.symmetry
    continuous = min(limits.motor_continuous_current_a, limits.driver_continuous_current_a)
    peak = min(limits.motor_peak_current_a, limits.driver_peak_current_a)
    loops = {
        Constraint("assembly_inner", "m", length): stroke.assembly_inner_m,
        Constraint("assembly_outer", "m", length): stroke.assembly_outer_m,
    }
    if second_loop:
        loops[Constraint("second_loop", "m", length)] = stroke.second_loop_m
    result = loops | {
        Constraint("transmission_angle", "deg", limits.min_transmission_angle_deg or 1.0):
            np.degrees(stroke.transmission_angle_rad) - limits.min_transmission_angle_deg,
        Constraint("hull_width", "m", length):
            0.5 * limits.hull_width_at_o_m - stroke.half_width_m,
        Constraint("hull_length", "m", length):
            limits.length_behind_o_m - stroke.length_behind_o_m,
        Constraint("symmetry_time_share", "", tolerances.time_share_warn or 1.0):
            tolerances.time_share_warn - stroke.time_share_imbalance,
        Constraint("symmetry_mean_angle", "rad", tolerances.mean_angle_warn_rad or 1.0):
            tolerances.mean_angle_warn_rad - stroke.mean_angle_rad,
        # The balance speed, NaN (not met) for a tail whose thrust never beats the drag.
        Constraint("swims", "m/s", 1.0): figures.speed_m_s,
        # Run as fast as the motor sustains, the two are equal: rounding must not count.
        Constraint("motor_speed", "rad/s", 1.0): figures.sustained_speed_rad_s * (1.0 + _ROUNDING)
            - figures.carrier_speed_rad_s,
    }  # fmt: skip
    if math.isfinite(continuous):
        result[Constraint("rms_current", "A", continuous)] = continuous - figures.rms_current_a
    if math.isfinite(peak):
        result[Constraint("peak_current", "A", peak)] = peak - figures.peak_current_a
    result |= _band_margins("tip_excursion", "m", stroke.tip_excursion_m,
                            limits.tip_excursion_m, length)  # fmt: skip
    result |= _band_margins("beat_frequency", "Hz", figures.beat_frequency_hz,
                            limits.beat_frequency_hz, 1.0)  # fmt: skip
    result |= _band_margins("strouhal_number", "", figures.strouhal_number,
                            limits.strouhal_number, 0.1)  # fmt: skip
    # A figure that could not be computed (a linkage that does not assemble) is not met.
    return {key: np.where(np.isnan(value), -np.inf, value) for key, value in result.items()}


def feasible(margin_table: Mapping[Constraint, FloatArray]) -> FloatArray:
    """Whether every margin of each design is >= 0."""
    return np.asarray(np.all([value >= 0.0 for value in margin_table.values()], axis=0))


def binding(margin_table: Mapping[Constraint, FloatArray], index: int) -> str:
    """The constraint closest to binding for design ``index`` (its smallest scaled margin).

    A margin that could not be measured (-inf: the linkage does not assemble) follows from a
    measured one that fails, where there is one: that one is named.
    """
    scaled = {key.name: float(value[index]) / key.scale for key, value in margin_table.items()}
    measured = {name: value for name, value in scaled.items() if math.isfinite(value)}
    if measured and min(measured.values()) < 0.0:
        scaled = measured
    return min(scaled, key=lambda name: scaled[name])
