"""The least-squares fit of a set of damping coefficients to measured runs, as one batch.

The coefficient sets, what a set needs of the runs (the refusals before fitting), the model's
cruising speed and mean yaw rate of every run for many coefficient vectors at once (one fish per
run and vector), the residuals and their Jacobian, and :func:`scipy.optimize.least_squares`
within the parameters' ranges. A problem holds one or more *folds* (subsets of the runs, each
with its own coefficient vector): the fit is one fold of every run, leave-one-out
(:mod:`.fit_loo`) one fold per left-out run, solved together. Why and how:
docs/swimming-dynamics.md (``fit``).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
import numpy.typing as npt
from scipy.optimize import least_squares

from fishtail_plant.errors import SwimInputError
from fishtail_plant.fish.figures import beat_means, steady_surge_speed
from fishtail_plant.fish.fish import FISH_PARAMETERS_BY_NAME, FishParameters, FloatArray
from fishtail_plant.fish.integrator import simulate
from fishtail_plant.fish.model import SwimModel
from fishtail_plant.fish.spheroid import crossflow_yaw_damping
from fishtail_plant.fish.tail_drive import (
    EngineTailDrive,
    TailDrive,
    constant_carrier_speed,
    servo_drive,
)
from fishtail_swim.offline.fit import DRAG, YAW_DAMPING, FitRefusedError
from fishtail_swim.offline.fit_free_body import YAW_DAMPING_SPAN, RunSettings
from fishtail_swim.offline.fit_measurements import SERVO, Measurements
from fishtail_swim.offline.inputs import Swimmer
from fishtail_swim.offline.progress import Progress
from fishtail_swim.offline.time_run import SUMMARY_BEATS

SURGE_LINEAR = "surge_linear_damping_kg_s"
#: The coefficient sets ``--coefficients`` offers; the turning sets step the free body in time.
COEFFICIENT_SETS: dict[str, tuple[str, ...]] = {
    "quadratic": (DRAG,),
    "linear-quadratic": (SURGE_LINEAR, DRAG),
    "turning": (DRAG, YAW_DAMPING),
    "linear-turning": (SURGE_LINEAR, DRAG, YAW_DAMPING),
}
#: Short names for messages.
SYMBOLS = {DRAG: "C_D", SURGE_LINEAR: "X_u", YAW_DAMPING: "K_D"}
#: Most evaluations (each one batch) of a fit by the balance and by the free body.
MAX_BALANCE_EVALUATIONS = 200
MAX_FREE_BODY_EVALUATIONS = 40
#: A scaled Jacobian whose condition number is above this cannot separate the coefficients.
MAX_CONDITION = 1e8
# Forward-difference step, relative to each coefficient's scale: the model is smooth and
# deterministic, so the step sets only the Jacobian's accuracy (~1e-6), not the solution's.
_DIFFERENCE_STEP = 1e-6
# A coefficient within this of a bound, in units of its scale, is on it.
_BOUND_TOLERANCE = 1e-6

IntArray = npt.NDArray[np.int_]


def coefficient_names(choice: str | None, measurements: Measurements) -> tuple[str, ...]:
    """The set ``choice`` names; without one, ``turning`` with turning data, else ``quadratic``."""
    if choice is None:
        choice = "turning" if measurements.has_turning else "quadratic"
    return COEFFICIENT_SETS[choice]


def check_determined(names: Sequence[str], measurements: Measurements) -> None:
    """Refuse a fit the runs cannot determine, before fitting.

    Raises:
        FitRefusedError: fewer runs than coefficients, runs at fewer different tail motions
            than speed coefficients (only different speeds separate linear from quadratic drag),
            or yaw damping without a measured turn.
    """
    described = " and ".join(names)
    if measurements.rows < len(names):
        raise FitRefusedError(
            f"fitting {described} needs at least {len(names)} measured rows, "
            f"got {measurements.rows}"
        )
    speed_names = [name for name in names if name != YAW_DAMPING]
    motions = measurements.distinct_motions()
    if motions < len(speed_names):
        what = "amplitude and frequency" if measurements.kind == SERVO else "carrier speed"
        raise FitRefusedError(
            f"fitting {described} needs runs at {len(speed_names)} or more different tail "
            f"motions to separate {' from '.join(SYMBOLS[n] for n in speed_names)}, got "
            f"{motions} (every run at one {what}): measure at other {what}s, or fit "
            "--coefficients quadratic"
        )
    if YAW_DAMPING in names:
        yaw = measurements.turning_yaw_rate_rad_s()
        if not np.isfinite(yaw).any():
            raise FitRefusedError(
                f"fitting {described} needs a measured turn (yaw_rate_rad_s or "
                "turning_radius_m) in some row, got none: fit --coefficients quadratic"
            )
        if not np.any(yaw[np.isfinite(yaw)] != 0.0):
            raise FitRefusedError(
                f"fitting {described} needs a turning run: every measured yaw rate is 0, and a "
                "fish that swims straight says nothing of its yaw damping"
            )


class TailRuns:
    """The tail of every measured run, as a drive for any batch of runs (rows may repeat)."""

    def __init__(self, swimmer: Swimmer, measurements: Measurements, fin_length_m: float):
        """Keep the Cardan tail (``swimmer.tail``) or the servo's fin length for the runs."""
        self.swimmer = swimmer
        self.measurements = measurements
        self.fin_length_m = fin_length_m
        self.beat_period_s = 2.0 * np.pi / measurements.beat_angular_frequency_rad_s

    def drive(self, rows: IntArray) -> TailDrive:
        """The tail drive of one fish per entry of ``rows``."""
        m = self.measurements
        if m.kind == SERVO:
            return servo_drive({
                "servo_fin_length_m": np.full(rows.size, self.fin_length_m),
                "servo_amplitude_rad": np.asarray(m.amplitude_rad)[rows],
                "servo_bias_rad": np.asarray(m.bias_rad)[rows],
                "servo_frequency_hz": np.asarray(m.frequency_hz)[rows],
            })  # fmt: skip
        return EngineTailDrive(self.swimmer.tail, constant_carrier_speed(m.carrier_speeds()[rows]))


