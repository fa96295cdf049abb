"""The driver node as a process: speed profiles on motor/cmd_profile, the pivot actuator's topics.

Each test starts ``python -m fishtail_driver.node`` on a ROS domain of its own (localhost
discovery, logs in tmp_path) and watches it from the probe node, waiting on messages and statuses,
never for fixed times.
"""

from __future__ import annotations

import math

from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from fishtail_common.interface import PIVOT_JOINT
from fishtail_common.testing import DISCOVERY_TIMEOUT_S
from fishtail_driver.parameters import DC_MOTOR_ENCODER
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
from fishtail_msgs.msg import CarrierSpeedProfile as ProfileMessage
from fishtail_testkit.modulation_fit import measure_following

OK, WARN = 0, 1
ONE_HZ = 2.0 * math.pi


def profile_message(mean: float, depth: float, phase: float) -> ProfileMessage:
    """A motor/cmd_profile message."""
    return ProfileMessage(mean_speed=mean, modulation_depth=depth, modulation_phase=phase)


def status_of(ros, diagnostics, part: str, mark: int = 0) -> list[tuple[int, object]]:
    """(level, status) of the driver's ``part`` status ("motor", "pivot") in diagnostics[mark:]."""
    found = []
    for array in diagnostics[mark:]:
        for status in array.status:
            if status.name.startswith("/driver:") and status.name.endswith(f": {part}"):
                level = status.level[0] if isinstance(status.level, bytes) else status.level
                found.append((int(level), status))
    return found


def stamp_s(message) -> float:
    """A header stamp in seconds."""
    return message.header.stamp.sec + 1e-9 * message.header.stamp.nanosec


def test_a_profile_modulates_the_carrier_once_a_revolution_and_the_watchdog_stops_it(
    driver_process, ros
):
    """The dc sim at its defaults, depth 0.5 at a 1 Hz beat, fastest at 2 rad."""
    driver = driver_process(
        params={"motor_model": "dc", **DC_MOTOR_ENCODER, "publish_rate_hz": 200.0,
                "cmd_timeout_sec": 0.5, "diagnostics_period_sec": 0.2}
    )  # fmt: skip
    motor = ros.record(JointState, "motor/joint_state")
    diagnostics = ros.record_diagnostics()
    ros.wait_for_publishers("motor/joint_state")
    ros.wait_for_subscribers("motor/cmd_profile")
    # pivot_actuator none: the driver has no pivot topics.
    assert ros.node.count_publishers("pivot/joint_state") == 0
    assert ros.node.count_subscribers("pivot/cmd_position") == 0

    commanded = CarrierSpeedProfile(ONE_HZ, 0.5, 2.0)
    publisher = ros.node.create_publisher(ProfileMessage, "motor/cmd_profile", 10)
    feeding = {"on": True}

    def feed() -> None:
        if feeding["on"]:
            publisher.publish(profile_message(ONE_HZ, 0.5, 2.0))

    ros.node.create_timer(0.1, feed)
    ros.spin_until(lambda: motor and motor[-1].velocity[0] > 1.0, 10.0, "the carrier turning")
    start = len(motor)
    first_angle = motor[start - 1].position[0]
    ros.spin_until(
        lambda: motor[-1].position[0] > first_angle + 7 * 2 * math.pi, 30.0, "7 revolutions"
    )
    samples = motor[start:]
    result = measure_following(
        [stamp_s(m) for m in samples],
        [m.position[0] for m in samples],
        [m.velocity[0] for m in samples],
        commanded,
        skip_revolutions=2,
    )
    # In simulated time the same motor gives depth 0.491 and lag 0.566 rad (test_modulation_fit),
    # and three runs of this test 0.490-0.494 and 0.565-0.570 rad; the bounds leave room for the
    # publish timer's jitter on a busy machine (0.1 rad is 16 ms at 1 Hz).
    assert abs(result.depth - 0.5) <= 0.04, result
    assert abs(result.phase_lag_rad - 0.57) <= 0.1, result
    _, status = status_of(ros, diagnostics, "motor")[-1]
    values = ros.values(status)
    assert (values["profile_mean_speed_rad_s"], values["profile_depth"],
            values["profile_phase_rad"]) == (f"{ONE_HZ:.4f}", "0.5000", "2.0000")  # fmt: skip

    # Silence: the watchdog stops the profile like a speed command.
    feeding["on"] = False
    mark = len(diagnostics)
    ros.spin_until(
        lambda: any(level == WARN and "no speed command" in status.message
                    for level, status in status_of(ros, diagnostics, "motor", mark)),
        5.0, "the watchdog's WARN",
    )  # fmt: skip
    ros.spin_until(lambda: motor[-1].velocity[0] < 0.01, 5.0, "the carrier stopped")
    _, status = status_of(ros, diagnostics, "motor")[-1]
    values = ros.values(status)
    assert values["watchdog_stops"] == "1" and values["profile_mean_speed_rad_s"] == "0.0000"
    assert driver.returncode is None, driver.output()


