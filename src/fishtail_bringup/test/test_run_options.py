"""fishtail-run's motor options: the driver's parameters and files they make (no node started)."""

from __future__ import annotations

from pathlib import Path

import pytest
import rclpy
import yaml
from rclpy.context import Context

from fishtail_bringup.run import Supervisor, main, motor_parameters
from fishtail_common.interface import PILOT_NODE, SUITE_NODES, SWIM_NODE

CONFIG = Path("config/oscillatory.yaml")
FISH = Path("config/fish.yaml")


def test_the_dc_motor_comes_with_its_gearbox_and_encoder():
    assert motor_parameters(None, "none") == []
    assert motor_parameters("first_order", "none") == ["motor_model:=first_order"]
    assert motor_parameters("dc", "water_swimming") == [
        "motor_model:=dc",
        "gear_ratio:=30.0",
        "encoder_counts_per_revolution:=64",
        "motor_load:=water_swimming",
    ]


def test_a_loaded_driver_reads_the_fish_and_its_own_parameters_come_last():
    driver_params = [*motor_parameters("dc", "water_held"), "gear_ratio:=18.75"]
    supervisor = Supervisor(
        CONFIG, "", driver_params, (*SUITE_NODES, SWIM_NODE), FISH, driver_reads_fish=True
    )
    commands = {node.name: supervisor.command_for(node) for node in (*SUITE_NODES, SWIM_NODE)}
    driver = commands["driver"]
    assert driver[driver.index("--ros-args") + 1 :][:4] == [
        "--params-file", str(CONFIG), "--params-file", str(FISH),
    ]  # fmt: skip
    # The driver's own parameters: a file of their own, last; --driver-param overrides --motor.
    assert driver[-2] == "--params-file"
    assert yaml.safe_load(Path(driver[-1]).read_text()) == {
        "/**/driver": {"ros__parameters": {
            "motor_model": "dc", "gear_ratio": 18.75, "encoder_counts_per_revolution": 64,
            "motor_load": "water_held",
        }},
    }  # fmt: skip
    assert str(FISH) in commands["swim"]
    # The monitor's swimming figures use the simulator's fin; the kinematics needs no fish.
    assert str(FISH) in commands["monitor"] and str(FISH) not in commands["kinematics"]
    unloaded = Supervisor(CONFIG, "", [], SUITE_NODES, FISH).command_for(SUITE_NODES[0])
    assert str(FISH) not in unloaded


@pytest.mark.parametrize("namespace", ["", "fish"])
@pytest.mark.parametrize("section", ["/**", "driver", "/**/driver", "/fish/driver"])
def test_driver_and_pilot_parameters_win_over_any_section_of_the_config(
    tmp_path, namespace, section
):
    # A config as the suite's begin, "/**" first, then a section for the node: ROS merged the
    # -p NAME:=VALUE into "/**", which it applied before the node's section, so it lost.
    config = tmp_path / "config.yaml"
    text = "/**:\n  ros__parameters:\n    joint_name: wild\n    control_rate_hz: 1.0\n"
    if section != "/**":
        pilot_section = section.replace("driver", "pilot")
        text += f"{section}:\n  ros__parameters:\n    joint_name: from_file\n"
        text += f"{pilot_section}:\n  ros__parameters:\n    control_rate_hz: 5.0\n"
    config.write_text(text)
    supervisor = Supervisor(
        config, namespace, ["joint_name:=abc"], (*SUITE_NODES, PILOT_NODE),
        pilot_params=["control_rate_hz:=12.5"],
    )  # fmt: skip
    for node, name, expected in (
        (SUITE_NODES[0], "joint_name", "abc"),
        (PILOT_NODE, "control_rate_hz", 12.5),
    ):
        context = Context()
        rclpy.init(args=supervisor.ros_arguments_for(node), context=context)
        try:
            ros_node = rclpy.create_node(node.name, context=context)
            assert ros_node.get_namespace() == f"/{namespace}"
            assert ros_node.declare_parameter(name, type(expected)()).value == expected
            ros_node.destroy_node()
        finally:
            context.try_shutdown()


def test_an_item_that_is_not_name_value_is_left_to_ros():
    supervisor = Supervisor(CONFIG, "", ["gear_ratio"], SUITE_NODES)
    assert supervisor.ros_arguments_for(SUITE_NODES[0])[-2:] == ["-p", "gear_ratio"]


def test_a_load_without_the_dc_motor_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--load", "water_swimming"])
    assert exit_info.value.code == 2
    assert "--load water_swimming needs --motor dc" in capsys.readouterr().err


def test_a_missing_fish_file_is_named(capsys, tmp_path):
    missing = tmp_path / "fish.yaml"
    assert main(["--motor", "dc", "--load", "air", "--fish", str(missing)]) == 2
    assert f"no parameter file {missing}" in capsys.readouterr().err


def test_the_view_gets_only_the_pacing_options_given_before_its_ros_arguments():
    from fishtail_bringup.run import build_parser, view_options
    from fishtail_common.interface import VIEW_NODE

    given = build_parser().parse_args(["--view", "--send-period-s", "0.5"])
    assert view_options(given) == ["--send-period-s", "0.5"]
    assert view_options(build_parser().parse_args(["--view"])) == []
    supervisor = Supervisor(Path("tail.yaml"), "", [], view_options=view_options(given))
    command = supervisor.command_for(VIEW_NODE)
    assert command[3:6] == ["--send-period-s", "0.5", "--ros-args"]
    assert "--send-period-s" not in supervisor.command_for(SUITE_NODES[0])
