"""``fishtail-swim steady``/``simulate --tail servo``: the servo's table, runs and refusals."""

import csv
import io
import re
from pathlib import Path

import numpy as np
import pytest

from fishtail_plant.fish.figures import steady_surge_speed
from fishtail_plant.fish.tail_drive import servo_drive
from fishtail_plant.values import load_fish_parameters
from fishtail_swim.offline.run_output import RUN_COLUMNS

CONFIG = Path(__file__).resolve().parents[3] / "config"
FISH = CONFIG / "fish.yaml"
SERVO = ("--tail", "servo", "--fish", FISH)
# A fin long enough that this fish swims straight without a bias (without the default fish's fin
# plate, the default 0.2 m fin settles into a circle whichever way its first stroke pushes it).
FIN_M = 0.3


def _rows(text):
    return list(csv.DictReader(io.StringIO(text)))


def _column(rows, name):
    return np.array([float(row[name]) for row in rows])


def test_servo_steady_is_the_librarys_steady_speed(swim_cli):
    status, out, err = swim_cli("steady", *SERVO, "--csv", "--servo-fin-length-m", 0.25,
        "--servo-bias-rad", 0.05, "--frequencies-hz", "0.5,1,2", "--amplitudes-rad", "0.2,0.4",
    )  # fmt: skip
    assert status == 0, err
    rows = _rows(out)
    frequency, amplitude = _column(rows, "beat_frequency_hz"), _column(rows, "amplitude_rad")
    # A row for each frequency and amplitude, the frequency the outer loop.
    np.testing.assert_array_equal(frequency, [0.5, 0.5, 1, 1, 2, 2])
    np.testing.assert_array_equal(amplitude, [0.2, 0.4] * 3)
    fish = load_fish_parameters(FISH)
    drive = servo_drive({
        "servo_fin_length_m": 0.25, "servo_bias_rad": 0.05,
        "servo_frequency_hz": frequency, "servo_amplitude_rad": amplitude,
    })  # fmt: skip
    expected = steady_surge_speed(drive, fish, 1.0 / frequency)
    speed = _column(rows, "speed_m_s")
    np.testing.assert_allclose(speed, expected, rtol=1e-9)
    np.testing.assert_allclose(_column(rows, "body_lengths_per_s"), speed / fish.body_length_m)
    # At the balance the mean thrust is the body's drag.
    np.testing.assert_allclose(_column(rows, "mean_thrust_n"), fish.drag_factor_kg_m * speed**2)
    assert "carrier_speed_rad_s" not in rows[0]


def test_servo_speed_grows_with_frequency_and_amplitude(swim_cli):
    status, out, _ = swim_cli("steady", *SERVO, "--csv", "--frequencies-hz", "0.5,1,1.5",
        "--amplitudes-rad", "0.1,0.2,0.4",
    )  # fmt: skip
    assert status == 0
    speed = _column(_rows(out), "speed_m_s").reshape(3, 3)  # (frequency, amplitude)
    assert np.all(np.diff(speed, axis=0) > 0.0)
    assert np.all(np.diff(speed, axis=1) > 0.0)
    # Every force is quadratic in velocity: U ~ f at one amplitude.
    np.testing.assert_allclose(speed[:, 0] / [0.5, 1.0, 1.5], speed[0, 0] / 0.5, rtol=1e-9)


def test_servo_steady_defaults_and_text_table(swim_cli, tmp_path):
    status, out, _ = swim_cli("steady", *SERVO)
    assert status == 0
    lines = out.splitlines()
    assert lines[0].split()[:4] == ["f", "[Hz]", "amplitude", "[rad]"]
    assert "efficiency" in lines[0] and "carrier" not in lines[0]
    assert len(lines) == 6  # 0.5 to 2.5 Hz
    # A servo file's frequency is one row; the flags win over the file.
    servo = tmp_path / "servo.yaml"
    servo.write_text(
        "/**:\n  ros__parameters:\n    servo_frequency_hz: 2.0\n    servo_amplitude_rad: 0.5\n",
        encoding="utf-8",
    )
    status, out, _ = swim_cli("steady", *SERVO, "--servo", servo, "--servo-amplitude-rad", 0.4)
    assert status == 0
    assert [line.split()[:2] for line in out.splitlines()[1:]] == [["2.0000", "0.4"]]


@pytest.mark.parametrize(("bias", "turn"), [(0.05, "left"), (-0.05, "right"), (0.0, "none")])
def test_servo_bias_turns_the_fish_its_way(swim_cli, tmp_path, bias, turn):
    output = tmp_path / "run.csv"
    status, out, err = swim_cli("simulate", *SERVO, "--servo-fin-length-m", FIN_M,
        "--servo-bias-rad", bias, "--duration", 30, "--steps-per-beat", 16, "--output", output,
    )  # fmt: skip
    assert status == 0, err
    radius = float(re.search(r"turning radius: (\S+)", out).group(1))
    table = np.loadtxt(output, delimiter=",", skiprows=1)
    heading = table[-1, 3]
    if turn == "none":
        # The first strokes yaw it (0.32 rad with the default fin plate, whose drag takes a
        # bigger bite of them; 0.1 without); then it holds its heading.
        assert abs(radius) > 1e3 and abs(heading) < 0.4
    else:
        assert f"body lengths, {turn})" in out
        # > 0 left (counter-clockwise seen from above): the heading grows.
        assert np.sign(heading) == (1.0 if turn == "left" else -1.0)
        assert 0.5 < abs(radius) < 10.0


