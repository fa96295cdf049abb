"""The suite under the upstream ROS 2 tools that a system install has, as real processes.

``ros2 launch``, ``ros2 run``, ``ros2 topic echo`` and ``ros2 param`` against the built workspace.

The tools are not published as wheels; ``make setup`` installs them from the pinned upstream
sources when ``../shared/upstream`` (or ``FISHTAIL_ROS2_UPSTREAM``) is there. Without those sources
this module is skipped with one line saying so; with them, a missing ``ros2`` is a set-up failure.
"""

from __future__ import annotations

import math
import os
import shutil
import signal
import subprocess
from pathlib import Path

import pytest
import yaml
from sensor_msgs.msg import JointState

from fishtail_common.parameter_files import load_parameter_file
from fishtail_kinematics.engine.errors import FishtailKinematicsError
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_msgs.msg import TailState

ROOT = Path(__file__).resolve().parents[1]
UPSTREAM = Path(os.environ.get("FISHTAIL_ROS2_UPSTREAM", ROOT.parent / "shared" / "upstream"))

if shutil.which("ros2") is None:
    if not (UPSTREAM / "install-ros2-tools.sh").is_file():
        pytest.skip(
            f"upstream ROS 2 tools tier skipped: no {UPSTREAM}/install-ros2-tools.sh "
            "(set FISHTAIL_ROS2_UPSTREAM to the pinned sources, then make setup)",
            allow_module_level=True,
        )
    pytest.fail(
        f"{UPSTREAM} is there but `ros2` is not on PATH: run make setup and source tools/env.sh",
        pytrace=False,
    )

#: Upstream CLI calls wait this long for discovery of the suite's nodes.
CLI_TIMEOUT_S = 20
#: Bound on each CLI process (discovery, a message, exit).
PROCESS_TIMEOUT_S = 60.0
#: ``ros2 launch`` forwards SIGINT to the nodes and waits for them.
LAUNCH_EXIT_TIMEOUT_S = 20.0
INFEASIBLE = {"pivot_offset_m": 0.05}  # |RS - PR| = 0.134 m is not less than OS


def launch_argv(*arguments: str) -> list[str]:
    """``ros2 launch fishtail_bringup fishtail.launch.py ARG:=VALUE ...``."""
    return ["ros2", "launch", "fishtail_bringup", "fishtail.launch.py", *arguments]


def run_cli(*arguments: str) -> subprocess.CompletedProcess[str]:
    """Run ``ros2 ARGUMENTS`` to completion (no daemon: each test has its own domain)."""
    return subprocess.run(
        ["ros2", *arguments], capture_output=True, text=True, timeout=PROCESS_TIMEOUT_S,
        env=dict(os.environ), stdin=subprocess.DEVNULL, check=False,
    )  # fmt: skip


def echo_once(topic: str, message_type: str) -> subprocess.Popen[str]:
    """Start ``ros2 topic echo --once TOPIC TYPE`` (given the type, it needs no daemon)."""
    return subprocess.Popen(
        ["ros2", "topic", "echo", "--once", "--no-daemon", "--spin-time", "5",
         "--timeout", str(CLI_TIMEOUT_S), topic, message_type],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=dict(os.environ),
        stdin=subprocess.DEVNULL,
    )  # fmt: skip


def echoed(process: subprocess.Popen[str]) -> dict:
    """The one message a finished ``ros2 topic echo --once`` printed, as a dict."""
    out, err = process.communicate(timeout=PROCESS_TIMEOUT_S)
    assert process.returncode == 0, f"ros2 topic echo exited {process.returncode}:\n{out}\n{err}"
    document, _, _ = out.partition("\n---")
    return yaml.safe_load(document)


def wait_for_echoes(ros, processes: list[subprocess.Popen[str]]) -> None:
    """Spin the probe (which commands the motor) until every echo process has exited."""
    ros.spin_until(
        lambda: all(p.poll() is not None for p in processes),
        PROCESS_TIMEOUT_S,
        "ros2 topic echo --once to print a message and exit",
    )


def engine_theta3(config: Path, carrier_angle: float) -> float:
    """θ3 of the engine for a parameter file's geometry."""
    geometry = geometry_from_parameters(geometry_parameters_in(load_parameter_file(config)))
    return make_tail(geometry).solve(carrier_angle, 0.0).theta3


def assert_clean_sigint_exit(launch) -> None:
    """``ros2 launch`` ended by SIGINT: exit 0, every node finished cleanly, motor stopped."""
    launch.send_signal(signal.SIGINT)
    status = launch.wait(LAUNCH_EXIT_TIMEOUT_S)
    output = launch.stdout() + launch.stderr()
    assert status == 0, f"ros2 launch exit status {status}:\n{output}"
    for process in ("driver-1", "node-2", "monitor-3"):
        assert f"[INFO] [{process}]: process has finished cleanly" in output, output
    assert "motor commanded to stop" in output, output


