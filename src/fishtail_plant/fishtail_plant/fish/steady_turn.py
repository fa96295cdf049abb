"""Steady turning against a steering input: one fish per input value, stepped from rest as a batch.

How well the fish turns by carrier modulation (depth and phase of a
:class:`~fishtail_kinematics.engine.carrier_profile.CarrierSpeedProfile`) or by a pivot shift:
each input value gets its fish and tail drive, :class:`PerFishDrive` steps them as one batch,
and :class:`SteadyTurn` holds the figures over the last whole beats after the start-up
transient, which is measured (:attr:`SteadyTurn.transient_beats`), not assumed. The method, the
tables and what they mean: docs/steering.md.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_plant.errors import SwimInputError
from fishtail_plant.fish.figures import beat_means, tail_figures
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.integrator import Trajectory, simulate
from fishtail_plant.fish.model import PSI, SwimModel
from fishtail_plant.fish.tail_drive import (
    EngineTailDrive,
    TailAcceleration,
    TailDrive,
    TailSample,
    constant_carrier_speed,
)

#: Beats from rest, the figures taken over the last :data:`AVERAGE_BEATS` of them. Measured:
#: mechanism 1's slowest fish settle to 1e-4 rad a beat in up to 47 beats, and what is left of
#: the transient falls about tenfold every 5 beats.
TURN_BEATS = 60
#: RK4 steps a beat. At depth 0.9 the carrier peaks at 4.4 times its mean speed; 32 steps leave
#: errors of 2e-3 rad a beat in the heading change, 64 steps 3e-5 (against 128).
TURN_STEPS_PER_BEAT = 64
#: Whole beats the figures average over.
AVERAGE_BEATS = 2
#: A fish has settled when its heading change per beat stays this close to its last beat's.
SETTLED_RAD_PER_BEAT = 1e-4


class TurnSettings(NamedTuple):
    """How a batch is stepped: beats from rest, RK4 steps a beat, beats averaged at the end."""

    beats: int = TURN_BEATS
    steps_per_beat: int = TURN_STEPS_PER_BEAT
    average_beats: int = AVERAGE_BEATS


#: The settings the defaults describe.
DEFAULT_SETTINGS = TurnSettings()


class SteadyTurn(NamedTuple):
    """Figures over the last whole beats, one element per fish (per input value)."""

    beat_frequency_hz: FloatArray
    yaw_rate_rad_s: FloatArray
    speed_m_s: FloatArray
    turning_radius_m: FloatArray
    tail_power_w: FloatArray
    #: The fin's angle to the body axis, averaged over time (> 0 to the left): the rudder
    #: deflection the steering gives, which the spec's rudder paragraph says turns the fish
    #: its way. Not the mid-point of the swing's extremes: the fin may dwell on one side.
    mean_fin_angle_rad: FloatArray
    #: The beat from which every fish's heading change per beat is within SETTLED_RAD_PER_BEAT
    #: of its last beat's (the run's beats if it never settles).
    transient_beats: int
    #: The largest change of a fish's heading change per beat over the last beat [rad]: what is
    #: left of the transient.
    last_drift_rad: float

    @property
    def yaw_per_beat_rad(self) -> FloatArray:
        """r̄/f: the heading change per beat [rad], the same at every beat frequency."""
        return self.yaw_rate_rad_s / self.beat_frequency_hz

    @property
    def distance_per_beat_m(self) -> FloatArray:
        """Ū/f: the distance swum per beat [m], the same at every beat frequency."""
        return self.speed_m_s / self.beat_frequency_hz

    def take(self, fish: npt.ArrayLike) -> SteadyTurn:
        """The figures of the fish at indices ``fish``; the batch's transient figures kept."""
        index = np.asarray(fish, dtype=int)
        return self._replace(**{name: getattr(self, name)[index] for name in _PER_FISH})


_PER_FISH = (
    "beat_frequency_hz", "yaw_rate_rad_s", "speed_m_s", "turning_radius_m", "tail_power_w",
    "mean_fin_angle_rad",
)  # fmt: skip


