"""The figure of ``fishtail-swim turning``: yaw per beat against phase, depth and pivot shift.

matplotlib is imported lazily with the Agg backend (as in :mod:`.swim_figures`), so importing this
module is cheap and works without a display.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from fishtail_pilot.steering_map import ModulationTurns, PivotTurns


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_turning(
    modulation: ModulationTurns | None,
    pivot: PivotTurns | None,
    unsteered_yaw_per_beat_rad: float,
    path: Path,
    title: str,
) -> Path:
    """One panel per study: r̄/f (left axis) and Ū/f (right axis) against its input, as PNG.

    The unsteered fish's r̄/f (the Cardan tail's own slight turn) is the dashed line.
    """
    panels: list[tuple[str, Any, Any, Any]] = []
    if modulation is not None:
        panels.append((
            f"modulation phase φ₀ [deg] (depth {modulation.scan_depth:g})",
            np.degrees(modulation.scan_phases_rad),
            modulation.scan.yaw_per_beat_rad, modulation.scan.distance_per_beat_m,
        ))  # fmt: skip
        panels.append((
            "signed depth (+: strongest left phase, −: strongest right)",
            modulation.signed_depth,
            modulation.table.yaw_per_beat_rad, modulation.table.distance_per_beat_m,
        ))  # fmt: skip
    if pivot is not None:
        panels.append((
            "pivot shift [mm] (+ towards the tail), carrier unmodulated",
            1e3 * pivot.shifts_m,
            pivot.table.yaw_per_beat_rad, pivot.table.distance_per_beat_m,
        ))  # fmt: skip
    plt = _pyplot()
    figure, axes_row = plt.subplots(1, len(panels), figsize=(5.0 * len(panels), 4.2), squeeze=False)
    for axes, (label, inputs, yaw, distance) in zip(axes_row[0], panels, strict=True):
        axes.plot(inputs, yaw, "o-", color="tab:blue", markersize=3, label="r̄/f")
        axes.axhline(unsteered_yaw_per_beat_rad, color="tab:blue", linestyle="--", linewidth=0.8,
                     label="unsteered")  # fmt: skip
        axes.axhline(0.0, color="black", linewidth=0.6)
        axes.set_xlabel(label)
        axes.set_ylabel("r̄/f: heading change per beat [rad] (+ left)")
        axes.grid(True)
        twin = axes.twinx()
        twin.plot(inputs, distance, "s-", color="tab:orange", markersize=2.5, linewidth=0.9,
                  label="Ū/f")  # fmt: skip
        twin.set_ylabel("Ū/f: distance per beat [m]", color="tab:orange")
        lines = axes.get_lines()[:2] + twin.get_lines()
        axes.legend(lines, [line.get_label() for line in lines], loc="best", fontsize=8)
    figure.suptitle(f"Steady turns: {title}")
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path
