"""Pieces every fishtail node of this package needs: parameter descriptors, signals, diagnostics."""

from __future__ import annotations

import signal
import sys
import threading

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import FloatingPointRange, ParameterDescriptor
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from fishtail_kinematics.engine.parameters import (
    GEOMETRY_PARAMETERS,
    MECHANISM_PARAMETER,
    MECHANISMS,
)

#: diagnostic_msgs/DiagnosticStatus.STALE, as a plain int for diagnostic_array().
LEVEL_STALE = 3


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


def diagnostic_status(
    node: Node, name: str, level: int, message: str, values: dict[str, str], hardware_id: str = ""
) -> DiagnosticStatus:
    """A DiagnosticStatus named ``<node's full name>: <name>``."""
    return DiagnosticStatus(
        level=bytes([level]),
        name=f"{node.get_fully_qualified_name()}: {name}",
        message=message,
        hardware_id=hardware_id,
        values=[KeyValue(key=key, value=value) for key, value in values.items()],
    )


def diagnostic_array(
    node: Node, name: str, level: int, message: str, values: dict[str, str], hardware_id: str = ""
) -> DiagnosticArray:
    """One-status DiagnosticArray stamped now."""
    return diagnostic_array_of(
        node, [diagnostic_status(node, name, level, message, values, hardware_id)]
    )


def diagnostic_array_of(node: Node, statuses: list[DiagnosticStatus]) -> DiagnosticArray:
    """DiagnosticArray of ``statuses`` stamped now."""
    array = DiagnosticArray(status=statuses)
    array.header.stamp = node.get_clock().now().to_msg()
    return array


def run_node(node_class, label: str, startup_errors: tuple[type[Exception], ...]) -> int:
    """Create ``node_class``, spin it until SIGINT/SIGTERM and shut down; the nodes' ``main``.

    A node that cannot start because of bad parameters (``startup_errors``) prints one line and
    returns 2 instead of a traceback.
    """
    stop = install_stop_handlers()
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = node_class()
    except (*startup_errors, rclpy.exceptions.ParameterException) as error:
        print(f"{label}: error: {error}", file=sys.stderr)
        rclpy.try_shutdown()
        return 2
    try:
        spin_until_signal(node, stop)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


def install_stop_handlers() -> threading.Event:
    """An event set by SIGINT or SIGTERM; installed before anything slow, so no signal is missed."""
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    return stop


def spin_until_signal(node: Node, stop: threading.Event) -> None:
    """Spin ``node`` on an EventsExecutor until ``stop`` is set, then return."""
    from rclpy.experimental import EventsExecutor

    executor = EventsExecutor()
    executor.add_node(node)
    try:
        while not stop.is_set() and rclpy.ok():
            executor.spin_once(timeout_sec=0.1)
    finally:
        executor.remove_node(node)
        executor.shutdown()
