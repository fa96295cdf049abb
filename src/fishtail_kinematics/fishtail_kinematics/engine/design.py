"""Design helpers: symmetric rocker, swing range, assembly interval, fin ratio mu, pivot shifts.

>>> round(symmetric_rocker_link(0.1, 0.1, 0.2), 6)
0.233926
>>> [round(x, 6) for x in assembly_interval(0.1, 0.1, 0.233926)]
[0.133926, 0.318601]
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from fishtail_kinematics.engine.errors import DesignError, FishtailKinematicsError
from fishtail_kinematics.engine.geometry import FloatArray, Geometry, OscillatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail, Tail, make_tail


def symmetric_rocker_link(
    ring_radius_m: float, crank_link_m: float, pivot_offset_m: float
) -> float:
    """RS that makes the swing symmetric about the mid-stroke pose: RS^2 = PR^2 + OS sqrt(OS^2+R^2).

    The closed form is the symmetry condition only while theta2 is monotone over the stroke.

    Raises:
        DesignError: theta2 is not monotone (very short PR), or the linkage cannot assemble.
    """
    rocker = math.sqrt(crank_link_m**2 + pivot_offset_m * math.hypot(pivot_offset_m, ring_radius_m))
    geometry = OscillatoryGeometry(
        ring_radius_m=ring_radius_m,
        crank_link_m=crank_link_m,
        rocker_link_m=rocker,
        pivot_offset_m=pivot_offset_m,
    )
    try:
        tail = OscillatoryTail(geometry)
    except FishtailKinematicsError as error:
        raise DesignError(f"the symmetric RS = {rocker:.6f} m does not assemble: {error}") from None
    if not tail.monotone:
        raise DesignError(
            f"RS = {rocker:.6f} m makes theta2 non-monotone (stationary at OP = "
            f"{tail.stationary_slider_positions}), where the closed-form symmetry condition "
            "does not hold"
        )
    return rocker


def assembly_interval(
    ring_radius_m: float, crank_link_m: float, rocker_link_m: float
) -> tuple[float, float]:
    """The open interval of OS in which the drive assembles over the whole stroke.

    From |RS - PR| < OS and OS^2 + R^2 < (RS + PR)^2.

    Raises:
        DesignError: no OS assembles.
    """
    low = abs(rocker_link_m - crank_link_m)
    reach_sq = (rocker_link_m + crank_link_m) ** 2 - ring_radius_m**2
    high = math.sqrt(reach_sq) if reach_sq > 0.0 else 0.0
    if not low < high:
        raise DesignError(
            f"no OS assembles: needs |RS - PR| = {low:.6f} m < OS < "
            f"sqrt((RS + PR)^2 - R^2) = {high:.6f} m"
        )
    return low, high


def swing_range_vs_pivot_offset(
    geometry: OscillatoryGeometry, pivot_offsets_m: FloatArray, rederive_rocker: bool = False
) -> FloatArray:
    """Swing range of theta3 in radians for each OS; NaN marks an OS that cannot assemble.

    With ``rederive_rocker`` each OS gets its symmetric RS, as a designer would do.
    """
    ranges = np.full(len(pivot_offsets_m), np.nan)
    for index, offset in enumerate(pivot_offsets_m):
        rocker = geometry.rocker_link_m
        try:
            if rederive_rocker:
                rocker = symmetric_rocker_link(
                    geometry.ring_radius_m, geometry.crank_link_m, float(offset)
                )
            tail = OscillatoryTail(
                dataclasses.replace(geometry, pivot_offset_m=float(offset), rocker_link_m=rocker)
            )
        except FishtailKinematicsError:
            continue
        ranges[index] = tail.swing_range_rad
    return ranges


#: Carrier angles of the cycle over which mu is fitted.
FIN_RATIO_SAMPLES = 3600


@dataclasses.dataclass(frozen=True)
class FinRatioFit:
    """theta5 ~ mu theta3 fitted by least squares over one cycle, and how well it holds."""

    mu: float
    rms_deviation_rad: float
    max_deviation_rad: float
    local_ratio_min: float
    local_ratio_max: float


def fit_fin_ratio(geometry: Geometry, samples: int = FIN_RATIO_SAMPLES) -> FinRatioFit:
    """Fit mu in theta5 ~ mu theta3 over one carrier cycle (uniform in the motor angle).

    The fin angle is the mechanism's fin joint (theta5).

    Raises:
        DesignError: the mechanism has no fin joint.
    """
    return _fin_ratio_of(make_tail(geometry), samples)


def _fin_ratio_of(tail: Tail, samples: int) -> FinRatioFit:
    if tail.fin_joint is None:
        raise DesignError(f"the {tail.name} tail has no fin joint: no fin ratio")
    state = tail.solve(np.linspace(0.0, 2.0 * math.pi, samples, endpoint=False))
    theta3 = np.asarray(state.theta3)
    theta5 = np.asarray(getattr(state, tail.fin_joint))
    mu = float(np.dot(theta3, theta5) / np.dot(theta3, theta3))
    deviation = theta5 - mu * theta3
    # The local ratio is meaningless near theta3 = 0; use the outer half of the swing.
    outer = np.abs(theta3) > 0.5 * np.max(np.abs(theta3))
    ratio = theta5[outer] / theta3[outer]
    return FinRatioFit(
        mu=mu,
        rms_deviation_rad=float(np.sqrt(np.mean(deviation**2))),
        max_deviation_rad=float(np.max(np.abs(deviation))),
        local_ratio_min=float(ratio.min()),
        local_ratio_max=float(ratio.max()),
    )


@dataclasses.dataclass(frozen=True)
class PivotShiftEffect:
    """What shifting the pivot S does to the swing (radians; see ``Tail.with_pivot_shift``)."""

    shift_m: float
    swing_bias_rad: float  # the swing's mid-line from the body axis
    swing_range_rad: float  # theta3's range (RS, and ST or SW with it)
    mid_stroke_theta3_rad: float  # theta3 at OP = 0: 0 for an evenly timed (symmetric) swing
    fin_min_rad: float  # the last link (ST or VT) from the body axis, over a revolution
    fin_max_rad: float
    fin_mean_rad: float  # its mean over a revolution: over time at a steady carrier speed


def pivot_shift_effect(
    tail: Tail, shift_m: float, samples: int = FIN_RATIO_SAMPLES
) -> PivotShiftEffect:
    """The swing of ``tail`` with its pivot shifted by ``shift_m``.

    The fin's extremes and mean come from ``samples`` carrier angles evenly over a revolution.

    Raises:
        PivotShiftError: a shift that is not finite or outside the feasible range.
    """
    shifted = tail.with_pivot_shift(shift_m)
    drive = shifted.drive
    fin = np.asarray(
        shifted.solve(np.linspace(0.0, 2.0 * math.pi, samples, endpoint=False)).fin_angle
    )
    return PivotShiftEffect(
        shift_m=shifted.pivot_shift_m,
        swing_bias_rad=shifted.swing_bias_rad,
        swing_range_rad=drive.swing_range_rad,
        mid_stroke_theta3_rad=drive.theta2_at(0.0) - drive.theta2_mid,
        fin_min_rad=float(fin.min()),
        fin_max_rad=float(fin.max()),
        fin_mean_rad=float(fin.mean()),
    )


def design_summary(geometry: Geometry) -> dict[str, object]:
    """Everything the ``design`` command prints, as a flat mapping of named figures."""
    tail = make_tail(geometry)
    drive = tail.drive
    summary: dict[str, object] = {}
    try:
        summary["symmetric_rocker_link_m"] = symmetric_rocker_link(
            geometry.ring_radius_m, geometry.crank_link_m, geometry.pivot_offset_m
        )
    except DesignError as error:
        summary["symmetric_rocker_link_m"] = f"none ({error})"
    summary["rocker_link_m"] = geometry.rocker_link_m
    summary["swing_range_rad"] = drive.swing_range_rad
    summary["swing_range_deg"] = math.degrees(drive.swing_range_rad)
    summary["theta2_min_rad"] = drive.theta2_min
    summary["theta2_max_rad"] = drive.theta2_max
    summary["theta2_monotone"] = drive.monotone
    theta2_mid_stroke = drive.theta2_at(0.0)
    summary["swing_asymmetry_rad"] = (drive.theta2_max - theta2_mid_stroke) - (
        theta2_mid_stroke - drive.theta2_min
    )
    low, high = assembly_interval(
        geometry.ring_radius_m, geometry.crank_link_m, geometry.rocker_link_m
    )
    summary["assembly_pivot_offset_min_m"] = low
    summary["assembly_pivot_offset_max_m"] = high
    if tail.fin_joint is not None:
        fit = _fin_ratio_of(tail, FIN_RATIO_SAMPLES)
        summary["fin_ratio_mu"] = fit.mu
        summary["fin_ratio_rms_deviation_rad"] = fit.rms_deviation_rad
        summary["fin_ratio_max_deviation_rad"] = fit.max_deviation_rad
        summary["fin_ratio_local_min"] = fit.local_ratio_min
        summary["fin_ratio_local_max"] = fit.local_ratio_max
    return summary
