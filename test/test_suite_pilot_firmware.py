"""The pilot's closed loop through the project's motor-board firmware in simavr.

``fishtail-run --firmware --goal 3,0.5``: the pilot commands motor/cmd_profile, the driver sends
it to the project's firmware as ``f`` (the board follows the profile at every PID frame), the
simulator swims the fish from the carrier's samples, and the pilot brings it to the goal. Only
the route's end is checked, whatever pace the host kept the simulator at.
"""

from __future__ import annotations

import sys

import pytest

from fishtail_boards.avr_board import PROJECT_FIRMWARE_DIR, built_artifacts
from fishtail_testkit.console_runs import run_until
from fishtail_testkit.firmware import built_firmware_or_skip

RUN = [sys.executable, "-m", "fishtail_bringup.run"]
#: The pure closed loop takes 10-15 s to a goal 3 m away; start-up, a simulator starved of CPU
#: on a loaded host and the motor's lag take the rest.
GOAL_TIMEOUT_S = 240.0


@pytest.mark.slow
def test_the_pilot_reaches_a_goal_through_the_project_firmware(ros_domain):
    firmware = built_firmware_or_skip()
    if built_artifacts(firmware / PROJECT_FIRMWARE_DIR) is None:
        pytest.skip(f"the project's firmware is not built in {firmware / PROJECT_FIRMWARE_DIR}")
    completed = run_until(
        [*RUN, "--firmware", "--goal", "3,0.5"], lambda out: "route done" in out, GOAL_TIMEOUT_S
    )
    output = completed.output
    assert completed.returncode == 0 and completed.seen, output
    assert "fishtail 1 (profile on board)" in output, output
    assert "waypoint (3, 0.5) reached" in output, output
    assert "stop acknowledged by the board" in output, output
