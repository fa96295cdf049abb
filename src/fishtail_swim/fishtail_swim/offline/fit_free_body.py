"""Fit C_D and K_D together to cruising speeds and mean yaw rates: the free body, stepped in time.

The mean yaw rate of the free fish (the Cardan tails swim a wide circle) needs time-stepped runs.
By the time scaling, runs at one carrier speed serve every row: a grid of K_D in one batch
starts the fit, :func:`scipy.optimize.least_squares` refines it, each evaluation one batch of
three fish. Why and how, and the K_D searched: docs/swimming-dynamics.md (``fit``, "With yaw
rates").
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np
from scipy.optimize import least_squares

from fishtail_plant.errors import SwimInputError
from fishtail_plant.fish.figures import beat_means
from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.fish.spheroid import crossflow_yaw_damping
from fishtail_swim.offline.fit import (
    DRAG,
    YAW_DAMPING,
    FitRefusedError,
    FitResult,
    FittedValue,
    balance_drag_coefficient,
    best_speed_ratio,
    drag_range,
)
from fishtail_swim.offline.fit_measurements import Measurements
from fishtail_swim.offline.inputs import Swimmer
from fishtail_swim.offline.progress import Progress
from fishtail_swim.offline.time_run import SUMMARY_BEATS, run_from_rest

#: Default run from rest: beats and steps per beat (the start-up transient falls about 100-fold
#: every 20 beats; the figures are over the last SUMMARY_BEATS).
FREE_BODY_BEATS = 50
FREE_BODY_STEPS_PER_BEAT = 32
#: The largest K_D searched, in units of the hull's cross-flow estimate.
YAW_DAMPING_SPAN = 30.0
#: Most runs of the refinement (each a batch of three fish).
MAX_RUNS = 12
# K_D grid of the start: 0 and half-decades up to the span (in cross-flow estimates).
_GRID = np.concatenate([[0.0], YAW_DAMPING_SPAN * np.logspace(-5.0, 0.0, 11)])
# Forward-difference steps: relative to the parameters' scales (the runs are deterministic, so
# only the Jacobian's accuracy, not the solution's, depends on them).
_DIFFERENCE_STEP = 1e-4
# Largest residual (relative) of a solved fit.
_SOLVED = 1e-6
# Largest residual of a fit reported at all (with a warning above _SOLVED).
_UNSOLVED = 1e-3
# A parameter this close to a bound (in units of its scale) is on it.
_BOUND_TOLERANCE = 1e-3
# Smallest C_D a search starts from, as a fraction of the range's top (the drag must be felt).
_SMALLEST_START = 1e-5


class RunSettings(NamedTuple):
    """The free body's runs: beats from rest and RK4 steps per beat."""

    beats: int = FREE_BODY_BEATS
    steps_per_beat: int = FREE_BODY_STEPS_PER_BEAT

    def describe(self) -> str:
        """The run in words, for the output."""
        return (
            f"free body stepped from rest, {self.beats} beats at {self.steps_per_beat} steps a "
            f"beat, speed and yaw rate over the last {SUMMARY_BEATS}"
        )


