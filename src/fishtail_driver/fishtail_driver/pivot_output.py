"""The pivot actuator's side of the driver node: its command, its joint state, its diagnostics.

``pivot_actuator`` chooses the output (:func:`make_pivot_output`): :class:`NoPivot` (no topics,
no status) or :class:`SimPivot`, the lead-screw model of :mod:`fishtail_plant.pivot_actuator`
behind ``pivot/cmd_position``, ``pivot/joint_state`` and a ``pivot`` status. The command
watchdog leaves the pivot where it is. Called on the node's one executor thread. Topics and
behaviour: docs/serial.md ("The pivot actuator").
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Protocol

from builtin_interfaces.msg import Time
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64

from fishtail_common.interface import (
    PIVOT_CMD_POSITION,
    PIVOT_JOINT,
    PIVOT_JOINT_STATE,
    Level,
    Status,
)
from fishtail_common.ros import ListenedPublisher, SuiteNodeBase, subscriber_qos
from fishtail_driver.parameters import NO_PIVOT, ParameterValues, pivot_limits
from fishtail_driver.stamping import IncreasingStamps
from fishtail_plant.pivot_actuator import PivotActuator, PivotCommandOutcome, PivotLimits

#: The node's stamping: the ROS stamp of a monotonic time for one stream, or None when it would
#: not be after that stream's previous stamp.
Stamper = Callable[[float, IncreasingStamps], Time | None]


class PivotOutput(Protocol):
    """What the driver node does with its pivot actuator."""

    def publish(self, monotonic_s: float) -> None:
        """At a publish tick: the actuator's state at ``monotonic_s``, to whoever listens."""

    def statuses(self) -> tuple[Status, ...]:
        """Its diagnostic statuses (none without an actuator)."""


class NoPivot:
    """``pivot_actuator: none``."""

    def publish(self, monotonic_s: float) -> None:
        """Nothing to publish."""

    def statuses(self) -> tuple[Status, ...]:
        """Nothing to report."""
        return ()


class SimPivot:
    """``pivot_actuator: sim``: the lead-screw model behind the pivot's topics."""

    def __init__(
        self,
        node: SuiteNodeBase,
        limits: PivotLimits,
        stamp: Stamper,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        """At rest at the design position (0 m); subscribe and advertise on ``node``."""
        self._node = node
        self._stamp = stamp
        self._clock = clock
        self.actuator = PivotActuator(limits, 0.0, clock())
        self.stamps = IncreasingStamps()
        self.commands = 0
        self.refused_commands = 0
        self.clipped_commands = 0
        #: Why the latest command was clipped or refused ("" when it was carried out as asked).
        self.note = ""
        self.message = JointState()
        self.message.name = [PIVOT_JOINT]
        self.publisher = ListenedPublisher(node, JointState, PIVOT_JOINT_STATE)
        node.create_subscription(
            Float64, PIVOT_CMD_POSITION.name, self._on_command, subscriber_qos(PIVOT_CMD_POSITION)
        )

    def _on_command(self, message: Float64) -> None:
        self.record(self.actuator.command(message.data, self._clock()))

    def record(self, outcome: PivotCommandOutcome) -> None:
        """Count a command's outcome; log and keep the reason of a clip or refusal."""
        self.commands += 1
        self.refused_commands += not outcome.accepted
        self.clipped_commands += outcome.clipped
        self.note = outcome.reason
        if outcome.reason:
            self._node.get_logger().warning(outcome.reason, throttle_duration_sec=1.0)

    def publish(self, monotonic_s: float) -> None:
        """The state at ``monotonic_s``, stamped with that time (the model is exact at any time)."""
        if not self.publisher.listened:
            return
        stamp = self._stamp(monotonic_s, self.stamps)
        if stamp is None:
            return
        position, velocity = self.actuator.state(monotonic_s)
        message = self.message
        message.header.stamp = stamp
        message.position = [position]
        message.velocity = [velocity]
        self.publisher.publish(message)

    def statuses(self) -> tuple[Status, ...]:
        """One status: WARN while the latest command was clipped or refused."""
        limits = self.actuator.limits
        position, velocity = self.actuator.state(self._clock())
        values = {
            "pivot_actuator": "sim",
            "position_m": f"{position:.5f}",
            "velocity_m_s": f"{velocity:.5f}",
            "target_m": f"{self.actuator.target_m:.5f}",
            "stroke_m": f"{limits.stroke_m:g}",
            "speed_m_s": f"{limits.speed_m_s:g}",
            "commands": str(self.commands),
            "refused_commands": str(self.refused_commands),
            "clipped_commands": str(self.clipped_commands),
            "last_note": self.note,
        }
        if self.note:
            return (Status("pivot", Level.WARN, self.note, values, "sim"),)
        text = f"simulated pivot at {position:+.4f} m, heading for {self.actuator.target_m:+.4f} m"
        return (Status("pivot", Level.OK, text, values, "sim"),)


def make_pivot_output(node: SuiteNodeBase, values: ParameterValues, stamp: Stamper) -> PivotOutput:
    """The pivot output ``values["pivot_actuator"]`` names (checked by ``pivot_refusal``)."""
    if values["pivot_actuator"] == NO_PIVOT:
        return NoPivot()
    return SimPivot(node, pivot_limits(values), stamp)
