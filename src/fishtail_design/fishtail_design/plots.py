"""``front.png``: the front in its objectives, search and verified, and the reference design.

Every pair of objectives gets a panel (one for two objectives, up to six for four): each front
design at its cycle-average figures and, joined to them, at its verified ones; the reference
design (the report's) marked; with a search of each mechanism, each mechanism's designs and
reference have their own marker. All of the synthesis' plotting is here.
"""

from __future__ import annotations

import itertools
import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the back end is chosen first)
import numpy as np  # noqa: E402

from fishtail_design.outcome import Outcome  # noqa: E402

#: Each mechanism's markers: front designs, the reference at its search and verified figures.
_MARKERS = {"oscillatory": ("o", "*", "X"), "undulatory": ("s", "P", "D")}


def _axis_label(outcome: Outcome, index: int) -> str:
    objective = outcome.problem.objectives[index]
    return f"{objective.label} [{objective.unit}]"


def draw_front(outcome: Outcome, path: Path) -> None:
    """Write the front's figure to ``path`` (PNG)."""
    objectives = outcome.problem.objectives
    pairs = list(itertools.combinations(range(len(objectives)), 2))
    columns = min(len(pairs), 3)
    rows = math.ceil(len(pairs) / columns)
    figure, axes = plt.subplots(rows, columns, figsize=(6.0 * columns, 4.8 * rows), squeeze=False)
    front, reference = outcome.front, outcome.reference
    for axis, (first, second) in zip(axes.flat, pairs, strict=False):
        search = front.scores.objectives
        verified = np.stack([objective.value(front.verified)
                             for objective in objectives], axis=1)  # fmt: skip
        for index in range(front.count):
            axis.plot([search[index, first], verified[index, first]],
                      [search[index, second], verified[index, second]],
                      color="0.75", linewidth=0.8, zorder=1)  # fmt: skip
        reference_search = reference.scores.objectives
        reference_verified = np.stack([objective.value(reference.verified)
                                       for objective in objectives], axis=1)  # fmt: skip
        several = len(reference.mechanisms) > 1
        for mechanism in reference.mechanisms:
            own, searched, checked = _MARKERS[mechanism]
            name = f" ({mechanism})" if several else ""
            mine = np.array([m == mechanism for m in front.mechanisms], dtype=bool)
            axis.scatter(search[mine, first], search[mine, second], s=18, color="tab:blue",
                         marker=own, label=f"front{name}, cycle-average (search)",
                         zorder=2)  # fmt: skip
            axis.scatter(verified[mine, first], verified[mine, second], s=18,
                         color="tab:orange", marker=own,
                         label=f"front{name}, time-stepped (verified)", zorder=3)  # fmt: skip
            at = reference.mechanisms.index(mechanism)
            axis.scatter(reference_search[at, first], reference_search[at, second],
                         marker=searched, s=160, color="tab:red", edgecolor="black",
                         label=f"reference{name}, search", zorder=4)  # fmt: skip
            axis.scatter(reference_verified[at, first], reference_verified[at, second],
                         marker=checked, s=110, color="tab:red", edgecolor="black",
                         label=f"reference{name}, verified", zorder=4)  # fmt: skip
        axis.set_xlabel(_axis_label(outcome, first))
        axis.set_ylabel(_axis_label(outcome, second))
        axis.grid(True, alpha=0.3)
    for axis in list(axes.flat)[len(pairs):]:
        axis.set_visible(False)
    axes.flat[0].legend(fontsize=8, loc="best")
    figure.suptitle(
        f"{outcome.problem.path.name}: {front.count} feasible designs on the front "
        f"({outcome.evaluated} evaluated, {outcome.generations} generations)\n"
        "reference: " + ", ".join(outcome.problem_of(m).reference_path.name
                                  for m in reference.mechanisms), fontsize=10,
    )  # fmt: skip
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
