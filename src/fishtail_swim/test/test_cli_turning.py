"""``fishtail-swim turning``: the tables are the library's steady turns; bad input is one line."""

import contextlib
import csv
import io
import math
from pathlib import Path

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.fish.steady_turn import TurnSettings, modulation_turns, pivot_shift_turns
from fishtail_plant.values import load_fish_parameters
from fishtail_swim.offline.cli import main

CONFIG = Path(__file__).resolve().parents[3] / "config"
OSCILLATORY = CONFIG / "oscillatory.yaml"
FISH = CONFIG / "fish.yaml"
#: A quick run: the identities checked hold at any number of beats.
QUICK = (
    "--beats", "12", "--steps-per-beat", "32", "--phases", "8", "--depths", "0.3,0.9",
    "--pivot-shifts=-0.02:0.02:3",
)  # fmt: skip
TURNING = ("turning", "--config", OSCILLATORY, "--fish", FISH)


def _tables(text):
    return [list(csv.DictReader(io.StringIO(block))) for block in text.strip().split("\n\n")]


def _column(rows, name):
    return np.array([float(row[name]) for row in rows])


@pytest.fixture(scope="module")
def csv_run():
    """The quick run's CSV tables (scan, depths, pivot shifts) and its stderr notes."""
    # Module-scoped, so captured here rather than with the per-test capsys.
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = main([str(a) for a in (*TURNING, *QUICK, "--csv")])
    assert status == 0, err.getvalue()
    return _tables(out.getvalue()), err.getvalue()


def test_csv_rows_are_the_librarys_steady_turns(csv_run):
    (scan, depths, pivot), notes = csv_run
    assert len(scan) == 8 and len(depths) == 5 and len(pivot) == 3
    tail = make_tail(OscillatoryGeometry())
    fish = load_fish_parameters(FISH)
    settings = TurnSettings(12, 32)
    phase = np.radians(_column(depths, "phase_deg"))
    signed = _column(depths, "depth") * np.where([row["side"] == "right" for row in depths], -1, 1)
    direct = modulation_turns(tail, fish, 4.0, np.abs(signed), np.nan_to_num(phase), settings)
    np.testing.assert_allclose(_column(depths, "yaw_rate_rad_s"), direct.yaw_rate_rad_s, rtol=1e-6)
    np.testing.assert_allclose(_column(depths, "speed_m_s"), direct.speed_m_s, rtol=1e-6)
    shifts = _column(pivot, "pivot_shift_mm") / 1e3
    shifted = pivot_shift_turns(tail, fish, 4.0, shifts, settings)
    np.testing.assert_allclose(_column(pivot, "yaw_rate_rad_s"), shifted.yaw_rate_rad_s, rtol=1e-6)
    assert "unsteered" in notes and "transient" in notes


def test_columns_agree_with_each_other(csv_run):
    (scan, depths, pivot), _ = csv_run
    frequency = 4.0 / (2.0 * math.pi)
    length = load_fish_parameters(FISH).body_length_m
    for rows in (scan, depths, pivot):
        yaw = _column(rows, "yaw_rate_rad_s")
        np.testing.assert_allclose(_column(rows, "yaw_per_beat_rad"), yaw / frequency, rtol=1e-9)
        np.testing.assert_allclose(
            _column(rows, "distance_per_beat_m"), _column(rows, "speed_m_s") / frequency, rtol=1e-9
        )
        radius = _column(rows, "turning_radius_m")
        np.testing.assert_allclose(
            _column(rows, "turning_radius_body_lengths"), radius / length, rtol=1e-9
        )
        np.testing.assert_array_equal(np.sign(radius), np.sign(yaw))
    # The unmodulated row is the reference the changes are taken from; each side turns its way.
    unmodulated = [row for row in depths if row["side"] == "none"]
    assert len(unmodulated) == 1 and float(unmodulated[0]["yaw_per_beat_change_rad"]) == 0.0
    sides = {row["side"]: float(row["yaw_per_beat_rad"]) for row in depths if row["depth"] == "0.9"}
    assert sides["left"] > 0.0 > sides["right"]


def test_text_output_titles_each_table_and_draws_the_figure(swim_cli, tmp_path):
    figure = tmp_path / "turning.png"
    status, out, err = swim_cli(*TURNING, *QUICK, "--figure", figure)
    assert status == 0, err
    assert "phase scan at depth 0.9: strongest left at phase" in out
    assert "modulation depth at the strongest phase each way" in out
    assert "pivot shift, carrier unmodulated" in out
    assert f"wrote {figure}" in out
    assert figure.stat().st_size > 10_000


def test_one_means_alone(swim_cli):
    status, out, _ = swim_cli(*TURNING, *QUICK, "--means", "pivot", "--csv")
    assert status == 0
    (pivot,) = _tables(out)
    assert [row["pivot_shift_mm"] for row in pivot] == ["-20", "0", "20"]


def test_a_run_too_short_for_the_transient_is_warned_about(swim_cli):
    status, _, err = swim_cli(*TURNING, "--beats", "4", "--steps-per-beat", "16", "--phases", "4",
        "--depths", "0.5", "--means", "modulation",
    )  # fmt: skip
    assert status == 0
    assert "warning: the start-up transient had not died out after 4 beats" in err


@pytest.mark.parametrize(
    ("arguments", "words"),
    [
        (("--depths", "0.95"), "depth = 0.95 is outside (0.0, 0.9]"),
        (("--depths", "0"), "depth = 0.0 is outside (0.0, 0.9]"),
        (("--depths", "a"), "not a number"),
        (("--depths", "nan"), "depth = nan is outside"),
        (("--pivot-shifts=-0.2:0.03:5",), "assembles for shifts in"),
        (("--pivot-shifts", "0.03:-0.03:5"), "high -0.03 must be above low 0.03"),
        (("--pivot-shifts", "0.03"), "low:high:count"),
        (("--phases", "2"), "phases = 2 is outside [3, 360]"),
        (("--beats", "2"), "beats = 2 is outside [3,"),
        (("--steps-per-beat", "x"), "not an integer"),
        (("--speed", "0"), "speed = 0.0 is outside (0.0, inf]"),
        (("--speed", "-4"), "speed = -4.0 is outside (0.0, inf]"),
        (("--means", "rudder"), "invalid choice"),
        (("--figure", "{tmp}/turning.svg"), "name it *.png"),
        (("--figure", "{tmp}/missing/turning.png"), "no directory"),
        (("--crank-link-m", "0.5"), "cannot assemble"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(swim_cli, tmp_path, arguments, words):
    arguments = [str(a).replace("{tmp}", str(tmp_path)) for a in arguments]
    status, out, err = swim_cli(*TURNING, *arguments)
    assert status == 2
    assert out == ""
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("fishtail-swim: error: ")
    assert words in lines[0]


def test_help_works(swim_cli):
    status, out, err = swim_cli("turning", "--help")
    assert status == 0 and err == ""
    assert out.startswith("usage: fishtail-swim turning")