def _fish_with(fish: FishParameters, names: Sequence[str], values: FloatArray) -> FishParameters:
    # One fish per row of values (N, k): the named coefficients replaced, the rest shared.
    return dataclasses.replace(fish, **{name: values[:, j] for j, name in enumerate(names)})


class RunModel:
    """The model's cruising speeds (and mean yaw rates) of runs, one batch per call.

    Without ``settings``: the cycle-average balance (sway and yaw held, no yaw rate). With them:
    the free body from rest, one run per beat period (the integrator steps every fish of a batch
    at one step, which must divide its beat period), speed and yaw rate over the last beats.
    """

    def __init__(
        self, tails: TailRuns, names: Sequence[str], settings: RunSettings | None = None
    ) -> None:
        """The model of ``tails``' runs with the coefficients ``names`` free."""
        self.tails = tails
        self.names = tuple(names)
        self.settings = settings
        self.batches = 0
        self.progress: Progress | None = None

    def values(self, rows: IntArray, coefficients: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Speed and mean yaw rate (0 for the balance) of run ``rows[i]`` with ``coefficients[i]``.

        Raises:
            NoSteadySpeedError: a balance with no positive speed.
            SwimInputError: a free-body run that diverges.
        """
        fish = self.tails.swimmer.fish
        self.batches += 1
        if self.settings is None:
            batch = _fish_with(fish, self.names, coefficients)
            speed = steady_surge_speed(
                self.tails.drive(rows), batch, self.tails.beat_period_s[rows]
            )
            return np.asarray(speed, dtype=float), np.zeros(rows.size)
        speed, yaw = np.empty(rows.size), np.empty(rows.size)
        periods = self.tails.beat_period_s[rows]
        for period in np.unique(periods):
            group = np.flatnonzero(periods == period)
            speed[group], yaw[group] = self._free_body(
                rows[group], coefficients[group], float(period)
            )
        if self.progress is not None:
            self.progress.update(self.batches)
        return speed, yaw

    def _free_body(
        self, rows: IntArray, coefficients: FloatArray, period: float
    ) -> tuple[FloatArray, FloatArray]:
        assert self.settings is not None
        fish = _fish_with(self.tails.swimmer.fish, self.names, coefficients)
        model = SwimModel(fish, self.tails.drive(rows))
        steps = self.settings.beats * self.settings.steps_per_beat
        try:
            trajectory = simulate(model, rows.size, period / self.settings.steps_per_beat, steps)
        except SwimInputError:
            raise SwimInputError(
                "the integration diverged (non-finite state): use more --steps-per-beat"
            ) from None
        means = beat_means(trajectory, period, SUMMARY_BEATS)
        return means.mean_speed_m_s, means.mean_yaw_rate_rad_s


class Bounds(NamedTuple):
    """Each coefficient's range and scale (for steps, tolerances and the solver's x_scale)."""

    lower: FloatArray
    upper: FloatArray
    scale: FloatArray


def coefficient_bounds(
    fish: FishParameters, names: Sequence[str], measurements: Measurements
) -> Bounds:
    """The ranges of the coefficients' specs, and their scales from the fish and the speeds.

    K_D's range ends at :data:`~.fit_free_body.YAW_DAMPING_SPAN` times the hull's cross-flow
    estimate: beyond any hull's, and too stiff a yaw equation for the runs' steps.
    """
    crossflow = crossflow_yaw_damping(
        float(fish.body_length_m), float(fish.body_diameter_m), float(fish.water_density_kg_m3)
    )
    drag = max(float(fish.drag_coefficient), 0.05)
    # A linear drag as strong as the quadratic one at the runs' typical speed.
    quadratic = 0.5 * float(fish.water_density_kg_m3) * float(fish.reference_area_m2) * drag
    typical = {
        DRAG: drag,
        SURGE_LINEAR: quadratic * float(np.median(measurements.speed_m_s)),
        YAW_DAMPING: crossflow,
    }
    lower, upper, scale = [], [], []
    for name in names:
        spec = FISH_PARAMETERS_BY_NAME[name]
        lower.append(-math.inf if spec.minimum is None else spec.minimum)
        high = math.inf if spec.maximum is None else spec.maximum
        upper.append(min(high, YAW_DAMPING_SPAN * crossflow) if name == YAW_DAMPING else high)
        scale.append(typical[name])
    return Bounds(np.array(lower), np.array(upper), np.array(scale))


class FitProblem:
    """Residuals and Jacobian of folds of runs, each fold with its own coefficient vector.

    Residuals: U_model / U_measured - 1 per run, and (r_model - r_measured) / r_scale per run
    with a measured turn in the turning sets, r_scale the RMS of the measured turns (so that a
    turn's relative error weighs as a speed's).
    """

    def __init__(
        self, model: RunModel, measurements: Measurements, folds: Sequence[IntArray], bounds: Bounds
    ) -> None:
        """The problem of ``folds`` (row indices into ``measurements``)."""
        self.model = model
        self.folds = [np.asarray(fold, dtype=int) for fold in folds]
        self.bounds = bounds
        self.speed = measurements.speed_m_s
        self.turning = YAW_DAMPING in model.names
        yaw = measurements.turning_yaw_rate_rad_s()
        self.yaw = yaw if self.turning else np.full(yaw.size, np.nan)
        measured = self.yaw[np.isfinite(self.yaw)]
        self.yaw_scale = float(np.sqrt(np.mean(measured**2))) if measured.size else 1.0
        self.cache: dict[bytes, tuple[FloatArray, FloatArray]] = {}

    @property
    def size(self) -> int:
        """Coefficients per fold."""
        return len(self.model.names)

    def _fold_residuals(self, fold: IntArray, speed: FloatArray, yaw: FloatArray) -> FloatArray:
        turned = np.isfinite(self.yaw[fold])
        return np.concatenate([
            speed / self.speed[fold] - 1.0, (yaw[turned] - self.yaw[fold][turned]) / self.yaw_scale
        ])  # fmt: skip

    def evaluate(self, x: FloatArray) -> tuple[FloatArray, FloatArray]:
        """Residuals and their (block-diagonal) Jacobian at ``x``, every fold in one batch."""
        key = np.asarray(x, dtype=float).tobytes()
        if key in self.cache:
            return self.cache[key]
        k = self.size
        points = np.asarray(x, dtype=float).reshape(len(self.folds), k)
        steps = _DIFFERENCE_STEP * self.bounds.scale
        rows, coefficients, steps_used = [], [], []
        for point, fold in zip(points, self.folds, strict=True):
            # The point and one forward step in each coefficient (backward at the upper bound),
            # each for every run of the fold.
            step = np.where(point + steps > self.bounds.upper, -steps, steps)
            steps_used.append(step)
            variants = np.vstack([point, point + np.diag(step)])
            coefficients.append(np.repeat(variants, fold.size, axis=0))
            rows.append(np.tile(fold, k + 1))
        speed, yaw = self.model.values(np.concatenate(rows), np.concatenate(coefficients))
        residuals, blocks, start = [], [], 0
        for fold, step in zip(self.folds, steps_used, strict=True):
            n = fold.size
            base = self._fold_residuals(fold, speed[start : start + n], yaw[start : start + n])
            columns = []
            for j in range(k):
                at = start + (j + 1) * n
                moved = self._fold_residuals(fold, speed[at : at + n], yaw[at : at + n])
                columns.append((moved - base) / step[j])
            residuals.append(base)
            blocks.append(np.column_stack(columns))
            start += (k + 1) * n
        jacobian = np.zeros((sum(block.shape[0] for block in blocks), k * len(self.folds)))
        row = 0
        for index, block in enumerate(blocks):
            jacobian[row : row + block.shape[0], index * k : (index + 1) * k] = block
            row += block.shape[0]
        self.cache[key] = (np.concatenate(residuals), jacobian)
        return self.cache[key]

    def residuals(self, x: FloatArray) -> FloatArray:
        """The residuals at ``x``."""
        return self.evaluate(x)[0]

    def jacobian(self, x: FloatArray) -> FloatArray:
        """d(residuals)/dx at ``x``."""
        return self.evaluate(x)[1]


def start_point(fish: FishParameters, names: Sequence[str], bounds: Bounds) -> FloatArray:
    """The fish's own values, moved off the bounds into the range (the solver starts inside)."""
    values = np.array([float(getattr(fish, name)) for name in names])
    values = np.where(values > bounds.lower + 0.01 * bounds.scale, values, 0.1 * bounds.scale)
    return np.minimum(values, 0.5 * (bounds.lower + bounds.upper))


