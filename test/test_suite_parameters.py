"""Geometry parameters of the kinematics node: infeasible sets are refused with the engine's reason.

At run time through /kinematics/set_parameters (the old geometry stays in force, checked on the
published θ3), and at start-up from a parameter file (exit status 2, one line on stderr).
"""

from __future__ import annotations

import time

import pytest
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from rcl_interfaces.srv import GetParameters, SetParameters
from sensor_msgs.msg import JointState

from fishtail_common.parameter_files import load_parameter_file
from fishtail_kinematics.engine.errors import FishtailKinematicsError
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_msgs.msg import TailState

TOLERANCE = 1e-12
INFEASIBLE = {"pivot_offset_m": 0.05}  # |RS - PR| = 0.134 m is not less than OS
FEASIBLE = {"phase_rad": 0.3}


def engine_reason(values: dict) -> str:
    """The engine's refusal of ``values``; fails the test if the engine accepts them."""
    with pytest.raises(FishtailKinematicsError) as error:
        make_tail(geometry_from_parameters(values))
    return str(error.value)


def double_parameter(name: str, value: float) -> Parameter:
    """An rcl_interfaces Parameter of type double."""
    return Parameter(
        name=name, value=ParameterValue(type=ParameterType.PARAMETER_DOUBLE, double_value=value)
    )


def set_parameters(ros, changes: dict[str, float]):
    """Call /kinematics/set_parameters; the list of SetParametersResult."""
    request = SetParameters.Request(
        parameters=[double_parameter(name, value) for name, value in changes.items()]
    )
    return ros.call(SetParameters, "/kinematics/set_parameters", request).results


def pose_errors(ros, motor, state, tail, after_ns: int) -> tuple[int, float]:
    """(samples compared, largest |θ3 - engine θ3|) over the samples stamped after ``after_ns``."""
    angles = {ros.stamp_ns(m): (m.position[0], m.velocity[0]) for m in motor.messages}
    compared, worst = 0, 0.0
    for message in state.messages:
        key = ros.stamp_ns(message)
        if key <= after_ns or key not in angles:
            continue
        angle, velocity = angles[key]
        expected = tail.solve(float(angle), float(velocity)).theta3
        worst = max(worst, abs(message.theta3 - expected))
        compared += 1
    return compared, worst


def wait_and_compare(ros, motor, state, tail, after_ns: int, count: int = 100) -> float:
    """Spin until ``count`` samples after ``after_ns`` are matched; the worst θ3 error."""
    ros.spin_until(
        lambda: pose_errors(ros, motor, state, tail, after_ns)[0] >= count,
        20.0,
        f"{count} tail/state samples matched to motor/joint_state",
    )
    return pose_errors(ros, motor, state, tail, after_ns)[1]


def test_infeasible_geometry_refused_at_run_time(start_node, ros, config_dir):
    """SetParameters with an infeasible OS is refused with the engine's reason; θ3 unchanged."""
    config_path = config_dir / "oscillatory.yaml"
    values = geometry_parameters_in(load_parameter_file(config_path))
    old_tail = make_tail(geometry_from_parameters(values))
    new_tail = make_tail(geometry_from_parameters({**values, **FEASIBLE}))
    reason = engine_reason({**values, **INFEASIBLE})

    start_node("driver", params={"publish_rate_hz": 200.0})
    start_node("kinematics", params_file=config_path)
    motor = ros.record(JointState, "motor/joint_state")
    state = ros.record(TailState, "tail/state")
    ros.wait_for_publishers("tail/state")
    ros.command_speed(8.0)
    assert wait_and_compare(ros, motor, state, old_tail, 0) <= TOLERANCE

    (result,) = set_parameters(ros, INFEASIBLE)
    refused_ns = time.time_ns()
    assert not result.successful
    assert result.reason == reason
    response = ros.call(
        GetParameters, "/kinematics/get_parameters", GetParameters.Request(names=["pivot_offset_m"])
    )
    assert response.values[0].double_value == values["pivot_offset_m"]
    worst = wait_and_compare(ros, motor, state, old_tail, refused_ns)
    assert worst <= TOLERANCE, f"θ3 left the old geometry after the refusal (off by {worst:.3g})"

    # The same path accepts a feasible change, and the published θ3 follows it: so the check
    # above would have seen a geometry that had changed.
    (result,) = set_parameters(ros, FEASIBLE)
    accepted_ns = time.time_ns()
    assert result.successful, result.reason
    worst = wait_and_compare(ros, motor, state, new_tail, accepted_ns)
    assert worst <= TOLERANCE, f"θ3 does not follow the accepted phase_rad (off by {worst:.3g})"


def test_infeasible_parameter_file_exits_with_status_2(start_node, params_file):
    """A kinematics node started with an infeasible geometry exits 2 with a one-line error."""
    path = params_file("oscillatory.yaml", **INFEASIBLE)
    reason = engine_reason(geometry_parameters_in(load_parameter_file(path)))
    process = start_node("kinematics", params_file=path)
    status = process.wait(timeout=20.0)
    assert status == 2, f"exit status {status}"
    lines = [line for line in process.stderr().splitlines() if line.strip()]
    assert lines == [f"kinematics: error: {reason}"]
    assert process.stdout().strip() == ""