def test_a_profile_beyond_the_limit_is_refused_with_what_is_achievable(driver_process, ros):
    """The previous profile stays in force; WARN with the reason until a profile is accepted."""
    driver_process(
        params={"publish_rate_hz": 200.0, "cmd_timeout_sec": 0.0, "diagnostics_period_sec": 0.2,
                "sim_time_constant_sec": 0.05}
    )  # fmt: skip
    motor = ros.record(JointState, "motor/joint_state")
    diagnostics = ros.record_diagnostics()
    ros.wait_for_subscribers("motor/cmd_profile")
    publisher = ros.node.create_publisher(ProfileMessage, "motor/cmd_profile", 10)

    def motor_values() -> dict[str, str]:
        found = status_of(ros, diagnostics, "motor")
        return ros.values(found[-1][1]) if found else {}

    publisher.publish(profile_message(4.0, 0.2, 0.0))
    ros.spin_until(lambda: motor_values().get("profile_depth") == "0.2000", 10.0, "the profile")
    ros.spin_until(lambda: motor and motor[-1].velocity[0] > 3.0, 10.0, "the carrier at speed")
    first_refused = len(motor)
    mark = len(diagnostics)
    publisher.publish(profile_message(15.0, 0.5, 0.0))  # peaks at 26 rad/s, the limit is 20

    def warned(count: int):
        def check():
            for level, status in status_of(ros, diagnostics, "motor", mark):
                if ros.values(status)["refused_profiles"] == str(count):
                    return (level, status)
            return None

        return check

    ros.spin_until(warned(1), 5.0, "the refusal on /diagnostics")
    level, status = warned(1)()
    values = ros.values(status)
    assert level == WARN
    assert (
        "its peak speed 25.98 rad/s exceeds max_speed_rad_s = 20 rad/s; achievable: depth "
        "0.28 at mean 15 rad/s, or mean 11.55 rad/s at depth 0.5"
    ) in status.message
    assert values["achievable_depth"] == "0.28"
    assert values["achievable_mean_speed_rad_s"] == "11.55"
    assert (values["profile_mean_speed_rad_s"], values["profile_depth"]) == ("4.0000", "0.2000")

    publisher.publish(profile_message(6.0, 0.95, 0.0))
    publisher.publish(profile_message(math.nan, 0.1, 0.0))
    ros.spin_until(warned(3), 5.0, "three refusals")
    level, status = warned(3)()
    assert level == WARN and "mean nan rad/s" in ros.values(status)["last_refused_profile"]
    # The motor kept the accepted profile throughout (4 rad/s +- 20 %, slightly lagged).
    assert min(m.velocity[0] for m in motor[first_refused:]) > 3.0

    mark = len(diagnostics)
    publisher.publish(profile_message(5.0, 0.0, 0.0))
    ros.spin_until(
        lambda: any(level == OK for level, _ in status_of(ros, diagnostics, "motor", mark)),
        5.0, "OK once a profile is accepted",
    )  # fmt: skip


