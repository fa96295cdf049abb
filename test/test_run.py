"""fishtail-run end to end: the suite starts, the tail beats, a verdict shows, everything stops."""

from __future__ import annotations

import doctest
import os
import re
import signal
import subprocess
import sys
import time

import pytest

import fishtail_bringup.console
from fishtail_boards.avr_board import PROJECT_FIRMWARE_DIR, built_artifacts
from fishtail_testkit.console_runs import run_until
from fishtail_testkit.firmware import built_firmware_or_skip
from fishtail_testkit.steering_doc import documented_square_seconds

RUN_TIMEOUT_S = 60.0
RUN = [sys.executable, "-m", "fishtail_bringup.run"]
#: The console's line once a beat was judged symmetric.
SYMMETRIC = " OK: symmetric"


def up(output: str, *nodes: str) -> bool:
    """Whether fishtail-run said each of ``nodes`` is up."""
    return all(f"{node} up" in output for node in nodes)


@pytest.fixture(params=["separate processes", "one process"])
def run(request) -> list[str]:
    """fishtail-run's command in each layout: a process per node, or all nodes in one."""
    return RUN + (["--one-process"] if request.param == "one process" else [])


def test_console_doctests():
    result = doctest.testmod(fishtail_bringup.console)
    assert result.attempted > 0 and result.failed == 0


def test_a_run_shows_beats_and_a_symmetric_verdict(ros_domain, run):
    # 12 rad/s gives a beat every 0.52 s; Ctrl-C once a beat was judged, however long that took.
    completed = run_until(
        [*run, "--speed", "12"],
        lambda out: up(out, "driver", "kinematics", "monitor") and SYMMETRIC in out,
        RUN_TIMEOUT_S,
    )
    output = completed.output
    assert completed.returncode == 0, output
    assert "driver up" in output and "kinematics up" in output and "monitor up" in output
    # The swing is judged symmetric, and never asymmetric. A beat with a gap in its input (a
    # loaded machine delays a sample) is NOT_JUDGED, which says nothing either way.
    assert " OK: symmetric" in output, output
    assert not re.search(r"beat \d+ (WARN|ERROR):", output), output
    assert "motor commanded to stop" in output


def test_duration_ends_the_run_by_itself(ros_domain):
    """``--duration``: the run stops by itself, the motor commanded to stop, every node ends well.

    One layout, and short: just longer than the nodes take to start on a loaded machine.
    """
    completed = subprocess.run(
        [*RUN, "--speed", "12", "--duration", "4"],
        env=os.environ.copy(), capture_output=True, text=True, timeout=RUN_TIMEOUT_S,
    )  # fmt: skip
    output = completed.stdout + completed.stderr
    assert completed.returncode == 0, output
    assert "at 12 rad/s for 4 s" in output, output
    assert "motor commanded to stop" in output and "fishtail-run: last state" in output, output
    assert "non-zero status" not in output and "killed" not in output, output


