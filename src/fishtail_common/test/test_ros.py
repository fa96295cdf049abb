import threading

import pytest
import rclpy
from rclpy.context import Context
from rclpy.signals import SignalHandlerOptions

from fishtail_common.interface import (
    DIAGNOSTICS,
    MOTOR_JOINT_STATE,
    TAIL_SYMMETRY,
    Level,
    Status,
)
from fishtail_common.parameters import ParameterSpec, ParameterValueError
from fishtail_common.ros import (
    declare,
    descriptor,
    diagnostic_array,
    publisher_qos,
    spin_until,
    subscriber_qos,
)

RATE = ParameterSpec("publish_rate_hz", 200.0, "rate", "Hz", 1.0, 1000.0, read_only=True)
COUNTS = ParameterSpec("counts", 2048, "counts per turn", minimum=1)
BACKEND = ParameterSpec("backend", "sim", "motor backend", choices=("sim", "serial"))


def test_descriptor_carries_text_range_and_read_only():
    rate = descriptor(RATE)
    assert rate.description == "rate [Hz]" and rate.read_only
    assert (rate.floating_point_range[0].from_value, rate.floating_point_range[0].to_value) == (
        1.0,
        1000.0,
    )
    counts = descriptor(COUNTS)
    assert counts.integer_range[0].from_value == 1
    assert not counts.floating_point_range
    assert descriptor(BACKEND).additional_constraints == "one of: sim, serial"


def test_qos_profiles_follow_the_kinds():
    """State is offered reliable (REP 2003) and taken best effort; the rest alike both ways."""
    from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

    assert publisher_qos(MOTOR_JOINT_STATE).reliability == ReliabilityPolicy.RELIABLE
    assert publisher_qos(MOTOR_JOINT_STATE).durability == DurabilityPolicy.VOLATILE
    assert subscriber_qos(MOTOR_JOINT_STATE).reliability == ReliabilityPolicy.BEST_EFFORT
    for topic in (DIAGNOSTICS, TAIL_SYMMETRY):
        assert publisher_qos(topic) == subscriber_qos(topic)
    assert publisher_qos(DIAGNOSTICS).reliability == ReliabilityPolicy.RELIABLE
    assert publisher_qos(TAIL_SYMMETRY).durability == DurabilityPolicy.TRANSIENT_LOCAL


@pytest.fixture
def context():
    context = Context()
    rclpy.init(context=context, signal_handler_options=SignalHandlerOptions.NO, domain_id=0)
    yield context
    context.try_shutdown()


def make_node(context, name: str, overrides: dict):
    from rclpy.parameter import Parameter

    return rclpy.create_node(
        name,
        context=context,
        parameter_overrides=[Parameter(key, value=value) for key, value in overrides.items()],
        start_parameter_services=False,
    )


def test_declare_returns_checked_values(context):
    node = make_node(context, "declare_ok", {"counts": 1920})
    try:
        assert declare(node, [RATE, COUNTS, BACKEND]) == {
            "publish_rate_hz": 200.0,
            "counts": 1920,
            "backend": "sim",
        }
    finally:
        node.destroy_node()


def test_declare_refuses_a_value_its_spec_refuses(context):
    node = make_node(context, "declare_bad", {"backend": "usb"})
    try:
        with pytest.raises(ParameterValueError, match="backend must be one of sim, serial"):
            declare(node, [BACKEND])
    finally:
        node.destroy_node()


def test_diagnostic_array_names_the_node_and_carries_the_values(context):
    node = make_node(context, "diag", {})
    try:
        array = diagnostic_array(
            node,
            Status("input", Level.OK, "fine"),
            Status("motor", Level.WARN, "slow", {"rate_hz": "12.0"}, "board"),
        )
        first, status = array.status
        assert (first.name, first.level, first.values) == ("/diag: input", bytes([0]), [])
        assert status.name == "/diag: motor"
        assert status.level == bytes([1])
        assert (status.message, status.hardware_id) == ("slow", "board")
        assert [(kv.key, kv.value) for kv in status.values] == [("rate_hz", "12.0")]
        assert array.header.stamp.sec > 0
    finally:
        node.destroy_node()


def test_spin_until_returns_when_the_event_is_set(context):
    node = make_node(context, "spinner", {})
    stop = threading.Event()
    ticks: list[int] = []

    def tick() -> None:
        ticks.append(1)
        if len(ticks) == 3:
            stop.set()

    node.create_timer(0.01, tick)
    try:
        spin_until([node], stop, period_s=0.01)
        assert len(ticks) >= 3
    finally:
        node.destroy_node()
