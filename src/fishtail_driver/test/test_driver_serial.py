"""End to end: the driver node with backend:=serial against fishtail-fake-board processes.

One scenario, in order: the board is missing when the driver starts (ERROR on /diagnostics), it
appears (OK); commanded speed makes motor/joint_state's angle advance; the board is killed and a
new one starts at the same link (ERROR, then WARN for the re-based phase, no jump in the
published angle); commands stop (the driver's watchdog sends m 0 0); commands resume; SIGINT to
the driver makes the board receive m 0 0 before the driver exits.
"""

from __future__ import annotations

import math
import signal
from pathlib import Path

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.qos import QoSProfile, qos_profile_sensor_data
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

DISCOVERY_S = 15.0
MAX_SPEED = 20.0
COUNT_RAD = 2 * math.pi / 2048


def motor_commands(log: Path) -> list[str]:
    """The m commands a fake board logged, in order."""
    if not log.exists():
        return []
    commands = []
    for line in log.read_text().splitlines():
        fields = line.split(maxsplit=1)
        if len(fields) == 2 and fields[1].startswith("m "):
            commands.append(fields[1])
    return commands


def driver_statuses(arrays: list) -> list[tuple[int, str]]:
    """(level, message) of the driver's motor status, in arrival order."""
    found = []
    for array in arrays:
        for status in array.status:
            if status.name.startswith("/driver:"):
                level = status.level[0] if isinstance(status.level, bytes) else status.level
                found.append((int(level), status.message))
    return found


def test_driver_serial_end_to_end(ros_probe, board_process, driver_process, tmp_path):
    """Missing board, motion, unplug/replug without an angle jump, watchdog stop, SIGINT stop."""
    link = tmp_path / "ttyFAKE"
    logs = [tmp_path / "board1.log", tmp_path / "board2.log"]
    driver = driver_process(
        params={
            "backend": "serial",
            "serial_port": str(link),
            "serial_poll_rate_hz": 100.0,
            "diagnostics_period_sec": 0.2,
            "cmd_timeout_sec": 0.5,
            "publish_rate_hz": 100.0,
        }
    )
    probe = ros_probe
    sensor = QoSProfile(depth=1000)
    sensor.reliability = qos_profile_sensor_data.reliability
    sensor.durability = qos_profile_sensor_data.durability
    joints = probe.record(JointState, "motor/joint_state", sensor)
    diagnostics = probe.record(DiagnosticArray, "/diagnostics", 50)
    publisher = probe.node.create_publisher(Float64, "motor/cmd_speed", 10)
    speed = {"value": None}

    def command() -> None:
        if speed["value"] is not None:
            publisher.publish(Float64(data=speed["value"]))

    probe.node.create_timer(0.1, command)

    def wait(predicate, timeout: float, what: str) -> None:
        if driver.popen.poll() is not None:
            raise AssertionError(f"the driver exited:\n{driver.output()}")
        probe.spin_until(predicate, timeout, what)

    def level_after(mark: int, level: int, text: str = ""):
        return lambda: any(
            lv == level and text in message for lv, message in driver_statuses(diagnostics[mark:])
        )

    def angle() -> float:
        return joints[-1].position[0] if joints else 0.0

    # 1. No board yet: the driver runs and reports ERROR with the cause.
    wait(level_after(0, 2, "does not exist"), DISCOVERY_S, "ERROR: port missing")
    # 2. The board appears: OK.
    first = board_process(link, log=logs[0])
    first.next_path()
    mark = len(diagnostics)
    wait(level_after(mark, 0), 6.0, "OK once the board is there")
    # 3. Commanded motion: the angle advances.
    probe.spin_until(lambda: probe.node.count_subscribers("motor/cmd_speed") >= 1, DISCOVERY_S,
                     "the driver's command subscription")  # fmt: skip
    speed["value"] = 5.0
    wait(lambda: angle() > 1.5, 5.0, "the joint_state angle to advance")
    assert any(c != "m 0 0" for c in motor_commands(logs[0]))
    # 4. Unplug (kill the board) and replug (a new board at the same link).
    first.kill(signal.SIGKILL)
    mark = len(diagnostics)
    wait(level_after(mark, 2), 3.0, "ERROR after the unplug")
    held = angle()
    second = board_process(link, log=logs[1])
    second.next_path()
    mark = len(diagnostics)
    # Connected again, WARN rather than OK: the new board counts from 0, so the angle was re-based
    # and the carrier phase may have shifted.
    wait(level_after(mark, 1, "phase_rad may need re-calibration"), 6.0, "WARN after the replug")
    wait(lambda: angle() > held + 1.5, 5.0, "motion after the replug")
    stamps = [m.header.stamp.sec + 1e-9 * m.header.stamp.nanosec for m in joints]
    angles = [m.position[0] for m in joints]
    gaps = [(stamps[i + 1] - stamps[i], i) for i in range(len(stamps) - 1)]
    gap, outage = max(gaps)
    assert gap > 0.1, "no outage in motor/joint_state: samples were published while unplugged"
    assert abs(angles[outage + 1] - angles[outage]) < 0.1, "the angle jumped across the replug"
    for i in range(len(angles) - 1):
        step = angles[i + 1] - angles[i]
        assert step >= -2 * COUNT_RAD - 1e-9, f"angle went back by {-step:.4f} rad"
        assert step <= 2 * MAX_SPEED * (stamps[i + 1] - stamps[i] + 0.05), f"jump {step:.3f}"
    # 5. Commands stop: the driver's watchdog stops the motor (m 0 0 on the board).
    speed["value"] = None
    wait(lambda: motor_commands(logs[1])[-1:] == ["m 0 0"], 3.0, "the watchdog's m 0 0")
    # 6. Commands resume, then SIGINT: the board receives m 0 0 before the driver exits.
    speed["value"] = 4.0
    wait(lambda: motor_commands(logs[1])[-1:] not in ([], ["m 0 0"]), 3.0, "motion again")
    driver.signal(signal.SIGINT)
    status = driver.wait(10.0)
    assert status == 0, driver.output()
    assert motor_commands(logs[1])[-1] == "m 0 0", motor_commands(logs[1])[-5:]
    assert "Traceback" not in driver.output()
    assert "carrier phase reference may have shifted" in driver.output()  # logged at the re-base
