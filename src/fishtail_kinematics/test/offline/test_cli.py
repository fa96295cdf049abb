"""fishtail-kinematics end to end: table, plot, design, and one-line errors with exit status 2."""

from __future__ import annotations

import csv
import dataclasses
import io
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fishtail_common.parameter_files import load_parameter_file
from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail, UndulatoryTail
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_kinematics.offline import cli
from fishtail_kinematics.offline.table_columns import table_columns

CONFIG = Path(__file__).resolve().parents[4] / "config"


def run(capsys, *argv: str) -> tuple[int, str, str]:
    status = cli.main(list(argv))
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def rows(text: str) -> tuple[list[str], np.ndarray]:
    reader = csv.reader(io.StringIO(text))
    header = next(reader)
    return header, np.array([[float(v) for v in row] for row in reader])


@pytest.mark.parametrize(
    ("name", "geometry"),
    [("oscillatory", OscillatoryGeometry()), ("undulatory", UndulatoryGeometry())],
)
def test_config_files_hold_the_report_geometry(name, geometry):
    values = load_parameter_file(CONFIG / f"{name}.yaml")
    assert values["mechanism"] == name
    assert geometry_from_parameters(geometry_parameters_in(values)) == geometry
    # Every value of the geometry is written in the file, none left to a default.
    assert set(dataclasses.asdict(geometry)) <= set(values)


def test_table_oscillatory_columns_and_values(capsys):
    status, out, err = run(
        capsys, "table", "--config", str(CONFIG / "oscillatory.yaml"), "--samples", "8"
    )
    assert status == 0 and err == ""
    header, data = rows(out)
    assert header == list(table_columns(OscillatoryTail.state_fields))
    assert data.shape == (8, len(header))
    np.testing.assert_allclose(data[:, 0], np.arange(8) * 2 * math.pi / 8, atol=1e-11)
    op = data[:, 1]
    np.testing.assert_allclose(op, 0.1 * np.cos(data[:, 0]), atol=1e-11)
    theta3 = data[:, header.index("theta3")]
    # Report: +-26.565 deg at the ends of the stroke (symmetric RS), tip on a circle of ST about S.
    assert theta3[0] == pytest.approx(-math.atan(0.1 / 0.2), abs=1e-10)
    assert theta3[4] == pytest.approx(math.atan(0.1 / 0.2), abs=1e-10)
    tip = data[:, [header.index("Tx"), header.index("Ty")]]
    np.testing.assert_allclose(np.hypot(tip[:, 0] - 0.2, tip[:, 1]), 0.15, atol=1e-11)
    # theta3_dot is rad/s at --speed 4 (default): zero at the stroke ends.
    assert data[0, header.index("theta3_dot")] == pytest.approx(0.0, abs=1e-12)


def test_table_speed_scales_rates(capsys):
    _, slow, _ = run(capsys, "table", "--samples", "6", "--speed", "1")
    _, fast, _ = run(capsys, "table", "--samples", "6", "--speed", "3")
    header, slow_rows = rows(slow)
    _, fast_rows = rows(fast)
    column = header.index("theta3_dot")
    np.testing.assert_allclose(fast_rows[:, column], 3 * slow_rows[:, column], atol=1e-11)


def test_table_undulatory_columns_and_flag_override(capsys, tmp_path):
    output = tmp_path / "cycle.csv"
    status, out, _ = run(
        capsys, "table", "--config", str(CONFIG / "undulatory.yaml"),
        "--pin-offset-m", "0.05", "--samples", "5", "--output", str(output),
    )  # fmt: skip
    assert status == 0 and out == ""
    header, data = rows(output.read_text())
    assert header == list(table_columns(UndulatoryTail.state_fields))
    assert data.shape == (5, 13)
    # AU^2 = (AS + SU cos t3)^2 + (SU sin t3)^2 with the overridden SU = 0.05.
    t3, au, a_s = (data[:, header.index(c)] for c in ("theta3", "AU", "AS"))
    np.testing.assert_allclose(au**2, (a_s + 0.05 * np.cos(t3)) ** 2 + (0.05 * np.sin(t3)) ** 2)