def solve(problem: FitProblem, start: FloatArray) -> tuple[FloatArray, bool]:
    """The least-squares coefficients of every fold from ``start`` (one vector per fold).

    Returns the solution and whether the solver converged within its evaluations.
    """
    folds = len(problem.folds)
    tile = problem.bounds
    free_body = problem.model.settings is not None
    solution = least_squares(
        problem.residuals, np.tile(start, folds), jac=problem.jacobian,
        bounds=(np.tile(tile.lower, folds), np.tile(tile.upper, folds)),
        x_scale=np.tile(tile.scale, folds), method="trf", xtol=1e-12, ftol=1e-12, gtol=1e-12,
        max_nfev=MAX_FREE_BODY_EVALUATIONS if free_body else MAX_BALANCE_EVALUATIONS,
    )  # fmt: skip
    return np.asarray(solution.x, dtype=float), bool(solution.status > 0)


def at_bound(point: FloatArray, bounds: Bounds) -> FloatArray:
    """-1 where a coefficient is on its lower bound, 1 on its upper, 0 inside."""
    near = _BOUND_TOLERANCE * bounds.scale
    return np.where(
        point <= bounds.lower + near, -1, np.where(point >= bounds.upper - near, 1, 0)
    ).astype(float)


def condition_number(jacobian: FloatArray, scale: FloatArray) -> float:
    """The condition number of the Jacobian with each coefficient in units of its scale."""
    singular = np.linalg.svd(jacobian * scale[None, :], compute_uv=False)
    if singular.size == 0 or singular[-1] <= 0.0:
        return math.inf
    return float(singular[0] / singular[-1])


def standard_errors(jacobian: FloatArray, residuals: FloatArray) -> FloatArray:
    """Standard errors from the residuals' spread through the Jacobian (NaN: no spread)."""
    rows, k = jacobian.shape
    if rows <= k:
        return np.full(k, np.nan)
    variance = float(residuals @ residuals) / (rows - k)
    try:
        covariance = np.linalg.inv(jacobian.T @ jacobian) * variance
    except np.linalg.LinAlgError:
        return np.full(k, np.inf)
    return np.sqrt(np.abs(np.diag(covariance)))
