"""The simulator process on a carrier stream with jumps: WARNed, not integrated, swimming on.

The probe publishes ``motor/joint_state`` itself at 200 Hz and 8 rad/s, stamped on a grid of its
clock, with one-sample spikes of 1e6 rad (before: a minute of 99 % CPU and no diagnostics for
one) and later a 10 rad step 0.1 ms after a sample that persists (before: 1e112 m/s and every
later sample dropped). Best effort may lose a sample; the assertions hold whatever is lost (five
spikes, so that one arrives).
"""

from __future__ import annotations

import math
import time

from nav_msgs.msg import Odometry
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState

from fishtail_common.interface import FISH_ODOM, Level

SIM_MODULE = "fishtail_swim.nodes.sim_node"
SPEED_RAD_S = 8.0
PERIOD_NS = 5_000_000
SPIKES_AT = (200, 250, 300, 350, 400)
SPIKE_RAD = 1e6
STEP_AT = 600
STEP_RAD = 10.0
SAMPLES = 1000
#: The step's sample comes this soon after the one before it.
STEP_AFTER_NS = 100_000
#: Longest wait for the WARN once the first spike was sent: the spikes span 1 s and the node
#: reports once a second (before, a 1e6 rad jump silenced it for 60-150 s).
RESPONSE_S = 5.0


def test_jumps_are_warned_and_the_fish_swims_on(start_node, ros, params_file):
    start_node(SIM_MODULE, name="swim", params_file=params_file("oscillatory.yaml"))
    odom = ros.record(Odometry, FISH_ODOM.name)
    diagnostics = ros.record_diagnostics()
    publisher = ros.node.create_publisher(JointState, "motor/joint_state", qos_profile_sensor_data)
    ros.wait_for_subscribers("motor/joint_state")
    ros.wait_for_publishers(FISH_ODOM.name)
    base_ns = ros.node.get_clock().now().nanoseconds - 10_000_000_000
    sent: dict[int, float] = {}
    spike_sent_at: list[float] = []

    def sample(k: int) -> tuple[int, float]:
        stamp_ns, angle = base_ns + k * PERIOD_NS, SPEED_RAD_S * k * PERIOD_NS * 1e-9
        if k in SPIKES_AT:
            angle += SPIKE_RAD
        if k >= STEP_AT:
            angle += STEP_RAD
        if k == STEP_AT:
            stamp_ns = base_ns + (k - 1) * PERIOD_NS + STEP_AFTER_NS
        return stamp_ns, angle

    def tick() -> None:
        k = len(sent)
        if k >= SAMPLES:
            return
        stamp_ns, angle = sample(k)
        message = JointState(name=["carrier_joint"], position=[angle], velocity=[SPEED_RAD_S])
        message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp_ns, 1_000_000_000)
        publisher.publish(message)
        sent[k] = angle
        if k in SPIKES_AT:
            spike_sent_at.append(time.monotonic())

    timer = ros.node.create_timer(PERIOD_NS * 1e-9, tick)

    def spike_warned() -> object:
        return [
            status
            for _, level, status in ros.statuses(diagnostics, "swim")
            if level == Level.WARN
            and "carrier jumped" in status.message
            and float(ros.values(status)["largest_jump_rad"]) > 0.99 * SPIKE_RAD
        ]

    ros.spin_until(lambda: spike_sent_at, 30.0, "the first spike sent")
    # Bounded response: within a diagnostics period or so of a spike, not minutes.
    waited = ros.spin_until(spike_warned, RESPONSE_S, "a WARN naming a 1e6 rad jump")
    assert waited < RESPONSE_S
    assert int(ros.values(spike_warned()[0])["carrier_jumps"]) >= 1

    ros.spin_until(lambda: len(sent) >= SAMPLES, 30.0, f"{SAMPLES} samples sent")
    last_ns = base_ns + (SAMPLES - 1) * PERIOD_NS
    ros.spin_until(
        lambda: any(ros.stamp_ns(o) >= last_ns - 50 * PERIOD_NS for o in odom.messages),
        10.0,
        "fish/odom for the last samples",
    )
    timer.cancel()
    after_step = [o for o in odom.messages if ros.stamp_ns(o) > base_ns + STEP_AT * PERIOD_NS]
    before_spike = [
        o for o in odom.messages if ros.stamp_ns(o) < base_ns + SPIKES_AT[0] * PERIOD_NS
    ]
    # Swimming on: most samples after the step followed, finite, at a fish's speed, further on.
    assert len(after_step) > 0.5 * (SAMPLES - STEP_AT), len(after_step)
    for message in odom.messages:
        twist, pose = message.twist.twist, message.pose.pose
        assert math.isfinite(pose.position.x) and math.isfinite(twist.linear.x)
        assert abs(twist.linear.x) < 2.0 and abs(twist.linear.y) < 2.0, twist
    assert after_step[-1].pose.pose.position.x > before_spike[-1].pose.pose.position.x + 0.01
    # No sample stamped at the spike or the step's was followed.
    jumped = {base_ns + k * PERIOD_NS for k in SPIKES_AT}
    jumped.add(base_ns + (STEP_AT - 1) * PERIOD_NS + STEP_AFTER_NS)
    assert not jumped & {ros.stamp_ns(o) for o in odom.messages}
    ros.spin_until(
        lambda: int(ros.values(ros.statuses(diagnostics, "swim")[-1][2])["carrier_jumps"]) >= 2,
        5.0,
        "both jumps counted",
    )