def test_launch_default_suite_and_sigint(start_process, ros, config_dir):
    """The default launch runs the suite; the tail follows the engine; SIGINT stops it cleanly."""
    launch = start_process("launch", launch_argv())
    motor = ros.record(JointState, "motor/joint_state")
    state = ros.record(TailState, "tail/state")
    ros.wait_for_publishers("tail/state")
    ros.wait_for_subscribers("motor/cmd_speed")
    ros.command_speed(4.0)
    angles = {}

    def matched() -> int:
        angles.update({ros.stamp_ns(m): m.position[0] for m in motor.messages})
        return sum(ros.stamp_ns(m) in angles for m in state.messages)

    ros.spin_until(lambda: matched() >= 50, 30.0, "50 tail states matched to carrier angles")
    config = config_dir / "oscillatory.yaml"
    for message in state.messages[:50]:
        key = ros.stamp_ns(message)
        if key in angles:
            assert message.theta3 == pytest.approx(engine_theta3(config, angles[key]), abs=1e-12)
            assert math.isnan(message.theta5), "mechanism 1 has no θ5"
    assert_clean_sigint_exit(launch)


def test_launch_undulatory_in_a_namespace_and_topic_echo(start_process, ros):
    """``mechanism:=undulatory namespace:=fish1``; ``ros2 topic echo --once`` of each tail topic."""
    launch = start_process("launch", launch_argv("mechanism:=undulatory", "namespace:=fish1"))
    ros.wait_for_subscribers("/fish1/motor/cmd_speed")
    ros.command_speed(4.0, topic="/fish1/motor/cmd_speed")
    echoes = {
        "state": echo_once("/fish1/tail/state", "fishtail_msgs/msg/TailState"),
        "joints": echo_once("/fish1/tail/joint_states", "sensor_msgs/msg/JointState"),
        "tip": echo_once("/fish1/tail/tip", "geometry_msgs/msg/PointStamped"),
        "motor": echo_once("/fish1/motor/joint_state", "sensor_msgs/msg/JointState"),
    }
    wait_for_echoes(ros, list(echoes.values()))
    state = echoed(echoes["state"])
    assert math.isfinite(state["theta5"]), f"mechanism 2 publishes θ5: {state}"
    assert echoed(echoes["joints"])["name"] == ["theta1", "theta2", "theta3", "theta4", "theta5"]
    tip = echoed(echoes["tip"])
    assert tip["header"]["frame_id"] == "tail_mechanism"
    assert all(math.isfinite(tip["point"][axis]) for axis in "xyz")
    assert echoed(echoes["motor"])["name"] == ["carrier_joint"]
    # Nothing leaks out of the namespace.
    assert ros.node.count_publishers("/tail/state") == 0
    assert_clean_sigint_exit(launch)


def test_launch_one_process_in_a_namespace_with_the_dc_motor(start_process, ros):
    """``one_process:=true``: one process hosts the nodes, each with its own parameters.

    In the namespace, the driver with its DC motor's gearbox; SIGINT stops them all.
    """
    launch = start_process(
        "launch", launch_argv("one_process:=true", "namespace:=fish1", "motor_model:=dc")
    )
    state = ros.record(TailState, "/fish1/tail/state")
    ros.wait_for_subscribers("/fish1/motor/cmd_speed")
    ros.command_speed(4.0, topic="/fish1/motor/cmd_speed")
    ros.wait_for_messages(state, 20, PROCESS_TIMEOUT_S, "tail/state from the one process")
    names = set(ros.node.get_node_names_and_namespaces())
    assert {("driver", "/fish1"), ("kinematics", "/fish1"), ("monitor", "/fish1")} <= names
    # --timeout: without a daemon the CLI must discover the node first.
    gear = run_cli(
        "param", "get", "--no-daemon", "--timeout", str(CLI_TIMEOUT_S), "/fish1/driver",
        "gear_ratio",
    )  # fmt: skip
    assert "30.0" in gear.stdout, gear.stdout + gear.stderr
    listed = run_cli("param", "list", "--no-daemon", "--spin-time", "5", "/fish1/kinematics")
    assert "mechanism" in listed.stdout and "gear_ratio" not in listed.stdout, listed.stderr
    launch.send_signal(signal.SIGINT)
    status = launch.wait(LAUNCH_EXIT_TIMEOUT_S)
    output = launch.stdout() + launch.stderr()
    assert status == 0, f"ros2 launch exit status {status}:\n{output}"
    assert "[INFO] [fishtail-one-process-1]: process has finished cleanly" in output, output
    assert output.count("]: process started with pid") == 1, output
    assert "motor commanded to stop" in output, output


