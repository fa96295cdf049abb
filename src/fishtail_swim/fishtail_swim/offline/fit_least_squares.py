"""Fit a coefficient set to the runs by least squares, and refuse a degenerate fit.

The general fit of ``fishtail-swim fit`` (any tail, any coefficient set): one fold of every run
(:class:`~.fit_problem.FitProblem`), then the refusals of a fit that ends on a bound or whose
Jacobian cannot separate the coefficients, and the standard errors. The closed form of
:mod:`.fit` and the time-scaled free body of :mod:`.fit_free_body` serve the Cardan tail's
quadratic and turning sets, as they always have. Refusals: docs/swimming-dynamics.md (``fit``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from fishtail_plant.fish.fish import FloatArray
from fishtail_swim.offline.fit import DRAG, YAW_DAMPING, FitRefusedError, FitResult, FittedValue
from fishtail_swim.offline.fit_free_body import YAW_DAMPING_SPAN, RunSettings
from fishtail_swim.offline.fit_measurements import Measurements
from fishtail_swim.offline.fit_problem import (
    MAX_CONDITION,
    MAX_FREE_BODY_EVALUATIONS,
    SURGE_LINEAR,
    SYMBOLS,
    Bounds,
    FitProblem,
    RunModel,
    TailRuns,
    at_bound,
    coefficient_bounds,
    condition_number,
    solve,
    standard_errors,
    start_point,
)
from fishtail_swim.offline.inputs import Swimmer
from fishtail_swim.offline.progress import Progress


def run_model(
    swimmer: Swimmer,
    measurements: Measurements,
    names: Sequence[str],
    fin_length_m: float,
    settings: RunSettings,
) -> RunModel:
    """The model a set is fitted with: the free body for the turning sets, else the balance."""
    tails = TailRuns(swimmer, measurements, fin_length_m)
    return RunModel(tails, names, settings if YAW_DAMPING in names else None)


def describe_model(model: RunModel) -> str:
    """How the model's values are found, in words, for the output."""
    if model.settings is None:
        return "cycle-average balance, sway and yaw held"
    return model.settings.describe() + " (one batch per beat period)"


def fit_coefficients(
    swimmer: Swimmer,
    measurements: Measurements,
    names: Sequence[str],
    fin_length_m: float,
    settings: RunSettings | None = None,
) -> FitResult:
    """The coefficients ``names`` that best fit every run, by bounded least squares.

    Raises:
        FitRefusedError: a fit that ends on a coefficient's bound, or whose Jacobian is singular
            or ill-conditioned (the runs cannot separate the coefficients).
        NoSteadySpeedError, SwimInputError: a model run without a speed, or one that diverges.
    """
    model = run_model(swimmer, measurements, names, fin_length_m, settings or RunSettings())
    bounds = coefficient_bounds(swimmer.fish, names, measurements)
    every = np.arange(measurements.rows)
    problem = FitProblem(model, measurements, [every], bounds)
    if model.settings is not None:
        model.progress = Progress(
            f"fit {', '.join(SYMBOLS[n] for n in names)} (at most "
            f"{MAX_FREE_BODY_EVALUATIONS} batches)", MAX_FREE_BODY_EVALUATIONS,
        )  # fmt: skip
    try:
        point, converged = solve(problem, start_point(swimmer.fish, names, bounds))
    finally:
        if model.progress is not None:
            model.progress.finish()
    residuals, jacobian = problem.evaluate(point)
    refuse_degenerate(point, jacobian, bounds, names)
    errors = standard_errors(jacobian, residuals)
    speed, yaw = model.values(every, np.tile(point, (every.size, 1)))
    fish = dataclasses.replace(
        swimmer.fish, **{name: float(value) for name, value in zip(names, point, strict=True)}
    )
    fitted = tuple(
        FittedValue(name, float(value), float(error), float(getattr(swimmer.fish, name)))
        for name, value, error in zip(names, point, errors, strict=True)
    )
    warnings = () if converged else (
        f"the fit stopped after {model.batches} batches before converging",
    )  # fmt: skip
    return FitResult(
        fish, fitted, speed, yaw if model.settings is not None else None,
        f"{describe_model(model)}; least squares over {len(names)} coefficients, "
        f"{model.batches} batches of every run",
        warnings=warnings,
    )  # fmt: skip


def refuse_degenerate(
    point: FloatArray, jacobian: FloatArray, bounds: Bounds, names: Sequence[str]
) -> None:
    """Refuse a fit on a coefficient's bound or with an ill-conditioned Jacobian.

    Raises:
        FitRefusedError: the first coefficient on a bound (saying what the runs point to), else
            a condition number above :data:`~.fit_problem.MAX_CONDITION`.
    """
    for name, side, low, high in zip(names, at_bound(point, bounds), *bounds[:2], strict=True):
        if side != 0:
            raise FitRefusedError(_bound_reason(name, side < 0, low if side < 0 else high))
    condition = condition_number(jacobian, bounds.scale)
    if condition > MAX_CONDITION:
        symbols = ", ".join(SYMBOLS[name] for name in names)
        raise FitRefusedError(
            f"the runs cannot separate {symbols}: the fit's Jacobian has condition number "
            f"{condition:.3g} (limit {MAX_CONDITION:g}); measure at more different tail motions "
            "(and turns), or fit fewer coefficients"
        )


def _bound_reason(name: str, lower: bool, bound: float) -> str:
    symbol = SYMBOLS[name]
    where = f"the fit ends on {symbol} = {bound:g}, its {'lower' if lower else 'upper'} bound"
    if name == DRAG and lower:
        return (
            f"{where}: the measured speeds are faster than the model swims with no drag: the tail "
            "cannot drive this fish that fast; check the tail, fin_span_m and the fish file"
        )
    if name == DRAG:
        return f"{where}: the measured speeds are slower than the model swims; check their units"
    if name == SURGE_LINEAR and lower:
        return (
            f"{where}: the speeds ask for no linear surge damping (or a negative one); fit a set "
            "without it (--coefficients quadratic or turning)"
        )
    if name == YAW_DAMPING and lower:
        return (
            f"{where}: the fish turns faster than the model does with no yaw damping; check the "
            "turns' signs (> 0 to the left) and units"
        )
    if name == YAW_DAMPING:
        return (
            f"{where}, {YAW_DAMPING_SPAN:g} times the hull's cross-flow estimate: the fish turns "
            "more slowly than the model does with the most yaw damping searched"
        )
    return f"{where}: the measurements push {symbol} out of its range"
