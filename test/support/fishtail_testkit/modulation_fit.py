"""How well a carrier followed a speed profile: the modulation achieved, revolution by revolution.

A motor lags its command, so a once-per-revolution speed modulation comes out shallower and later
(in carrier angle) than commanded. Over each whole revolution of recorded samples (time, carrier
angle, carrier speed) this fits

    speed(phi) ~ a0 + a1 cos(phi) + b1 sin(phi)

by least squares, each sample weighted by the angle it stands for (half the angle from its
predecessor to its successor), so that the fit approximates the Fourier integral over the angle
and does not favour the slow half-revolution, where time-regular samples crowd. The commanded law
has exactly this form (:class:`~fishtail_kinematics.engine.carrier_profile.CarrierSpeedProfile`:
a0 = Omega / sqrt(1 - delta²), amplitude a0 delta, the peak at phi_0), so

* achieved depth = sqrt(a1² + b1²) / a0,
* achieved peak angle = atan2(b1, a1), and the phase lag = achieved peak - phi_0, wrapped to
  (-pi, pi]: positive when the speed peaks later in the revolution than commanded,
* achieved mean speed = 2 pi / the revolution's duration.

Speeds can come from the source (a model's true speed) or from the angles
(:func:`speeds_from_angles`: central differences, no delay, a gain above 0.99 up to 4 Hz beats at
100 samples per second) when the source's own estimate is a lagging filter (the serial backend's
0.1 s window). :func:`follow_simulated` runs a simulated motor under a profile the way the driver
node does, in simulated time, for the tests and ``bench/bench_profile_following.py``. Plain Python
and numpy.

>>> import math
>>> from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
>>> profile = CarrierSpeedProfile(2 * math.pi, depth=0.5, phase_rad=1.0)
>>> times = np.arange(0.0, 3.0, 0.005)
>>> angles, speeds, _ = profile.motion()(times)
>>> result = measure_following(times, angles, speeds, profile)
>>> len(result.revolutions), round(result.depth, 3), abs(round(result.phase_lag_rad, 3))
(2, 0.5, 0.0)
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import numpy.typing as npt

from fishtail_driver.backends import SimMotor
from fishtail_driver.profile_command import CarrierCommand
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile

FloatArray = npt.NDArray[np.float64]
TWO_PI = 2.0 * math.pi
#: Fewer samples than this in a revolution: too few for a fit of three coefficients.
MIN_SAMPLES_PER_REVOLUTION = 12
#: A revolution with a wider gap between two samples is not fitted.
MAX_GAP_RAD = math.pi / 6.0


def wrap_angle(angle_rad: float) -> float:
    """``angle_rad`` wrapped into (-pi, pi]."""
    wrapped = math.remainder(angle_rad, TWO_PI)
    return math.pi if wrapped == -math.pi else wrapped


@dataclasses.dataclass(frozen=True)
class RevolutionFit:
    """The modulation achieved over one revolution."""

    #: Which revolution since the first sample (0 the first).
    index: int
    start_time_s: float
    duration_s: float
    #: 2 pi / duration.
    mean_speed_rad_s: float
    #: a0: the speed's average over the angle.
    offset_rad_s: float
    #: sqrt(a1² + b1²).
    amplitude_rad_s: float
    #: The carrier angle of the fitted speed's peak, wrapped into (-pi, pi].
    peak_angle_rad: float
    samples: int

    @property
    def depth(self) -> float:
        """Amplitude over offset: the achieved delta."""
        return self.amplitude_rad_s / self.offset_rad_s if self.offset_rad_s > 0.0 else math.nan


@dataclasses.dataclass(frozen=True)
class FollowingResult:
    """The revolutions' fits against the commanded profile, and their summary."""

    commanded: CarrierSpeedProfile
    revolutions: tuple[RevolutionFit, ...]
    #: Whole revolutions recorded but not fitted (too few samples, a gap).
    left_out: int = 0

    @property
    def depth(self) -> float:
        """The achieved depth, averaged over the revolutions."""
        return float(np.mean([fit.depth for fit in self.revolutions]))

    @property
    def depth_ratio(self) -> float:
        """Achieved over commanded depth (NaN for a flat command)."""
        delta = self.commanded.depth
        return self.depth / delta if delta > 0.0 else math.nan

    @property
    def phase_lags_rad(self) -> list[float]:
        """Each revolution's peak angle minus the commanded one, wrapped into (-pi, pi]."""
        return [
            wrap_angle(fit.peak_angle_rad - self.commanded.phase_rad) for fit in self.revolutions
        ]

    @property
    def phase_lag_rad(self) -> float:
        """The revolutions' phase lags, averaged on the circle."""
        lags = self.phase_lags_rad
        return math.atan2(sum(map(math.sin, lags)), sum(map(math.cos, lags)))

    @property
    def mean_speed_rad_s(self) -> float:
        """The achieved mean speed: the revolutions' total angle over their total time."""
        return TWO_PI * len(self.revolutions) / sum(fit.duration_s for fit in self.revolutions)

    @property
    def depth_spread(self) -> float:
        """Largest minus smallest depth of the revolutions."""
        depths = [fit.depth for fit in self.revolutions]
        return max(depths) - min(depths)

    @property
    def phase_lag_spread_rad(self) -> float:
        """Largest minus smallest phase lag of the revolutions (about their circular mean)."""
        centre = self.phase_lag_rad
        offsets = [wrap_angle(lag - centre) for lag in self.phase_lags_rad]
        return max(offsets) - min(offsets)


