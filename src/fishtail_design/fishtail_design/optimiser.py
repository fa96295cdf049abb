"""The search: pymoo's NSGA-II over the design space, each generation evaluated as batches.

NSGA-II (Deb et al. 2002, as pymoo implements it) keeps a population ranked by Pareto
dominance, feasible designs first (Deb's constraint domination: an infeasible design never
beats a feasible one). Each generation's offspring are scored by
:func:`~fishtail_design.evaluation.evaluate_rows` through an executor (in this process, local
processes or a Dask cluster: the same numbers), the run is seeded, and after every generation
the whole state goes to a checkpoint from which ``--resume`` continues to the same front.
Why NSGA-II and how the run is set: docs/design.md ("The search").
"""

from __future__ import annotations

import functools
import hashlib
import pickle
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from pymoo.algorithms.moo.nsga2 import NSGA2
from pymoo.core.evaluator import Evaluator
from pymoo.core.problem import Problem as PymooProblem
from pymoo.problems.static import StaticProblem

from fishtail_design.errors import CheckpointError
from fishtail_design.evaluation import FIGURES, Scores, constraint_list, evaluate_rows
from fishtail_design.executors import Executor, evaluate_in_batches
from fishtail_design.problem import Problem
from fishtail_plant.fish.fish import FloatArray

#: What an infeasible or failed design's objectives and violations become for the optimiser
#: (pymoo's sorting needs finite numbers; any feasible design beats it).
_WORST = 1e12
#: The checkpoint's format: a different one is refused rather than misread.
_CHECKPOINT_FORMAT = 1


class GenerationReport(NamedTuple):
    """Where a search is: after ``generation`` of ``generations``, and the front's best values."""

    generation: int
    generations: int
    evaluated: int
    feasible: int
    best: tuple[float, ...]  # per objective, over the feasible designs so far (NaN: none yet)
    elapsed_s: float

    @property
    def eta_s(self) -> float:
        """The time left at the pace so far."""
        return self.elapsed_s / max(self.generation, 1) * (self.generations - self.generation)


class SearchResult(NamedTuple):
    """The feasible non-dominated designs of the final population, with their scores."""

    rows: FloatArray  # (designs, variables)
    scores: Scores
    evaluated: int
    generations: int


def problem_fingerprint(problem: Problem) -> str:
    """A digest of the problem's files and the search settings: what a checkpoint belongs to."""
    digest = hashlib.sha256()
    for path in (problem.path, problem.fish_path, problem.motor_path):
        digest.update(path.read_bytes())
    digest.update(repr(problem.search).encode())
    return digest.hexdigest()


class _Space(PymooProblem):  # type: ignore[misc]
    """The design space as pymoo sees it: bounds, objective and constraint counts."""

    def __init__(self, problem: Problem, constraints: int) -> None:
        space = problem.space
        super().__init__(
            n_var=len(space.names), n_obj=len(problem.objectives), n_ieq_constr=constraints,
            xl=space.lower, xu=space.upper,
        )  # fmt: skip


def _for_pymoo(problem: Problem, scores: Scores, scales: FloatArray) -> tuple[FloatArray, FloatArray]:
    """F (minimised) and G (<= 0 met, scaled) of ``scores``, finite."""
    objectives = np.stack(
        [objective.to_minimise(scores.objectives[:, index])
         for index, objective in enumerate(problem.objectives)], axis=1,
    )  # fmt: skip
    violation = -scores.margins / scales
    feasible = np.all(violation <= 0.0, axis=1) & np.all(np.isfinite(objectives), axis=1)
    objectives = np.where(feasible[:, None] & np.isfinite(objectives), objectives, _WORST)
    violation = np.where(np.isfinite(violation), violation, _WORST)
    return objectives, np.minimum(violation, _WORST)


class _Checkpoint(NamedTuple):
    format: int
    fingerprint: str
    algorithm: Any
    evaluated: int
    best: tuple[float, ...]
    elapsed_s: float


def _save(path: Path, checkpoint: _Checkpoint) -> None:
    """Write ``checkpoint`` whole or not at all (a run killed mid-write keeps the last one)."""
    partial = path.with_name(path.name + ".partial")
    partial.write_bytes(pickle.dumps(checkpoint, protocol=pickle.HIGHEST_PROTOCOL))
    partial.replace(path)


