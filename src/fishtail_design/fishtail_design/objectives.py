"""What a design is judged by: the objectives a user picks two to four of.

Each objective is a figure of :class:`~fishtail_design.performance.Performance` with its unit and
whether more is better; the optimiser minimises, so it sees the figures to maximise negated.
Definitions: docs/design.md ("Objectives").

>>> [objective.name for objective in OBJECTIVES.values()]
['speed', 'cost_of_transport', 'turning', 'peak_current']
>>> OBJECTIVES["speed"].to_minimise(np.array([1.5])).tolist()
[-1.5]
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import NamedTuple

import numpy as np

from fishtail_design.errors import ProblemFileError
from fishtail_plant.fish.fish import FloatArray


class Objective(NamedTuple):
    """An objective: its name, the figure it reads, its unit and label, and its direction."""

    name: str
    field: str
    unit: str
    label: str
    maximise: bool

    def value(self, figures: object) -> FloatArray:
        """The objective's figure for every design (of the search's or the verified figures)."""
        return np.asarray(getattr(figures, self.field), dtype=float)

    def to_minimise(self, values: FloatArray) -> FloatArray:
        """The figure as the optimiser minimises it."""
        return -values if self.maximise else values


OBJECTIVES = {
    objective.name: objective
    for objective in (
        Objective("speed", "body_lengths_per_s", "L/s", "cruising speed", True),
        Objective("cost_of_transport", "cost_of_transport_j_kg_m", "J/(kg m)",
                  "cost of transport (electrical)", False),
        Objective("turning", "turning_rad_per_beat", "rad/beat",
                  "heading change per beat, the weaker way", True),
        Objective("peak_current", "peak_current_a", "A", "peak motor current", False),
    )
}  # fmt: skip


def objectives_named(names: Sequence[str]) -> tuple[Objective, ...]:
    """The objectives ``names`` (two to four, each once).

    Raises:
        ProblemFileError: an unknown or repeated name, or fewer than two or more than four.
    """
    unknown = [name for name in names if name not in OBJECTIVES]
    if unknown:
        raise ProblemFileError(
            f"objectives: unknown {unknown[0]!r} (choose from {', '.join(OBJECTIVES)})"
        )
    if len(set(names)) != len(names) or not 2 <= len(names) <= 4:
        raise ProblemFileError(
            f"objectives: pick two to four different ones of {', '.join(OBJECTIVES)}, got "
            f"{list(names)}"
        )
    return tuple(OBJECTIVES[name] for name in names)