def speeds_from_angles(times_s: npt.ArrayLike, angles_rad: npt.ArrayLike) -> FloatArray:
    """The speed at each sample: its neighbours' angle difference over their time difference.

    One-sided at the ends. The plain difference, not a higher-order formula for uneven spacing,
    which amplifies the encoder's quantisation where two samples come close together.
    """
    times = np.asarray(times_s, dtype=float)
    angles = np.asarray(angles_rad, dtype=float)
    if times.size < 2:
        raise ValueError("speeds from angles need at least two samples")
    speeds = np.empty_like(angles)
    speeds[1:-1] = (angles[2:] - angles[:-2]) / (times[2:] - times[:-2])
    speeds[0] = (angles[1] - angles[0]) / (times[1] - times[0])
    speeds[-1] = (angles[-1] - angles[-2]) / (times[-1] - times[-2])
    return speeds


def _fit(angles: FloatArray, speeds: FloatArray, weights: FloatArray) -> tuple[float, float, float]:
    """Weighted least squares of speed ~ a0 + a1 cos + b1 sin; (a0, a1, b1)."""
    basis = np.column_stack((np.ones_like(angles), np.cos(angles), np.sin(angles)))
    root = np.sqrt(weights)
    coefficients, *_ = np.linalg.lstsq(basis * root[:, None], speeds * root, rcond=None)
    return float(coefficients[0]), float(coefficients[1]), float(coefficients[2])


