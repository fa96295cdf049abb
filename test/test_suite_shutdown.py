"""SIGINT and SIGTERM end every node of the suite cleanly, the driver stopping the motor first."""

from __future__ import annotations

import signal

import pytest
from sensor_msgs.msg import JointState

from fishtail_msgs.msg import TailState

EXIT_WITHIN_S = 5.0


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_signal_ends_every_node_cleanly(start_node, ros, config_dir, signum):
    """Each node exits with status 0 within a few seconds; the driver logs the motor stop."""
    config_path = config_dir / "oscillatory.yaml"
    nodes = [
        start_node("driver", params={"publish_rate_hz": 200.0}),
        start_node("kinematics", params_file=config_path),
        start_node("monitor"),
    ]
    motor = ros.record(JointState, "motor/joint_state")
    state = ros.record(TailState, "tail/state")
    ros.wait_for_publishers("tail/symmetry")
    ros.wait_for_subscribers("tail/state", 2)  # monitor and the probe
    ros.command_speed(4.0)
    # The suite is running: the motor turns and tail/state flows.
    ros.spin_until(
        lambda: len(state) >= 20 and bool(motor) and motor.messages[-1].velocity[0] > 1.0,
        15.0,
        "the motor turning and tail/state flowing",
    )
    for node in nodes:
        assert node.returncode is None, f"{node.name} exited early"
        node.send_signal(signum)
    for node in nodes:
        status = node.wait(EXIT_WITHIN_S)
        assert status == 0, f"{node.name}: exit status {status} after {signum.name}"
    for node in nodes:
        assert "Traceback" not in node.stderr(), f"{node.name} printed a traceback"
    log = nodes[0].stderr()
    assert "motor commanded to stop; driver exiting" in log