class PerFishDrive:
    """A batch of fish each with a tail drive of its own (one fish each), as one drive.

    Every drive is asked for its fish at that fish's times (a column of a time array shaped
    like the batch, or the same times for all); each is vectorised over the times.
    """

    def __init__(self, drives: Sequence[TailDrive]) -> None:
        """Put ``drives`` side by side, fish ``k`` driven by ``drives[k]``.

        Raises:
            SwimInputError: no drive.
        """
        if not drives:
            raise SwimInputError("a batch needs at least one drive")
        self.drives = tuple(drives)

    def _columns(self, time_s: npt.ArrayLike) -> list[FloatArray]:
        times = np.asarray(time_s, dtype=float)
        if times.ndim == 0:
            times = times.reshape(1)
        count = len(self.drives)
        if times.shape[-1] == count and count > 1:
            return [times[..., fish : fish + 1] for fish in range(count)]
        if times.shape[-1] != 1:
            raise SwimInputError(
                f"times of shape {times.shape} do not broadcast against {count} fish"
            )
        return [times] * count

    def _stacked(
        self,
        time_s: npt.ArrayLike,
        evaluate: Callable[[TailDrive, FloatArray], tuple[FloatArray, ...]],
    ) -> list[FloatArray]:
        columns = self._columns(time_s)
        parts = [evaluate(drive, times) for drive, times in zip(self.drives, columns, strict=True)]
        shape = columns[0].shape
        return [
            np.concatenate([np.broadcast_to(part[field], shape) for part in parts], axis=-1)
            for field in range(len(parts[0]))
        ]

    def sample(self, time_s: npt.ArrayLike) -> TailSample:
        """Each fish's tip, tip velocity, fin angle and rate, side by side on the last axis."""
        return TailSample(*self._stacked(time_s, lambda drive, times: drive.sample(times)))

    def acceleration(self, time_s: npt.ArrayLike) -> TailAcceleration:
        """Each fish's tip and fin accelerations, side by side on the last axis."""
        return TailAcceleration(
            *self._stacked(time_s, lambda drive, times: drive.acceleration(times))
        )


def modulated_drive(tail: Tail, profiles: Sequence[CarrierSpeedProfile]) -> PerFishDrive:
    """``tail`` turned by each profile from carrier angle 0 at t = 0, one fish per profile."""
    return PerFishDrive([EngineTailDrive(tail, profile.motion()) for profile in profiles])


def constant_speed_drive(tails: Sequence[Tail], speed_rad_s: float) -> PerFishDrive:
    """Each tail (e.g. one per pivot shift) turned at ``speed_rad_s``, one fish per tail."""
    carrier = constant_carrier_speed(speed_rad_s)
    return PerFishDrive([EngineTailDrive(tail, carrier) for tail in tails])


def steady_turn(
    drive: TailDrive,
    fish: FishParameters,
    fish_count: int,
    beat_period_s: float,
    settings: TurnSettings = DEFAULT_SETTINGS,
    progress: Callable[[int], None] | None = None,
) -> SteadyTurn:
    """Step ``fish_count`` fish of ``drive`` from rest and take their figures over whole beats.

    Every fish beats with ``beat_period_s`` (a modulated carrier keeps its revolution's
    duration). ``progress`` is called with the number of steps done.

    Raises:
        SwimInputError: settings whose beats cannot hold a transient and the beats averaged,
            or what :func:`~fishtail_plant.fish.integrator.simulate` refuses.
    """
    if settings.beats <= settings.average_beats or settings.average_beats < 1:
        raise SwimInputError(
            f"{settings.beats} beats cannot hold a transient and {settings.average_beats} "
            "beats to average"
        )
    model = SwimModel(fish, drive)
    step_s = beat_period_s / settings.steps_per_beat
    trajectory = simulate(
        model, fish_count, step_s, settings.beats * settings.steps_per_beat, progress=progress
    )
    means = beat_means(trajectory, beat_period_s, settings.average_beats)
    # The tail figures only over the averaged beats: the forces of the whole run are not needed.
    last = settings.average_beats * settings.steps_per_beat + 1
    window = Trajectory(trajectory.time_s[-last:], trajectory.state[-last:])
    tail = tail_figures(model, window, beat_period_s, settings.average_beats)
    fin = np.broadcast_to(drive.sample(window.time_s[:, None]).fin_angle, window.state.shape[:2])
    mean_fin = np.trapezoid(fin, window.time_s, axis=0) / (window.time_s[-1] - window.time_s[0])
    transient, drift = _transient(trajectory, settings.steps_per_beat)
    frequency = np.full(fish_count, 1.0 / beat_period_s)
    return SteadyTurn(
        frequency, means.mean_yaw_rate_rad_s, means.mean_speed_m_s, means.turning_radius_m,
        tail.tail_power_w, mean_fin, transient, drift,
    )  # fmt: skip


def _transient(trajectory: Trajectory, steps_per_beat: int) -> tuple[int, float]:
    headings = trajectory.state[::steps_per_beat, :, PSI]
    per_beat = np.diff(headings, axis=0)
    away = np.abs(per_beat - per_beat[-1]).max(axis=1) > SETTLED_RAD_PER_BEAT
    unsettled = np.flatnonzero(away)
    transient = 0 if unsettled.size == 0 else int(unsettled[-1]) + 1
    drift = float(np.abs(per_beat[-1] - per_beat[-2]).max()) if per_beat.shape[0] > 1 else np.inf
    return transient, drift