def test_a_carrier_beyond_the_limit_is_warned_and_far_beyond_it_not_followed(
    start_node, ros, params_file
):
    """1.3 x max_carrier_speed_rad_s (5 rad/s here): integrated, WARN; 3 x: all jumps, WARN."""
    limit = 5.0
    start_node(
        SIM_MODULE,
        name="swim",
        params_file=params_file("oscillatory.yaml"),
        params={"max_carrier_speed_rad_s": limit},
    )
    odom = ros.record(Odometry, FISH_ODOM.name)
    diagnostics = ros.record_diagnostics()
    publisher = ros.node.create_publisher(JointState, "motor/joint_state", qos_profile_sensor_data)
    ros.wait_for_subscribers("motor/joint_state")
    base_ns = ros.node.get_clock().now().nanoseconds - 10_000_000_000
    state = {"k": 0, "angle": 0.0, "speed": 1.3 * limit}

    def tick() -> None:
        k = state["k"] = state["k"] + 1
        state["angle"] += state["speed"] * PERIOD_NS * 1e-9
        message = JointState(name=["carrier_joint"], position=[state["angle"]])
        message.header.stamp.sec, message.header.stamp.nanosec = divmod(
            base_ns + k * PERIOD_NS, 1_000_000_000
        )
        publisher.publish(message)

    timer = ros.node.create_timer(PERIOD_NS * 1e-9, tick)

    def warned(text: str) -> object:
        return [
            status
            for _, level, status in ros.statuses(diagnostics, "swim")
            if level == Level.WARN and text in status.message
        ]

    ros.spin_until(lambda: warned("beyond max_carrier_speed_rad_s"), 10.0, "a speed WARN")
    status = warned("beyond max_carrier_speed_rad_s")[0]
    assert float(ros.values(status)["carrier_speed_rad_s"]) > limit
    assert ros.values(status)["carrier_jumps"] == "0"
    assert len(odom) > 0
    state["speed"] = 3.0 * limit
    switch_ns = base_ns + (state["k"] + 1) * PERIOD_NS
    ros.spin_until(lambda: warned("carrier jumped"), 10.0, "a jump WARN at 3 x the limit")
    ros.spin_for(1.0)
    timer.cancel()
    values = ros.values(ros.statuses(diagnostics, "swim")[-1][2])
    assert int(values["carrier_jumps"]) > 100, values
    # Not followed: past the switch only the guard's fresh start after each stale_timeout_sec
    # (2 s) of nothing accepted, which the fish takes as a restart (nothing integrated).
    after = [o for o in odom.messages if ros.stamp_ns(o) > switch_ns]
    assert len(after) <= 3, len(after)
    assert all(abs(o.twist.twist.linear.x) < 2.0 for o in odom.messages)
