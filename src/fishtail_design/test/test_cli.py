import csv
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from fishtail_common.parameter_files import default_parameter_file
from fishtail_design.cli import main

WORKED = default_parameter_file("design/report-fish")


def _small_problem(tmp_path: Path) -> Path:
    """The worked problem at a size a test can afford, its files named absolutely."""
    document = yaml.safe_load(WORKED.read_text())
    config = WORKED.parent.parent
    document["fish"] = str(config / "fish.yaml")
    document["motor"] = str(config / "motors" / "pololu-37d-12v.yaml")
    document["reference"] = str(config / "oscillatory.yaml")
    document["search"] = {"population": 12, "generations": 3, "seed": 3, "samples_per_beat": 64,
                          "refine_population": 4, "refine_generations": 1}  # fmt: skip
    path = tmp_path / "problem.yaml"
    path.write_text(yaml.safe_dump(document))
    return path


def test_a_bad_problem_file_ends_in_one_line(tmp_path, capsys):
    path = tmp_path / "problem.yaml"
    path.write_text("mechanism: flapping\n")
    assert main([str(path), "--output-dir", str(tmp_path / "out")]) == 1
    error = capsys.readouterr().err
    assert error.startswith(f"fishtail-design: {path}: mechanism: 'flapping'")
    assert error.count("\n") == 1


def test_a_bad_option_is_a_usage_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_:
        main([str(_small_problem(tmp_path)), "--pick", "prettiest"])
    assert exit_.value.code == 2
    assert "choose fastest, efficient, turning or a rank" in capsys.readouterr().err


@pytest.mark.slow
def test_a_search_writes_the_front_the_report_and_the_picks_files(tmp_path, capsys):
    output = tmp_path / "out"
    status = main([str(_small_problem(tmp_path)), "--output-dir", str(output), "--pick",
                   "fastest", "--pick", "1"])  # fmt: skip
    assert status == 0, capsys.readouterr().err
    with (output / "front.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    assert rows and [int(row["rank"]) for row in rows] == list(range(1, len(rows) + 1))
    # Every design of the front is feasible: no negative margin.
    margins = [name for name in rows[0] if name.startswith("margin_")]
    assert all(float(row[name]) >= 0.0 for row in rows for name in margins)
    report = (output / "report.md").read_text()
    assert "| reference (oscillatory.yaml) | fastest | rank-1 |" in report
    assert (output / "front.png").stat().st_size > 10_000
    for pick in ("fastest", "rank-1"):
        for name in ("kinematics.yaml", "fish.yaml", "motor.yaml"):
            assert (output / pick / name).is_file()
    assert (output / "checkpoint.pickle").is_file()


@pytest.mark.integration
def test_a_pick_runs_in_the_suite_unchanged_with_the_figures_front_csv_gives(tmp_path):
    output = tmp_path / "out"
    assert main([str(_small_problem(tmp_path)), "--output-dir", str(output)]) == 0
    with (output / "front.csv").open() as stream:
        rows = list(csv.DictReader(stream))
    pick = output / "fastest"
    files = ["--config", str(pick / "kinematics.yaml"), "--fish", str(pick / "fish.yaml")]
    environment = dict(os.environ)
    motor = subprocess.run(
        [sys.executable, "-m", "fishtail_swim.offline.cli", "motor", *files,
         "--motor", str(pick / "motor.yaml")],
        capture_output=True, text=True, timeout=600, env=environment, check=False,
    )  # fmt: skip
    assert motor.returncode == 0, motor.stderr
    found = re.search(r"sustains ([0-9.]+) Hz .*RMS current ([0-9.]+) A", motor.stdout)
    assert found, motor.stdout
    # The fastest pick is the design with the largest verified speed among the feasible ones.
    fastest = max(rows, key=lambda row: float(row["verified_speed_m_s"]))
    # The same run: the figures as the motor command prints them (three digits).
    assert found.group(1) == f"{float(fastest['verified_beat_frequency_hz']):#.3g}"
    assert found.group(2) == f"{float(fastest['verified_rms_current_a']):.3g}"
    simulate = subprocess.run(
        [sys.executable, "-m", "fishtail_swim.offline.cli", "simulate", *files, "--duration", "2",
         "--output", str(tmp_path / "run.csv")],
        capture_output=True, text=True, timeout=600, env=environment, check=False,
    )  # fmt: skip
    assert simulate.returncode == 0, simulate.stderr
