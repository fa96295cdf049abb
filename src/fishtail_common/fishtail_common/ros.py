"""The rclpy side that every fishtail node shares.

QoS profiles, parameter declarations, diagnostics, publishers that know whether anyone listens,
and the runtime that starts a process's nodes (one, or several on one executor), spins them and
stops them on SIGINT or SIGTERM.
"""

from __future__ import annotations

import copy
import dataclasses
import signal
import sys
import threading
import traceback
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.node import Node
from rclpy.publisher import Publisher
from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
from rclpy.qos_overriding_options import QoSOverridingOptions
from rclpy.signals import SignalHandlerOptions

from fishtail_common.interface import QosKind, Status, Topic
from fishtail_common.parameters import ParameterSpec, ParameterValue

_RELIABLE = QoSProfile(depth=10)
_LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
_PUBLISHER_PROFILES = {
    QosKind.STATE: _RELIABLE,
    QosKind.RELIABLE: _RELIABLE,
    QosKind.LATCHED: _LATCHED,
}
_SUBSCRIBER_PROFILES = {
    QosKind.STATE: qos_profile_sensor_data,
    QosKind.RELIABLE: _RELIABLE,
    QosKind.LATCHED: _LATCHED,
}


def suite_publisher(node: Node, message_type: type[Any], topic: Topic) -> Publisher:
    """A publisher of ``topic`` with its QoS, which ``qos_overrides`` parameters may change.

    rclpy declares ``qos_overrides.<topic>.publisher.{history,depth,reliability}`` (read-only),
    so that a parameter file sets them as it does for rclcpp nodes (README, "QoS overrides").
    """
    return node.create_publisher(
        message_type,
        topic.name,
        publisher_qos(topic),
        qos_overriding_options=QoSOverridingOptions.with_default_policies(),
    )


def publisher_qos(topic: Topic) -> QoSProfile:
    """The QoS a publisher of one of the suite's topics offers (README, "Topics": why).

    A copy: rclpy's QoS overrides change the profile given to a publisher in place.
    """
    return copy.copy(_PUBLISHER_PROFILES[topic.qos])


def subscriber_qos(topic: Topic) -> QoSProfile:
    """The QoS the suite's own subscribers of one of its topics ask for (a copy)."""
    return copy.copy(_SUBSCRIBER_PROFILES[topic.qos])


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
    """A fishtail node: :func:`run_nodes` calls :meth:`before_exit` once it stops spinning."""

    def before_exit(self) -> None:
        """Leave the hardware safe (the driver stops the motor); nothing by default."""


@dataclasses.dataclass(frozen=True)
class NodeFactory:
    """How a process creates one of the suite's nodes.

    ``create`` takes :class:`rclpy.node.Node`'s keyword options (``cli_args`` ...); a node that
    cannot start because of its parameters raises a :class:`ValueError`, one of
    ``startup_errors`` or rclpy's ParameterException, and ``label`` names it in the error line.
    """

    create: Callable[..., SuiteNodeBase]
    label: str
    startup_errors: tuple[type[Exception], ...] = ()


def run_node(
    factory: Callable[[], SuiteNodeBase],
    label: str,
    startup_errors: tuple[type[Exception], ...] = (),
    args: list[str] | None = None,
) -> int:
    """A node's ``main``: create it, spin until SIGINT/SIGTERM, exit cleanly; the exit status.

    ``args`` are the process's command line (its ``--ros-args``); see :func:`run_nodes`.
    """
    return run_nodes([(NodeFactory(factory, label, startup_errors), {})], args)


def run_nodes(
    nodes: Sequence[tuple[NodeFactory, Mapping[str, Any]]], args: list[str] | None = None
) -> int:
    """Host ``nodes`` in this process on one executor until SIGINT/SIGTERM; the exit status.

    Each node is created with its own rclpy Node options (e.g. ``cli_args`` with its
    ``--params-file`` and ``-p``, which apply to that node alone); ``args`` are the process's
    global ROS arguments (``rclpy.init``). A node that cannot start because of bad parameters
    prints ``<label>: error: <reason>`` (no traceback) and the process returns 2, after the nodes
    already created have left their hardware safe: one node that cannot start stops them all.
    Once spinning ends every node's :meth:`SuiteNodeBase.before_exit` runs, even if another's
    raised; a failing one makes the status 1.
    """
    stop = install_stop_handlers()
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    created: list[tuple[NodeFactory, SuiteNodeBase]] = []
    status = 0
    try:
        for factory, options in nodes:
            refusals: tuple[type[Exception], ...] = (
                ValueError,
                *factory.startup_errors,
                rclpy.exceptions.ParameterException,
            )
            try:
                created.append((factory, factory.create(**options)))
            except refusals as error:
                print(f"{factory.label}: error: {error}", file=sys.stderr)
                return 2
        spin_until([node for _, node in created], stop)
    finally:
        # In start-up order: the driver, first, stops the motor before the others wind down.
        for factory, node in created:
            try:
                node.before_exit()
            except Exception:  # the other nodes must still leave safely
                traceback.print_exc()
                print(f"{factory.label}: error: failed to exit cleanly", file=sys.stderr)
                status = 1
            node.destroy_node()
        rclpy.try_shutdown()
    return status


# ---- publishers


class ListenedPublisher:
    """A publisher that knows whether anyone subscribes, so that nobody's messages go unbuilt.

    :attr:`listened` asks the graph for the matched subscriptions (about 1 µs, against the
    10-20 µs of building and publishing a message nobody takes). Not through the publisher's
    matched events: with the EventsExecutor a publisher that has event callbacks can hang or crash
    when it is destroyed while the graph changes (ros2/rclpy#1644), which is exactly what
    happens when a suite stops. A transient-local topic is always listened: a late subscriber
    gets its latest message, so it must be built whether or not anyone subscribes now. A
    volatile topic's late subscriber gets the next message after it matched, as it would without
    the check.
    """

    def __init__(self, node: Node, message_type: type[Any], topic: Topic) -> None:
        """Create the publisher of ``topic`` on ``node`` (:func:`suite_publisher`)."""
        self.always = topic.qos is QosKind.LATCHED
        self.publisher = suite_publisher(node, message_type, topic)

    @property
    def subscribers(self) -> int:
        """The matched subscriptions now."""
        return int(self.publisher.get_subscription_count())

    @property
    def listened(self) -> bool:
        """Whether a message published now would reach anyone (or must be kept for later)."""
        return self.always or self.publisher.get_subscription_count() > 0

    def publish(self, message: Any) -> None:
        """Publish ``message`` (whether or not anyone listens)."""
        self.publisher.publish(message)

    def get_subscription_count(self) -> int:
        """The matched subscriptions, under rclpy's publisher's name for it."""
        return self.publisher.get_subscription_count()
