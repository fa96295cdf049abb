#!/usr/bin/env python3
"""Reduce the MSU robotic-fish trajectories to one speed (and turning radius) per run.

Reads docs/validation/msufish-runs.csv (raw camera-track time series, see its header) and writes
docs/validation/msufish-measurements.csv in the suite's validation format
``amplitude_rad,bias_rad,frequency_hz,speed_m_s,turning_radius_m``.

Per run (one amplitude, bias and trial):

* the tail-beat period is measured in the logged time base as the dominant oscillation of the yaw
  rate (1.2-3 Hz of logged time, after a cubic detrend); a beat is one yaw oscillation;
* speed = mean surge over the last whole beat, rescaled from the logged time base to the commanded
  tail frequency (TAIL_FREQUENCY_HZ): speed = u_logged * TAIL_FREQUENCY_HZ / f_yaw_logged. This is
  the distance swum per beat times the beat frequency, so it does not depend on the frame rate;
* turning radius (bias != 0) = mean ground speed / mean yaw rate over the same beat (a ratio, so
  also independent of the time base); positive for a left turn (see SIGN_* below);
* runs shorter than MIN_BEATS beats are left out (listed as comments).

The fish is still accelerating at the end of most runs: the speeds are lower bounds of the steady
speed; the rise over the last beat is written as a comment beside each row.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
RAW = ROOT / "docs" / "validation" / "msufish-runs.csv"
OUT = ROOT / "docs" / "validation" / "msufish-measurements.csv"

# Commanded tail frequency: the authors' loaders set omega_a = 2*pi rad/s for these data
# (folder "2pi - SmoothDataAndFiniteDifferences"). Set to None to trust the logged time base
# instead (then frequency_hz = the measured yaw frequency, about 2 Hz, and speeds double).
TAIL_FREQUENCY_HZ: float | None = 1.0
# Logged bias +b is taken as the fin turned to the fish's left (our positive bias). Assumption: the
# tracking frame is image coordinates (y down, so a positive logged yaw rate is clockwise seen from
# above); then positive logged bias gives left turns, i.e. the fish turns toward the biased side.
SIGN_BIAS = 1.0
SIGN_LEFT_TURN_FROM_LOGGED_R = -1.0
MIN_BEATS = 3.0
YAW_BAND_HZ = (1.2, 3.0)


@dataclass(frozen=True)
class Run:
    """One trial: the time series of one STATES file."""

    amplitude_deg: int
    bias_deg: int
    trial: int
    data: np.ndarray  # columns t, u, v, r, psi, x, y


def read_runs(path: Path) -> list[Run]:
    """Group the raw CSV rows into runs, in file order."""
    groups: dict[tuple[int, int, int], list[list[float]]] = {}
    with path.open() as f:
        rows = csv.reader(line for line in f if not line.startswith("#"))
        header = next(rows)
        assert header[:3] == ["amplitude_deg", "bias_deg", "trial"], header
        for row in rows:
            key = (int(row[0]), int(row[1]), int(row[2]))
            groups.setdefault(key, []).append([float(v) for v in row[3:]])
    return [Run(a, b, n, np.asarray(v)) for (a, b, n), v in groups.items()]


def yaw_frequency(t: np.ndarray, r: np.ndarray) -> float:
    """Dominant yaw-rate oscillation frequency in the logged time base [Hz of t]."""
    s = r - np.polyval(np.polyfit(t, r, 3), t)
    n_fft = 16384
    dt = float(np.median(np.diff(t)))
    spectrum = np.abs(np.fft.rfft(s * np.hanning(len(s)), n=n_fft))
    freq = np.fft.rfftfreq(n_fft, dt)
    band = (freq > YAW_BAND_HZ[0]) & (freq < YAW_BAND_HZ[1])
    return float(freq[band][np.argmax(spectrum[band])])


def reduce_run(run: Run) -> tuple[list[str], str]:
    """Return the measurement row (empty if the run is too short) and its comment."""
    t, u, v, r = run.data[:, 0], run.data[:, 1], run.data[:, 2], run.data[:, 3]
    label = f"Amp{run.amplitude_deg}Bias{run.bias_deg} trial {run.trial}"
    f_yaw = yaw_frequency(t, r)
    beat = 1.0 / f_yaw
    beats = (t[-1] - t[0]) * f_yaw
    if beats < MIN_BEATS:
        return [], f"# left out {label}: {beats:.1f} beats < {MIN_BEATS}"
    last = t >= t[-1] - beat
    prev = (t >= t[-1] - 2 * beat) & ~last
    scale = 1.0 if TAIL_FREQUENCY_HZ is None else TAIL_FREQUENCY_HZ / f_yaw
    frequency = f_yaw if TAIL_FREQUENCY_HZ is None else TAIL_FREQUENCY_HZ
    speed = float(u[last].mean()) * scale
    rise = float(u[last].mean() / u[prev].mean() - 1.0)
    radius = ""
    if run.bias_deg != 0:
        ground = float(np.hypot(u[last], v[last]).mean())
        r_mean = float(r[last].mean())
        radius = f"{SIGN_LEFT_TURN_FROM_LOGGED_R * ground / r_mean:.3f}"
    row = [
        f"{math.radians(run.amplitude_deg):.4f}",
        f"{SIGN_BIAS * math.radians(run.bias_deg):.4f}",
        f"{frequency:.3f}",
        f"{speed:.4f}",
        radius,
    ]
    comment = (
        f"# {label}: {beats:.1f} beats, yaw at {f_yaw:.2f} Hz of logged time, "
        f"last-beat surge {u[last].mean():.4f} m/s logged, rise over last beat {100 * rise:+.0f}%"
    )
    return row, comment


def main() -> None:
    """Read the raw runs and write the measurement CSV."""
    lines = [
        "# msufish-measurements.csv - written by tools/validation/reduce_msufish.py",
        "# from msufish-runs.csv (MSU servo tail-actuated robotic fish, April 2019);",
        "# see README-data.md.",
        "# amplitude_rad, bias_rad: commanded (folder names); bias positive = fin to",
        "#   the fish's left (assumed sign mapping, see the script).",
        "# frequency_hz: commanded 1 Hz per the authors' scripts (omega_a = 2*pi);",
        "#   the logged time base would say about 2 Hz (see README-data.md).",
        "# speed_m_s: mean surge over the last whole tail beat = distance per beat x",
        "#   frequency; the fish is still accelerating in most runs, so this is a",
        "#   LOWER BOUND of the steady speed.",
        "# turning_radius_m: last-beat mean ground speed / mean yaw rate, + = left",
        "#   turn; transient, not steady.",
        "# Each data row follows the comment that describes its run.",
        "amplitude_rad,bias_rad,frequency_hz,speed_m_s,turning_radius_m",
    ]
    for run in read_runs(RAW):
        row, comment = reduce_run(run)
        lines.append(comment)
        if row:
            lines.append(",".join(row))
    OUT.write_text("\n".join(lines) + "\n")
    print(f"wrote {OUT.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
