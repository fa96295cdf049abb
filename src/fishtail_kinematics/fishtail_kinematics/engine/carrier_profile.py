"""The carrier's speed over one revolution: a mean speed and a once-per-revolution modulation.

A one-way motor cannot bias the tail's swing, but it can run the carrier faster through one
half-stroke than the other, which steers the fish. :class:`CarrierSpeedProfile` is that law as a
function of the carrier angle (what the driver measures and follows), with a revolution lasting
2 pi / Omega at every depth, and its motion in time in closed form (no integration). The law and
its closed form: docs/steering.md; how the driver follows it: docs/serial.md ("Speed profiles").

>>> profile = CarrierSpeedProfile(mean_speed_rad_s=2 * math.pi, depth=0.5, phase_rad=0.0)
>>> round(profile.speed_at(0.0) / profile.speed_at(math.pi), 6)  # (1 + delta) / (1 - delta)
3.0
>>> motion = profile.motion()
>>> angle, speed, _ = motion(np.array([0.0, 0.5, 1.0]))  # one revolution takes 2 pi / Omega
>>> np.round(angle, 9).tolist()
[0.0, 3.141592654, 6.283185307]
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.errors import CarrierProfileError

FloatArray = npt.NDArray[np.float64]
#: phi(t), phi_dot(t), phi_ddot(t) of the carrier, for any array of times.
CarrierMotion = Callable[[npt.ArrayLike], tuple[FloatArray, FloatArray, FloatArray]]

#: The deepest modulation accepted: at delta = 0.9 the slowest point runs at 0.23 Omega and the
#: fastest at 4.4 Omega; deeper, the carrier all but stops once a revolution.
MAX_DEPTH = 0.9
#: The carrier's top speed by default [rad/s]: the driver's max_speed_rad_s, within which the pilot
#: keeps a profile's peak.
DEFAULT_TOP_SPEED_RAD_S = 20.0
TWO_PI = 2.0 * math.pi


@dataclasses.dataclass(frozen=True)
class CarrierSpeedProfile:
    """Mean speed Omega [rad/s], depth delta and the fastest point's carrier angle phi_0 [rad].

    phi_dot(phi) = Omega (1 + delta cos(phi - phi_0)) / sqrt(1 - delta²).

    Raises:
        CarrierProfileError: a negative or non-finite speed, a depth outside [0, MAX_DEPTH], or
            a non-finite phase.
    """

    mean_speed_rad_s: float
    depth: float = 0.0
    phase_rad: float = 0.0

    def __post_init__(self) -> None:
        """Refuse a negative or non-finite speed, a depth outside [0, MAX_DEPTH], a NaN phase."""
        if not (math.isfinite(self.mean_speed_rad_s) and self.mean_speed_rad_s >= 0.0):
            raise CarrierProfileError(
                f"mean_speed_rad_s = {self.mean_speed_rad_s!r}: must be finite and >= 0 "
                "(the motor turns one way)"
            )
        if not (math.isfinite(self.depth) and 0.0 <= self.depth <= MAX_DEPTH):
            raise CarrierProfileError(
                f"depth = {self.depth!r}: must be in [0, {MAX_DEPTH}] (the fraction by which the "
                "speed rises above and falls below its mean once a revolution)"
            )
        if not math.isfinite(self.phase_rad):
            raise CarrierProfileError(f"phase_rad = {self.phase_rad!r}: must be finite")

    @property
    def _scale(self) -> float:
        return self.mean_speed_rad_s / math.sqrt(1.0 - self.depth * self.depth)

    @property
    def peak_speed_rad_s(self) -> float:
        """The fastest speed, at phi = phi_0."""
        return self._scale * (1.0 + self.depth)

    @property
    def lowest_speed_rad_s(self) -> float:
        """The slowest speed, at phi = phi_0 + pi."""
        return self._scale * (1.0 - self.depth)

    def speed_at(self, angle_rad: float) -> float:
        """The carrier speed at carrier angle ``angle_rad`` (the driver's per-sample path)."""
        return self._scale * (1.0 + self.depth * math.cos(angle_rad - self.phase_rad))

    def mean_phase(self, angle_rad: npt.ArrayLike) -> FloatArray:
        """The mean phase nu (Omega t from phi_0) of carrier angle(s), continuous in the angle."""
        chi = np.asarray(angle_rad, dtype=float) - self.phase_rad
        half = 0.5 * chi
        wrapped = 2.0 * np.arctan2(
            math.sqrt(1.0 - self.depth) * np.sin(half), math.sqrt(1.0 + self.depth) * np.cos(half)
        )
        # nu - chi is periodic and within (-pi, pi): pick the branch nearest chi.
        result: FloatArray = wrapped + TWO_PI * np.round((chi - wrapped) / TWO_PI)
        return result

    def angle_at_phase(self, mean_phase: npt.ArrayLike) -> FloatArray:
        """The carrier angle at mean phase(s) nu: the inverse of :meth:`mean_phase`."""
        nu = np.asarray(mean_phase, dtype=float)
        half = 0.5 * nu
        wrapped = 2.0 * np.arctan2(
            math.sqrt(1.0 + self.depth) * np.sin(half), math.sqrt(1.0 - self.depth) * np.cos(half)
        )
        chi = wrapped + TWO_PI * np.round((nu - wrapped) / TWO_PI)
        result: FloatArray = chi + self.phase_rad
        return result

    def motion(self, start_time_s: float = 0.0, start_angle_rad: float = 0.0) -> CarrierMotion:
        """phi(t), phi_dot(t), phi_ddot(t), starting at ``start_angle_rad`` at ``start_time_s``.

        Before ``start_time_s`` the same law runs backwards (the formula holds for any t).
        """
        start_phase = float(self.mean_phase(start_angle_rad))
        omega, depth, phase, scale = self.mean_speed_rad_s, self.depth, self.phase_rad, self._scale

        def carrier(time_s: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
            elapsed = np.asarray(time_s, dtype=float) - start_time_s
            if depth == 0.0:
                # Unmodulated the phase means nothing: the constant speed itself, not its round
                # trip through the phase (a few ulps off, which the recoil's tail accelerations,
                # differences over 1e-4 rad, would make depend on the phase).
                angle = start_angle_rad + omega * elapsed
                return angle, np.full_like(angle, omega), np.zeros_like(angle)
            nu = start_phase + omega * elapsed
            angle = self.angle_at_phase(nu)
            chi = angle - phase
            speed = scale * (1.0 + depth * np.cos(chi))
            # phi_ddot = d(phi_dot)/d(phi) * phi_dot
            acceleration = -scale * depth * np.sin(chi) * speed
            return angle, speed, acceleration

        return carrier
