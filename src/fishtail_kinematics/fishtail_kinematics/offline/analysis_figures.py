"""The analysis's figures of a recording: theta3 and its rate, the tip path, the fin angles."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from fishtail_kinematics.engine.geometry import FloatArray
from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_kinematics.offline import plots
from fishtail_kinematics.offline.recording import AnalysisError, Recording


def default_output_dir(source: Path) -> Path:
    """``<input name>_figures`` in the current directory (the name without a file suffix)."""
    resolved = source.resolve()
    return Path(f"{resolved.stem if resolved.is_file() else resolved.name}_figures")


def write_figures(
    recording: Recording,
    state: Mapping[str, FloatArray],
    tail: Tail,
    output_dir: str | Path | None,
) -> list[Path]:
    """theta3 and its rate against time, the tip path, and theta3 with the fin joint's angle.

    Raises:
        AnalysisError: the directory cannot be created or a figure cannot be written.
    """
    directory = Path(output_dir) if output_dir is not None else default_output_dir(recording.source)
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise AnalysisError(f"cannot create {directory}: {error.strerror}") from None
    title = f"{recording.source.name}, {tail.name}"
    time_s = recording.time_s
    try:
        written = [
            plots.plot_tail_angle(
                time_s, state["theta3"], state["theta3_dot"], directory / "theta3.png", title
            ),
            plots.plot_tip_path(state["tip_x"], state["tip_y"], directory / "tip_path.png", title),
        ]
        if tail.fin_joint is not None:
            theta3, fin = state["theta3"], state[tail.fin_joint]
            denominator = float(np.dot(theta3, theta3))
            mu = float(np.dot(theta3, fin) / denominator) if denominator > 0.0 else math.nan
            written.append(
                plots.plot_fin_angles(
                    time_s, theta3, fin, mu, directory / f"theta3_{tail.fin_joint}.png", title
                )
            )
    except OSError as error:
        raise AnalysisError(f"cannot write figures to {directory}: {error.strerror}") from None
    return written