def _load(path: Path, fingerprint: str) -> _Checkpoint:
    """The checkpoint at ``path`` if it belongs to this problem.

    Raises:
        CheckpointError: a missing or unreadable file, or one of another problem or settings.
    """
    try:
        checkpoint = pickle.loads(path.read_bytes())
    except FileNotFoundError:
        raise CheckpointError(f"--resume: no checkpoint {path}") from None
    except (OSError, pickle.UnpicklingError, EOFError, AttributeError, ImportError) as error:
        raise CheckpointError(f"--resume: cannot read {path} ({error})") from None
    if not isinstance(checkpoint, _Checkpoint) or checkpoint.format != _CHECKPOINT_FORMAT:
        raise CheckpointError(f"--resume: {path} is not a checkpoint of this version")
    if checkpoint.fingerprint != fingerprint:
        raise CheckpointError(
            f"--resume: {path} belongs to another problem or search settings (its files or "
            "population, generations, seed or samples changed since)"
        )
    return checkpoint


def _best(problem: Problem, scores: Scores, previous: tuple[float, ...]) -> tuple[float, ...]:
    feasible = np.all(scores.margins >= 0.0, axis=1)
    best = []
    for index, objective in enumerate(problem.objectives):
        values = scores.objectives[feasible, index]
        values = values[np.isfinite(values)]
        candidates = [value for value in (*values.tolist(), previous[index]) if np.isfinite(value)]
        pick = max if objective.maximise else min
        best.append(pick(candidates) if candidates else float("nan"))
    return tuple(best)


def optimise(
    problem: Problem,
    executor: Executor,
    batch_size: int,
    checkpoint: Path | None = None,
    resume: bool = False,
    report: Callable[[GenerationReport], None] | None = None,
) -> SearchResult:
    """Run the search to its last generation and return the final front.

    Raises:
        CheckpointError: ``resume`` from a checkpoint that is missing or of another problem.
        ExecutorError: a batch that failed or an executor that stopped answering.
    """
    constraints = constraint_list(problem)
    scales = np.array([constraint.scale for constraint in constraints])
    space = _Space(problem, len(constraints))
    fingerprint = problem_fingerprint(problem)
    settings = problem.search
    function = functools.partial(evaluate_rows, problem)
    if resume:
        if checkpoint is None:
            raise CheckpointError("--resume needs the checkpoint's --output-dir")
        state = _load(checkpoint, fingerprint)
        algorithm, evaluated, best, spent = (state.algorithm, state.evaluated, state.best,
                                             state.elapsed_s)  # fmt: skip
    else:
        algorithm = NSGA2(pop_size=settings.population, eliminate_duplicates=True)
        algorithm.setup(space, termination=("n_gen", settings.generations), seed=settings.seed)
        evaluated, best, spent = 0, (float("nan"),) * len(problem.objectives), 0.0
    started = time.monotonic() - spent
    while algorithm.has_next():
        population = algorithm.ask()
        rows = np.asarray(population.get("X"), dtype=float)
        scores = evaluate_in_batches(executor, function, rows, batch_size)
        objectives, violation = _for_pymoo(problem, scores, scales)
        Evaluator().eval(StaticProblem(space, F=objectives, G=violation), population)
        algorithm.tell(infills=population)
        evaluated += rows.shape[0]
        best = _best(problem, scores, best)
        elapsed = time.monotonic() - started
        if checkpoint is not None:
            _save(checkpoint, _Checkpoint(_CHECKPOINT_FORMAT, fingerprint, algorithm, evaluated,
                                          best, elapsed))  # fmt: skip
        if report is not None:
            done = algorithm.n_gen - 1
            feasible = int(np.sum(np.all(scores.margins >= 0.0, axis=1)))
            report(GenerationReport(done, settings.generations, evaluated, feasible, best, elapsed))
    return _front(problem, algorithm, evaluated, settings.generations)


def _front(problem: Problem, algorithm: Any, evaluated: int, generations: int) -> SearchResult:
    """The final population's feasible non-dominated designs, scored again in this process."""
    result = algorithm.result()
    rows = np.atleast_2d(np.asarray(result.X, dtype=float)) if result.X is not None else None
    if rows is None or rows.size == 0:
        columns = (len(problem.objectives), len(constraint_list(problem)), len(FIGURES))
        empty = Scores(*(np.empty((0, count)) for count in columns))
        return SearchResult(np.empty((0, len(problem.space.names))), empty, evaluated, generations)
    scores = evaluate_rows(problem, rows)
    feasible = np.all(scores.margins >= 0.0, axis=1)
    order = np.argsort(-scores.objectives[:, 0] if problem.objectives[0].maximise
                       else scores.objectives[:, 0], kind="stable")  # fmt: skip
    keep = order[feasible[order]]
    return SearchResult(rows[keep], Scores(*(field[keep] for field in scores)), evaluated,
                        generations)  # fmt: skip
