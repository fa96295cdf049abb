"""How the tail moves: the one interface the dynamics need, for the engine's tails and a sinusoid.

A :class:`TailDrive` gives, for every fish of a batch at a time t, the tip and its velocity in
the tail frame, the fin's angle and rate, and (for a fin with chord) their accelerations; the
dynamics need nothing else of the tail. :class:`EngineTailDrive` is either mechanism of the
engine turned by a carrier motion, :class:`SinusoidalTailDrive` the servo fish of the literature.
Frames and drives: docs/swimming-dynamics.md ("Tail drives").

>>> import math
>>> drive = SinusoidalTailDrive(fin_length_m=0.2, mean_angle_rad=0.0, amplitude_rad=0.3,
...                             angular_frequency_rad_s=2 * math.pi)
>>> sample = drive.sample(0.0)
>>> float(sample.tip_x), round(float(sample.tip_y_dot), 6), round(float(sample.fin_rate), 4)
(0.2, 0.376991, 1.885)
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import NamedTuple, Protocol

import numpy as np
import numpy.typing as npt

from fishtail_common.parameters import ParameterSpec
from fishtail_kinematics.engine.geometry import LinkageState
from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_plant.errors import FishParameterError, SwimParameterError
from fishtail_plant.fish.fish import FloatArray, PerFish

# Carrier-angle step of the central difference that gives the engine tail's accelerations: the
# truncation error ~ delta² ~ 1e-8 relative and the rounding error ~ 1e-16/delta ~ 1e-12.
_ANGLE_STEP_RAD = 1e-4
# Batches up to this size are solved sample by sample on the engine's float path.
_SCALAR_PATH_MAX = 16


class TailSample(NamedTuple):
    """The tail at one time, in the tail frame at O: one element per fish."""

    tip_x: FloatArray
    tip_y: FloatArray
    tip_x_dot: FloatArray
    tip_y_dot: FloatArray
    fin_angle: FloatArray
    fin_rate: FloatArray


class TailAcceleration(NamedTuple):
    """Second derivatives of the tip position and the fin angle (for the recoil term)."""

    tip_x_ddot: FloatArray
    tip_y_ddot: FloatArray
    fin_acceleration: FloatArray


class TailDrive(Protocol):
    """The tail motion of a batch of fish, evaluated at any time."""

    def sample(self, time_s: npt.ArrayLike) -> TailSample:
        """Tip, its velocity, fin angle and rate at ``time_s`` (broadcast against the batch)."""

    def acceleration(self, time_s: npt.ArrayLike) -> TailAcceleration:
        """Tip and fin accelerations at ``time_s``."""


#: phi(t), phi_dot(t), phi_ddot(t) of the carrier for every fish.
CarrierMotion = Callable[[npt.ArrayLike], tuple[FloatArray, FloatArray, FloatArray]]


def constant_carrier_speed(speed_rad_s: PerFish) -> CarrierMotion:
    """The carrier at constant speed from phi = 0: phi = phi_dot t, one speed per fish.

    Raises:
        SwimParameterError: a non-finite speed.
    """
    speed = np.asarray(speed_rad_s, dtype=float)
    if not np.isfinite(speed).all():
        bad = speed.ravel()[np.flatnonzero(~np.isfinite(speed.ravel()))[0]]
        raise SwimParameterError("carrier_speed_rad_s", float(bad), -np.inf, np.inf, "rad/s")

    def motion(time_s: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        t = np.asarray(time_s, dtype=float)
        angle = speed * t
        return angle, np.broadcast_to(speed, angle.shape), np.zeros_like(angle)

    return motion


def _as_array(value: object) -> FloatArray:
    return np.asarray(value, dtype=float)


class LinkageSolver(Protocol):
    """What a drive asks of a linkage: its pose and rates at carrier angles and speeds."""

    def solve(self, motor_angle: npt.ArrayLike, motor_velocity: npt.ArrayLike) -> LinkageState:
        """Pose and rates (floats for floats, arrays for arrays)."""

    def fin_angle_field(self) -> str:
        """The state field of the last link's angle to the body axis."""


