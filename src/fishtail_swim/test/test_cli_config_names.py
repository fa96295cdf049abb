"""``fishtail-swim --config``: other nodes' parameters are accepted, a name no node declares not."""

from pathlib import Path

from fishtail_driver.parameters import DRIVER_PARAMETERS
from fishtail_kinematics.nodes import kinematics_node, monitor_node
from fishtail_pilot import node as pilot_node
from fishtail_plant.values import LOAD_PARAMETERS
from fishtail_swim.nodes import sim_node
from fishtail_swim.offline.inputs import ROS_NAMES, suite_parameter_names

CONFIG = Path(__file__).resolve().parents[3] / "config"
OSCILLATORY = (CONFIG / "oscillatory.yaml").read_text(encoding="utf-8")
FISH = CONFIG / "fish.yaml"


def test_the_known_names_are_the_nodes_parameters():
    declared = {spec.name for spec in (*DRIVER_PARAMETERS, *LOAD_PARAMETERS)}
    for module in (kinematics_node, monitor_node, sim_node, pilot_node):
        declared |= {spec.name for spec in module.PARAMETERS}
    assert suite_parameter_names() == declared | ROS_NAMES


def _config(tmp_path: Path, extra: str) -> Path:
    path = tmp_path / "suite.yaml"
    path.write_text(OSCILLATORY + extra, encoding="utf-8")
    return path


def test_other_nodes_parameters_are_accepted(swim_cli, tmp_path):
    extra = (
        "driver:\n  ros__parameters:\n    publish_rate_hz: 100.0\n"
        "monitor:\n  ros__parameters:\n    beat_timeout_sec: 4.0\n"
        "pilot:\n  ros__parameters:\n    control_rate_hz: 10.0\n    use_sim_time: false\n"
    )
    config = _config(tmp_path, extra)
    status, out, err = swim_cli("steady", "--config", config, "--fish", FISH, "--speeds", "4")
    assert (status, err) == (0, "")
    assert out


def test_a_name_no_node_declares_is_one_line_naming_file_and_name(swim_cli, tmp_path):
    config = _config(tmp_path, "driver:\n  ros__parameters:\n    publish_rate: 100.0\n")
    status, out, err = swim_cli("steady", "--config", config, "--fish", FISH, "--speeds", "4")
    assert status == 2
    assert out == ""
    assert len(err.splitlines()) == 1, err
    assert str(config) in err
    assert "unknown parameter 'publish_rate'" in err
