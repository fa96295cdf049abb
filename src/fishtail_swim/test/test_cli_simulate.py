"""``fishtail-swim simulate``: the CSV, its figures and the summary agree."""

import csv
import math
import re
from pathlib import Path

import numpy as np

from fishtail_swim.offline.run_output import RUN_COLUMNS

CONFIG = Path(__file__).resolve().parents[3] / "config"
OSCILLATORY = CONFIG / "oscillatory.yaml"
FISH = CONFIG / "fish.yaml"
SPEED_RAD_S = 8.0
STEPS_PER_BEAT = 16


def test_simulate_writes_a_csv_whose_whole_beats_give_the_summarys_speed(swim_cli, tmp_path):
    output, figures = tmp_path / "run.csv", tmp_path / "figures"
    status, out, err = swim_cli("simulate", "--config", OSCILLATORY, "--fish", FISH,
        "--speed", SPEED_RAD_S, "--duration", 10, "--steps-per-beat", STEPS_PER_BEAT,
        "--output", output, "--figures", figures,
    )  # fmt: skip
    assert status == 0, err
    with open(output, encoding="utf-8") as stream:
        reader = csv.reader(stream)
        assert tuple(next(reader)) == RUN_COLUMNS
        table = np.array([[float(value) for value in row] for row in reader])
    period = 2.0 * math.pi / SPEED_RAD_S
    np.testing.assert_allclose(np.diff(table[:, 0]), period / STEPS_PER_BEAT, rtol=1e-9)
    assert table[-1, 0] >= 10.0 - 1e-9
    np.testing.assert_allclose(table[:, 7], SPEED_RAD_S * table[:, 0], rtol=1e-10)
    # The last two whole beats: beat ends every STEPS_PER_BEAT rows, distance end to end.
    last_end = (table.shape[0] - 1) // STEPS_PER_BEAT * STEPS_PER_BEAT
    ends = table[[last_end - 2 * STEPS_PER_BEAT, last_end - STEPS_PER_BEAT, last_end]]
    distance = np.hypot(np.diff(ends[:, 1]), np.diff(ends[:, 2])).sum()
    match = re.search(r"mean speed: (\S+) m/s over the last 2 whole beats", out)
    assert match is not None, out
    # The summary prints 6 significant digits; the CSV's positions carry 12.
    assert abs(float(match.group(1)) / (distance / (2.0 * period)) - 1.0) < 1e-5
    lengths = float(re.search(r"body lengths per second: (\S+)", out).group(1))
    assert abs(lengths - float(match.group(1)) / 0.5) < 1e-3 * lengths
    for line in ("turning radius:", "Strouhal number:", "Froude efficiency:"):
        assert line in out
    for name in ("speed.png", "path.png", "heading.png", "beat_thrust.png"):
        assert (figures / name).stat().st_size > 1000
        assert f"wrote {figures / name}" in out


def test_simulate_without_figures_writes_only_the_csv(swim_cli, tmp_path):
    output = tmp_path / "run.csv"
    status, out, _ = swim_cli("simulate", "--config", OSCILLATORY, "--fish", FISH, "--speed", 12,
        "--duration", 2, "--steps-per-beat", 8, "--output", output,
    )  # fmt: skip
    assert status == 0
    assert output.is_file()
    assert [line for line in out.splitlines() if line.startswith("wrote")] == [f"wrote {output}"]
