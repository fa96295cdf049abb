"""``fishtail-swim``: every bad input is one line on stderr and exit status 2; --help works."""

from pathlib import Path

import pytest

CONFIG = Path(__file__).resolve().parents[3] / "config"
OSCILLATORY = CONFIG / "oscillatory.yaml"
FISH = CONFIG / "fish.yaml"


@pytest.fixture
def bad_files(tmp_path):
    """Parameter files that cannot be used, by name."""
    files = {
        "not_yaml": "/**: [unclosed\n",
        "unknown_fish": "/**:\n  ros__parameters:\n    fin_colour: 3.0\n",
        "negative_fish": "/**:\n  ros__parameters:\n    body_mass_kg: -1.0\n",
        "no_parameters": "just text\n",
    }
    for name, text in files.items():
        (tmp_path / f"{name}.yaml").write_text(text, encoding="utf-8")
    return tmp_path


STEADY = ("steady", "--config", OSCILLATORY, "--fish", FISH)


@pytest.mark.parametrize(
    ("arguments", "words"),
    [
        (("steady", "--config", "/no/such.yaml"), "no such file"),
        (("steady", "--fish", "/no/such.yaml"), "no such file"),
        (("steady", "--config", "{tmp}/not_yaml.yaml"), "not valid YAML"),
        (("steady", "--config", "{tmp}/no_parameters.yaml"), "not a ROS 2 parameter file"),
        ((*STEADY[:3], "--fish", "{tmp}/unknown_fish.yaml"), "unknown fish parameter"),
        ((*STEADY[:3], "--fish", "{tmp}/negative_fish.yaml"), "body_mass_kg"),
        ((*STEADY, "--speeds", "4,abc"), "not a number"),
        ((*STEADY, "--speeds", "-4"), "speed = -4.0 is outside (0.0, inf] rad/s"),
        ((*STEADY, "--speeds", "0"), "speed = 0.0 is outside (0.0, inf] rad/s"),
        ((*STEADY, "--speeds", "nan"), "speed = nan is outside"),
        ((*STEADY, "--speed-range", "8:2:4"), "last 2 must be above first 8"),
        ((*STEADY, "--speed-range", "2:8"), "first:last:count"),
        ((*STEADY, "--speed-range", "2:8:0"), "count = 0 is outside [1, 10000]"),
        ((*STEADY, "--drag-coefficient", "nan"), "drag_coefficient = nan is outside"),
        ((*STEADY, "--drag-coefficient", "-1"), "drag_coefficient"),
        ((*STEADY, "--body-length-m", "inf"), "body_length_m = inf is outside"),
        ((*STEADY, "--crank-link-m", "0.5"), "cannot assemble"),
        ((*STEADY, "--ring-radius-m", "-0.1"), "ring_radius_m"),
        ((*STEADY, "--speeds", "4", "--speed-range", "2:8:3"), "not allowed with"),
        (("simulate", "--output", "{tmp}/missing/run.csv"), "no directory"),
        (("simulate", "--output", "{tmp}/run.csv", "--speed", "0"), "speed = 0.0 is outside (0.0,"),
        (("simulate", "--output", "{tmp}/run.csv", "--speed", "-2"), "speed = -2.0 is outside"),
        (("simulate", "--output", "{tmp}/run.csv", "--duration", "0"), "duration = 0.0 is outside"),
        (("simulate", "--output", "{tmp}/run.csv", "--duration", "0.5"), "shorter than one beat"),
        (("simulate", "--output", "{tmp}/run.csv", "--steps-per-beat", "2"), "outside [4, 100000]"),
        # Over MAX_STEPS RK4 steps: refused before allocating (911 GiB) or writing (831 MB).
        (("simulate", "--output", "{tmp}/run.csv", "--duration", "1e9"), "limit of 1000000"),
        (
            ("simulate", "--output", "{tmp}/run.csv", "--speed", "1e6", "--duration", "1"),
            "take --duration at most 0.19635 s",
        ),
        (
            ("simulate", "--output", "{tmp}/run.csv", "--speed", "1e300", "--duration", "1e300"),
            "limit of 1000000",
        ),
        (("simulate",), "--output"),
        (("swim",), "invalid choice"),
        ((), "required"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(swim_cli, bad_files, arguments, words):
    arguments = [str(a).replace("{tmp}", str(bad_files)) for a in arguments]
    if arguments and arguments[0] == "simulate" and "--config" not in arguments:
        arguments[1:1] = ["--config", str(OSCILLATORY), "--fish", str(FISH)]
    status, out, err = swim_cli(*arguments)
    assert status == 2
    assert out == ""
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("fishtail-swim: error: ")
    assert words in lines[0]
    assert not (bad_files / "run.csv").exists()


@pytest.mark.parametrize("command", [(), ("steady",), ("simulate",)])
def test_help_works(swim_cli, command):
    status, out, err = swim_cli(*command, "--help")
    assert status == 0
    assert out.startswith("usage: fishtail-swim")
    assert err == ""