def test_design_prints_the_report_figures(capsys):
    status, out, _ = run(capsys, "design", "--config", str(CONFIG / "undulatory.yaml"))
    assert status == 0
    values = dict(line.split(": ", 1) for line in out.splitlines())
    assert float(values["swing_range_deg"]) == pytest.approx(53.1301024, abs=1e-6)
    assert float(values["symmetric_rocker_link_m"]) == pytest.approx(0.233926, abs=1e-6)
    assert float(values["assembly_pivot_offset_min_m"]) == pytest.approx(0.133926, abs=1e-6)
    assert 0.0 < float(values["fin_ratio_mu"]) < 3.0
    assert values["mechanism"] == "undulatory"


def test_pivot_prints_the_feasible_range_and_a_markdown_table(capsys):
    status, out, _ = run(
        capsys, "pivot", "--config", str(CONFIG / "oscillatory.yaml"), "--shifts-mm", "-70", "0",
        "20",
    )  # fmt: skip
    assert status == 0
    lines = out.splitlines()
    assert lines[0] == "mechanism: oscillatory"
    # |RS - PR| - OS and sqrt((RS + PR)^2 - R^2) - OS for the report's symmetric drive.
    assert lines[1] == "feasible pivot shifts: -66.074 mm < shift < +118.601 mm"
    assert lines[2].startswith("| shift mm | swing bias deg |") and lines[3].startswith("|---:")
    assert lines[4] == "| -70 | cannot assemble | | | | |"
    assert lines[5].startswith("| +0 | +0.000 | 53.130 | +0.000 |")
    bias = math.degrees(
        OscillatoryTail(OscillatoryGeometry()).with_pivot_shift(0.02).swing_bias_rad
    )
    assert lines[6].startswith(
        f"| +20 | {bias:+.3f} | {math.degrees(2 * math.atan(0.1 / 0.22)):.3f} |"
    )
    assert len(lines) == 7


@pytest.mark.parametrize("mechanism", ["oscillatory", "undulatory"])
def test_plot_writes_the_report_figures(capsys, tmp_path, mechanism):
    status, out, _ = run(
        capsys, "plot", "--mechanism", mechanism, "--samples", "90", "--output-dir", str(tmp_path)
    )
    assert status == 0
    written = [Path(line) for line in out.splitlines()]
    expected = {"theta3.png", "tip_path.png", "swing_range.png"}
    if mechanism == "undulatory":
        expected.add("theta3_theta5.png")
    assert {path.name for path in written} == expected
    for path in written:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert path.stat().st_size > 10_000


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (["table", "--pivot-offset-m", "0.05"], "|RS - PR| < OS fails"),
        (["table", "--ring-radius-m", "nan"], "ring_radius_m = nan is outside"),
        (["design", "--config", "/nonexistent.yaml"], "cannot read parameter file"),
        (["table", "--mechanism", "undulatory", "--pin-offset-m", "0.11"], "0 < SU < SW - VW"),
        (["plot", "--speed", "0"], "positive --speed"),
    ],
)
def test_bad_geometry_is_one_line_and_status_2(capsys, argv, fragment):
    status, out, err = run(capsys, *argv)
    assert status == 2
    assert out == ""
    assert err.count("\n") == 1 and err.startswith("fishtail-kinematics: error:")
    assert fragment in err


@pytest.mark.parametrize(
    "argv",
    [
        ["table", "--samples", "1"],
        ["table", "--samples", "many"],
        ["table", "--speed", "-4"],
        ["table", "--speed", "inf"],
        ["table", "--mechanism", "wiggly"],
        ["frobnicate"],
    ],
)
def test_bad_flags_exit_2_with_one_line(capsys, argv):
    with pytest.raises(SystemExit) as raised:
        cli.main(argv)
    assert raised.value.code == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "error:" in err, err


def test_bad_yaml_file(capsys, tmp_path):
    config = tmp_path / "broken.yaml"
    config.write_text("/**:\n  ros__parameters: [1, 2\n")
    status, _, err = run(capsys, "design", "--config", str(config))
    assert status == 2 and "not valid YAML" in err


def test_console_script_runs_as_a_process(tmp_path):
    completed = subprocess.run(
        [sys.executable, "-m", "fishtail_kinematics.offline.cli", "table", "--samples", "3",
         "--pivot-offset-m", "0.01"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert completed.returncode == 2
    assert "Traceback" not in completed.stderr
    assert completed.stderr.startswith("fishtail-kinematics: error: linkage cannot assemble")
