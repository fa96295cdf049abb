"""The rclpy side that every fishtail node shares.

QoS profiles, parameter declarations, diagnostics, and the runtime that starts a node, spins it
and stops it on SIGINT or SIGTERM.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Callable, Iterable

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
from rclpy.signals import SignalHandlerOptions

from fishtail_common.interface import QosKind, Status, Topic
from fishtail_common.parameters import ParameterSpec, ParameterValue

_PROFILES = {
    QosKind.SENSOR_DATA: qos_profile_sensor_data,
    QosKind.RELIABLE: QoSProfile(depth=10),
    QosKind.LATCHED: QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL),
}


def qos_profile(topic: Topic) -> QoSProfile:
    """The QoS profile of one of the suite's topics."""
    return _PROFILES[topic.qos]


# ---- parameters


def descriptor(spec: ParameterSpec) -> ParameterDescriptor:
    """The ROS descriptor of ``spec``: its text, its range (shown by ``ros2 param describe``)."""
    result = ParameterDescriptor(description=spec.text, read_only=spec.read_only)
    if spec.choices:
        result.additional_constraints = "one of: " + ", ".join(spec.choices)
    if isinstance(spec.default, float) and (spec.minimum is not None or spec.maximum is not None):
        low = spec.minimum if spec.minimum is not None else -sys.float_info.max
        high = spec.maximum if spec.maximum is not None else sys.float_info.max
        result.floating_point_range = [FloatingPointRange(from_value=low, to_value=high)]
    elif type(spec.default) is int and (spec.minimum is not None or spec.maximum is not None):
        low_int = int(spec.minimum) if spec.minimum is not None else -(2**63)
        high_int = int(spec.maximum) if spec.maximum is not None else 2**63 - 1
        result.integer_range = [IntegerRange(from_value=low_int, to_value=high_int, step=1)]
    return result


def declare(node: Node, specs: Iterable[ParameterSpec]) -> dict[str, ParameterValue]:
    """Declare every spec on ``node``; the values in force (file or command line), each checked.

    A value its spec refuses raises :class:`fishtail_common.parameters.ParameterValueError`: the
    node's start-up error (see :func:`run_node`).
    """
    values = {}
    for spec in specs:
        value = node.declare_parameter(spec.name, spec.default, descriptor(spec)).value
        values[spec.name] = spec.check(value)
    return values


# ---- diagnostics


def diagnostic_array(node: Node, *statuses: Status) -> DiagnosticArray:
    """A DiagnosticArray of ``statuses``, each named ``"<node's full name>: <name>"``, stamped now.

    Readers that keep a node's latest status per name see them all; put the one that matters most
    last for those that keep only the latest of a node.
    """
    prefix = node.get_fully_qualified_name()
    array = DiagnosticArray(
        status=[
            DiagnosticStatus(
                level=bytes([int(status.level)]),
                name=f"{prefix}: {status.name}",
                message=status.message,
                hardware_id=status.hardware_id,
                values=[KeyValue(key=key, value=value) for key, value in status.values.items()],
            )
            for status in statuses
        ]
    )
    array.header.stamp = node.get_clock().now().to_msg()
    return array


# ---- runtime


def install_stop_handlers() -> threading.Event:
    """An event set by SIGINT or SIGTERM; install it before anything slow, so no signal is lost."""
    stop = threading.Event()
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.set())
    return stop


def spin_until(nodes: Iterable[Node], stop: threading.Event, period_s: float = 0.1) -> None:
    """Spin ``nodes`` (all of one context) on an EventsExecutor until ``stop`` is set."""
    from rclpy.experimental import EventsExecutor

    added = list(nodes)
    context = added[0].context
    executor = EventsExecutor(context=context)
    for node in added:
        executor.add_node(node)
    try:
        while not stop.is_set() and context.ok():
            executor.spin_once(timeout_sec=period_s)
    finally:
        for node in added:
            executor.remove_node(node)
        executor.shutdown()


class SuiteNodeBase(Node):
    """A fishtail node: :func:`run_node` calls :meth:`before_exit` once it stops spinning."""

    def before_exit(self) -> None:
        """Leave the hardware safe (the driver stops the motor); nothing by default."""


def run_node(
    factory: Callable[[], SuiteNodeBase],
    label: str,
    startup_errors: tuple[type[Exception], ...] = (),
    args: list[str] | None = None,
) -> int:
    """A node's ``main``: create it, spin until SIGINT/SIGTERM, exit cleanly; the exit status.

    A node that cannot start because of bad parameters (a :class:`ValueError`, which
    :class:`~fishtail_common.parameters.ParameterValueError` is, one of ``startup_errors`` or
    rclpy's ParameterException) prints ``<label>: error: <reason>`` and returns 2, no traceback.
    """
    refusals: tuple[type[Exception], ...] = (
        ValueError,
        *startup_errors,
        rclpy.exceptions.ParameterException,
    )
    stop = install_stop_handlers()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    try:
        node = factory()
    except refusals as error:
        print(f"{label}: error: {error}", file=sys.stderr)
        rclpy.try_shutdown()
        return 2
    try:
        spin_until([node], stop)
    finally:
        node.before_exit()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