def test_sigint_stops_every_node(ros_domain, run):
    process = subprocess.Popen(
        [*run, "--mechanism", "undulatory"],
        env=os.environ.copy(),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    lines = []
    deadline = time.monotonic() + RUN_TIMEOUT_S
    # Wait until the console shows a computed tail state, i.e. all nodes run and talk.
    for line in process.stdout:
        lines.append(line)
        if "carrier" in line and "--" not in line.split("carrier")[1][:12]:
            break
        assert time.monotonic() < deadline, "".join(lines)
    process.send_signal(signal.SIGINT)
    rest, _ = process.communicate(timeout=RUN_TIMEOUT_S)
    output = "".join(lines) + rest
    assert process.returncode == 0, output
    assert "motor commanded to stop; driver exiting" in output
    assert "non-zero status" not in output and "killed" not in output


def test_a_subset_of_nodes_on_this_computer(ros_domain, start_node, run):
    """The shore half: kinematics and monitor only, following a driver started elsewhere."""
    driver = start_node("driver", params={"cmd_timeout_sec": 0.5})
    completed = run_until(
        [*run, "--nodes", "kinematics,monitor", "--speed", "12"],
        lambda out: up(out, "kinematics", "monitor") and SYMMETRIC in out,
        RUN_TIMEOUT_S,
    )
    output = completed.output
    assert completed.returncode == 0, output
    assert "kinematics up" in output and "monitor up" in output
    assert "driver up" not in output  # the driver is the other process's
    # The console's command reached that driver: the tail beat and beats were judged. (Not
    # necessarily the last one: on a loaded machine a gap in the input leaves a beat unjudged.)
    assert any(" OK: symmetric" in line for line in output.splitlines()), output
    assert driver.returncode is None


def test_no_command_leaves_the_motor_to_another_computer(ros_domain, ros, run):
    """``--nodes driver --no-command`` (the fish half): the driver runs, nobody commands it."""
    from std_msgs.msg import Float64

    commands = ros.record(Float64, "motor/cmd_speed", 10)
    process = subprocess.Popen(
        [*run, "--nodes", "driver", "--no-command"],
        env=os.environ.copy(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    try:
        # The probe's own recorder and the driver's: only then is the driver up.
        ros.wait_for_subscribers("motor/cmd_speed", count=2)
        ros.spin_for(1.0)  # ten command periods
        assert len(commands) == 0
        assert ros.node.count_publishers("motor/cmd_speed") == 0
    finally:
        process.send_signal(signal.SIGINT)
        output, _ = process.communicate(timeout=RUN_TIMEOUT_S)
    assert process.returncode == 0, output
    assert "driver up" in output and "kinematics up" not in output


def test_unknown_node_name_is_a_one_line_error():
    completed = subprocess.run(
        [sys.executable, "-m", "fishtail_bringup.run", "--nodes", "driver,planner"],
        env=os.environ.copy(), capture_output=True, text=True, timeout=RUN_TIMEOUT_S,
    )  # fmt: skip
    assert completed.returncode == 2
    assert "unknown node planner: choose from driver, kinematics, monitor" in completed.stderr


def test_the_loaded_dc_motor_shows_its_torque_and_current(ros_domain, run):
    """``--motor dc --load water_swimming``: the motor turns the tail in water; the line says so."""
    completed = run_until(
        [*run, "--motor", "dc", "--load", "water_swimming", "--speed", "12"],
        lambda out: any(" N m, " in line and SYMMETRIC in line for line in out.splitlines()),
        RUN_TIMEOUT_S,
    )
    output = completed.output
    assert completed.returncode == 0, output
    assert "motor turning the oscillatory tail (water_swimming)" in output
    lines = [line for line in output.splitlines() if " N m, " in line]
    assert lines, output
    assert any(" OK: symmetric" in line for line in lines), output


def test_the_suite_runs_on_the_firmware_in_simavr(ros_domain):
    """``--firmware``: the driver on the project's firmware in simavr; the carrier turns, all stop.

    The board follows the profile (the driver says so once connected). One layout only (the
    simulator alone needs most of a core). Skips where set-up could not build the firmware
    (saying why).
    """
    firmware = built_firmware_or_skip()
    if built_artifacts(firmware / PROJECT_FIRMWARE_DIR) is None:
        pytest.skip(f"the project's firmware is not built in {firmware / PROJECT_FIRMWARE_DIR}")

    def turned(out: str) -> bool:
        carriers = [float(m) for m in re.findall(r"carrier +([0-9.]+) rad", out)]
        on_the_board = "[board] /dev/" in out and up(out, "driver", "kinematics", "monitor")
        said = "fishtail 1 (profile on board)" in out  # once connected
        return on_the_board and said and bool(carriers) and carriers[-1] > 5.0

    completed = run_until([*RUN, "--firmware", "--speed", "8"], turned, RUN_TIMEOUT_S)
    output = completed.output
    assert completed.returncode == 0, output
    assert "on the firmware in simavr" in output and "[board] /dev/" in output, output
    assert "driver up: backend serial" in output, output
    assert "the project's firmware (profile on the board)" in output, output
    assert re.search(r"motor board on \S+: fishtail 1 \(profile on board\)", output), output
    carriers = [float(m) for m in re.findall(r"carrier +([0-9.]+) rad", output)]
    assert carriers and carriers[-1] > 5.0, output  # turned, whatever pace the host kept
    assert "stop acknowledged by the board" in output, output
    assert "non-zero status" not in output and "killed" not in output, output


def test_firmware_stock_picks_the_stock_firmware(tmp_path, monkeypatch):
    """``--firmware`` alone: the project's where built, else stock; ``--firmware stock``: stock."""
    from fishtail_bringup import firmware_board

    monkeypatch.setenv("FISHTAIL_ROOT", str(tmp_path))  # nothing built here
    assert firmware_board.pick_firmware("auto") == "stock"
    assert firmware_board.pick_firmware("fishtail") == "fishtail"
    assert "run make firmware" in (firmware_board.missing_firmware("fishtail") or "")
    stock = firmware_board.board_command(tmp_path / "link", "none", tmp_path, None, "stock")
    project = firmware_board.board_command(tmp_path / "link", "none", tmp_path, None, "fishtail")
    assert stock[stock.index("--build-dir") + 1] == str(tmp_path / "build" / "firmware")
    assert project[project.index("--build-dir") + 1] == str(
        tmp_path / "build" / "firmware" / "fishtail"
    )


def test_firmware_in_water_gives_the_driver_k_for_its_motor_and_load():
    """On the project's firmware in water the driver gets k for the board's motor and the load.

    The board's motor is the 37D 30:1; no k on stock, unloaded or in air.
    """
    from pathlib import Path

    import yaml

    from fishtail_bringup import firmware_board
    from fishtail_common.parameter_files import default_parameter_file
    from fishtail_driver.protocol import parse_profile_tuning
    from fishtail_plant.motor.board_units import Scale
    from fishtail_plant.motor.profile_tuning import profile_tuning

    config, fish = default_parameter_file("oscillatory"), default_parameter_file("fish")
    tuning = firmware_board.board_tuning("fishtail", "water_swimming", config, fish)
    assert tuning == profile_tuning("water_swimming", Scale(64, 30.0)) == "8:5955:1889:5:690"
    assert parse_profile_tuning(tuning) is not None  # within the firmware's ranges
    held = firmware_board.board_tuning("fishtail", "water_held", config, fish)
    assert held is not None and held != tuning
    for firmware, load in (("stock", "water_swimming"), ("fishtail", "none"), ("fishtail", "air")):
        assert firmware_board.board_tuning(firmware, load, config, fish) is None
    items = firmware_board.driver_parameters(Path("/tmp/link"), tuning)
    (item,) = [item for item in items if item.startswith("serial_profile_tuning:=")]
    assert yaml.safe_load(item.partition(":=")[2]) == tuning  # a string, whatever its digits
    assert not any("tuning" in item for item in firmware_board.driver_parameters(Path("/l")))
    assert f"k {tuning}" in firmware_board.describe("fishtail", tuning)


#: A waypoint line of the console: which, how, where, and the time into the route.
WAYPOINT = re.compile(
    r"waypoint \((?P<x>[-\d.]+), (?P<y>[-\d.]+)\) (?P<how>reached|rounded) at "
    r"\([-\d.]+, [-\d.]+\) m, (?P<into>[\d.]+) s into the route"
)
#: The console's status line: the fish's heading.
HEADING = re.compile(r" heading +(?P<deg>[-+][\d.]+)°")


def test_the_square_is_flown_round_without_a_loop_in_its_documented_time(ros_domain):
    """``--square 2``, the whole suite (mechanism 1): every corner in turn, without a loop.

    The route within 1.3 times docs/steering.md's closed-loop figure; the heading turning less
    than a loop would add.
    """
    completed = run_until(
        [*RUN, "--swim", "--square", "2"], lambda out: "route done" in out, 4.0 * RUN_TIMEOUT_S
    )
    output = completed.output
    assert completed.returncode == 0 and completed.seen, output
    waypoints = [match.groupdict() for match in WAYPOINT.finditer(output)]
    corners = [(float(w["x"]), float(w["y"])) for w in waypoints]
    assert corners == [(2.0, 0.0), (2.0, 2.0), (0.0, 2.0), (0.0, 0.0)], output
    assert waypoints[-1]["how"] == "reached", output
    allowed_s = 1.3 * documented_square_seconds()["oscillatory"]
    assert float(waypoints[-1]["into"]) <= allowed_s, output
    # The status line comes once a second: the heading's changes between lines are well under
    # 180 degrees, so unwrapped they add up to the turn. Round a square three corners turn the
    # fish 270 degrees; a loop would add 360.
    flown = output[output.index("goal (2.00, 0.00) m") : output.index("route done")]
    headings = [float(match["deg"]) for match in HEADING.finditer(flown)]
    pairs = zip(headings[:-1], headings[1:], strict=True)
    steps = [(b - a + 180.0) % 360.0 - 180.0 for a, b in pairs]
    assert sum(abs(step) for step in steps) < 360.0 + 180.0, output


def child_processes(pid: int) -> list[tuple[int, str]]:
    """(pid, command line) of the processes whose parent is ``pid`` (from /proc)."""
    children = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as stream:
                # The parent's pid is the second field after the ")" that ends the name.
                parent = int(stream.read().rpartition(")")[2].split()[1])
            with open(f"/proc/{entry}/cmdline", "rb") as stream:
                command = stream.read().replace(b"\0", b" ").decode()
        except (FileNotFoundError, ProcessLookupError):
            continue  # ended meanwhile
        if parent == pid:
            children.append((int(entry), command))
    return children


def test_one_process_hosts_every_node_with_its_own_parameters(ros_domain, ros):
    """--one-process: one child process, the nodes in the namespace, the driver's -p its own."""
    diagnostics = ros.record_diagnostics()
    process = subprocess.Popen(
        [*RUN, "--one-process", "--namespace", "fish1", "--driver-param", "publish_rate_hz:=500.0"],
        env=os.environ.copy(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    try:
        expected = {("driver", "/fish1"), ("kinematics", "/fish1"), ("monitor", "/fish1")}
        ros.spin_until(
            lambda: expected <= set(ros.node.get_node_names_and_namespaces()),
            RUN_TIMEOUT_S,
            "the three nodes in /fish1",
        )
        children = child_processes(process.pid)
        assert len(children) == 1, children
        assert "fishtail_bringup.one_process" in children[0][1]
        assert child_processes(children[0][0]) == []  # the nodes are not processes of their own

        def driver_rate() -> str | None:
            for array in diagnostics:
                for status in array.status:
                    if status.name.startswith("/fish1/driver"):
                        return ros.values(status).get("joint_state_expected_rate_hz")
            return None

        ros.spin_until(driver_rate, RUN_TIMEOUT_S, "the driver's /diagnostics")
        assert driver_rate() == "500"
    finally:
        process.send_signal(signal.SIGINT)
        output, _ = process.communicate(timeout=RUN_TIMEOUT_S)
    assert process.returncode == 0, output
    assert "[suite]" in output and "motor commanded to stop; driver exiting" in output


def test_a_node_that_cannot_start_fails_the_one_process(ros_domain):
    completed = subprocess.run(
        [*RUN, "--one-process", "--driver-param", "backend:=telepathy", "--duration", "30"],
        env=os.environ.copy(), capture_output=True, text=True, timeout=RUN_TIMEOUT_S,
    )  # fmt: skip
    output = completed.stdout + completed.stderr
    assert completed.returncode == 1, output
    assert "driver: error: " in output and "telepathy" in output
    assert "node process suite exited early with status 2" in output
    assert "kinematics up" not in output  # the nodes after it were never created
