"""The carrier as the simulator knows it: a line between two samples, and steps it already took.

Both are :data:`~fishtail_plant.fish.tail_drive.CarrierMotion` callables. :class:`LinearCarrier`
is what the dynamics integrate on between two ``motor/joint_state`` samples;
:class:`RecordedCarrier` gives back the carrier at sub-step times of earlier intervals, so that
the tail's figures of many sub-steps are computed in one vectorised call instead of one per
sample.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from fishtail_plant.fish.fish import FloatArray


class LinearCarrier:
    """The carrier between two samples: phi = phi0 + phi_dot (t - t0), a CarrierMotion."""

    def __init__(self) -> None:
        """At rest at phi = 0 until :meth:`set` is called."""
        self.start_time_s = 0.0
        self.start_angle_rad = 0.0
        self.speed_rad_s = 0.0

    def set(self, start_time_s: float, start_angle_rad: float, speed_rad_s: float) -> None:
        """Follow the line through (t0, phi0) with slope ``speed_rad_s`` from now on."""
        self.start_time_s = start_time_s
        self.start_angle_rad = start_angle_rad
        self.speed_rad_s = speed_rad_s

    def __call__(self, time_s: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """phi, phi_dot and phi_ddot (0) at ``time_s``."""
        elapsed = np.asarray(time_s, dtype=float) - self.start_time_s
        angle = self.start_angle_rad + self.speed_rad_s * elapsed
        return angle, np.full_like(angle, self.speed_rad_s), np.zeros_like(angle)


class RecordedCarrier:
    """The carrier at the times it was recorded at, each with the speed of its own interval.

    A time that ends one interval and starts the next has two speeds; the recorded one is the
    interval's that was integrated up to it, which a piecewise-linear lookup could not tell.
    """

    def __init__(self) -> None:
        """Empty until :meth:`record`."""
        self.times_s: FloatArray = np.empty(0)
        self.angles_rad: FloatArray = np.empty(0)
        self.speeds_rad_s: FloatArray = np.empty(0)

    def record(self, times_s: FloatArray, angles_rad: FloatArray, speeds_rad_s: FloatArray) -> None:
        """Answer for these times (increasing), with these angles and speeds, from now on."""
        self.times_s, self.angles_rad, self.speeds_rad_s = times_s, angles_rad, speeds_rad_s

    def __call__(self, time_s: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        """phi, phi_dot and phi_ddot (0) at recorded times, in the shape of ``time_s``.

        Raises:
            ValueError: a time that was not recorded.
        """
        times = np.asarray(time_s, dtype=float)
        index = np.searchsorted(self.times_s, times)
        found = index < self.times_s.size
        found[found] = self.times_s[index[found]] == times[found]
        if not found.all():
            missing = float(times[~found].flat[0])
            raise ValueError(f"the carrier was not recorded at t = {missing!r} s")
        return self.angles_rad[index], self.speeds_rad_s[index], np.zeros(times.shape)
