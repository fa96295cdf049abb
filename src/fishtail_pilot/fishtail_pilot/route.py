"""Waypoints flown in turn: the route ``fishtail-run --goal`` and ``--square`` send the pilot.

Plain Python (no rclpy), so that the console's node and the closed loop without ROS follow a
route by the same rule: the next waypoint becomes the goal once the fish is within the tolerance
of the current one (when the pilot, with the same tolerance, reports it reached), or once it has
passed a waypoint that is not the last close by, as a waypoint follower does at a corner it
cannot turn onto: coming back to it would take a loop (docs/steering.md, "The square").
"""

from __future__ import annotations

import math

#: A waypoint before the last counts as passed within this distance [m]: the fish is past the
#: line through it across its leg and this close to it: the default fish's tightest turning
#: radius (1.0 m, mechanism 1), inside which turning back to a corner takes a loop.
PASS_WITHIN_M = 1.0


class GoalRoute:
    """Waypoints visited in turn: the current one until the fish reaches or passes it.

    >>> route = GoalRoute([(1.0, 0.0), (1.0, 1.0), (0.0, 1.0)], tolerance_m=0.2)
    >>> route.current
    (1.0, 0.0)
    >>> route.update((0.9, 0.05)), route.current
    ('reached', (1.0, 1.0))
    >>> route.update((1.3, 1.2)), route.current
    ('passed', (0.0, 1.0))
    >>> route.update((0.0, 0.9)), route.current, route.finished
    ('reached', None, True)
    """

    def __init__(
        self,
        waypoints: list[tuple[float, float]],
        tolerance_m: float,
        pass_within_m: float = PASS_WITHIN_M,
    ) -> None:
        """Start at the first waypoint; its leg starts where the fish is first seen."""
        self.waypoints = list(waypoints)
        self.tolerance_m = tolerance_m
        self.pass_within_m = pass_within_m
        self.index = 0
        self._leg_start: tuple[float, float] | None = None

    @property
    def current(self) -> tuple[float, float] | None:
        """The waypoint being swum to (None when all are reached)."""
        return self.waypoints[self.index] if self.index < len(self.waypoints) else None

    @property
    def finished(self) -> bool:
        """Every waypoint reached."""
        return self.index >= len(self.waypoints)

    def update(self, position_m: tuple[float, float]) -> str | None:
        """Move on if the current waypoint is reached or passed: ``"reached"``, ``"passed"``.

        None: still swimming to it (an unknown, NaN, position reaches and passes nothing).
        """
        goal = self.current
        if goal is None:
            return None
        if self._leg_start is None and all(map(math.isfinite, position_m)):
            self._leg_start = (float(position_m[0]), float(position_m[1]))
        gap_x, gap_y = position_m[0] - goal[0], position_m[1] - goal[1]
        distance = math.hypot(gap_x, gap_y)
        # Written as "within" so that NaN is neither reached nor passed.
        if distance <= self.tolerance_m:
            return self._next(goal, "reached")
        if self.index + 1 < len(self.waypoints) and distance <= self.pass_within_m:
            start = self._leg_start
            assert start is not None  # a finite distance comes from a finite position
            leg_x, leg_y = goal[0] - start[0], goal[1] - start[1]
            if gap_x * leg_x + gap_y * leg_y > 0.0:
                return self._next(goal, "passed")
        return None

    def _next(self, goal: tuple[float, float], how: str) -> str:
        self.index += 1
        self._leg_start = goal
        return how


def square_route(side_m: float) -> list[tuple[float, float]]:
    """A square's corners, side ``side_m``, anticlockwise from the start (0, 0) and back to it.

    >>> square_route(2.0)
    [(2.0, 0.0), (2.0, 2.0), (0.0, 2.0), (0.0, 0.0)]
    """
    return [(side_m, 0.0), (side_m, side_m), (0.0, side_m), (0.0, 0.0)]
