"""The Cardan tail's C_D from cruising speeds in closed form, the fit's checks and its fish file.

``fishtail-swim fit``'s results (:class:`FitResult`) and refusals, C_D of the Cardan tail from
speeds alone by the cycle-average balance in closed form, the check that the model does not
contradict the measurements, and the fitted fish file. The measurements file:
:mod:`.fit_measurements`; the general least-squares fit: :mod:`.fit_least_squares`; the
time-scaled free body with yaw rates: :mod:`.fit_free_body`. docs/swimming-dynamics.md (``fit``).
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np

from fishtail_plant.errors import SwimError
from fishtail_plant.fish.figures import cycle_mean_tail_force, steady_surge_speed
from fishtail_plant.fish.fish import (
    FISH_PARAMETERS,
    FISH_PARAMETERS_BY_NAME,
    FishParameters,
    FloatArray,
)
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed
from fishtail_swim.offline.fit_measurements import Measurements
from fishtail_swim.offline.inputs import Swimmer

DRAG = "drag_coefficient"
YAW_DAMPING = "yaw_damping_kg_m2"
# Relative step of the central difference dC_D/ds (error ~ step², far below the spread's).
_SLOPE_STEP = 1e-4
#: A fit the model contradicts: its cruising speed is the carrier speed times s(C_D), so the
#: measured U/phi-dot must agree. An RMS relative speed residual above this (a timed run's errors
#: are a few %), or a C_D standard error above MAX_DRAG_RELATIVE_ERROR of C_D, is refused.
MAX_RELATIVE_RESIDUAL = 0.2
MAX_DRAG_RELATIVE_ERROR = 0.5


class FitRefusedError(SwimError):
    """No parameter value inside its range reproduces the measurements."""


class FitContradictedError(FitRefusedError):
    """The model contradicts the measurements: its fit leaves them unexplained.

    ``reason`` is the message without the hint to --force (for the warning --force gives).
    """

    def __init__(self, reason: str) -> None:
        """The error for ``reason``, its message with the hint to --force."""
        super().__init__(f"{reason} (--force reports and writes the fit anyway)")
        self.reason = reason


class FittedValue(NamedTuple):
    """A fitted parameter, its standard error and the value the fish had before the fit.

    The standard error comes from the residuals' spread: NaN with as many rows as parameters.
    """

    name: str
    value: float
    standard_error: float
    previous: float


class FitResult(NamedTuple):
    """The fitted fish and, per measured row, the model's values with it."""

    fish: FishParameters
    fitted: tuple[FittedValue, ...]
    model_speed_m_s: FloatArray
    model_yaw_rate_rad_s: FloatArray | None
    #: How the model's values were found, in words, for the output.
    method: str
    #: Each row's own balancing C_D (speeds only), else None.
    row_drag_coefficient: FloatArray | None = None
    #: Warnings the output must show (e.g. a fit that stopped before converging).
    warnings: tuple[str, ...] = ()


def best_speed_ratio(measurements: Measurements) -> tuple[float, float]:
    """s* = U/w minimising the relative speed residuals, and its standard error (NaN: 1 row).

    Residual of row i: s x_i - 1 with x_i = w_i / U_i, linear in s.
    """
    x = measurements.carrier_speeds() / measurements.speed_m_s
    ratio = float(x.sum() / (x * x).sum())
    if x.size < 2:
        return ratio, math.nan
    residuals = ratio * x - 1.0
    variance = float((residuals * residuals).sum()) / (x.size - 1)
    return ratio, math.sqrt(variance / float((x * x).sum()))


def drag_range() -> tuple[float, float]:
    """The range of drag_coefficient's spec."""
    spec = FISH_PARAMETERS_BY_NAME[DRAG]
    low = -math.inf if spec.minimum is None else spec.minimum
    high = math.inf if spec.maximum is None else spec.maximum
    return low, high


class BalanceFit(NamedTuple):
    """The held-body balance's C_D (not yet checked against its range) and each row's."""

    drag_coefficient: float
    standard_error: float
    row_drag_coefficient: FloatArray


def balance_drag_coefficient(swimmer: Swimmer, measurements: Measurements) -> BalanceFit:
    """C_D from the speeds by the cycle-average balance, in closed form.

    The derivation: docs/swimming-dynamics.md (``fit``, "Speeds only").
    """
    carriers, speeds = measurements.carrier_speeds(), measurements.speed_m_s
    ratio, ratio_error = best_speed_ratio(measurements)
    # The balance's speed is proportional to the carrier speed: any reference speed gives the
    # same C_D; the median keeps the tail's samples at a measured speed's scale.
    reference = float(np.median(carriers))
    fitted_speed = ratio * reference * np.array([1.0, 1.0 - _SLOPE_STEP, 1.0 + _SLOPE_STEP])
    all_carriers = np.concatenate([carriers, np.full(3, reference)])
    all_speeds = np.concatenate([speeds, fitted_speed])
    drive = EngineTailDrive(swimmer.tail, constant_carrier_speed(all_carriers))
    thrust = cycle_mean_tail_force(drive, swimmer.fish, all_speeds, 2.0 * np.pi / all_carriers)
    fish = swimmer.fish
    dynamic_area = 0.5 * float(fish.water_density_kg_m3) * float(fish.reference_area_m2)
    balancing = thrust / (dynamic_area * all_speeds * all_speeds)
    slope = (balancing[-1] - balancing[-2]) / (2.0 * _SLOPE_STEP * ratio)
    return BalanceFit(
        float(balancing[-3]), abs(float(slope)) * ratio_error, balancing[: carriers.size]
    )


