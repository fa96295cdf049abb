"""A finished synthesis: the front ranked on its verified figures, the picks and the reference.

:func:`outcome` puts the search's front, its verified figures and the reference design (the
problem's own, e.g. the report's linkage with the motor's default ratio) side by side, ranks the
front on the verified figures and says which constraint binds each design. The writers
(:mod:`.output`, :mod:`.report`, :mod:`.plots`) read nothing else.
"""

from __future__ import annotations

import dataclasses
import math

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

    values: dict[str, FloatArray]  # each variable by name
    scores: Scores
    verified: Verified
    binding: tuple[str, ...]  # the constraint closest to binding, per design

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
        )


@dataclasses.dataclass(frozen=True)
class Outcome:
    """The ranked front and the reference design of a problem."""

    problem: Problem
    constraints: tuple[Constraint, ...]
    front: Designs
    reference: Designs
    evaluated: int
    generations: int

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
    names = tuple(binding(table, index) for index in range(scores.objectives.shape[0]))
    return Designs(values, scores, verified, names)


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
                        Verified(*(np.empty(0) for _ in Verified._fields)), ())  # fmt: skip
        return Outcome(problem, constraints, empty, reference, evaluated, generations)
    order = verified_order(problem, verified, verified_feasible(problem, verified))
    return Outcome(problem, constraints, front.take(order), reference, evaluated, generations)


def verify_reference(problem: Problem) -> Verified:
    """The reference design's verified figures (its search speed starts the motor run)."""
    values = reference_values(problem)
    scores, _ = score_designs(problem, values)
    start = scores.figures[:, FIGURES.index("carrier_speed_rad_s")]
    return verify_designs(problem, values, start)

