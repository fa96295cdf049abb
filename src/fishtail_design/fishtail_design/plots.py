"""``front.png``: the front in its objectives, search and verified, and the reference design.

Every pair of objectives gets a panel (one for two objectives, up to six for four): each front
design at its cycle-average figures and, joined to them, at its verified ones; the reference
design (the report's) marked. All of the synthesis' plotting is here.
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
        axis.scatter(search[:, first], search[:, second], s=18, color="tab:blue",
                     label="front, cycle-average (search)", zorder=2)  # fmt: skip
        axis.scatter(verified[:, first], verified[:, second], s=18, color="tab:orange",
                     label="front, time-stepped (verified)", zorder=3)  # fmt: skip
        reference_search = reference.scores.objectives
        reference_verified = [objective.value(reference.verified)
                              for objective in objectives]  # fmt: skip
        axis.scatter(reference_search[:, first], reference_search[:, second], marker="*", s=160,
                     color="tab:red", edgecolor="black", label="reference, search", zorder=4)
        axis.scatter(reference_verified[first], reference_verified[second], marker="X", s=110,
                     color="tab:red", edgecolor="black", label="reference, verified", zorder=4)
        axis.set_xlabel(_axis_label(outcome, first))
        axis.set_ylabel(_axis_label(outcome, second))
        axis.grid(True, alpha=0.3)
    for axis in list(axes.flat)[len(pairs):]:
        axis.set_visible(False)
    axes.flat[0].legend(fontsize=8, loc="best")
    figure.suptitle(
        f"{outcome.problem.path.name}: {front.count} feasible designs on the front "
        f"({outcome.evaluated} evaluated, {outcome.generations} generations); "
        f"reference: {outcome.problem.reference_path.name}", fontsize=10,
    )  # fmt: skip
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
