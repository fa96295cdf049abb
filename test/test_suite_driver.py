"""The driver on its own: refused commands leave the speed alone, the watchdog stops the motor."""

from __future__ import annotations

import math
import time

from sensor_msgs.msg import JointState

SPEED_RAD_S = 4.0
CMD_TIMEOUT_S = 0.5
TIME_CONSTANT_S = 0.15  # the sim motor's default first-order lag
COUNTS_PER_REVOLUTION = 2048
ANGLE_PER_COUNT_RAD = 2.0 * math.pi / COUNTS_PER_REVOLUTION
OK, WARN = 0, 1


def test_refused_commands_and_watchdog(start_node, ros):
    """Negative and non-finite commands change nothing; silence stops the motor with a WARN."""
    start_node(
        "driver",
        params={
            "publish_rate_hz": 200.0,
            "cmd_timeout_sec": CMD_TIMEOUT_S,
            "diagnostics_period_sec": 0.2,
            "sim_time_constant_sec": TIME_CONSTANT_S,
            "encoder_counts_per_revolution": COUNTS_PER_REVOLUTION,
        },
    )
    motor = ros.record(JointState, "motor/joint_state")
    diagnostics = ros.record_diagnostics()
    ros.wait_for_publishers("motor/joint_state")
    ros.wait_for_subscribers("motor/cmd_speed")
    commander = ros.command_speed(SPEED_RAD_S, period_s=0.1)

    def velocity() -> float:
        return motor.messages[-1].velocity[0] if motor.messages else 0.0

    ros.spin_until(lambda: velocity() > 0.99 * SPEED_RAD_S, 10.0, "the motor at 4 rad/s")

    # Refused commands, each right after a valid one: had one been applied, the speed would sag
    # towards it for the 0.1 s until the next valid command (by ~2 rad/s for a stop) - or, for
    # NaN, the motor model would raise.
    refused = [-1.0, math.nan, -math.inf, math.inf, -1e-9]
    commander.speed = None
    first_refused = len(motor)
    for bad in refused:
        commander.publish(SPEED_RAD_S)
        commander.publish(bad)
        ros.spin_for(0.1)
    commander.speed = SPEED_RAD_S  # valid commands again (keeps the watchdog fed meanwhile)
    ros.spin_until(
        lambda: any(
            ros.values(s).get("rejected_commands") == str(len(refused))
            for _, _, s in ros.statuses(diagnostics, "driver")
        ),
        5.0,
        f"driver diagnostics counting {len(refused)} rejected commands",
    )
    during = [m.velocity[0] for m in motor.messages[first_refused:]]
    assert len(during) > 20
    assert all(len(m.effort) == 0 for m in motor.messages)  # the first-order model has no torque
    assert min(during) > 0.99 * SPEED_RAD_S, f"speed sagged to {min(during):.3f} rad/s"
    _, level, status = ros.statuses(diagnostics, "driver")[-1]
    values = ros.values(status)
    assert level == OK, status.message
    assert values["commanded_speed_rad_s"] == f"{SPEED_RAD_S:.4f}"
    assert values["watchdog_stops"] == "0"

    # Silence: the watchdog stops the motor CMD_TIMEOUT_S after the last command.
    commander.speed = None
    commander.publish(SPEED_RAD_S)
    last_command_ns = time.time_ns()
    ros.spin_until(
        lambda: velocity() < 1e-3,
        CMD_TIMEOUT_S + 10 * TIME_CONSTANT_S + 3.0,
        "motor/joint_state velocity below 1e-3 rad/s after the commands stopped",
    )
    stopped_index = len(motor)
    samples = [(ros.stamp_ns(m), m.velocity[0]) for m in motor.messages]
    # Not before the timeout: samples stamped up to 0.8 timeout after the last command are at speed.
    early = [v for stamp, v in samples if last_command_ns < stamp < last_command_ns + 4e8]
    assert early and min(early) > 0.99 * SPEED_RAD_S, "the motor slowed before the timeout"

    # The angle stops advancing: over the next 0.5 s it moves by less than one encoder count.
    ros.spin_for(0.5)
    after = motor.messages[stopped_index:]
    assert len(after) > 20, f"only {len(after)} motor/joint_state samples in 0.5 s"
    advance = after[-1].position[0] - after[0].position[0]
    assert advance <= ANGLE_PER_COUNT_RAD + 1e-12, f"angle still advancing by {advance:.4f} rad"
    assert max(abs(m.velocity[0]) for m in after) < 1e-3

    def watchdog_warning():
        for received, level, status in ros.statuses(diagnostics, "driver"):
            if received > last_command_ns and level == WARN:
                return status
        return None

    ros.spin_until(watchdog_warning, 5.0, "a WARN from the driver's diagnostics")
    status = watchdog_warning()
    assert "no speed command" in status.message
    assert ros.values(status)["watchdog_stops"] == "1"
    assert ros.values(status)["commanded_speed_rad_s"] == "0.0000"


def test_dc_motor_publishes_effort_and_its_current(start_node, ros):
    """motor_model dc: the loop holds the speed; effort and the motor's current are published."""
    start_node(
        "driver",
        params={
            "motor_model": "dc",
            "gear_ratio": 30.0,  # the default motor's gearbox and encoder (Pololu 37D 30:1)
            "encoder_counts_per_revolution": 64,
            "publish_rate_hz": 100.0,
            "diagnostics_period_sec": 0.2,
            "cmd_timeout_sec": CMD_TIMEOUT_S,
        },
    )
    motor = ros.record(JointState, "motor/joint_state")
    diagnostics = ros.record_diagnostics()
    ros.wait_for_publishers("motor/joint_state")
    ros.wait_for_subscribers("motor/cmd_speed")
    ros.command_speed(SPEED_RAD_S, period_s=0.1)

    def at_speed() -> bool:
        return bool(motor.messages) and abs(motor.messages[-1].velocity[0] / SPEED_RAD_S - 1) < 0.03

    ros.spin_until(at_speed, 10.0, "the dc motor within 3 % of 4 rad/s")
    latest = motor.messages[-1]
    # No load is attached in the node: the gearbox passes no torque on to the carrier.
    assert list(latest.effort) == [0.0]
    assert list(motor.messages[0].effort) == [0.0]

    def motor_figures() -> dict[str, str] | None:
        for _, _, status in reversed(ros.statuses(diagnostics, "driver")):
            values = ros.values(status)
            if values.get("motor_model") == "dc" and float(values.get("speed_rad_s", 0)) > 3.0:
                return values
        return None

    ros.spin_until(motor_figures, 5.0, "driver diagnostics with the dc motor at speed")
    values = motor_figures()
    # Friction alone at 4 rad/s: k I = τ_c + b ω_m, 0.11 A; d V I at PWM ~33/255: ~0.17 W.
    assert 0.05 < float(values["current_a"]) < 0.5
    assert 0.0 < float(values["supply_power_w"]) < 1.0
    assert values["pid_running"] == "true"
