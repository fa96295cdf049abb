"""The kinematics node follows pivot/joint_state: its tail/state says what the shifted engine says.

The node runs as a process of its own on the test's ROS domain (``ros_domain``); this test's probe
(``ros``) streams carrier samples and the pivot actuator's shift, both on timers, and waits for
the tail states and diagnostics that answer them (never a fixed sleep).
"""

from __future__ import annotations

import dataclasses
import math
import sys

import pytest

from fishtail_common import pytest_fixtures
from fishtail_common.interface import PIVOT_JOINT, PIVOT_JOINT_STATE
from fishtail_common.testing import NodeProcess
from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail

pytestmark = pytest.mark.filterwarnings("ignore:module 'sre_:DeprecationWarning")
# The shared fixtures, registered for these tests by being names of this module.
ros_domain = pytest_fixtures.ros_domain
ros = pytest_fixtures.ros
SPEED_RAD_S = 4.0
SAMPLE_PERIOD_S = 0.01
#: A shift at which the report's drive cannot assemble: OS + s beyond sqrt((RS + PR)^2 - R^2).
INFEASIBLE_M = 0.2
WAIT_S = 20.0


class Suite:
    """The kinematics node process and the probe's streams and recorders."""

    def __init__(self, probe, tmp_path, mechanism: str) -> None:
        """Start the node, record its output and start streaming the carrier."""
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.qos import qos_profile_sensor_data
        from sensor_msgs.msg import JointState

        from fishtail_msgs.msg import TailState

        self.probe = probe
        self.mechanism = mechanism
        argv = [sys.executable, "-m", "fishtail_kinematics.nodes.kinematics_node", "--ros-args",
                "-p", f"mechanism:={mechanism}", "-p", "markers_rate_hz:=0.0"]  # fmt: skip
        self.process = NodeProcess("kinematics", argv, tmp_path)
        self.states = probe.record(TailState, "tail/state")
        self.diagnostics = probe.record(DiagnosticArray, "/diagnostics", 50)
        node = probe.node
        carrier = node.create_publisher(JointState, "motor/joint_state", qos_profile_sensor_data)
        pivot = node.create_publisher(JointState, PIVOT_JOINT_STATE.name, qos_profile_sensor_data)
        start_ns = node.get_clock().now().nanoseconds
        #: The shift the actuator reports, published with every carrier sample (None: silent).
        self.shift: float | None = None

        def tick() -> None:
            now = node.get_clock().now()
            elapsed_s = (now.nanoseconds - start_ns) * 1e-9
            sample = JointState(
                name=["carrier_joint"], position=[SPEED_RAD_S * elapsed_s], velocity=[SPEED_RAD_S]
            )
            sample.header.stamp = now.to_msg()
            if self.shift is not None:
                reading = JointState(name=[PIVOT_JOINT], position=[self.shift], velocity=[0.0])
                reading.header.stamp = now.to_msg()
                pivot.publish(reading)
            carrier.publish(sample)

        self.timer = node.create_timer(SAMPLE_PERIOD_S, tick)

    def wait(self, predicate, what: str) -> None:
        """Spin until ``predicate()``; fails at once, with the node's output, if it exits."""

        def check() -> object:
            if self.process.returncode is not None:
                raise AssertionError(
                    f"the node exited waiting for {what}:\n{self.process.output()}"
                )
            return predicate()

        self.probe.spin_until(check, WAIT_S, what)

    def next_state(self, condition, what: str):
        """The first tail/state from now on that meets ``condition``."""
        start = len(self.states)
        found = []

        def arrived() -> bool:
            found[:] = [m for m in self.states[start:] if condition(m)]
            return bool(found)

        self.wait(arrived, what)
        return found[0]

    def kinematics_status(self, condition, what: str):
        """The first status of the node from now on that meets ``condition``."""
        start = len(self.diagnostics)
        found = []

        def arrived() -> bool:
            found[:] = [
                status
                for array in self.diagnostics[start:]
                for status in array.status
                if status.name.startswith("/kinematics") and condition(status)
            ]
            return bool(found)

        self.wait(arrived, what)
        return found[0]


def values(status) -> dict[str, str]:
    return {pair.key: pair.value for pair in status.values}


