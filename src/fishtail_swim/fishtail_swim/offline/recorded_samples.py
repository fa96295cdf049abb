"""The samples a recorded run's messages give, for :mod:`fishtail_swim.offline.recorded_run`.

:class:`TopicSamples` takes the window's fish/odom, tail/state, motor/joint_state and
pivot/joint_state messages into brackets of the frames
(:class:`~fishtail_swim.offline.frame_sampling.Brackets`) and C's path; :func:`read_goals` takes
the distinct goals of goal_pose. Each sample sits at its header stamp on the run's clock
(:class:`RunClock`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from fishtail_common.bag_reading import BagFile, stamp_ns, yaw_of_quaternion
from fishtail_common.interface import CARRIER_JOINT, MECHANISM_CODES, PIVOT_JOINT
from fishtail_plant.fish.fish import FloatArray
from fishtail_swim.offline.frame_sampling import Brackets, DecimatedPath

#: Distinct goals kept; later ones are ignored with a note.
MAX_GOALS = 1000
#: Goals closer than this to the previous one are the same goal sent again.
SAME_GOAL_M = 1e-6

MECHANISM_OF_CODE = {code: name for name, code in MECHANISM_CODES.items()}
_ODOM_COLUMNS = ("x", "y", "psi", "u", "v")


@dataclasses.dataclass(frozen=True)
class RunClock:
    """t = 0 at the first fish/odom stamp; that sample's receive time maps stamps to the bag's."""

    origin_ns: int  # the first fish/odom stamp
    first_receive_ns: int  # its receive time

    @property
    def receive_offset_ns(self) -> int:
        """Receive time minus stamp of the first fish/odom sample."""
        return self.first_receive_ns - self.origin_ns

    def seconds(self, stamp: int) -> float:
        """A stamp (ns) as seconds of the run."""
        return (stamp - self.origin_ns) * 1e-9


class TopicSamples:
    """What the messages leave: each topic's brackets, C's path, tail/state's mechanisms."""

    def __init__(
        self, frame_time_s: FloatArray, path: DecimatedPath, pivot_from_state: bool
    ) -> None:
        """Empty brackets at ``frame_time_s``; ``pivot_from_state``: no pivot/joint_state."""
        self.odometry = Brackets(frame_time_s, len(_ODOM_COLUMNS))
        self.carrier = Brackets(frame_time_s, 2)
        self.pivot = Brackets(frame_time_s, 1)
        self.path = path
        self.pivot_from_state = pivot_from_state
        self.mechanisms: dict[int, int] = {}
        self.no_carrier_joint = 0

    def add_odometry(self, t: float, message: Any) -> None:
        """A fish/odom sample: the pose, the body-frame velocity, and C's path."""
        pose = message.pose.pose
        q = pose.orientation
        twist = message.twist.twist.linear
        x, y = float(pose.position.x), float(pose.position.y)
        psi = yaw_of_quaternion(float(q.x), float(q.y), float(q.z), float(q.w))
        if t > self.odometry.last_t:
            self.path.add(t, x, y)
        self.odometry.add(t, (x, y, psi, float(twist.x), float(twist.y)))

    def add_state(self, t: float, message: Any) -> None:
        """A tail/state sample: the carrier, the mechanism, the pivot shift if none is recorded."""
        self.carrier.add(t, (float(message.motor_angle), float(message.motor_velocity)))
        code = int(message.mechanism)
        self.mechanisms[code] = self.mechanisms.get(code, 0) + 1
        if self.pivot_from_state and hasattr(message, "pivot_shift"):
            self.pivot.add(t, (float(message.pivot_shift),))

    def add_joint(self, t: float, message: Any) -> None:
        """A motor/joint_state sample: the carrier joint's angle and speed."""
        sample = joint_sample(message, CARRIER_JOINT)
        if sample is None:
            self.no_carrier_joint += 1
        else:
            self.carrier.add(t, sample)

    def add_pivot(self, t: float, message: Any) -> None:
        """A pivot/joint_state sample: the pivot shift."""
        sample = joint_sample(message, PIVOT_JOINT)
        if sample is not None:
            self.pivot.add(t, sample[:1])

    def finish(self) -> None:
        """After the last message: the brackets of the frames after every topic's last sample."""
        for brackets in (self.odometry, self.carrier, self.pivot):
            brackets.finish()

    def notes(self, joint_topic: str | None) -> list[str]:
        """What was ignored, for the user."""
        notes = []
        if self.no_carrier_joint:
            notes.append(
                f"{self.no_carrier_joint} {joint_topic} messages without {CARRIER_JOINT} ignored"
            )
        for name, brackets in (
            ("fish/odom", self.odometry), ("carrier", self.carrier), ("pivot", self.pivot)
        ):  # fmt: skip
            if brackets.dropped:
                notes.append(f"{brackets.dropped} {name} samples repeated or out of order ignored")
        return notes

    def mechanism(self) -> str | None:
        """The mechanism tail/state names most often, None without tail/state."""
        if not self.mechanisms:
            return None
        code = max(self.mechanisms, key=lambda c: self.mechanisms[c])
        return MECHANISM_OF_CODE.get(code)


def _joint_index(names: Sequence[str], joint: str) -> int | None:
    names = list(names)
    if joint in names:
        return names.index(joint)
    return 0 if len(names) == 1 else None


def joint_sample(message: Any, joint: str) -> tuple[float, float] | None:
    """(position, velocity) of ``joint`` in a JointState (the only joint if it is not named)."""
    index = _joint_index(message.name, joint)
    if index is None or index >= len(message.position):
        return None
    velocity = float(message.velocity[index]) if index < len(message.velocity) else 0.0
    return float(message.position[index]), velocity if math.isfinite(velocity) else 0.0


def read_goals(
    bag: BagFile, topic: str | None, clock: RunClock
) -> tuple[FloatArray, FloatArray, list[str]]:
    """Each distinct goal (a goal sent again is one) and when it was first sent, whole bag."""
    times: list[float] = []
    goals: list[tuple[float, float]] = []
    notes: list[str] = []
    ignored = 0
    if topic is not None:
        for _, receive_ns, message in bag.messages(bag.connections_of(topic)):
            stamp = stamp_ns(message)
            stamp = stamp if stamp else receive_ns - clock.receive_offset_ns
            position = message.pose.position
            goal = (float(position.x), float(position.y))
            if not all(math.isfinite(v) for v in goal):
                continue
            if goals and math.dist(goal, goals[-1]) <= SAME_GOAL_M:
                continue
            if len(goals) >= MAX_GOALS:
                ignored += 1
                continue
            times.append(clock.seconds(stamp))
            goals.append(goal)
    if ignored:
        notes.append(f"more than {MAX_GOALS} goals: {ignored} later ones not drawn")
    order = np.argsort(np.asarray(times), kind="stable")
    return (
        np.asarray(times, dtype=np.float64)[order],
        np.asarray(goals, dtype=np.float64).reshape(-1, 2)[order],
        notes,
    )
