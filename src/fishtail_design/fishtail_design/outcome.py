"""A finished synthesis: the front ranked on its verified figures, the picks and the reference.

:func:`outcome` puts the search's front, its verified figures and the reference design (the
problem's own, e.g. the report's linkage with the motor's default ratio) side by side, ranks the
front on the verified figures and says which constraint binds each design;
:func:`merge_outcomes` joins the outcomes of a search of each mechanism (``mechanism: both``)
into one, its fronts ranked together. The writers (:mod:`.output`, :mod:`.report`,
:mod:`.plots`) read nothing else.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from fishtail_common.parameter_files import load_parameter_file
from fishtail_design.constraints import Constraint, binding
from fishtail_design.errors import DesignError
from fishtail_design.evaluation import FIGURES, Scores, score_designs
from fishtail_design.problem import Problem
from fishtail_design.variables import (
    CARRIER_SPEED,
    GEAR_RATIO,
    GEARBOX_EFFICIENCY,
)
from fishtail_design.verification import Verified, verified_order, verify_designs
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_plant.fish.fish import FloatArray

#: The picks a user may ask for by name, and what each maximises or minimises (verified).
PICKS = {
    "fastest": ("body_lengths_per_s", True),
    "efficient": ("cost_of_transport_j_kg_m", False),
    "turning": ("turning_rad_per_beat", True),
}


@dataclasses.dataclass(frozen=True)
class Designs:
    """Designs with everything known of them, one element (row) per design."""

    values: dict[str, FloatArray]  # each variable by name (NaN: not one of its mechanism's)
    scores: Scores
    verified: Verified
    binding: tuple[str, ...]  # the constraint closest to binding, per design
    mechanisms: tuple[str, ...]  # each design's mechanism

    @property
    def count(self) -> int:
        """How many designs."""
        return int(self.scores.objectives.shape[0])

    def figure(self, name: str) -> FloatArray:
        """A search-tier figure (a field of Performance or Stroke) of every design."""
        return np.asarray(self.scores.figures[:, FIGURES.index(name)], dtype=float)

    def take(self, index: npt.ArrayLike) -> Designs:
        """The designs at ``index``, in that order."""
        rows = np.asarray(index, dtype=int)
        return Designs(
            {name: value[rows] for name, value in self.values.items()},
            Scores(*(field[rows] for field in self.scores)),
            Verified(*(np.asarray(field)[rows] for field in self.verified)),
            tuple(self.binding[row] for row in rows.tolist()),
            tuple(self.mechanisms[row] for row in rows.tolist()),
        )


@dataclasses.dataclass(frozen=True)
class Outcome:
    """The ranked front and the reference design of a problem."""

    problem: Problem
    constraints: tuple[Constraint, ...]
    front: Designs
    reference: Designs  # the reference design of each mechanism
    evaluated: int
    generations: int
    #: The problem of each mechanism searched (``mechanism: both``: two); () is (problem,).
    problems: tuple[Problem, ...] = ()

    def problem_of(self, mechanism: str) -> Problem:
        """The problem of the designs of ``mechanism``."""
        return next(p for p in self.problems or (self.problem,) if p.mechanism == mechanism)

    def variable_names(self) -> tuple[str, ...]:
        """Every variable of every mechanism's designs, each once: the lengths, then the rest."""
        problems = self.problems or (self.problem,)
        lengths = dict.fromkeys(name for p in problems for name in p.space.linkage_names)
        rest = self.problem.space.variable_names()[len(self.problem.space.linkage_names) :]
        return (*lengths, *rest)

    def pick(self, choice: str) -> int:
        """The index in the front of a pick: ``fastest``, ``efficient``, ``turning`` or a rank.

        Raises:
            DesignError: an unknown name, a rank outside the front, or an empty front.
        """
        if self.front.count == 0:
            raise DesignError("the front is empty: no feasible design was found")
        if choice.isdigit():
            rank = int(choice)
            if not 1 <= rank <= self.front.count:
                raise DesignError(f"--pick {choice}: the front ranks 1 to {self.front.count}")
            return rank - 1
        if choice not in PICKS:
            raise DesignError(f"--pick {choice}: choose {', '.join(PICKS)} or a rank")
        field, maximise = PICKS[choice]
        values = np.asarray(getattr(self.front.verified, field), dtype=float)
        usable = np.where(verified_feasible(self.problem, self.front.verified), values, np.nan)
        if np.all(np.isnan(usable)):
            raise DesignError(f"--pick {choice}: no verified design of the front has a {field}")
        return int(np.nanargmax(usable) if maximise else np.nanargmin(usable))


def verified_feasible(problem: Problem, verified: Verified) -> FloatArray:
    """Whether each design's verified run meets the motor's and the driver's limits and swims."""
    limits = problem.limits
    continuous = min(limits.motor_continuous_current_a, limits.driver_continuous_current_a)
    peak = min(limits.motor_peak_current_a, limits.driver_peak_current_a)
    with np.errstate(invalid="ignore"):
        return np.asarray(
            (verified.sustained == 1.0) & (verified.speed_m_s > 0.0)
            & (verified.rms_current_a <= continuous) & (verified.peak_current_a <= peak)
        )  # fmt: skip


