"""Waypoints flown in turn: the route ``fishtail-run --goal`` and ``--square`` send the pilot.

Plain Python (no rclpy), so that the console's node and the closed loop without ROS follow a
route by the same rule: the next waypoint becomes the goal once the fish is within the tolerance
of the current one, which is when the pilot, with the same tolerance, reports it reached.
"""

from __future__ import annotations

import math


class GoalRoute:
    """Waypoints visited in turn: the current one until the fish is within the tolerance of it.

    >>> route = GoalRoute([(1.0, 0.0), (1.0, 1.0)], tolerance_m=0.2)
    >>> route.current
    (1.0, 0.0)
    >>> route.update((0.9, 0.05)), route.current
    (True, (1.0, 1.0))
    >>> route.update((1.0, 0.9)), route.current, route.finished
    (True, None, True)
    """

    def __init__(self, waypoints: list[tuple[float, float]], tolerance_m: float) -> None:
        """Start at the first waypoint."""
        self.waypoints = list(waypoints)
        self.tolerance_m = tolerance_m
        self.index = 0

    @property
    def current(self) -> tuple[float, float] | None:
        """The waypoint being swum to (None when all are reached)."""
        return self.waypoints[self.index] if self.index < len(self.waypoints) else None

    @property
    def finished(self) -> bool:
        """Every waypoint reached."""
        return self.index >= len(self.waypoints)

    def update(self, position_m: tuple[float, float]) -> bool:
        """Move to the next waypoint if the current one is reached; whether it moved."""
        goal = self.current
        if goal is None:
            return False
        # Written as "not within" so that an unknown (NaN) position reaches nothing.
        if not math.hypot(goal[0] - position_m[0], goal[1] - position_m[1]) <= self.tolerance_m:
            return False
        self.index += 1
        return True


def square_route(side_m: float) -> list[tuple[float, float]]:
    """A square's corners, side ``side_m``, anticlockwise from the start (0, 0) and back to it.

    >>> square_route(2.0)
    [(2.0, 0.0), (2.0, 2.0), (0.0, 2.0), (0.0, 0.0)]
    """
    return [(side_m, 0.0), (side_m, side_m), (0.0, side_m), (0.0, 0.0)]