def fit_revolutions(
    times_s: npt.ArrayLike,
    angles_rad: npt.ArrayLike,
    speeds_rad_s: npt.ArrayLike,
    max_gap_rad: float = MAX_GAP_RAD,
) -> list[RevolutionFit]:
    """One fit per whole revolution, counted from the first sample's angle.

    The angles are the unwrapped carrier angle (increasing: a one-way motor). A revolution spans
    [phi_start + 2 pi k, phi_start + 2 pi (k + 1)); the last, incomplete one is left out, and so
    is a revolution with fewer than :data:`MIN_SAMPLES_PER_REVOLUTION` samples or with a gap
    wider than ``max_gap_rad`` between two samples (a stalled recorder: the fit would guess
    across it). Its duration is interpolated between the samples around its two ends.
    """
    times = np.asarray(times_s, dtype=float)
    angles = np.asarray(angles_rad, dtype=float)
    speeds = np.asarray(speeds_rad_s, dtype=float)
    if not times.shape == angles.shape == speeds.shape or times.ndim != 1:
        raise ValueError("times, angles and speeds must be 1-D arrays of one length")
    if times.size < 3:
        return []
    # The angle each sample stands for: half the span from its predecessor to its successor.
    spans = np.empty_like(angles)
    spans[1:-1] = 0.5 * (angles[2:] - angles[:-2])
    spans[0] = angles[1] - angles[0]
    spans[-1] = angles[-1] - angles[-2]
    turns = np.floor((angles - angles[0]) / TWO_PI).astype(int)
    fits = []
    for turn in range(int(turns[-1])):  # the last turn is incomplete
        inside = np.flatnonzero(turns == turn)
        if inside.size < MIN_SAMPLES_PER_REVOLUTION:
            continue
        around = angles[max(inside[0] - 1, 0) : inside[-1] + 2]
        if np.max(np.diff(around)) > max_gap_rad:
            continue
        start_angle = angles[0] + TWO_PI * turn
        start_s = float(np.interp(start_angle, angles, times))
        end_s = float(np.interp(start_angle + TWO_PI, angles, times))
        offset, cosine, sine = _fit(angles[inside], speeds[inside], np.maximum(spans[inside], 0.0))
        fits.append(
            RevolutionFit(
                index=turn,
                start_time_s=start_s,
                duration_s=end_s - start_s,
                mean_speed_rad_s=TWO_PI / (end_s - start_s),
                offset_rad_s=offset,
                amplitude_rad_s=math.hypot(cosine, sine),
                peak_angle_rad=math.atan2(sine, cosine),
                samples=int(inside.size),
            )
        )
    return fits


def measure_following(
    times_s: npt.ArrayLike,
    angles_rad: npt.ArrayLike,
    speeds_rad_s: npt.ArrayLike,
    commanded: CarrierSpeedProfile,
    skip_revolutions: int = 0,
) -> FollowingResult:
    """The modulation achieved against ``commanded``, over the whole revolutions recorded.

    ``skip_revolutions`` leaves out the first ones (the motor settling after the command changed).
    ValueError when no whole revolution remains.
    """
    angles = np.asarray(angles_rad, dtype=float)
    fits = [
        fit
        for fit in fit_revolutions(times_s, angles, speeds_rad_s)
        if fit.index >= skip_revolutions
    ]
    if not fits:
        raise ValueError("no whole revolution with enough samples to measure the modulation")
    whole = int((angles[-1] - angles[0]) // TWO_PI)
    return FollowingResult(commanded, tuple(fits), whole - skip_revolutions - len(fits))


@dataclasses.dataclass(frozen=True)
class Recording:
    """Samples of a carrier: times [s], measured angles [rad], speeds [rad/s]."""

    times_s: FloatArray
    angles_rad: FloatArray
    speeds_rad_s: FloatArray


def follow_simulated(
    motor: SimMotor, profile: CarrierSpeedProfile, sample_rate_hz: float, duration_s: float
) -> Recording:
    """Run ``motor`` under ``profile`` for ``duration_s`` of simulated time, as the node does.

    At every sample (``sample_rate_hz``, the node's publish rate) the motor is advanced, its
    encoder read, and the speed :meth:`CarrierCommand.follow` returns for that angle commanded.
    The speeds recorded are the model's (not estimated from the encoder).
    """
    command = CarrierCommand(max_speed_rad_s=profile.peak_speed_rad_s)
    command.set_profile(profile.mean_speed_rad_s, profile.depth, profile.phase_rad)
    motor.command(command.commanded_speed_rad_s)
    period_s = 1.0 / sample_rate_hz
    count = int(duration_s * sample_rate_hz)
    times, angles, speeds = np.empty(count), np.empty(count), np.empty(count)
    for index in range(count):
        motor.advance(period_s)
        angle = motor.measured_angle_rad()
        times[index], angles[index], speeds[index] = (
            (index + 1) * period_s,
            angle,
            motor.speed_rad_s,
        )
        speed = command.follow(angle)
        if speed is not None:
            motor.command(speed)
    return Recording(times, angles, speeds)