def beat_period(carrier_speed_rad_s: float) -> float:
    """2 pi / Omega: a revolution of the carrier, modulated or not.

    Raises:
        SwimInputError: a carrier speed that is not finite and > 0.
    """
    if not (math.isfinite(carrier_speed_rad_s) and carrier_speed_rad_s > 0.0):
        raise SwimInputError(f"carrier speed must be > 0 rad/s, got {carrier_speed_rad_s!r}")
    return 2.0 * math.pi / carrier_speed_rad_s


def modulation_turns(
    tail: Tail,
    fish: FishParameters,
    mean_speed_rad_s: float,
    depths: npt.ArrayLike,
    phases_rad: npt.ArrayLike,
    settings: TurnSettings = DEFAULT_SETTINGS,
    progress: Callable[[int], None] | None = None,
) -> SteadyTurn:
    """The steady turn at each (depth, phase) pair (broadcast together), one batch.

    Raises:
        CarrierProfileError: a depth outside [0, 0.9] (the engine's).
        SwimInputError: a carrier speed that is not finite and > 0, or bad settings.
    """
    period = beat_period(mean_speed_rad_s)
    depth, phase = np.broadcast_arrays(
        np.atleast_1d(np.asarray(depths, dtype=float)),
        np.atleast_1d(np.asarray(phases_rad, dtype=float)),
    )
    profiles = [
        CarrierSpeedProfile(mean_speed_rad_s, float(d), float(p))
        for d, p in zip(depth, phase, strict=True)
    ]
    drive = modulated_drive(tail, profiles)
    return steady_turn(drive, fish, depth.size, period, settings, progress)


def pivot_shift_turns(
    tail: Tail,
    fish: FishParameters,
    carrier_speed_rad_s: float,
    pivot_shifts_m: npt.ArrayLike,
    settings: TurnSettings = DEFAULT_SETTINGS,
    progress: Callable[[int], None] | None = None,
) -> SteadyTurn:
    """The steady turn at each pivot shift (the carrier at constant speed), one batch.

    Raises:
        PivotShiftError: a shift outside ``tail.pivot_shift_range()`` (the engine's).
        SwimInputError: a carrier speed that is not finite and > 0, or bad settings.
    """
    period = beat_period(carrier_speed_rad_s)
    shifts = np.atleast_1d(np.asarray(pivot_shifts_m, dtype=float))
    tails = [tail.with_pivot_shift(float(shift)) for shift in shifts]
    drive = constant_speed_drive(tails, carrier_speed_rad_s)
    return steady_turn(drive, fish, shifts.size, period, settings, progress)


class StrongestPhases(NamedTuple):
    """The modulation phases that turn the fish most to the left and to the right."""

    left_rad: float
    right_rad: float
    #: r̄/f [rad] at those phases, from the scan's trigonometric interpolant.
    left_yaw_per_beat_rad: float
    right_yaw_per_beat_rad: float


def strongest_phases(
    phases_rad: npt.ArrayLike, yaw_per_beat_rad: npt.ArrayLike, resolution: int = 3600
) -> StrongestPhases:
    """The phases of the largest and smallest r̄/f of a scan equally spaced over a revolution.

    The effect is smooth and periodic in phi_0 (to first order in the depth a pure first
    harmonic), so the scan's trigonometric interpolant is evaluated on ``resolution`` phases and
    its extremes taken: the best phases are found between the scanned ones. Phases in [0, 2 pi).

    Raises:
        SwimInputError: fewer than 3 phases, not equally spaced over 2 pi, or values not shaped
            like them.
    """
    phases = np.asarray(phases_rad, dtype=float)
    values = np.asarray(yaw_per_beat_rad, dtype=float)
    count = phases.size
    spacing = 2.0 * np.pi / count if count else 0.0
    if (
        count < 3
        or values.shape != phases.shape
        or not np.allclose(np.diff(phases), spacing, atol=1e-9)
    ):
        raise SwimInputError("the phase scan must be 3 or more phases equally spaced over 2 pi")
    coefficients = np.fft.rfft(values) / count
    weights = np.full(coefficients.size, 2.0)
    weights[0] = 1.0
    if count % 2 == 0:
        weights[-1] = 1.0  # the Nyquist term is its own conjugate
    fine = np.arange(resolution) * (2.0 * np.pi / resolution)
    harmonics = np.arange(coefficients.size)
    curve = (
        (weights * coefficients)[None, :] * np.exp(1j * np.outer(fine - phases[0], harmonics))
    ).real.sum(axis=1)
    left, right = int(np.argmax(curve)), int(np.argmin(curve))
    return StrongestPhases(
        float(fine[left]), float(fine[right]), float(curve[left]), float(curve[right])
    )
