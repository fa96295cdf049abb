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
from pymoo.core.sampling import Sampling
from pymoo.operators.sampling.rnd import FloatRandomSampling
from pymoo.problems.static import StaticProblem

from fishtail_design.errors import CheckpointError
from fishtail_design.evaluation import Scores, constraint_list, evaluate_rows
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


class SearchSpace(NamedTuple):
    """What the optimiser needs of a problem: bounds, directions, constraint scales, settings."""

    lower: FloatArray
    upper: FloatArray
    maximise: tuple[bool, ...]  # per objective
    scales: FloatArray  # per constraint: what a margin is divided by
    population: int
    generations: int
    seed: int
    fingerprint: str  # what a checkpoint must belong to

    @classmethod
    def of(cls, problem: Problem) -> SearchSpace:
        """The search space of a synthesis problem."""
        constraints = constraint_list(problem)
        search = problem.search
        return cls(
            problem.space.lower, problem.space.upper,
            tuple(objective.maximise for objective in problem.objectives),
            np.array([constraint.scale for constraint in constraints]),
            search.population, search.generations, search.seed, problem_fingerprint(problem),
        )  # fmt: skip


def refinement_space(problem: Problem) -> SearchSpace:
    """The refinement's search space: the same bounds, its own population and generations."""
    space = SearchSpace.of(problem)
    search = problem.search
    return space._replace(
        population=search.refine_population, generations=search.refine_generations,
        fingerprint=space.fingerprint + ":refinement",
    )  # fmt: skip


class _Space(PymooProblem):
    """The design space as pymoo sees it: bounds, objective and constraint counts."""

    def __init__(self, space: SearchSpace) -> None:
        super().__init__(
            n_var=space.lower.size, n_obj=len(space.maximise), n_ieq_constr=space.scales.size,
            xl=space.lower, xu=space.upper,
        )  # fmt: skip


def _for_pymoo(space: SearchSpace, scores: Scores) -> tuple[FloatArray, FloatArray]:
    """F (minimised) and G (<= 0 met, scaled) of ``scores``, finite."""
    signs = np.where(np.array(space.maximise), -1.0, 1.0)
    objectives = scores.objectives * signs
    violation = -scores.margins / space.scales
    feasible = np.all(violation <= 0.0, axis=1) & np.all(np.isfinite(objectives), axis=1)
    objectives = np.where(feasible[:, None] & np.isfinite(objectives), objectives, _WORST)
    violation = np.where(np.isfinite(violation), violation, _WORST)
    return objectives, np.minimum(violation, _WORST)


class _Seeded(Sampling):
    """The given rows first, then random ones up to the population (pymoo's float sampling)."""

    def __init__(self, rows: FloatArray) -> None:
        super().__init__()
        self.rows = rows

    def _do(self, problem: Any, n_samples: int, **kwargs: Any) -> FloatArray:
        given = self.rows[:n_samples]
        rest = FloatRandomSampling()._do(problem, n_samples - given.shape[0], **kwargs)
        return np.vstack([given, np.asarray(rest, dtype=float).reshape(-1, given.shape[1])])


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


def _best(space: SearchSpace, scores: Scores, previous: tuple[float, ...]) -> tuple[float, ...]:
    feasible = np.all(scores.margins >= 0.0, axis=1)
    best = []
    for index, maximise in enumerate(space.maximise):
        values = scores.objectives[feasible, index]
        values = values[np.isfinite(values)]
        candidates = [value for value in (*values.tolist(), previous[index]) if np.isfinite(value)]
        pick = max if maximise else min
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
    """Run a synthesis problem's search to its last generation and return the final front.

    Raises:
        CheckpointError: ``resume`` from a checkpoint that is missing or of another problem.
        ExecutorError: a batch that failed or an executor that stopped answering.
    """
    return search(SearchSpace.of(problem), functools.partial(evaluate_rows, problem), executor,
                  batch_size, checkpoint, resume, report)  # fmt: skip


def search(
    space: SearchSpace,
    function: Callable[[FloatArray], Scores],
    executor: Executor,
    batch_size: int,
    checkpoint: Path | None = None,
    resume: bool = False,
    report: Callable[[GenerationReport], None] | None = None,
    initial: FloatArray | None = None,
) -> SearchResult:
    """NSGA-II over ``space``, ``function`` scoring each batch of rows; the final front.

    ``initial``: rows of the first population (the rest drawn at random), e.g. a cheaper
    search's front.

    Raises:
        CheckpointError: ``resume`` from a checkpoint that is missing or of another problem.
        ExecutorError: a batch that failed or an executor that stopped answering.
    """
    pymoo_space = _Space(space)
    objectives_count = len(space.maximise)
    if resume:
        if checkpoint is None:
            raise CheckpointError("--resume needs the checkpoint's --output-dir")
        state = _load(checkpoint, space.fingerprint)
        algorithm, evaluated, best, spent = (state.algorithm, state.evaluated, state.best,
                                             state.elapsed_s)  # fmt: skip
    else:
        sampling: Any = FloatRandomSampling()
        if initial is not None and initial.shape[0]:
            sampling = _Seeded(np.clip(initial, space.lower, space.upper))
        algorithm = NSGA2(pop_size=space.population, sampling=sampling, eliminate_duplicates=True)
        algorithm.setup(pymoo_space, termination=("n_gen", space.generations), seed=space.seed)
        evaluated, best, spent = 0, (float("nan"),) * objectives_count, 0.0
    started = time.monotonic() - spent
    while algorithm.has_next():
        population = algorithm.ask()
        rows = np.asarray(population.get("X"), dtype=float)
        scores = evaluate_in_batches(executor, function, rows, batch_size)
        objectives, violation = _for_pymoo(space, scores)
        Evaluator().eval(StaticProblem(pymoo_space, F=objectives, G=violation), population)
        algorithm.tell(infills=population)
        evaluated += rows.shape[0]
        best = _best(space, scores, best)
        elapsed = time.monotonic() - started
        if checkpoint is not None:
            _save(checkpoint, _Checkpoint(_CHECKPOINT_FORMAT, space.fingerprint, algorithm,
                                          evaluated, best, elapsed))  # fmt: skip
        if report is not None:
            done = algorithm.n_gen - 1
            feasible = int(np.sum(np.all(scores.margins >= 0.0, axis=1)))
            report(GenerationReport(done, space.generations, evaluated, feasible, best, elapsed))
    return _front(space, function, algorithm, evaluated)


def _front(
    space: SearchSpace, function: Callable[[FloatArray], Scores], algorithm: Any, evaluated: int
) -> SearchResult:
    """The final population's feasible non-dominated designs, scored again in this process.

    Ordered by the first objective (best first).
    """
    result = algorithm.result()
    rows = np.empty((0, space.lower.size)) if result.X is None else np.atleast_2d(
        np.asarray(result.X, dtype=float))  # fmt: skip
    if rows.shape[0] == 0:
        # An empty front: score one design for the columns' shapes and keep none of it.
        probe = function(space.lower[None, :])
        return SearchResult(rows, Scores(*(field[:0] for field in probe)), evaluated,
                            space.generations)  # fmt: skip
    scores = function(rows)
    feasible = np.all(scores.margins >= 0.0, axis=1)
    first = scores.objectives[:, 0]
    order = np.argsort(-first if space.maximise[0] else first, kind="stable")
    keep = order[feasible[order]]
    return SearchResult(rows[keep], Scores(*(field[keep] for field in scores)), evaluated,
                        space.generations)  # fmt: skip