def check_drag_in_range(drag_coefficient: float, model: str) -> None:
    """Refuse a C_D outside its spec's range, saying which way the measurements point.

    Raises:
        FitRefusedError: ``drag_coefficient`` below or above the range.
    """
    low, high = drag_range()
    if drag_coefficient < low:
        raise FitRefusedError(
            f"the measured speeds are faster than the {model} swims at C_D = {low:g} (they need "
            f"C_D = {drag_coefficient:.4g}): the tail cannot drive this fish that fast; check the "
            "tail geometry, fin_span_m and the fish file"
        )
    if drag_coefficient > high:
        raise FitRefusedError(
            f"the measured speeds are slower than the {model} swims at C_D = {high:g} (they need "
            f"C_D = {drag_coefficient:.4g}): check the carrier speeds and units"
        )


def fit_drag(swimmer: Swimmer, measurements: Measurements) -> FitResult:
    """C_D from cruising speeds by the held-body balance; the model's speeds at every row.

    Raises:
        FitRefusedError: no C_D in its range reproduces the speeds.
    """
    balance = balance_drag_coefficient(swimmer, measurements)
    check_drag_in_range(balance.drag_coefficient, "held-body balance")
    fish = dataclasses.replace(swimmer.fish, drag_coefficient=balance.drag_coefficient)
    # The model's speeds from the library's balance at each measured carrier speed: the closed
    # form above used the speeds' proportionality, this does not.
    carriers = measurements.carrier_speeds()
    drive = EngineTailDrive(swimmer.tail, constant_carrier_speed(carriers))
    model_speed = steady_surge_speed(drive, fish, 2.0 * np.pi / carriers)
    fitted = FittedValue(
        DRAG, balance.drag_coefficient, balance.standard_error, float(swimmer.fish.drag_coefficient)
    )
    return FitResult(
        fish, (fitted,), model_speed, None,
        "cycle-average balance, sway and yaw held; C_D in closed form",
        balance.row_drag_coefficient,
    )  # fmt: skip


def check_model_agrees(result: FitResult, measurements: Measurements) -> None:
    """Refuse a fit the model contradicts (MAX_RELATIVE_RESIDUAL, MAX_DRAG_RELATIVE_ERROR).

    With quadratic drag alone the Cardan tail's cruising speed is proportional to the carrier
    speed, so the speeds must rise with it; speeds that fall, or scatter far beyond a timed run's
    errors, leave a C_D that describes none of the rows.

    Raises:
        FitContradictedError: the RMS relative speed residual or C_D's relative standard error
            above its limit (the message says which, and whether the speeds fall).
    """
    speeds = measurements.speed_m_s
    residual = _rms(result.model_speed_m_s / speeds - 1.0)
    drag = next(value for value in result.fitted if value.name == DRAG)
    error = drag.standard_error / drag.value  # NaN with one row: no spread, no refusal
    over = []
    if residual > MAX_RELATIVE_RESIDUAL:
        over.append(
            f"RMS speed residual {100.0 * residual:.3g} % (limit {100 * MAX_RELATIVE_RESIDUAL:g} %)"
        )
    if error > MAX_DRAG_RELATIVE_ERROR:
        over.append(
            f"C_D = {drag.value:.4g} +- {drag.standard_error:.2g}, a standard error of "
            f"{100.0 * error:.3g} % (limit {100 * MAX_DRAG_RELATIVE_ERROR:g} %)"
        )
    if not over:
        return
    found = f"the model contradicts the measurements: {' and '.join(over)}"
    if measurements.carrier_speed_rad_s is None or len(result.fitted) != 1:
        raise FitContradictedError(
            f"{found}; check the tail's columns, the rows and their units, or fit another "
            "--coefficients set"
        )
    carriers = measurements.carrier_speed_rad_s
    how = "scatter far from"
    if np.ptp(carriers) > 0.0 and np.polyfit(np.log(carriers), np.log(speeds), 1)[0] <= 0.0:
        how = "fall as the carrier speeds up, against"
    raise FitContradictedError(
        f"{found}; the speeds {how} the "
        "model's cruising speed, proportional to the carrier speed: check the carrier speeds, "
        "the rows and their units"
    )


def _yaml_float(value: float) -> str:
    # repr round-trips; YAML 1.1 (PyYAML, ROS) reads "1e-05" as a string, so give it a point.
    text = repr(float(value))
    if "e" in text and "." not in text:
        mantissa, exponent = text.split("e")
        text = f"{mantissa}.0e{exponent}"
    return text


def fish_file_text(result: FitResult, measurements_source: str) -> str:
    """A complete fish parameter file (config/fish.yaml's format) with the fitted values."""
    source = " ".join(measurements_source.split())
    names = ", ".join(value.name for value in result.fitted)
    lines = [
        "# The robotic fish for the swimming dynamics (fishtail_swim), in the ROS 2 parameter-file",
        f"# format. Written by `fishtail-swim fit`: {names} fitted to the measurements in",
        f"# {source}; every other value is the one the fit used (docs/swimming-dynamics.md).",
        "/**:",
        "  ros__parameters:",
    ]
    fitted = {value.name: value for value in result.fitted}
    for spec in FISH_PARAMETERS:
        value = float(getattr(result.fish, spec.name))
        if spec.name in fitted:
            error = fitted[spec.name].standard_error
            spread = "" if math.isnan(error) else f" +- {error:.3g}"
            comment = f"fitted{spread} (was {fitted[spec.name].previous:.6g})"
        else:
            comment = spec.text
        lines.append(f"    {spec.name}: {_yaml_float(value)}  # {comment}")
    return "\n".join(lines) + "\n"


def _rms(values: FloatArray) -> float:
    return float(np.sqrt(np.mean(values * values)))
