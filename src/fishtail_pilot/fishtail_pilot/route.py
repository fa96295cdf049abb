"""Waypoints flown in turn: the route ``fishtail-run --goal`` and ``--square`` send the pilot.

Plain Python (no rclpy), so that the console's node and the closed loop without ROS follow a
route by the same rule: the next waypoint becomes the goal once the fish is within the tolerance
of the current one (when the pilot, with the same tolerance, reports it reached), or, for a
waypoint before the last, once it is inside a circle of acceptance round it as wide as the fish's
tightest turn: from there it turns onto the next leg instead of overshooting the corner and
looping back to it (docs/steering.md, "The square").
"""

from __future__ import annotations

import math

#: The circle of acceptance round a waypoint before the last [m]: the default fish's tightest
#: turning radius (1.0 m, mechanism 1). A fish that turns for the next waypoint this far out
#: rounds the corner on its tightest circle; one that holds on to the corner overshoots it by
#: that circle and the next corner can fall inside it.
ACCEPTANCE_RADIUS_M = 1.0


class GoalRoute:
    """Waypoints visited in turn: the current one until the fish reaches or rounds it.

    >>> route = GoalRoute([(2.0, 0.0), (2.0, 2.0), (0.0, 2.0)], tolerance_m=0.2)
    >>> route.current
    (2.0, 0.0)
    >>> route.update((1.5, 0.0)), route.current
    ('rounded', (2.0, 2.0))
    >>> route.update((2.1, 1.9)), route.current
    ('reached', (0.0, 2.0))
    >>> route.update((0.5, 2.0)), route.finished
    (None, False)
    >>> route.update((0.1, 2.1)), route.current, route.finished
    ('reached', None, True)
    """

    def __init__(
        self,
        waypoints: list[tuple[float, float]],
        tolerance_m: float,
        acceptance_radius_m: float = ACCEPTANCE_RADIUS_M,
    ) -> None:
        """The waypoints, the tolerance that reaches them, and the circle that rounds a corner."""
        self.waypoints = list(waypoints)
        self.tolerance_m = tolerance_m
        self.acceptance_radius_m = acceptance_radius_m
        self.index = 0

    @property
    def current(self) -> tuple[float, float] | None:
        """The waypoint being swum to (None when all are reached)."""
        return self.waypoints[self.index] if self.index < len(self.waypoints) else None

    @property
    def finished(self) -> bool:
        """Every waypoint reached."""
        return self.index >= len(self.waypoints)

    def update(self, position_m: tuple[float, float]) -> str | None:
        """Move on if the current waypoint is reached or rounded: ``"reached"``, ``"rounded"``.

        None: still swimming to it (an unknown, NaN, position reaches and rounds nothing).
        """
        goal = self.current
        if goal is None:
            return None
        distance = math.hypot(position_m[0] - goal[0], position_m[1] - goal[1])
        # Written as "within" so that NaN is neither reached nor rounded.
        if distance <= self.tolerance_m:
            return self._next("reached")
        if self.index + 1 < len(self.waypoints) and distance <= self.acceptance_radius_m:
            return self._next("rounded")
        return None

    def _next(self, how: str) -> str:
        self.index += 1
        return how


def square_route(side_m: float) -> list[tuple[float, float]]:
    """A square's corners, side ``side_m``, anticlockwise from the start (0, 0) and back to it.

    >>> square_route(2.0)
    [(2.0, 0.0), (2.0, 2.0), (0.0, 2.0), (0.0, 0.0)]
    """
    return [(side_m, 0.0), (side_m, side_m), (0.0, side_m), (0.0, 0.0)]