def reference_values(problem: Problem) -> dict[str, FloatArray]:
    """The reference design: the reference file's linkage, the motor's default ratio, fastest.

    Raises:
        DesignError: a reference file of another mechanism, or a motor without a default ratio.
    """
    values = load_parameter_file(problem.reference_path)
    geometry = geometry_from_parameters(geometry_parameters_in(values))
    if geometry.mechanism != problem.mechanism:
        raise DesignError(
            f"{problem.reference_path}: a {geometry.mechanism} linkage, the problem's designs are "
            f"{problem.mechanism}"
        )
    ratio = problem.motor.default_gear_ratio
    if ratio is None:
        raise DesignError(f"{problem.motor_path}: no default gear ratio for the reference design")
    design = {name: np.array([getattr(geometry, name)]) for name in problem.space.linkage_names}
    design[GEAR_RATIO] = np.array([ratio])
    design[GEARBOX_EFFICIENCY] = np.array([problem.motor.efficiency(ratio)])
    design[CARRIER_SPEED] = np.array([math.nan])
    return design


def _designs(problem: Problem, values: dict[str, FloatArray], verified: Verified) -> Designs:
    scores, table = score_designs(problem, values)
    count = scores.objectives.shape[0]
    names = tuple(binding(table, index) for index in range(count))
    return Designs(values, scores, verified, names, (problem.mechanism,) * count)


def outcome(
    problem: Problem,
    rows: FloatArray,
    verified: Verified,
    evaluated: int,
    generations: int,
    reference_verified: Verified,
) -> Outcome:
    """The front of ``rows`` with its ``verified`` figures, ranked, and the reference design."""
    values = problem.space.decode(rows) if rows.size else {
        name: np.empty(0) for name in problem.space.variable_names()
    }  # fmt: skip
    front = _designs(problem, values, verified) if rows.size else None
    reference = _designs(problem, reference_values(problem), reference_verified)
    constraints = tuple(score_designs(problem, reference.values)[1])
    if front is None:
        empty = Designs(values, Scores(*(np.empty((0, field.shape[1])) for field in
                                         reference.scores)),
                        Verified(*(np.empty(0) for _ in Verified._fields)), (), ())  # fmt: skip
        return Outcome(problem, constraints, empty, reference, evaluated, generations)
    order = verified_order(problem, verified, verified_feasible(problem, verified))
    return Outcome(problem, constraints, front.take(order), reference, evaluated, generations)


def merge_outcomes(outcomes: Sequence[Outcome]) -> Outcome:
    """One outcome of the outcomes of a search of each mechanism, the fronts ranked together.

    The designs keep their mechanism; a variable or a constraint that a mechanism does not have
    is NaN in its designs' rows (mechanism 1 has no ``second_loop``, no ``swing_arm_m``). The
    objectives, limits and settings are the problems' shared ones.
    """
    first = outcomes[0]
    problems = tuple(p for outcome in outcomes for p in outcome.problems or (outcome.problem,))
    constraints: dict[str, Constraint] = {}
    for outcome in outcomes:
        constraints = _ordered_union(constraints, {c.name: c for c in outcome.constraints})
    merged = dataclasses.replace(first, problems=problems, constraints=tuple(constraints.values()))
    names = merged.variable_names()

    def joined(part: str) -> Designs:
        pieces = [_widened(getattr(outcome, part), outcome.constraints, names, constraints)
                  for outcome in outcomes]  # fmt: skip
        return Designs(
            {name: np.concatenate([piece.values[name] for piece in pieces]) for name in names},
            Scores(*(np.concatenate([getattr(piece.scores, field) for piece in pieces])
                     for field in Scores._fields)),  # fmt: skip
            Verified(*(np.concatenate([np.asarray(getattr(piece.verified, field), dtype=float)
                                       for piece in pieces]) for field in Verified._fields)),
            tuple(name for piece in pieces for name in piece.binding),
            tuple(mechanism for piece in pieces for mechanism in piece.mechanisms),
        )  # fmt: skip

    front = joined("front")
    order = verified_order(first.problem, front.verified,
                           verified_feasible(first.problem, front.verified))  # fmt: skip
    return dataclasses.replace(
        merged, front=front.take(order), reference=joined("reference"),
        evaluated=sum(outcome.evaluated for outcome in outcomes),
    )  # fmt: skip


def _ordered_union(
    known: dict[str, Constraint], more: dict[str, Constraint]
) -> dict[str, Constraint]:
    """``known`` and the constraints of ``more`` it lacks, each after its predecessor there."""
    names = list(known)
    previous: str | None = None
    for name in more:
        if name not in names:
            names.insert(names.index(previous) + 1 if previous else 0, name)
        previous = name
    return {name: known.get(name) or more[name] for name in names}


def _widened(
    designs: Designs,
    own: tuple[Constraint, ...],
    names: tuple[str, ...],
    constraints: dict[str, Constraint],
) -> Designs:
    """``designs`` with every variable of ``names`` and a margin column per constraint (NaN)."""
    count = designs.count
    values = {name: designs.values.get(name, np.full(count, np.nan)) for name in names}
    columns = {constraint.name: index for index, constraint in enumerate(own)}
    margins = np.full((count, len(constraints)), np.nan)
    for index, name in enumerate(constraints):
        if name in columns:
            margins[:, index] = designs.scores.margins[:, columns[name]]
    return dataclasses.replace(designs, values=values,
                               scores=designs.scores._replace(margins=margins))  # fmt: skip


def verify_reference(problem: Problem) -> Verified:
    """The reference design's verified figures (its search speed starts the motor run)."""
    values = reference_values(problem)
    scores, _ = score_designs(problem, values)
    start = scores.figures[:, FIGURES.index("carrier_speed_rad_s")]
    return verify_designs(problem, values, start)
