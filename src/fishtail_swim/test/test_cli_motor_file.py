"""``fishtail-swim motor --motor FILE``: the motor of a motor file, its ratios, the overrides."""

from pathlib import Path

import pytest
import yaml

CONFIG = Path(__file__).resolve().parents[3] / "config"
FISH = CONFIG / "fish.yaml"
DEFAULT_MOTOR = CONFIG / "motors" / "pololu-37d-12v.yaml"
#: A short run: the links' inertia only, two beat frequencies.
QUICK = ("--fish", FISH, "--surroundings", "air", "--frequencies", "1,2")


def test_the_default_motor_file_sizes_as_the_default_motor(swim_cli):
    status, by_options, err = swim_cli("motor", *QUICK)
    assert status == 0, err
    status, by_file, err = swim_cli("motor", *QUICK, "--motor", DEFAULT_MOTOR)
    assert status == 0, err
    assert by_file == by_options
    assert by_file.startswith("motor: 12 V, gear 30:1, efficiency 0.76; R 2.18 ohm")


def test_gear_ratio_picks_a_ratio_of_the_file_and_options_override_its_values(swim_cli):
    status, out, err = swim_cli(
        "motor", *QUICK, "--motor", DEFAULT_MOTOR, "--gear-ratio", "50", "--supply-voltage-v", "9"
    )
    assert status == 0, err
    # 50:1's efficiency from its stall torque, 21 kg cm; R and k the file's.
    assert out.startswith("motor: 9 V, gear 50:1, efficiency 0.683322; R 2.18 ohm, k 0.01115 N m/A")


@pytest.mark.parametrize(
    ("arguments", "words"),
    [
        (("--gear-ratio", "40"),
         "--gear-ratio 40 with --motor {file}: gear ratio 40 is not offered: the gearbox's ratios "
         "are 6.25, 10, 18.75, 30, 50, 70, 102.08, 131.25, 150"),
        (("--resistance-ohm", "2"),
         "--resistance-ohm cannot go with --motor: the file gives the motor"),
        (("--stall-torque-n-m", "1", "--no-load-speed-rpm", "100"),
         "--stall-torque-n-m cannot go with --motor"),
        (("--gearbox-efficiency", "1.5"), "--gearbox-efficiency must be in (0, 1], got 1.5"),
        (("--coulomb-friction-n-m", "2"),
         "--coulomb-friction-n-m = 2.0 is outside [0.0, 1.0] N m"),
    ],
)  # fmt: skip
def test_options_the_file_cannot_take_are_refused_in_one_line(swim_cli, arguments, words):
    status, out, err = swim_cli("motor", "--fish", FISH, "--motor", DEFAULT_MOTOR, *arguments)
    assert (status, out) == (2, "")
    assert len(err.strip().splitlines()) == 1
    assert err.startswith("fishtail-swim: error: ")
    assert words.format(file=DEFAULT_MOTOR) in err


@pytest.mark.parametrize(
    ("change", "words"),
    [
        (lambda content: content["motor"].update(resistance_ohm=-1.0),
         "{file}: motor.resistance_ohm = -1.0 is outside [0.01, 1000.0] ohm"),
        (lambda content: content.update(colour="blue"), "{file}: unknown key 'colour' (known: "),
        (lambda content: content.pop("current"), "{file}: missing key 'current'"),
    ],
)  # fmt: skip
def test_a_bad_motor_file_is_one_line_naming_the_file_and_the_key(
    swim_cli, tmp_path, change, words
):
    content = yaml.safe_load(DEFAULT_MOTOR.read_text(encoding="utf-8"))
    change(content)
    path = tmp_path / "motor.yaml"
    path.write_text(yaml.safe_dump(content), encoding="utf-8")
    status, out, err = swim_cli("motor", "--fish", FISH, "--motor", path)
    assert (status, out) == (2, "")
    assert len(err.strip().splitlines()) == 1
    assert err.startswith(f"fishtail-swim: error: {words.format(file=path)}")


def test_a_missing_motor_file_is_one_line(swim_cli, tmp_path):
    status, _, err = swim_cli("motor", "--fish", FISH, "--motor", tmp_path / "none.yaml")
    assert status == 2
    missing = f"cannot read motor file {tmp_path}/none.yaml: No such file or directory"
    assert err == f"fishtail-swim: error: {missing}\n"
