"""The figures of a time-stepped run as PNG files: speed, path, heading, thrust over a beat.

matplotlib is imported lazily with the Agg backend, so importing this module is cheap and works
without a display.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from fishtail_plant.fish.fish import FloatArray


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(figure: Any, path: Path) -> Path:
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    _pyplot().close(figure)
    return path


def plot_speed(
    time_s: FloatArray, surge_m_s: FloatArray, mean_speed_m_s: float, path: Path, title: str
) -> Path:
    """Surge speed u against time, with the mean speed over the last whole beats."""
    plt = _pyplot()
    figure, axes = plt.subplots(figsize=(7, 4))
    axes.plot(time_s, surge_m_s, color="tab:blue", linewidth=1.0, label="u (surge)")
    axes.axhline(mean_speed_m_s, color="black", linestyle="--", linewidth=1.0,
                 label=f"Ū = {mean_speed_m_s:.4g} m/s (last whole beats)")  # fmt: skip
    axes.set_xlabel("time [s]")
    axes.set_ylabel("speed [m/s]")
    axes.set_title(f"Speed: {title}")
    axes.legend(loc="lower right")
    axes.grid(True)
    return _save(figure, path)


def plot_path(x_m: FloatArray, y_m: FloatArray, path: Path, title: str) -> Path:
    """The centre of mass's path in the world plane (equal axes)."""
    plt = _pyplot()
    figure, axes = plt.subplots(figsize=(7, 5))
    axes.plot(x_m, y_m, color="black", linewidth=1.2, label="path of C, the centre of mass")
    axes.plot(x_m[:1], y_m[:1], "o", color="tab:green", label="start")
    axes.plot(x_m[-1:], y_m[-1:], "s", color="tab:red", label="end")
    axes.set_aspect("equal", adjustable="datalim")
    axes.set_xlabel("X [m]")
    axes.set_ylabel("Y [m]")
    axes.set_title(f"Path of the centre of mass C: {title}")
    axes.legend()
    axes.grid(True)
    return _save(figure, path)


def plot_heading(time_s: FloatArray, heading_rad: FloatArray, path: Path, title: str) -> Path:
    """Heading psi [deg] against time."""
    plt = _pyplot()
    figure, axes = plt.subplots(figsize=(7, 4))
    axes.plot(time_s, np.degrees(heading_rad), color="tab:purple", linewidth=1.0)
    axes.set_xlabel("time [s]")
    axes.set_ylabel("ψ [deg]")
    axes.set_title(f"Heading: {title}")
    axes.grid(True)
    return _save(figure, path)


def plot_beat_thrust(
    beat_time_s: FloatArray, thrust_n: FloatArray, mean_thrust_n: float, path: Path, title: str
) -> Path:
    """The trailing-edge force's forward component over the last whole beat, and its mean."""
    plt = _pyplot()
    figure, axes = plt.subplots(figsize=(7, 4))
    axes.plot(beat_time_s, thrust_n, color="tab:orange", linewidth=1.4, label="F_T,x")
    axes.axhline(mean_thrust_n, color="black", linestyle="--", linewidth=1.0,
                 label=f"mean {mean_thrust_n:.4g} N")  # fmt: skip
    axes.set_xlabel("time in the beat [s]")
    axes.set_ylabel("thrust [N]")
    axes.set_title(f"Thrust over the last beat: {title}")
    axes.legend()
    axes.grid(True)
    return _save(figure, path)