def test_servo_simulate_writes_the_csv_figures_and_summary(swim_cli, tmp_path):
    output, figures = tmp_path / "run.csv", tmp_path / "figures"
    status, out, err = swim_cli("simulate", *SERVO, "--servo-frequency-hz", 2,
        "--servo-amplitude-rad", 0.4, "--servo-bias-rad", 0.1, "--duration", 3,
        "--steps-per-beat", 16, "--output", output, "--figures", figures,
    )  # fmt: skip
    assert status == 0, err
    with open(output, encoding="utf-8") as stream:
        header = next(csv.reader(stream))
    assert tuple(header) == tuple(name for name in RUN_COLUMNS if name != "carrier_angle_rad")
    table = np.loadtxt(output, delimiter=",", skiprows=1)
    np.testing.assert_allclose(np.diff(table[:, 0]), 0.5 / 16, rtol=1e-9)
    # The fin angle is the servo's command: 0.1 + 0.4 sin(2 pi 2 t).
    fin = table[:, header.index("fin_angle_rad")]
    np.testing.assert_allclose(fin, 0.1 + 0.4 * np.sin(4.0 * np.pi * table[:, 0]), atol=1e-10)
    for line in ("mean speed:", "body lengths per second:", "turning radius:", "Strouhal number:",
                 "Froude efficiency:", "mean thrust:"):  # fmt: skip
        assert line in out
    for name in ("speed.png", "path.png", "heading.png", "beat_thrust.png"):
        assert (figures / name).stat().st_size > 1000


def test_servo_check_steps_the_free_body(swim_cli):
    status, out, err = swim_cli("steady", *SERVO, "--csv", "--check", "--frequencies-hz", "2",
        "--servo-fin-length-m", FIN_M,
    )  # fmt: skip
    assert status == 0, err
    balance, checked = (_rows(part) for part in out.split("\n\n"))
    assert list(checked[0])[:3] == ["beat_frequency_hz", "amplitude_rad", "held_speed_m_s"]
    assert float(checked[0]["held_speed_m_s"]) == float(balance[0]["speed_m_s"])
    assert 0.0 < float(checked[0]["free_speed_m_s"])


@pytest.mark.parametrize(
    ("arguments", "words"),
    [
        (
            ("steady", "--tail", "servo", "--speeds", "4"),
            "--speeds/--speed-range is for the Cardan tail (its linkage and carrier), not with "
            "--tail servo",
        ),
        (("steady", "--tail", "servo", "--speed-range", "2:8:3"), "--speeds/--speed-range is for"),
        (("simulate", "--tail", "servo", "--speed", "4"), "--speed is for the Cardan tail"),
        (("steady", "--tail", "servo", "--config", CONFIG / "oscillatory.yaml"), "--config is for"),
        (("steady", "--tail", "servo", "--mechanism", "undulatory"), "--mechanism is for"),
        (("simulate", "--tail", "servo", "--crank-link-m", "0.1"), "--crank-link-m is for"),
        (
            ("steady", "--servo-bias-rad", "0.1"),
            "--servo-bias-rad is for the servo tail: add --tail servo",
        ),
        (("simulate", "--tail", "cardan", "--servo-frequency-hz", "2"), "--servo-frequency-hz is"),
        (("steady", "--frequencies-hz", "1,2"), "--frequencies-hz is for the servo tail"),
        (("steady", "--amplitudes-rad", "0.2"), "--amplitudes-rad is for the servo tail"),
        (("steady", "--servo", "servo.yaml"), "--servo is for the servo tail"),
        (
            ("steady", "--tail", "servo", "--frequencies-hz", "1", "--servo-frequency-hz", "2"),
            "--frequencies-hz and --servo-frequency-hz: give one",
        ),
        (("steady", "--tail", "servo", "--frequencies-hz", "0"), "servo_frequency_hz = 0.0"),
        (("steady", "--tail", "servo", "--servo-amplitude-rad", "4"), "servo_amplitude_rad = 4.0"),
        (("simulate", "--tail", "servo", "--servo-fin-length-m", "nan"), "servo_fin_length_m"),
        (("steady", "--tail", "servo", "--servo", "/no/such.yaml"), "no such file"),
        (("steady", "--tail", "servo", "--servo", "{fish}"), "unknown servo tail parameter"),
        (("steady", "--tail", "servo", "--amplitudes-rad", "0"), "no positive balance speed"),
        (
            ("simulate", "--tail", "servo", "--servo-frequency-hz", "0.1", "--duration", "5"),
            "shorter than one beat (10 s at 0.1 Hz)",
        ),
        (
            ("simulate", "--tail", "servo", "--servo-frequency-hz", "100", "--duration", "1e6"),
            "at --servo-frequency-hz 100 Hz and --steps-per-beat 32",
        ),
        (("steady", "--tail", "fin"), "tail must be one of cardan, servo"),
    ],
)
def test_mixed_or_bad_servo_input_is_one_line_and_exit_2(swim_cli, tmp_path, arguments, words):
    arguments = [str(a).replace("{fish}", str(FISH)) for a in arguments]
    if arguments[0] == "simulate":
        arguments += ["--output", str(tmp_path / "run.csv")]
    status, out, err = swim_cli(*arguments)
    assert status == 2
    assert out == ""
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("fishtail-swim: error: ")
    assert words in lines[0]
    assert not (tmp_path / "run.csv").exists()