class _Runs:
    """Runs batches of the free body at one carrier speed; counts them and reports progress."""

    def __init__(
        self, swimmer: Swimmer, carrier_speed_rad_s: float, settings: RunSettings, scale: float
    ) -> None:
        self.swimmer = swimmer
        self.carrier = carrier_speed_rad_s
        self.settings = settings
        self.yaw_damping_scale = scale
        self.steps = settings.beats * settings.steps_per_beat
        self.count = 0
        self.progress = Progress(
            f"fit C_D and K_D (at most {MAX_RUNS + 1} runs)", self.steps * (MAX_RUNS + 1)
        )

    def ratios(self, drag: FloatArray, damping: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The ratios s = U/w and q = <r>/w of one fish per (C_D, K_D) pair."""
        fish = dataclasses.replace(
            self.swimmer.fish, drag_coefficient=drag, yaw_damping_kg_m2=damping
        )
        period = 2.0 * math.pi / self.carrier
        shifted = _ShiftedProgress(self.progress, self.count * self.steps)
        self.count += 1
        run = run_from_rest(
            Swimmer(fish, self.swimmer.tail), np.full(drag.size, self.carrier),
            period / self.settings.steps_per_beat, self.steps, shifted,
        )  # fmt: skip
        means = beat_means(run.trajectory, run.beat_period_s, SUMMARY_BEATS)
        return means.mean_speed_m_s / self.carrier, means.mean_yaw_rate_rad_s / self.carrier


class _ShiftedProgress(Progress):
    # One progress line over every run: each run's count is shifted by the runs before it.
    def __init__(self, whole: Progress, offset: float) -> None:
        self.whole = whole
        self.offset = offset

    def update(self, done: float) -> None:
        self.whole.update(self.offset + done)

    def finish(self) -> None:
        """The whole fit's line ends when the fit does."""


def _grid_start(
    runs: _Runs, drag: float, speed_ratio: float, yaw_ratio: float
) -> tuple[float, float]:
    """The start (C_D, K_D): K_D where the grid's curvature q/s crosses the measured q*/s*.

    The curvature is nearly independent of C_D; C_D is then scaled by (s/s*)², as if the speed
    went as 1/sqrt(C_D). A model turning the other way at every K_D is refused here.
    """
    damping = _GRID * runs.yaw_damping_scale
    speed, yaw = runs.ratios(np.full(damping.size, drag), damping)
    curvature = yaw / speed
    if yaw_ratio != 0.0 and np.all(np.sign(curvature) == -np.sign(yaw_ratio)):
        model_turn = "left (> 0)" if curvature[0] > 0.0 else "right (< 0)"
        raise FitRefusedError(
            f"the model turns {model_turn} at every K_D tried, the measured mean yaw rates the "
            "other way: yaw rates are counter-clockwise seen from above (z up) positive"
        )
    # The curvature shrinks towards 0 as K_D grows: take the first interval that brackets the
    # target, else the nearer end (the refinement then finds the bound and the fit is refused).
    below = curvature - yaw_ratio / speed_ratio
    crossing = np.flatnonzero(np.sign(below[:-1]) != np.sign(below[1:]))
    if crossing.size == 0:
        i = int(np.argmin(np.abs(below)))
        return drag * (speed[i] / speed_ratio) ** 2, float(damping[i])
    i = int(crossing[0])
    weight = below[i] / (below[i] - below[i + 1])
    start_speed = speed[i] + weight * (speed[i + 1] - speed[i])
    start_damping = damping[i] + weight * (damping[i + 1] - damping[i])
    return float(drag * (start_speed / speed_ratio) ** 2), float(start_damping)


class _Equations:
    """Residuals (s/s* - 1, (q - q*)/scale) and their Jacobian, one run of three fish per point."""

    def __init__(self, runs: _Runs, speed_ratio: float, yaw_ratio: float, scales: FloatArray):
        self.runs = runs
        self.targets = np.array([speed_ratio, yaw_ratio])
        self.scales = scales
        self.yaw_scale = abs(yaw_ratio) if yaw_ratio != 0.0 else 1e-3 * speed_ratio
        self.upper_drag = drag_range()[1]
        self.cache: dict[bytes, tuple[FloatArray, FloatArray]] = {}

    def ratios(self, point: FloatArray) -> tuple[FloatArray, FloatArray]:
        """(s, q) at ``point`` = (C_D, K_D), and d(s, q)/d(C_D, K_D)."""
        key = np.asarray(point, dtype=float).tobytes()
        if key not in self.cache:
            steps = _DIFFERENCE_STEP * self.scales
            if point[0] + steps[0] > self.upper_drag:
                steps[0] = -steps[0]
            drag = point[0] + np.array([0.0, steps[0], 0.0])
            damping = point[1] + np.array([0.0, 0.0, steps[1]])
            speed, yaw = self.runs.ratios(drag, damping)
            values = np.array([speed[0], yaw[0]])
            jacobian = np.column_stack([
                [speed[1] - speed[0], yaw[1] - yaw[0]], [speed[2] - speed[0], yaw[2] - yaw[0]]
            ]) / steps  # fmt: skip
            self.cache[key] = (values, jacobian)
        return self.cache[key]

    def residuals(self, point: FloatArray) -> FloatArray:
        """The two residuals the fit drives to zero."""
        values, _ = self.ratios(point)
        return np.array([
            values[0] / self.targets[0] - 1.0, (values[1] - self.targets[1]) / self.yaw_scale
        ])  # fmt: skip

    def jacobian(self, point: FloatArray) -> FloatArray:
        """d(residuals)/d(C_D, K_D)."""
        _, jacobian = self.ratios(point)
        return jacobian / np.array([[self.targets[0]], [self.yaw_scale]])


def fit_drag_and_yaw_damping(
    swimmer: Swimmer, measurements: Measurements, settings: RunSettings | None = None
) -> FitResult:
    """C_D and K_D from cruising speeds and mean yaw rates by the time-stepped free body.

    Raises:
        ValueError: measurements without yaw rates.
        FitRefusedError: a fit that ends on a bound with the measurements unmatched, a model that
            turns the other way at every K_D, or one that does not converge.
        SwimInputError: runs that diverge at these steps per beat.
    """
    if measurements.yaw_rate_rad_s is None:
        raise ValueError("fit_drag_and_yaw_damping needs yaw rates")
    settings = settings or RunSettings()
    carriers = measurements.carrier_speeds()
    speed_ratio, speed_error = best_speed_ratio(measurements)
    yaw_per_carrier = measurements.yaw_rate_rad_s / carriers
    yaw_ratio = float(yaw_per_carrier.mean())
    yaw_error = float(yaw_per_carrier.std(ddof=1)) / math.sqrt(carriers.size)
    fish = swimmer.fish
    scale = crossflow_yaw_damping(
        float(fish.body_length_m), float(fish.body_diameter_m), float(fish.water_density_kg_m3)
    )
    runs = _Runs(swimmer, float(np.median(carriers)), settings, scale)
    low_drag, high_drag = drag_range()
    balance = balance_drag_coefficient(swimmer, measurements).drag_coefficient
    # The balance's C_D starts the search even where it is out of range: the free body differs.
    grid_drag = min(max(balance, _SMALLEST_START * high_drag), 0.5 * high_drag)
    high_damping = YAW_DAMPING_SPAN * scale
    try:
        drag_start, damping_start = _grid_start(runs, grid_drag, speed_ratio, yaw_ratio)
        drag_start = min(max(drag_start, _SMALLEST_START * high_drag), 0.5 * high_drag)
        equations = _Equations(runs, speed_ratio, yaw_ratio, np.array([drag_start, scale]))
        solution = least_squares(
            equations.residuals, np.array([drag_start, damping_start]), jac=equations.jacobian,
            bounds=([low_drag, 0.0], [high_drag, high_damping]),
            x_scale=np.array([drag_start, scale]), max_nfev=MAX_RUNS,
            xtol=1e-12, ftol=1e-12, gtol=1e-12,
        )  # fmt: skip
    except SwimInputError as error:
        raise SwimInputError(f"{error} (--steps-per-beat)") from None
    finally:
        runs.progress.finish()
    point = np.asarray(solution.x, dtype=float)
    values, jacobian = equations.ratios(point)
    residual = float(np.max(np.abs(equations.residuals(point))))
    warnings = []
    if residual > _SOLVED:
        lower, upper = np.array([low_drag, 0.0]), np.array([high_drag, high_damping])
        near = _BOUND_TOLERANCE * np.array([drag_start, scale])
        side = np.where(point <= lower + near, -1, np.where(point >= upper - near, 1, 0))
        side = np.where(side == 0, np.asarray(solution.active_mask), side)
        model = f"measured U/w {speed_ratio:.4g} m/rad and mean yaw rate/w {yaw_ratio:.4g}"
        model += f", the model's {values[0]:.4g} and {values[1]:.4g} there"
        _refuse_at_bound(side, high_damping, scale, model)
        if residual > _UNSOLVED:
            raise FitRefusedError(
                f"the fit did not converge in {runs.count} runs (largest relative residual "
                f"{residual:.2g} at C_D = {point[0]:.4g}, K_D = {point[1]:.4g})"
            )
        warnings.append(
            f"the fit stopped after {runs.count} runs with relative residual {residual:.2g}"
        )
    errors = _propagated_errors(jacobian, speed_error, yaw_error)
    fitted_fish = dataclasses.replace(
        fish, drag_coefficient=float(point[0]), yaw_damping_kg_m2=float(point[1])
    )
    return FitResult(
        fitted_fish,
        (
            FittedValue(DRAG, float(point[0]), errors[0], float(fish.drag_coefficient)),
            FittedValue(YAW_DAMPING, float(point[1]), errors[1], float(fish.yaw_damping_kg_m2)),
        ),
        values[0] * carriers,
        values[1] * carriers,
        f"{settings.describe()}; {runs.count} runs of one batch each (C_D from the held-body "
        f"balance alone: {balance:.4g})",
        warnings=tuple(warnings),
    )


def _refuse_at_bound(side: FloatArray, high_damping: float, scale: float, model: str) -> None:
    """A fit stuck on a bound (``side``: -1 lower, 1 upper, 0 inside) is refused, saying why."""
    low_drag, high_drag = drag_range()
    if side[0] < 0:
        raise FitRefusedError(
            f"the measured speeds are faster than the free body swims at C_D = {low_drag:g} "
            f"({model}): the tail cannot drive this fish that fast; check the tail geometry, "
            "fin_span_m and the fish file"
        )
    if side[0] > 0:
        raise FitRefusedError(
            f"the measured speeds are slower than the free body swims at C_D = {high_drag:g} "
            f"({model}): check the carrier speeds and units"
        )
    if side[1] < 0:
        raise FitRefusedError(
            f"the fish turns faster than the model does with no yaw damping, K_D = 0 ({model}): "
            "check the yaw rates' units"
        )
    if side[1] > 0:
        raise FitRefusedError(
            f"the fish turns more slowly than the model does at K_D = {high_damping:.4g} kg m^2, "
            f"{YAW_DAMPING_SPAN:g} times the hull's cross-flow estimate {scale:.4g} and the "
            f"largest the fit searches ({model})"
        )


def _propagated_errors(jacobian: FloatArray, speed_error: float, yaw_error: float) -> list[float]:
    """Standard errors of (C_D, K_D) from those of s* and q* through the inverse Jacobian."""
    if math.isnan(speed_error) or math.isnan(yaw_error):
        return [math.nan, math.nan]
    try:
        inverse = np.linalg.inv(jacobian)
    except np.linalg.LinAlgError:
        return [math.inf, math.inf]
    covariance = inverse @ np.diag([speed_error**2, yaw_error**2]) @ inverse.T
    return [float(math.sqrt(covariance[0, 0])), float(math.sqrt(covariance[1, 1]))]
