"""``fishtail-swim urdf``: the library's robot model, on stdout or in a file; bad input."""

import io
from pathlib import Path

import pytest
import yourdfpy

from fishtail_common.parameter_files import load_parameter_file
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_plant.values import load_fish_parameters
from fishtail_swim.robot_model import SWING_JOINT, TAIL_FIN, robot_description

CONFIG = Path(__file__).resolve().parents[3] / "config"
FISH = CONFIG / "fish.yaml"


def _expected(mechanism, top_carrier_speed_rad_s=20.0):
    values = load_parameter_file(CONFIG / f"{mechanism}.yaml")
    tail = make_tail(geometry_from_parameters(geometry_parameters_in(values)))
    return robot_description(tail, load_fish_parameters(FISH), top_carrier_speed_rad_s)


def _load(text):
    return yourdfpy.URDF.load(io.StringIO(text), load_meshes=False, load_collision_meshes=False)


@pytest.mark.parametrize("mechanism", ["oscillatory", "undulatory"])
def test_urdf_prints_the_model_of_the_config_and_the_fish(swim_cli, mechanism):
    status, out, err = swim_cli("urdf", "--config", CONFIG / f"{mechanism}.yaml", "--fish", FISH)
    assert status == 0, err
    assert err == ""
    assert out == _expected(mechanism)


def test_urdf_writes_the_model_to_output(swim_cli, tmp_path):
    output = tmp_path / "fish.urdf"
    status, out, err = swim_cli("urdf", "--mechanism", "undulatory", "--fish", FISH,
                                "--output", output)  # fmt: skip
    assert status == 0, err
    assert out == f"wrote {output}\n"
    assert output.read_text(encoding="utf-8") == _expected("undulatory")


def test_flags_override_the_files(swim_cli):
    status, out, err = swim_cli(
        "urdf", "--config", CONFIG / "oscillatory.yaml", "--fish", FISH, "--fin-span-m", "0.12",
        "--tail-link-m", "0.18", "--max-carrier-speed-rad-s", "10",
    )  # fmt: skip
    assert status == 0, err
    urdf, default = _load(out), _load(_expected("oscillatory"))
    (fin,) = urdf.link_map[TAIL_FIN].visuals
    assert fin.geometry.box.size[2] == pytest.approx(0.12)
    assert urdf.joint_map[f"{TAIL_FIN}_mount"].origin[0, 3] == pytest.approx(0.18)
    # Half the top carrier speed: half the velocity limit, the same range.
    limit, default_limit = urdf.joint_map[SWING_JOINT].limit, default.joint_map[SWING_JOINT].limit
    assert limit.velocity == pytest.approx(0.5 * default_limit.velocity)
    assert (limit.lower, limit.upper) == (default_limit.lower, default_limit.upper)


@pytest.mark.parametrize(
    ("arguments", "words"),
    [
        (("--output", "{tmp}/missing/fish.urdf"), "no directory"),
        (("--output", "{tmp}"), "it is a directory"),
        (("--config", "/no/such.yaml"), "no such file"),
        (("--crank-link-m", "0.5"), "cannot assemble"),
        (("--mechanism", "undulatory", "--pin-offset-m", "0.5"), "0 < SU < SW - VW"),
        (("--body-length-m", "-1"), "body_length_m = -1.0 is outside"),
        (("--max-carrier-speed-rad-s", "0"), "max_carrier_speed_rad_s = 0.0 is outside"),
        (("--max-carrier-speed-rad-s", "fast"), "not a number"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(swim_cli, tmp_path, arguments, words):
    arguments = [argument.replace("{tmp}", str(tmp_path)) for argument in arguments]
    status, out, err = swim_cli("urdf", "--fish", FISH, *arguments)
    assert status == 2
    assert out == ""
    assert len(err.splitlines()) == 1, err
    assert words in err