class EngineTailDrive:
    """A tail of the kinematics engine (either mechanism) turned by a carrier motion."""

    def __init__(self, tail: Tail | LinkageSolver, carrier: CarrierMotion) -> None:
        """Drive ``tail`` with ``carrier`` (e.g. :func:`constant_carrier_speed`)."""
        self.tail = tail
        self.carrier = carrier
        self._angle_field = tail.fin_angle_field()
        self._rate_field = f"{self._angle_field}_dot"

    def _pose_and_rates(
        self, angle: FloatArray, speed: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        angle, speed = np.broadcast_arrays(angle, speed)
        fields = ("tip_x", "tip_y", "tip_x_dot", "tip_y_dot", self._angle_field, self._rate_field)
        if angle.size <= _SCALAR_PATH_MAX:
            # A message's few sub-step times: the engine's float path, a few µs a sample, beats
            # its array path's fixed cost of some 100 µs a call.
            values = np.empty((len(fields), angle.size))
            for index, (phi, phi_dot) in enumerate(zip(angle.flat, speed.flat, strict=True)):
                state = self.tail.solve(float(phi), float(phi_dot))
                values[:, index] = [getattr(state, field) for field in fields]
            shaped = values.reshape(len(fields), *angle.shape)
            tip_x, tip_y, tip_x_dot, tip_y_dot, fin, rate = shaped
            return tip_x, tip_y, tip_x_dot, tip_y_dot, fin, rate
        return self._array_pose_and_rates(angle, speed)

    def _array_pose_and_rates(
        self, angle: FloatArray, speed: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        fields = ("tip_x", "tip_y", "tip_x_dot", "tip_y_dot", self._angle_field, self._rate_field)
        state = self.tail.solve(angle, speed)
        tip_x, tip_y, tip_x_dot, tip_y_dot, fin, rate = (
            _as_array(getattr(state, field)) for field in fields
        )
        return tip_x, tip_y, tip_x_dot, tip_y_dot, fin, rate

    def sample(self, time_s: npt.ArrayLike) -> TailSample:
        """The engine's tip, tip velocity, fin angle and rate at the carrier's angle and speed."""
        angle, speed, _ = self.carrier(time_s)
        return TailSample(*self._pose_and_rates(angle, speed))

    def acceleration(self, time_s: npt.ArrayLike) -> TailAcceleration:
        """The second derivatives q'' phi_dot² + q' phi_ddot of the tip and the fin angle.

        q' is the engine's exact rate at unit carrier speed, q'' its central difference in phi.
        """
        angle, speed, carrier_acceleration = self.carrier(time_s)
        return self.acceleration_at(angle, speed, carrier_acceleration)

    def acceleration_at(
        self, angle: FloatArray, speed: FloatArray, carrier_acceleration: FloatArray
    ) -> TailAcceleration:
        """:meth:`acceleration` at carrier angles, speeds and accelerations (broadcast)."""
        # The linkage repeats every revolution: difference about the angle within it, or a
        # carrier that has turned for long (10^8 revolutions) leaves phi ± h a rounding of
        # ~1e-7 rad apart from the step of 1e-4 and the curvature 1e-3 wrong.
        phase = np.remainder(np.asarray(angle, dtype=float), 2.0 * np.pi)
        unit = np.ones_like(phase)
        ahead = self._pose_and_rates(phase + _ANGLE_STEP_RAD, unit)
        behind = self._pose_and_rates(phase - _ANGLE_STEP_RAD, unit)
        here = self._pose_and_rates(phase, unit)
        scale = 0.5 / _ANGLE_STEP_RAD
        result = []
        for rate_index in (2, 3, 5):
            curvature = (ahead[rate_index] - behind[rate_index]) * scale
            result.append(curvature * speed**2 + here[rate_index] * carrier_acceleration)
        return TailAcceleration(*result)


class LinkageBatchDrive(EngineTailDrive):
    """Many linkages at once, one per fish (e.g. an ``OscillatoryBatch``), each on its carrier.

    The linkages' lengths are arrays, so every sample goes through the array path.
    """

    def _pose_and_rates(
        self, angle: FloatArray, speed: FloatArray
    ) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
        return self._array_pose_and_rates(*np.broadcast_arrays(angle, speed))


class SinusoidalTailDrive:
    """A rigid fin of length l_fin pivoting at O: theta = alpha0 + alpha_a sin(omega t)."""

    def __init__(
        self,
        fin_length_m: PerFish,
        mean_angle_rad: PerFish,
        amplitude_rad: PerFish,
        angular_frequency_rad_s: PerFish,
    ) -> None:
        """Keep the fin's length and motion (floats or per-fish arrays).

        Raises:
            SwimParameterError: a length or frequency that is not positive, an angle outside
                [-pi, pi], a negative amplitude, or a non-finite value.
        """
        for name, value, low in (
            ("fin_length_m", fin_length_m, 1e-6),
            ("mean_angle_rad", mean_angle_rad, -np.pi),
            ("amplitude_rad", amplitude_rad, 0.0),
            ("angular_frequency_rad_s", angular_frequency_rad_s, 1e-9),
        ):
            values = np.asarray(value, dtype=float).ravel()
            high = np.pi if name.endswith("_rad") else np.inf
            bad = ~((values >= low) & (values <= high) & np.isfinite(values))
            if bad.any():
                index = int(np.flatnonzero(bad)[0])
                fish = index if np.ndim(value) else None
                raise SwimParameterError(name, float(values[index]), low, high, "", fish)
        self.fin_length_m = np.asarray(fin_length_m, dtype=float)
        self.mean_angle_rad = np.asarray(mean_angle_rad, dtype=float)
        self.amplitude_rad = np.asarray(amplitude_rad, dtype=float)
        self.angular_frequency_rad_s = np.asarray(angular_frequency_rad_s, dtype=float)

    @property
    def beat_period_s(self) -> FloatArray:
        """2 pi / omega."""
        return 2.0 * np.pi / self.angular_frequency_rad_s

    def _angle(self, time_s: npt.ArrayLike) -> tuple[FloatArray, FloatArray, FloatArray]:
        phase = self.angular_frequency_rad_s * np.asarray(time_s, dtype=float)
        sin_phase, cos_phase = np.sin(phase), np.cos(phase)
        angle = self.mean_angle_rad + self.amplitude_rad * sin_phase
        rate = self.amplitude_rad * self.angular_frequency_rad_s * cos_phase
        acceleration = -self.amplitude_rad * self.angular_frequency_rad_s**2 * sin_phase
        return angle, rate, acceleration

    def sample(self, time_s: npt.ArrayLike) -> TailSample:
        """T = l_fin (cos theta, sin theta) and its velocity l_fin theta_dot (-sin, cos)."""
        angle, rate, _ = self._angle(time_s)
        cos_angle, sin_angle = np.cos(angle), np.sin(angle)
        length = self.fin_length_m
        return TailSample(
            length * cos_angle, length * sin_angle,
            -length * sin_angle * rate, length * cos_angle * rate, angle, rate,
        )  # fmt: skip

    def acceleration(self, time_s: npt.ArrayLike) -> TailAcceleration:
        """Tip and fin accelerations, in closed form."""
        angle, rate, acceleration = self._angle(time_s)
        cos_angle, sin_angle = np.cos(angle), np.sin(angle)
        length = self.fin_length_m
        return TailAcceleration(
            length * (-sin_angle * acceleration - cos_angle * rate**2),
            length * (cos_angle * acceleration - sin_angle * rate**2),
            acceleration,
        )


#: A servo tail (:class:`SinusoidalTailDrive`) as the command lines and measurement files give it.
SERVO_TAIL_PARAMETERS: tuple[ParameterSpec, ...] = (
    ParameterSpec("servo_fin_length_m", 0.2,
                  "servo tail: fin length l_fin from the pivot O to the trailing edge", "m",
                  1e-6, 20.0, exclusive_minimum=True),
    ParameterSpec("servo_amplitude_rad", 0.3,
                  "servo tail: fin angle amplitude alpha_a (half the peak-to-peak swing)", "rad",
                  0.0, float(np.pi)),
    ParameterSpec("servo_bias_rad", 0.0,
                  "servo tail: mean fin angle alpha0 (> 0 turns the fin to the fish's left)",
                  "rad", -float(np.pi), float(np.pi)),
    ParameterSpec("servo_frequency_hz", 1.0, "servo tail: beat frequency f", "Hz", 1e-6, 100.0,
                  exclusive_minimum=True),
)  # fmt: skip
SERVO_TAIL_PARAMETERS_BY_NAME = {spec.name: spec for spec in SERVO_TAIL_PARAMETERS}


def servo_drive(values: Mapping[str, PerFish]) -> SinusoidalTailDrive:
    """The servo tail of :data:`SERVO_TAIL_PARAMETERS` values (floats or per-fish arrays).

    Names not given keep their defaults; f becomes omega = 2 pi f.

    Raises:
        FishParameterError: an unknown name.
        SwimParameterError: a value the drive refuses.
    """
    unknown = sorted(set(values) - set(SERVO_TAIL_PARAMETERS_BY_NAME))
    if unknown:
        raise FishParameterError(f"unknown servo tail parameter {unknown[0]!r}")
    chosen = {spec.name: values.get(spec.name, spec.default) for spec in SERVO_TAIL_PARAMETERS}
    return SinusoidalTailDrive(
        fin_length_m=np.asarray(chosen["servo_fin_length_m"], dtype=float),
        mean_angle_rad=np.asarray(chosen["servo_bias_rad"], dtype=float),
        amplitude_rad=np.asarray(chosen["servo_amplitude_rad"], dtype=float),
        angular_frequency_rad_s=2.0 * np.pi * np.asarray(chosen["servo_frequency_hz"], float),
    )
