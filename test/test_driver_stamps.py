"""The driver process at 1 kHz on the sim: every motor/joint_state stamp after the one before.

Over a few thousand samples received by another process, with the motor turning: no stamp at or
before its predecessor, none dropped for it (``dropped_backward_stamps`` stays 0: only a step of
the system clock back would cost samples), and the angle advances with the stamps.
"""

from __future__ import annotations

from sensor_msgs.msg import JointState

SAMPLES = 3000


def test_stamps_strictly_increase_at_1khz(start_node, ros):
    """Strictly increasing stamps, none dropped, and the angle never runs ahead of them."""
    start_node("driver", params={"publish_rate_hz": 1000.0, "diagnostics_period_sec": 0.5,
                                 "sim_time_constant_sec": 0.01})  # fmt: skip
    motor = ros.record(JointState, "motor/joint_state")
    diagnostics = ros.record_diagnostics()
    ros.wait_for_publishers("motor/joint_state")
    ros.wait_for_subscribers("motor/cmd_speed")
    ros.command_speed(4.0, period_s=0.1)
    ros.wait_for_messages(motor, SAMPLES, 60.0, f"{SAMPLES} joint states")
    messages = list(motor.messages)
    stamps = [ros.stamp_ns(m) for m in messages]
    back = [i for i in range(1, len(stamps)) if stamps[i] <= stamps[i - 1]]
    assert not back, f"{len(back)} stamps not after the previous one, first at sample {back[0]}"
    for before, after in zip(messages, messages[1:], strict=False):
        elapsed = (ros.stamp_ns(after) - ros.stamp_ns(before)) * 1e-9
        advance = after.position[0] - before.position[0]
        # At most 4 rad/s plus one encoder count of quantisation at either end.
        assert advance <= 4.0 * elapsed + 2 * 3.1e-3, (advance, elapsed)
    ros.spin_until(lambda: ros.statuses(diagnostics, "driver"), 10.0, "driver diagnostics")
    for _, _, status in ros.statuses(diagnostics, "driver"):
        assert ros.values(status)["dropped_backward_stamps"] == "0"
