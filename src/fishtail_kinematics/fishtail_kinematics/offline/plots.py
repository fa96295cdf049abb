"""The report's figures as PNG files, from arrays (computed by the CLI or read from a recording).

matplotlib is imported lazily with the Agg backend, so importing this module is cheap and works
without a display.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(figure, path: Path) -> Path:
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    _pyplot().close(figure)
    return path


def plot_tail_angle(
    time_s: np.ndarray, theta3: np.ndarray, theta3_dot: np.ndarray, path: Path, title: str
) -> Path:
    """theta3 [deg] and its rate [rad/s] against time (the report's figures 11 and 12)."""
    plt = _pyplot()
    figure, (upper, lower) = plt.subplots(2, 1, sharex=True, figsize=(7, 5.5))
    upper.plot(time_s, np.degrees(theta3), color="black", linewidth=1.4)
    upper.set_ylabel("θ3 [deg]")
    upper.set_title(f"Tail angle θ3 and rate: {title}")
    upper.grid(True)
    lower.plot(time_s, theta3_dot, color="tab:blue", linewidth=1.4)
    lower.set_ylabel("dθ3/dt [rad/s]")
    lower.set_xlabel("time [s]")
    lower.grid(True)
    return _save(figure, path)


def plot_tip_path(tip_x: np.ndarray, tip_y: np.ndarray, path: Path, title: str) -> Path:
    """Path of the tail tip T in the frame at O (the report's figures 13 and 16)."""
    plt = _pyplot()
    figure, axes = plt.subplots(figsize=(6, 5))
    axes.plot(tip_x, tip_y, color="tab:blue", linewidth=1.5, label="path of the tip T")
    axes.plot([0.0], [0.0], linestyle="none", marker="+", markersize=10, color="grey",
              label="O (0, 0): ring-gear centre, the frame's origin")  # fmt: skip
    axes.legend(loc="best", fontsize=8)
    axes.set_xlabel("T_x [m] (body axis, towards the tail)")
    axes.set_ylabel("T_y [m] (left)")
    axes.set_title(f"Tail tip path: {title}")
    axes.set_aspect("equal", adjustable="datalim")
    axes.grid(True)
    return _save(figure, path)


def plot_swing_range(
    pivot_offsets_m: np.ndarray,
    range_fixed_rocker_rad: np.ndarray,
    range_symmetric_rocker_rad: np.ndarray,
    current_offset_m: float,
    path: Path,
    title: str,
) -> Path:
    """Swing range against OS (the report's figure 14); gaps are offsets that cannot assemble."""
    plt = _pyplot()
    figure, axes = plt.subplots(figsize=(7, 4.5))
    axes.plot(
        pivot_offsets_m, np.degrees(range_fixed_rocker_rad), label="RS as configured", linewidth=1.5
    )
    axes.plot(
        pivot_offsets_m,
        np.degrees(range_symmetric_rocker_rad),
        label="RS re-derived symmetric",
        linestyle="--",
        linewidth=1.5,
    )
    axes.axvline(current_offset_m, color="grey", linewidth=0.8, label="configured OS")
    axes.set_xlabel("OS [m]")
    axes.set_ylabel("swing range θ3max − θ3min [deg]")
    axes.set_title(f"Swing range against OS (gaps: cannot assemble): {title}")
    axes.legend()
    axes.grid(True)
    return _save(figure, path)


def plot_fin_angles(
    time_s: np.ndarray, theta3: np.ndarray, theta5: np.ndarray, mu: float, path: Path, title: str
) -> Path:
    """theta3 and theta5 together (the report's figures 15 and 18)."""
    plt = _pyplot()
    figure, axes = plt.subplots(figsize=(7, 4.5))
    axes.plot(time_s, np.degrees(theta3), label="θ3 (swing arm SW)", linewidth=1.4)
    axes.plot(time_s, np.degrees(theta5), label="θ5 (fin link VT)", linewidth=1.4)
    axes.set_xlabel("time [s]")
    axes.set_ylabel("angle [deg]")
    axes.set_title(f"θ3 and θ5 (fitted θ5 ≈ {mu:.3f} θ3): {title}")
    axes.legend()
    axes.grid(True)
    return _save(figure, path)


def cycle_time(motor_angle_rad: np.ndarray, speed_rad_s: float) -> np.ndarray:
    """Time of each carrier angle at constant speed, for plots of computed cycles.

    Raises:
        ValueError: a speed that is not positive and finite.
    """
    if not (math.isfinite(speed_rad_s) and speed_rad_s > 0.0):
        raise ValueError(f"speed must be positive and finite for a time axis, got {speed_rad_s!r}")
    return np.asarray(motor_angle_rad) / speed_rad_s
