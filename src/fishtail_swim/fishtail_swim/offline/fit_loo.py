"""Leave-one-out: each run predicted by the coefficients fitted to the other runs.

The residuals of a fit say how well the coefficients describe the runs they were fitted to; the
leave-one-out errors say how well the model *predicts* a run it has not seen. Every fold (all
runs but one) is one block of one least-squares problem, solved together in one batch per
evaluation; a fold the other runs cannot determine (:func:`~.fit_problem.check_determined`) has
no prediction. docs/swimming-dynamics.md (``fit``, "Leave-one-out").
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from fishtail_plant.fish.fish import FloatArray
from fishtail_swim.offline.fit import FitRefusedError, FitResult
from fishtail_swim.offline.fit_measurements import Measurements
from fishtail_swim.offline.fit_problem import (
    MAX_FREE_BODY_EVALUATIONS,
    FitProblem,
    RunModel,
    check_determined,
    coefficient_bounds,
    solve,
)
from fishtail_swim.offline.progress import Progress


class LeaveOneOut(NamedTuple):
    """Each run's speed and mean yaw rate predicted from the other runs (NaN: not predicted)."""

    speed_m_s: FloatArray
    yaw_rate_rad_s: FloatArray | None
    #: Whether the folds' fit converged within the solver's evaluations.
    converged: bool

    @property
    def predicted(self) -> FloatArray:
        """Which runs have a prediction."""
        return np.isfinite(self.speed_m_s)


def leave_one_out(model: RunModel, measurements: Measurements, result: FitResult) -> LeaveOneOut:
    """Predict every run from a fit to the others, the fit's coefficients the start.

    Raises:
        NoSteadySpeedError, SwimInputError: a model run without a speed, or one that diverges.
    """
    names = model.names
    rows = measurements.rows
    turning = model.settings is not None
    predicted = np.full(rows, np.nan)
    predicted_yaw = np.full(rows, np.nan) if turning else None
    left_out, folds = [], []
    for row in range(rows):
        fold = np.delete(np.arange(rows), row)
        try:
            check_determined(names, measurements.take(fold))
        except FitRefusedError:
            continue
        left_out.append(row)
        folds.append(fold)
    if not folds:
        return LeaveOneOut(predicted, predicted_yaw, True)
    fish = model.tails.swimmer.fish
    bounds = coefficient_bounds(fish, names, measurements)
    problem = FitProblem(model, measurements, folds, bounds)
    start = np.array([value.value for value in result.fitted])
    if turning:
        model.progress = Progress(
            f"leave-one-out ({len(folds)} folds, at most {MAX_FREE_BODY_EVALUATIONS} batches)",
            MAX_FREE_BODY_EVALUATIONS,
        )
        model.batches = 0
    try:
        point, converged = solve(problem, start)
    finally:
        if model.progress is not None:
            model.progress.finish()
            model.progress = None
    coefficients = point.reshape(len(folds), len(names))
    speed, yaw = model.values(np.array(left_out), coefficients)
    predicted[left_out] = speed
    if predicted_yaw is not None:
        predicted_yaw[left_out] = yaw
    return LeaveOneOut(predicted, predicted_yaw, converged)