def test_the_pivot_moves_at_its_speed_clips_to_its_stroke_and_ignores_the_watchdog(
    driver_process, ros
):
    """pivot_actuator sim at 0.02 m/s within +-0.03 m: to 0.02 m in 1 s, then beyond the stroke."""
    driver_process(
        params={"pivot_actuator": "sim", "pivot_speed_m_s": 0.02, "pivot_stroke_m": 0.03,
                "publish_rate_hz": 100.0, "cmd_timeout_sec": 0.3, "diagnostics_period_sec": 0.2}
    )  # fmt: skip
    pivot = ros.record(JointState, "pivot/joint_state")
    diagnostics = ros.record_diagnostics()
    ros.wait_for_publishers("pivot/joint_state")
    ros.wait_for_subscribers("pivot/cmd_position")
    commands = ros.node.create_publisher(Float64, "pivot/cmd_position", 10)
    ros.spin_until(lambda: len(pivot) >= 3, DISCOVERY_TIMEOUT_S, "pivot joint states")
    assert pivot[-1].name == [PIVOT_JOINT] and pivot[-1].position[0] == 0.0

    start = len(pivot)
    commands.publish(Float64(data=0.02))
    ros.spin_until(
        lambda: pivot[-1].position[0] == 0.02 and pivot[-1].velocity[0] == 0.0,
        5.0, "the pivot at 0.02 m",
    )  # fmt: skip
    moving = [m for m in pivot[start:] if 0.0 < m.position[0] < 0.02]
    assert len(moving) > 50, "fewer samples than 1 s at 100 Hz holds"
    assert all(m.velocity[0] == 0.02 for m in moving)
    first, last = moving[0], moving[-1]
    slope = (last.position[0] - first.position[0]) / (stamp_s(last) - stamp_s(first))
    assert abs(slope - 0.02) < 0.0002
    # Stamped with the time the state holds for: the move started where the line meets 0 and
    # took 0.02 / 0.02 = 1 s.
    # It arrived between the last sample still on its way and the first one there, whatever the
    # sampling's jitter.
    started = stamp_s(first) - first.position[0] / 0.02
    arrived = next(stamp_s(m) for m in pivot[start:] if m.position[0] == 0.02)
    assert stamp_s(last) - 1e-6 <= started + 1.0 <= arrived + 1e-6

    mark = len(diagnostics)
    commands.publish(Float64(data=0.05))
    ros.spin_until(
        lambda: any(level == WARN and "achievable +0.0300 m" in status.message
                    for level, status in status_of(ros, diagnostics, "pivot", mark)),
        5.0, "the clip on /diagnostics",
    )  # fmt: skip
    ros.spin_until(lambda: pivot[-1].position[0] == 0.03, 5.0, "the pivot at the stroke's end")
    commands.publish(Float64(data=math.nan))
    ros.spin_until(
        lambda: any(ros.values(status)["refused_commands"] == "1"
                    for _, status in status_of(ros, diagnostics, "pivot")),
        5.0, "the refused NaN",
    )  # fmt: skip
    _, status = status_of(ros, diagnostics, "pivot")[-1]
    assert "not a finite number" in status.message and ros.values(status)["target_m"] == "0.03000"

    # The carrier's watchdog stops the motor and leaves the pivot where it is.
    ros.node.create_publisher(Float64, "motor/cmd_speed", 10).publish(Float64(data=2.0))
    ros.spin_until(
        lambda: any(ros.values(status)["watchdog_stops"] == "1"
                    for _, status in status_of(ros, diagnostics, "motor")),
        5.0, "the watchdog",
    )  # fmt: skip
    after = len(pivot)
    ros.spin_until(lambda: len(pivot) >= after + 20, 5.0, "20 more pivot joint states")
    assert all(m.position[0] == 0.03 and m.velocity[0] == 0.0 for m in pivot[after:])


def test_a_simulated_pivot_beside_the_board_is_refused_at_start(driver_process, tmp_path):
    driver = driver_process(params={"backend": "serial", "serial_port": str(tmp_path / "tty"),
                                    "pivot_actuator": "sim"})  # fmt: skip
    assert driver.wait(30.0) == 2, driver.output()
    errors = [line for line in driver.output().splitlines() if line.startswith("driver: error:")]
    assert len(errors) == 1, driver.output()
    assert "pivot_actuator sim needs backend sim (got backend serial)" in errors[0]
