"""What ``fishtail-swim simulate`` writes: the run as CSV, its figures, and a summary."""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import TextIO

import numpy as np

from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.fish.model import PSI, SURGE, SWAY, YAW_RATE, X, Y
from fishtail_swim.offline import swim_figures
from fishtail_swim.offline.time_run import RunFigures, TimeRun

#: The CSV's columns before the tail's own: time, world pose, body velocities.
POSE_COLUMNS = ("t_s", "x_m", "y_m", "psi_rad", "u_m_s", "v_m_s", "r_rad_s")
#: The CSV's last columns: fin angle, tip in the body frame.
FIN_COLUMNS = ("fin_angle_rad", "tip_x_body_m", "tip_y_body_m")
#: The CSV's columns with the Cardan tail, whose own column is the carrier angle (the servo tail
#: has none).
RUN_COLUMNS = (*POSE_COLUMNS, "carrier_angle_rad", *FIN_COLUMNS)


def write_run_csv(run: TimeRun, path: Path) -> None:
    """One row per step of the first fish of the run (the CLI's run has one)."""
    time_s = run.trajectory.time_s
    state = run.trajectory.state[:, :1]
    flow, _, tail = run.model.forces(time_s[:, None], state)
    own = run.beats.run_columns(time_s)
    names = (*POSE_COLUMNS, *(name for name, _ in own), *FIN_COLUMNS)
    columns = [
        time_s, state[:, 0, X], state[:, 0, Y], state[:, 0, PSI],
        state[:, 0, SURGE], state[:, 0, SWAY], state[:, 0, YAW_RATE],
        *(values for _, values in own),
        tail.fin_angle[:, 0], flow.tip_body_x[:, 0], flow.tip_body_y[:, 0],
    ]  # fmt: skip
    with open(path, "w", encoding="utf-8", newline="") as stream:
        writer = csv.writer(stream, lineterminator="\n")
        writer.writerow(names)
        for row in zip(*columns, strict=True):
            writer.writerow([f"{value:.12g}" for value in row])


def write_figures(run: TimeRun, figures: RunFigures, directory: Path) -> list[Path]:
    """Speed against time, path, heading, and thrust over the last whole beat, as PNG."""
    time_s = run.trajectory.time_s
    state = run.trajectory.state[:, 0]
    title = run.beats.label(0)
    end = float(figures.end_s[0])
    period = float(run.beat_period_s[0])
    in_beat = (time_s >= end - period - 1e-9 * period) & (time_s <= end + 1e-9 * period)
    flow, _, _ = run.model.forces(time_s[in_beat, None], run.trajectory.state[in_beat, :1])
    return [
        swim_figures.plot_speed(time_s, state[:, SURGE], float(figures.means.mean_speed_m_s[0]),
                                directory / "speed.png", title),
        swim_figures.plot_path(state[:, X], state[:, Y], directory / "path.png", title),
        swim_figures.plot_heading(time_s, state[:, PSI], directory / "heading.png", title),
        swim_figures.plot_beat_thrust(time_s[in_beat] - (end - period), flow.force.x[:, 0],
                                      float(figures.tail.mean_thrust_n[0]),
                                      directory / "beat_thrust.png", title),
    ]  # fmt: skip


def _radius_text(radius_m: float, body_length_m: float) -> str:
    if not math.isfinite(radius_m):
        return "inf (straight)"
    side = "left" if radius_m > 0.0 else "right"
    return f"{abs(radius_m):.4g} m ({abs(radius_m) / body_length_m:.4g} body lengths, {side})"


def print_summary(run: TimeRun, figures: RunFigures, fish: FishParameters, out: TextIO) -> None:
    """Mean speed over the last whole beats, body lengths/s, turning radius, St, efficiency."""
    length = float(np.mean(fish.body_length_m))
    speed = float(figures.means.mean_speed_m_s[0])
    start, end = float(figures.start_s[0]), float(figures.end_s[0])
    lines = [
        f"mean speed: {speed:.6g} m/s over the last {figures.beats} whole beats "
        f"(t = {start:.6g} to {end:.6g} s)",
        f"body lengths per second: {speed / length:.4g}",
        f"turning radius: {_radius_text(float(figures.means.turning_radius_m[0]), length)}",
        f"Strouhal number: {float(figures.tail.strouhal_number[0]):.4g}",
        f"Froude efficiency: {float(figures.tail.froude_efficiency[0]):.4g}",
        f"mean thrust: {float(figures.tail.mean_thrust_n[0]):.4g} N, "
        f"tail power: {float(figures.tail.tail_power_w[0]):.4g} W",
    ]
    out.write("\n".join(lines) + "\n")