@pytest.mark.parametrize("one_process", ["false", "true"])
def test_launch_arguments_win_over_the_params_file_and_the_file_over_the_motor_defaults(
    start_process, ros, config_dir, tmp_path, one_process
):
    """A user's file that names the driver loses to ``motor_model:=dc`` and beats its defaults.

    Its ``driver:`` section sets ``motor_model`` (the launch argument must win, not the file); its
    ``/**`` section sets the encoder, which ``motor_model:=dc`` only defaults (the file must win).
    """
    document = yaml.safe_load((config_dir / "oscillatory.yaml").read_text(encoding="utf-8"))
    document["/**"]["ros__parameters"]["encoder_counts_per_revolution"] = 100
    document["driver"] = {"ros__parameters": {"motor_model": "first_order"}}
    user_file = tmp_path / "my_tail.yaml"
    user_file.write_text(yaml.safe_dump(document), encoding="utf-8")
    start_process(
        "launch",
        launch_argv(f"params_file:={user_file}", "motor_model:=dc", f"one_process:={one_process}"),
    )
    ros.wait_for_subscribers("motor/cmd_speed")

    def driver_parameter(name: str) -> str:
        result = run_cli(
            "param", "get", "--no-daemon", "--timeout", str(CLI_TIMEOUT_S), "/driver", name
        )
        return result.stdout + result.stderr

    assert "String value is: dc" in driver_parameter("motor_model")
    assert "Integer value is: 100" in driver_parameter("encoder_counts_per_revolution")
    assert "Double value is: 30.0" in driver_parameter("gear_ratio")  # the DC motor's gearbox


def test_ros2_run_and_param_set_of_an_infeasible_geometry(start_process, ros, config_dir):
    """``ros2 run`` with a params file; ``ros2 param set`` of an infeasible OS shows the reason."""
    config = config_dir / "undulatory.yaml"
    values = geometry_parameters_in(load_parameter_file(config))
    with pytest.raises(FishtailKinematicsError) as refusal:
        make_tail(geometry_from_parameters({**values, **INFEASIBLE}))
    node = start_process(
        "ros2-run",
        ["ros2", "run", "fishtail_kinematics", "node", "--ros-args", "--params-file", str(config)],
    )
    ros.wait_for_subscribers("motor/joint_state")

    result = run_cli(
        "param", "set", "--no-daemon", "--timeout", str(CLI_TIMEOUT_S),
        "/kinematics", "pivot_offset_m", repr(INFEASIBLE["pivot_offset_m"]),
    )  # fmt: skip
    output = result.stdout + result.stderr
    assert "Setting parameter failed" in output, output
    assert str(refusal.value) in output, output

    result = run_cli(
        "param", "get", "--no-daemon", "--timeout", str(CLI_TIMEOUT_S),
        "/kinematics", "pivot_offset_m",
    )  # fmt: skip
    assert result.returncode == 0, result.stdout + result.stderr
    assert result.stdout.split() == ["Double", "value", "is:", repr(values["pivot_offset_m"])]

    # `ros2 run` does not forward SIGINT; a terminal's Ctrl-C signals the whole process group.
    os.killpg(node.pid, signal.SIGINT)
    status = node.wait(LAUNCH_EXIT_TIMEOUT_S)
    assert status == 0, node.output()


def test_sigterm_to_launch_leaves_nodes_and_the_watchdog_stops_the_motor(start_process, ros):
    """SIGTERM ends ``ros2 launch`` alone; the watchdog stops the motor when commands stop.

    Upstream launch leaves its nodes running on SIGTERM; SIGINT to the process group ends them.
    """
    launch = start_process("launch", launch_argv())
    motor = ros.record(JointState, "motor/joint_state")
    ros.wait_for_subscribers("motor/cmd_speed")
    commander = ros.command_speed(4.0)
    ros.spin_until(
        lambda: motor.messages and motor.messages[-1].velocity[0] > 3.5,
        30.0,
        "the carrier to reach 4 rad/s",
    )
    launch.send_signal(signal.SIGTERM)
    assert launch.wait(LAUNCH_EXIT_TIMEOUT_S) == -signal.SIGTERM
    assert ros.node.count_publishers("motor/joint_state") == 1, "the driver outlives ros2 launch"

    commander.speed = None  # whoever commanded the motor is gone too
    ros.spin_until(
        lambda: motor.messages[-1].velocity[0] < 0.05,
        30.0,
        "the driver's watchdog to stop the motor",
    )
    os.killpg(launch.pid, signal.SIGINT)
    ros.spin_until(
        lambda: ros.node.count_publishers("motor/joint_state") == 0,
        LAUNCH_EXIT_TIMEOUT_S,
        "the nodes to exit on SIGINT to the process group",
    )
