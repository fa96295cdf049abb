"""One batch of designs in, their objectives, constraint margins and figures out.

:func:`evaluate_rows` is what an executor runs on each batch: the optimiser's rows decoded into
linkages, motors and carrier speeds, the stroke and the cycle-average performance of all of them
at once, then every constraint's margin and every objective. Its result is plain arrays, so that
batches can travel between processes and machines and be joined in order.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_design.constraints import Constraint, margins
from fishtail_design.linkages import LINKAGE_TYPES, Stroke
from fishtail_design.performance import Performance, performance
from fishtail_design.problem import Problem
from fishtail_design.variables import CARRIER_SPEED, GEAR_RATIO, GEARBOX_EFFICIENCY
from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.motor.duty import MotorConstants

#: The figures a batch reports besides its objectives and margins, in column order.
FIGURES = (*Performance._fields, *Stroke._fields)


class Scores(NamedTuple):
    """A batch's results, one row per design: objectives, margins and figures as columns."""

    objectives: FloatArray  # (N, objectives), as the user reads them (not negated)
    margins: FloatArray  # (N, constraints), >= 0: met
    figures: FloatArray  # (N, FIGURES)


def constraint_list(problem: Problem) -> tuple[Constraint, ...]:
    """The problem's constraints in column order (they depend on its limits only)."""
    rows = problem.space.encode(_any_design(problem))[None, :]
    return tuple(score_designs(problem, problem.space.decode(rows))[1])


def _any_design(problem: Problem) -> dict[str, float]:
    space = problem.space
    middle = 0.5 * (space.lower + space.upper)
    values = dict(zip(space.names, middle.tolist(), strict=True))
    if space.gear_ratios:
        values[GEAR_RATIO] = space.gear_ratios[0]
    return values


def score_designs(
    problem: Problem, designs: dict[str, FloatArray]
) -> tuple[Scores, dict[Constraint, FloatArray]]:
    """The scores and the named margins of ``designs`` (each variable by name, shape (N,))."""
    samples = problem.search.samples_per_beat
    linkages = LINKAGE_TYPES[problem.mechanism](designs)
    stroke = linkages.stroke(samples, problem.limits.length_behind_o_m)
    motor = MotorConstants.of(
        problem.motor.parameters(problem.motor.default_gear_ratio),
        designs[GEAR_RATIO], designs[GEARBOX_EFFICIENCY],
    )  # fmt: skip
    turning = any(objective.name == "turning" for objective in problem.objectives)
    figures = performance(
        linkages, problem.fish, motor, designs[CARRIER_SPEED], samples,
        problem.turning_depth if turning else None,
    )  # fmt: skip
    table = margins(stroke, figures, problem.limits, linkages.has_second_loop)
    objectives = np.stack([objective.value(figures) for objective in problem.objectives], axis=1)
    columns = np.stack([*figures, *stroke], axis=1)
    return Scores(objectives, np.stack(list(table.values()), axis=1), columns), table


def evaluate_rows(problem: Problem, rows: npt.ArrayLike) -> Scores:
    """The scores of the designs ``rows`` (the optimiser's variables, one design per row).

    A design's scores are the same bits whatever batch it is in. numpy sums a lone column
    pairwise but columns side by side in order, so a single design is scored as a pair.
    """
    table = np.atleast_2d(np.asarray(rows, dtype=float))
    if table.shape[0] == 1:
        pair = score_designs(problem, problem.space.decode(np.repeat(table, 2, axis=0)))[0]
        return Scores(*(field[:1] for field in pair))
    return score_designs(problem, problem.space.decode(table))[0]
