"""fishtail-run's motor options: the driver's parameters and files they make (no node started)."""

from __future__ import annotations

from pathlib import Path

import pytest

from fishtail_bringup.run import Supervisor, main, motor_parameters
from fishtail_common.interface import SUITE_NODES, SWIM_NODE

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
    # The last of two -p for one name is the one ROS applies: --driver-param overrides --motor.
    items = [driver[i + 1] for i, word in enumerate(driver) if word == "-p"]
    assert items[-2:] == ["motor_load:=water_held", "gear_ratio:=18.75"]
    assert str(FISH) in commands["swim"]
    # The monitor's swimming figures use the simulator's fin; the kinematics needs no fish.
    assert str(FISH) in commands["monitor"] and str(FISH) not in commands["kinematics"]
    unloaded = Supervisor(CONFIG, "", [], SUITE_NODES, FISH).command_for(SUITE_NODES[0])
    assert str(FISH) not in unloaded


def test_a_load_without_the_dc_motor_is_a_usage_error(capsys):
    with pytest.raises(SystemExit) as exit_info:
        main(["--load", "water_swimming"])
    assert exit_info.value.code == 2
    assert "--load water_swimming needs --motor dc" in capsys.readouterr().err


def test_a_missing_fish_file_is_named(capsys, tmp_path):
    missing = tmp_path / "fish.yaml"
    assert main(["--motor", "dc", "--load", "air", "--fish", str(missing)]) == 2
    assert f"no parameter file {missing}" in capsys.readouterr().err
