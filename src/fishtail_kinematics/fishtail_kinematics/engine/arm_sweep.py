"""Mechanism 2's second loop followed from the straight pose over SW's angle, as far as it goes.

A pivot shift turns SW's swing to angles the design never reached, so a shifted tail needs the
loop's branch, continuous with the straight pose, there. :class:`ArmSweep` follows it outwards in
small steps, once per design geometry and only as far as some shift has needed, and remembers
where it ends, so that later shifts cost a look-up and a polynomial fit. Why the loop depends on
SW's angle alone, and the ranges found: docs/kinematics.md ("The pivot shift").

>>> sweep = ArmSweep(lambda angle, guess: guess, straight_slider_a_distance=0.1)
>>> sweep.cover(-0.01, 0.02) is None
True
>>> [round(value, 4) for value in sweep.reach()]
[-0.01, 0.02]
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable

import numpy as np

from fishtail_kinematics.engine.errors import FishtailKinematicsError
from fishtail_kinematics.engine.geometry import FloatArray

#: Angle step of the continuation, rad: close to the design's own sweep (about 0.00046 rad for the
#: report), where one Newton solve from the previous pose converges in two or three steps.
SWEEP_STEP_RAD = 0.0005

#: Solves the loop for SW at ``angle`` from the guess AS = ``guess``, returning AS; raises a
#: FishtailKinematicsError naming the reason where the branch cannot go on.
PoseSolver = Callable[[float, float], float]


class ArmSweep:
    """The branch's slider distances AS at SW angles on a grid of :data:`SWEEP_STEP_RAD`.

    Each side (negative and positive angles) is extended on demand by :meth:`cover`; a side that
    met the end of the branch keeps its reason. Safe to share between threads.
    """

    def __init__(
        self,
        solve_pose: PoseSolver,
        straight_slider_a_distance: float,
        step_rad: float = SWEEP_STEP_RAD,
    ) -> None:
        """Start at the straight pose (SW along the axis, AS = ``straight_slider_a_distance``)."""
        self._solve_pose = solve_pose
        self._step = step_rad
        # One list of (angle, AS) per side, each starting at the straight pose and ordered away
        # from it; a side's end, once met, as the reason text.
        self._sides = {
            -1: [(0.0, straight_slider_a_distance)],
            1: [(0.0, straight_slider_a_distance)],
        }
        self._ends: dict[int, str] = {}
        self._lock = threading.Lock()
        self._arrays: tuple[FloatArray, FloatArray] | None = None  # all samples, by angle

    def reach(self) -> tuple[float, float]:
        """The SW angles [low, high] over which the branch has been followed so far, rad."""
        return self._sides[-1][-1][0], self._sides[1][-1][0]

    def cover(self, low_rad: float, high_rad: float) -> str | None:
        """Follow the branch over [low_rad, high_rad]: None if it is there, else why it is not."""
        with self._lock:
            for side, target in ((-1, low_rad), (1, high_rad)):
                reason = self._extend(side, target)
                if reason is not None:
                    return reason
        return None

    def _extend(self, side: int, target_rad: float) -> str | None:
        samples = self._sides[side]
        while side * samples[-1][0] < side * target_rad:
            if side in self._ends:
                return self._ends[side]
            angle = (len(samples)) * self._step * side
            if abs(angle) > math.pi:
                self._ends[side] = "SW would have to turn beyond the straight pose's opposite"
                continue
            try:
                slider = self._solve_pose(angle, samples[-1][1])
            except FishtailKinematicsError as error:
                self._ends[side] = str(error)
                continue
            samples.append((angle, slider))
            self._arrays = None
        return None

    def samples(
        self, low_rad: float, high_rad: float, most: int = 256
    ) -> tuple[FloatArray, FloatArray]:
        """Angles and AS of the followed branch over [low_rad, high_rad], one step beyond each end.

        Call :meth:`cover` first. The samples are in increasing angle, evenly thinned to at most
        about ``most`` (a smooth seed polynomial needs no more, and a fit costs by the sample).
        """
        with self._lock:
            if self._arrays is None:
                ordered = [*reversed(self._sides[-1][1:]), *self._sides[1]]
                self._arrays = (
                    np.array([angle for angle, _ in ordered]),
                    np.array([slider for _, slider in ordered]),
                )
            angles, sliders = self._arrays
        first = max(int(np.searchsorted(angles, low_rad - self._step)) - 1, 0)
        last = min(
            int(np.searchsorted(angles, high_rad + self._step, side="right")), angles.size - 1
        )
        # Both ends kept, the rest evenly spaced.
        chosen = np.unique(
            np.linspace(first, last, min(most, last - first + 1)).round().astype(int)
        )
        return angles[chosen], sliders[chosen]


def last_working_shift(
    works: Callable[[float], bool], limit: float, grid_steps: int, tolerance: float
) -> float:
    """The shift nearest ``limit`` up to which ``works`` holds, coming from zero (where it does).

    ``works`` is tried at ``grid_steps`` - 1 shifts between zero and ``limit``, then within
    ``tolerance`` of ``limit`` (``limit`` itself is open: there the drive cannot assemble); at the
    first that fails, bisection with the last that worked narrows the boundary to ``tolerance``
    and the working side is returned. If none fails, ``limit`` itself.

    >>> round(last_working_shift(lambda shift: shift < 0.0123, 0.1, 64, 1e-9), 6)
    0.0123
    >>> round(last_working_shift(lambda shift: shift < 0.09995, 0.1, 64, 1e-9), 6)
    0.09995
    >>> last_working_shift(lambda shift: True, -0.05, 64, 1e-9)
    -0.05
    """
    good = 0.0
    trials = [limit * step / grid_steps for step in range(1, grid_steps)]
    for shift in [*trials, limit - math.copysign(tolerance, limit)]:
        if not works(shift):
            bad = shift
            break
        good = shift
    else:
        return limit
    while abs(bad - good) > tolerance:
        middle = 0.5 * (good + bad)
        if works(middle):
            good = middle
        else:
            bad = middle
    return good
