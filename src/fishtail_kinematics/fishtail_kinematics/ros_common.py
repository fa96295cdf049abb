"""Pieces every fishtail node of this package needs: parameter descriptors, signals, diagnostics."""

from __future__ import annotations

import signal
import threading

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor
from rclpy.node import Node

from fishtail_kinematics.parameters import GEOMETRY_PARAMETERS, MECHANISM_PARAMETER, MECHANISMS


def float_descriptor(
    text: str, low: float, high: float, read_only: bool = False
) -> ParameterDescriptor:
    """A float parameter descriptor with an inclusive range."""
    return ParameterDescriptor(
        description=text,
        floating_point_range=[FloatingPointRange(from_value=low, to_value=high)],
        read_only=read_only,
    )


def declare_geometry_parameters(node: Node) -> None:
    """Declare the mechanism and every geometry parameter with its range and description."""
    node.declare_parameter(
        MECHANISM_PARAMETER,
        MECHANISMS[0],
        ParameterDescriptor(description="tail mechanism: " + " or ".join(MECHANISMS)),
    )
    for spec in GEOMETRY_PARAMETERS:
        node.declare_parameter(
            spec.name,
            spec.default,
            float_descriptor(
                f"{spec.symbol} [{spec.unit}]: {spec.description}", spec.minimum, spec.maximum
            ),
        )


def geometry_parameter_values(node: Node) -> dict[str, object]:
    """Current values of the geometry parameters of ``node``."""
    names = [MECHANISM_PARAMETER, *(spec.name for spec in GEOMETRY_PARAMETERS)]
    return {name: node.get_parameter(name).value for name in names}


def diagnostic_array(
    node: Node, name: str, level: int, message: str, values: dict[str, str], hardware_id: str = ""
) -> DiagnosticArray:
    """One-status DiagnosticArray stamped now."""
    status = DiagnosticStatus(
        level=bytes([level]),
        name=f"{node.get_fully_qualified_name()}: {name}",
        message=message,
        hardware_id=hardware_id,
        values=[KeyValue(key=key, value=value) for key, value in values.items()],
    )
    array = DiagnosticArray(status=[status])
    array.header.stamp = node.get_clock().now().to_msg()
    return array


def spin_until_signal(node: Node) -> None:
    """Spin ``node`` on an EventsExecutor until SIGINT or SIGTERM, then return."""
    from rclpy.experimental import EventsExecutor

    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    executor = EventsExecutor()
    executor.add_node(node)
    try:
        while not stop.is_set() and rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
    finally:
        executor.remove_node(node)
        executor.shutdown()