def level(status) -> int:
    return status.level[0] if isinstance(status.level, bytes) else int(status.level)


def assert_state_is_the_engines(state, tail) -> None:
    """The published state is the engine's (the node's float path) for its carrier sample."""
    expected = tail.solve(state.motor_angle, state.motor_velocity)
    assert state.pivot_shift == tail.pivot_shift_m
    assert state.swing_bias == tail.swing_bias_rad
    for name in ("theta3", "fin_angle", "theta2"):
        assert getattr(state, name) == pytest.approx(getattr(expected, name), abs=1e-12), name
    assert state.tip.x == pytest.approx(expected.tip_x, abs=1e-12)
    assert state.tip.y == pytest.approx(expected.tip_y, abs=1e-12)


@pytest.fixture
def suite(ros, tmp_path, request):
    running = Suite(ros, tmp_path, request.param)
    try:
        running.wait(
            lambda: running.probe.node.count_subscribers(PIVOT_JOINT_STATE.name) >= 1,
            "the node's pivot/joint_state subscription",
        )
        yield running
    finally:
        running.timer.cancel()
        running.process.stop()


@pytest.mark.parametrize("suite", ["oscillatory", "undulatory"], indirect=True)
def test_the_node_solves_with_the_latest_pivot_shift_and_keeps_the_last_good_one(suite):
    oscillatory = suite.mechanism == "oscillatory"
    design = make_tail(OscillatoryGeometry() if oscillatory else UndulatoryGeometry())
    last = "theta3" if oscillatory else "theta5"

    # No pivot message: the design's tail, the fin along the last link's joint angle.
    state = suite.next_state(lambda m: True, "a first tail/state")
    assert state.pivot_shift == 0.0 and state.swing_bias == 0.0
    assert state.fin_angle == getattr(state, last)
    assert_state_is_the_engines(state, design)

    # The actuator moves S 30 mm towards the tail: the bias and the fin angle follow the engine.
    suite.shift = 0.03
    shifted = design.with_pivot_shift(0.03)
    state = suite.next_state(lambda m: m.pivot_shift == 0.03, "a tail/state with the shift")
    assert_state_is_the_engines(state, shifted)
    assert state.swing_bias == pytest.approx(math.radians(1.639), abs=math.radians(0.001))
    if oscillatory:
        assert state.fin_angle == pytest.approx(state.theta3 + state.swing_bias, abs=1e-12)
    else:
        assert state.fin_angle == state.theta5

    # A shift the linkage cannot take, then a NaN: refused on /diagnostics, and the node solves
    # on with the last good tail.
    for bad, reason in ((INFEASIBLE_M, "feasible range"), (math.nan, "finite")):
        suite.shift = bad
        status = suite.kinematics_status(
            lambda s: "pivot/joint_state refused" in s.message, f"the refusal of {bad} m"
        )
        assert reason in status.message
        assert level(status) == 1  # WARN
        assert int(values(status)["pivot_refused"]) >= 1
        assert values(status)["pivot_shift_m"] == "0.03"
        later = suite.next_state(lambda m: True, f"a tail/state after refusing {bad} m")
        assert_state_is_the_engines(later, shifted)

    # A geometry that assembles with S unshifted but not where the actuator holds it: refused.
    from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
    from rcl_interfaces.srv import SetParameters

    value = ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=0.3)
    request = SetParameters.Request(parameters=[Parameter(name="pivot_offset_m", value=value)])
    (result,) = suite.probe.call(SetParameters, "/kinematics/set_parameters", request).results
    assert not result.successful and "pivot shift 0.030000 m" in result.reason
    make_tail(dataclasses.replace(design.geometry, pivot_offset_m=0.3))  # unshifted, it would

    # Back to the design: exactly what the unshifted engine gives.
    suite.shift = 0.0
    state = suite.next_state(lambda m: m.pivot_shift == 0.0, "a tail/state with S back")
    assert state.swing_bias == 0.0 and state.fin_angle == getattr(state, last)
    assert_state_is_the_engines(state, design)
    status = suite.kinematics_status(
        lambda s: "refused" not in s.message, "a status without a refusal"
    )
    assert values(status)["pivot_shift_m"] == "0.0"
    assert suite.process.returncode is None
