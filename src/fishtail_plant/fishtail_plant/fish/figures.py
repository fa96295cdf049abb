"""Swimming figures of a trajectory over whole beats, and the cycle-average steady speed.

What the command line, the steering tables and the checks report of a run: Ū, thrust, tail
power, Froude efficiency, St and the turning radius, all over whole beats so that the wiggle
within a beat does not count. Beat ends must fall on recorded samples (a step that divides the
beat period). Definitions: docs/swimming-dynamics.md ("The report's mechanisms with the default
fish"; the steady speed under "Checks").

>>> from fishtail_plant.fish.tail_drive import SinusoidalTailDrive
>>> drive = SinusoidalTailDrive(0.2, 0.0, np.array([0.2, 0.4]), 2 * np.pi)
>>> speeds = steady_surge_speed(drive, FishParameters(), drive.beat_period_s)
>>> bool(speeds[1] > speeds[0] > 0.0)
True
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_plant.errors import BeatAlignmentError, NoSteadySpeedError
from fishtail_plant.fish import formulas
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.integrator import Trajectory
from fishtail_plant.fish.model import (
    PSI,
    SURGE,
    SWAY,
    YAW_RATE,
    FinDrag,
    GeneralisedForce,
    Recoil,
    SwimModel,
    X,
    Y,
    fin_direction,
    fin_drag,
    fin_recoil,
)
from fishtail_plant.fish.model import trailing_edge_force as _trailing_edge_force
from fishtail_plant.fish.tail_drive import TailDrive, TailSample

# How far period/step may be from an integer and still count as whole steps per beat.
_ALIGNMENT_TOLERANCE = 1e-6
#: Samples per beat of the cycle means (a periodic trapezoid rule: spectrally accurate).
CYCLE_SAMPLES = 128
#: The same with a fin plate's drag: |w| w has a kink where w changes sign, so the rule is no
#: longer spectral (at 128 samples the balance speed is some 1e-7 off; at 1024, 1e-10).
FIN_DRAG_CYCLE_SAMPLES = 1024
# Bracket doublings and bisections of the steady speed with a fin's drag: 2^-64 of the bracket.
_BRACKET_DOUBLINGS = 60
_BISECTIONS = 64
# The balance speed's root is found to this fraction of itself (or of 1 µm/s near 0).
_ROOT_TOLERANCE = 1e-12
_ROOT_FLOOR_M_S = 1e-6


class BeatWindow(NamedTuple):
    """Record indices of the beat ends of each fish: shape (beats + 1, N), the last beat last."""

    indices: npt.NDArray[np.int_]
    duration_s: FloatArray


def beat_window(trajectory: Trajectory, beat_period_s: npt.ArrayLike, beats: int) -> BeatWindow:
    """The last ``beats`` whole beats (from t = 0, one per period) recorded for each fish.

    Raises:
        BeatAlignmentError: the recording interval does not divide a beat period, or the
            trajectory holds fewer than ``beats`` whole beats (or ``beats`` < 1).
    """
    period = np.broadcast_to(np.asarray(beat_period_s, dtype=float), trajectory.state.shape[1:2])
    per_beat = period / trajectory.step_s
    samples_per_beat = np.rint(per_beat).astype(int)
    if np.any(np.abs(per_beat - samples_per_beat) > _ALIGNMENT_TOLERANCE * per_beat) or np.any(
        samples_per_beat < 1
    ):
        raise BeatAlignmentError(
            f"the recording interval {trajectory.step_s!r} s does not divide the beat periods "
            f"{period.tolist()} s"
        )
    last = trajectory.time_s.size - 1
    complete = last // samples_per_beat
    if beats < 1 or np.any(complete < beats):
        raise BeatAlignmentError(
            f"{beats} whole beats asked, the trajectory holds {complete.tolist()}"
        )
    ends = complete * samples_per_beat
    indices = ends[None, :] - np.arange(beats, -1, -1)[:, None] * samples_per_beat[None, :]
    return BeatWindow(indices, beats * period)


def _window_mean(values: FloatArray, time_s: FloatArray, window: BeatWindow) -> FloatArray:
    # Trapezoidal mean of each fish's column over its own window: cumulative integral, differenced.
    steps = np.diff(time_s)[:, None] * 0.5 * (values[1:] + values[:-1])
    integral = np.concatenate([np.zeros((1, values.shape[1])), np.cumsum(steps, axis=0)])
    fish = np.arange(values.shape[1])
    start, end = window.indices[0], window.indices[-1]
    mean = (integral[end, fish] - integral[start, fish]) / window.duration_s
    return np.asarray(mean, dtype=float)


class BeatMeans(NamedTuple):
    """Means over whole beats, one element per fish."""

    mean_speed_m_s: FloatArray
    mean_surge_m_s: FloatArray
    mean_sway_m_s: FloatArray
    mean_yaw_rate_rad_s: FloatArray
    heading_change_per_beat_rad: FloatArray
    turning_radius_m: FloatArray


def beat_means(trajectory: Trajectory, beat_period_s: npt.ArrayLike, beats: int) -> BeatMeans:
    """Ū, <u>, <v>, <r>, the heading change per beat and the turning radius over the last beats.

    Raises:
        BeatAlignmentError: as :func:`beat_window`.
    """
    window = beat_window(trajectory, beat_period_s, beats)
    fish = np.arange(trajectory.state.shape[1])
    ends = trajectory.state[window.indices, fish[None, :]]
    chords = np.hypot(np.diff(ends[..., X], axis=0), np.diff(ends[..., Y], axis=0))
    turns = np.diff(ends[..., PSI], axis=0)
    mean_chord = chords.mean(axis=0)
    mean_turn = turns.mean(axis=0)
    with np.errstate(divide="ignore"):
        radius = np.where(
            mean_turn != 0.0, mean_chord / (2.0 * np.sin(0.5 * mean_turn)), np.inf
        )
    state, time_s = trajectory.state, trajectory.time_s
    return BeatMeans(
        chords.sum(axis=0) / window.duration_s,
        _window_mean(state[..., SURGE], time_s, window),
        _window_mean(state[..., SWAY], time_s, window),
        _window_mean(state[..., YAW_RATE], time_s, window),
        mean_turn,
        radius,
    )


def turning_radius(trajectory: Trajectory, beat_period_s: npt.ArrayLike, beats: int) -> FloatArray:
    """Signed radius of the circle the beat-end positions lie on (> 0 left, inf straight).

    Raises:
        BeatAlignmentError: as :func:`beat_window`.
    """
    return beat_means(trajectory, beat_period_s, beats).turning_radius_m


class TailFigures(NamedTuple):
    """Time-stepped tail figures over whole beats, one element per fish."""

    mean_thrust_n: FloatArray
    tail_power_w: FloatArray
    froude_efficiency: FloatArray
    tip_excursion_m: FloatArray
    strouhal_number: FloatArray


def tail_power(force: GeneralisedForce, tail: TailSample) -> FloatArray:
    """Rate at which the tail works against the reactive force: -F_T . (-Tx_dot, Ty_dot).

    The tip's velocity relative to the body is (-Tx_dot, Ty_dot) in the body frame (the tail
    frame's x points backward).
    """
    power: FloatArray = formulas.tip_power(force.x, force.y, tail.tip_x_dot, tail.tip_y_dot)
    return power


def fin_drag_tail_power(plate: FinDrag, tail: TailSample) -> FloatArray:
    """Rate at which the tail works against the fin plate's drag, as it moves in the body.

    The plate's resultant acts at T, which moves at (-Tx_dot, Ty_dot), and its moment about T
    on a plate turning at -th_dot in the body frame. Held at rest it is ∫ k |w|³ ds >= 0.
    """
    power: FloatArray = formulas.fin_drag_power(
        plate.force.x, plate.force.y, plate.moment_about_tip, tail.tip_x_dot, tail.tip_y_dot,
        tail.fin_rate,
    )  # fmt: skip
    return power


def recoil_tail_power(
    recoil: Recoil,
    fish: FishParameters,
    tail: TailSample,
    body_acceleration: tuple[FloatArray, FloatArray, FloatArray] | None = None,
) -> FloatArray:
    """Rate at which the tail works against the fin's recoil, a force at mid-chord M.

    M moves in the body at (-Tx_dot, Ty_dot) - (c/2) th_dot (sin th, cos th). The recoil's
    added-mass part needs the body's acceleration (u_dot, v_dot, r_dot); None: the body is held.
    Held at rest its mean is zero (a derivative of a periodic quantity), but not with the body
    moving: the tail then works against -m c w_c (th_dot - r) t, along the plate.
    """
    force_x, force_y = recoil.rest.x, recoil.rest.y
    if body_acceleration is not None:
        along = sum(
            g * rate for g, rate in zip(recoil.direction, body_acceleration, strict=True)
        )
        pull = recoil.added_mass_kg * along
        force_x = force_x - pull * recoil.direction[0]
        force_y = force_y - pull * recoil.direction[1]
    power: FloatArray = formulas.recoil_power(
        np.asarray(fish.fin_chord_m), *fin_direction(tail), tail.tip_x_dot, tail.tip_y_dot,
        tail.fin_rate, force_x, force_y,
    )  # fmt: skip
    return power


class HeldTail(NamedTuple):
    """The tail's push on the body, its yaw moment about C and its power, per sample."""

    push_n: FloatArray
    yaw_moment_n_m: FloatArray
    power_w: FloatArray
    tail: TailSample  # the tail at those samples


def held_tail(
    drive: TailDrive,
    fish: FishParameters,
    time_s: npt.ArrayLike,
    surge_speed_m_s: npt.ArrayLike,
    yaw_rate_rad_s: npt.ArrayLike = 0.0,
) -> HeldTail:
    """The tail's forces on the body held at u = U, v = 0, r (towed, not accelerating).

    As :func:`tail_thrust_and_power`: Lighthill's force and the plate's drag in the push and the
    moment; the tail's work against all three, the recoil included, in the power (towed at U its
    mean is not zero: the carrier pays it). The recoil's push is left out (its mean over a beat
    is zero); its moment is kept, which turning at r leaves nonzero.
    """
    time = np.asarray(time_s, dtype=float)
    tail = drive.sample(time)
    u = np.asarray(surge_speed_m_s, dtype=float) + np.zeros_like(tail.tip_x)
    r = np.asarray(yaw_rate_rad_s, dtype=float) + np.zeros_like(u)
    held = np.zeros_like(u)
    force = _trailing_edge_force(fish, tail, u, held, r).force
    push, moment, power = force.x, force.z, tail_power(force, tail)
    if fish.has_fin_drag:
        plate = fin_drag(fish, tail, u, held, r)
        push, moment = push + plate.force.x, moment + plate.force.z
        power = power + fin_drag_tail_power(plate, tail)
    if np.any(np.asarray(fish.fin_chord_m) > 0.0):
        recoil = fin_recoil(fish, tail, drive.acceleration(time), u, held, r)
        moment = moment + recoil.rest.z
        power = power + recoil_tail_power(recoil, fish, tail)
    return HeldTail(push, moment, power, tail)


def tail_thrust_and_power(
    model: SwimModel, time_s: npt.ArrayLike, state: FloatArray
) -> tuple[FloatArray, FloatArray, TailSample]:
    """The tail's push on the body F_x and its power into the water at each state, and the tail.

    The push: Lighthill's force and the plate's drag. The power: the tail's work against both
    and against the recoil of a fin with chord, so that its mean is what the carrier delivers to
    the water. The recoil's push is left out: over whole beats of periodic swimming it is the
    change of a periodic momentum, zero.
    """
    flow, _, tail = model.forces(time_s, state)
    push, power = flow.force.x, tail_power(flow.force, tail)
    u, v, r = (state[..., column] for column in (SURGE, SWAY, YAW_RATE))
    if model.has_fin_drag:
        plate = fin_drag(model.fish, tail, u, v, r)
        push, power = push + plate.force.x, power + fin_drag_tail_power(plate, tail)
    if model.has_recoil:
        rates = model.derivatives(time_s, state)
        recoil = fin_recoil(model.fish, tail, model.drive.acceleration(time_s), u, v, r)
        body_acceleration = (rates[..., SURGE], rates[..., SWAY], rates[..., YAW_RATE])
        power = power + recoil_tail_power(recoil, model.fish, tail, body_acceleration)
    return push, power, tail


def tail_figures(
    model: SwimModel, trajectory: Trajectory, beat_period_s: npt.ArrayLike, beats: int
) -> TailFigures:
    """<F_T,x>, P_tail, eta = <F_T,x> Ū / P_tail, A and St = f A / Ū over the last beats.

    Thrust and power as :func:`tail_thrust_and_power`: with a fin plate, its drag in both, and
    the tail's work against its recoil in the power.

    Raises:
        BeatAlignmentError: as :func:`beat_window`.
    """
    window = beat_window(trajectory, beat_period_s, beats)
    push, power, tail = tail_thrust_and_power(model, trajectory.time_s[:, None], trajectory.state)
    thrust = _window_mean(push, trajectory.time_s, window)
    mean_power = _window_mean(power, trajectory.time_s, window)
    speed = beat_means(trajectory, beat_period_s, beats).mean_speed_m_s
    start, end = window.indices[0], window.indices[-1]
    record = np.arange(trajectory.time_s.size)[:, None]
    inside = (record >= start[None, :]) & (record <= end[None, :])
    tip_y = np.broadcast_to(tail.tip_y, inside.shape)
    excursion = np.where(inside, tip_y, -np.inf).max(axis=0) - np.where(
        inside, tip_y, np.inf
    ).min(axis=0)
    frequency = beats / window.duration_s
    return TailFigures(
        thrust, mean_power, thrust * speed / mean_power, excursion, frequency * excursion / speed
    )


def _tail_force_x(
    fish: FishParameters, tail: TailSample, surge_speed_m_s: npt.ArrayLike
) -> FloatArray:
    """The tail's x force on the body held at u = U, v = r = 0: Lighthill's and the plate's."""
    u = np.asarray(surge_speed_m_s, dtype=float) + np.zeros_like(tail.tip_x)
    zero = np.zeros_like(u)
    force: FloatArray = _trailing_edge_force(fish, tail, u, zero, zero).force.x
    if fish.has_fin_drag:
        force = force + fin_drag(fish, tail, u, zero, zero).force.x
    return force


def _cycle_samples(
    drive: TailDrive, beat_period_s: npt.ArrayLike, samples: int
) -> TailSample:
    period = np.asarray(beat_period_s, dtype=float)
    return drive.sample(np.arange(samples)[:, None] / samples * period)


def cycle_mean_tail_force(
    drive: TailDrive,
    fish: FishParameters,
    surge_speed_m_s: npt.ArrayLike,
    beat_period_s: npt.ArrayLike,
    samples: int | None = None,
) -> FloatArray:
    """<F_T,x> over one beat with the body held at u = U, v = r = 0 (one element per fish).

    Lighthill's force and the fin plate's drag. The recoil of a fin with chord is a time
    derivative of a periodic quantity when the body is held, so its mean is zero and it is left
    out. ``samples`` per beat: by default :func:`cycle_samples_for` the fish.
    """
    tail = _cycle_samples(drive, beat_period_s, samples or cycle_samples_for(fish))
    return np.asarray(_tail_force_x(fish, tail, surge_speed_m_s).mean(axis=0), dtype=float)


def cycle_samples_for(fish: FishParameters) -> int:
    """Samples per beat for the cycle means of ``fish``: more when its plate's drag has a kink."""
    return FIN_DRAG_CYCLE_SAMPLES if fish.has_fin_drag else CYCLE_SAMPLES


def steady_surge_speed(
    drive: TailDrive,
    fish: FishParameters,
    beat_period_s: npt.ArrayLike,
    samples: int | None = None,
    strict: bool = True,
) -> FloatArray:
    """The U > 0 with <F_T,x>(U) = ½ rho S C_D U² + X_u U (sway and yaw held), one per fish.

    With v = r = 0 Lighthill's force is a quadratic in U (v_T is affine in U), so its cycle
    mean a + b U + c U² follows exactly from the means at U = 0, 1, -1 m/s and, without a fin's
    drag, the balance is a quadratic equation: no iteration. The plate's drag |w| w is not a
    polynomial in U: then the balance is bracketed and bisected, one bracket per fish.

    ``samples`` per beat: by default :func:`cycle_samples_for` the fish. Not ``strict``: NaN for
    a fish without a balance, so that a batch of candidate designs keeps its shape.

    Raises:
        NoSteadySpeedError: ``strict``, and a fish whose cycle-mean thrust never balances its
            drag at U > 0.
    """
    tail = _cycle_samples(drive, beat_period_s, samples or cycle_samples_for(fish))
    lighthill = fish if not fish.has_fin_drag else dataclasses.replace(
        fish, fin_normal_drag_coefficient=0.0
    )
    at_rest, ahead, astern = (
        _tail_force_x(lighthill, tail, speed).mean(axis=0) for speed in (0.0, 1.0, -1.0)
    )
    linear = 0.5 * (ahead - astern) - np.asarray(fish.surge_linear_damping_kg_s)
    quadratic = 0.5 * (ahead + astern) - at_rest - np.asarray(fish.drag_factor_kg_m)
    # a + b U + q U² = 0 with q < 0 (drag wins at speed) and a > 0 (thrust at rest).
    discriminant = linear * linear - 4.0 * quadratic * at_rest
    usable = (quadratic < 0.0) & (at_rest > 0.0) & (discriminant >= 0.0)
    if fish.has_fin_drag:
        return _bisected_speed(fish, tail, at_rest, linear, quadratic, usable, discriminant, strict)
    if not strict:
        with np.errstate(divide="ignore", invalid="ignore"):
            root = np.sqrt(np.where(usable, discriminant, np.nan))
            return np.asarray(np.where(usable, (2.0 * at_rest) / (root - linear), np.nan))
    if not usable.all():
        bad = int(np.flatnonzero(~np.broadcast_to(usable, at_rest.shape))[0])
        raise NoSteadySpeedError(
            f"fish {bad}: cycle-mean thrust {float(at_rest.ravel()[bad]):.6g} N at rest with "
            f"net quadratic coefficient {float(np.ravel(quadratic)[bad]):.6g} N s²/m² has no "
            "positive balance speed"
        )
    root = np.sqrt(discriminant)
    # The positive root, written to avoid cancellation: 2a / (-b + sqrt(b² - 4 a q)) with q < 0.
    return np.asarray((2.0 * at_rest) / (root - linear), dtype=float)


def _bisected_speed(
    fish: FishParameters,
    tail: TailSample,
    at_rest: FloatArray,
    linear: FloatArray,
    quadratic: FloatArray,
    usable: FloatArray,
    discriminant: FloatArray,
    strict: bool,
) -> FloatArray:
    """The balance with the plate's drag: bracket [0, U_hi] by doubling, then bisect.

    Not ``strict``: NaN where the thrust at rest does not beat the plate's drag, or where no
    bracket is found.
    """
    def net(speed: FloatArray) -> FloatArray:
        # Lighthill's polynomial, the damping, and the plate's drag averaged over the beat.
        u = speed + np.zeros_like(tail.tip_x)
        zero = np.zeros_like(u)
        plate = fin_drag(fish, tail, u, zero, zero).force.x.mean(axis=0)
        value: FloatArray = at_rest + speed * (linear + quadratic * speed) + plate
        return value

    rest = net(np.zeros_like(at_rest))
    moving = rest > 0.0
    if strict and not moving.all():
        bad = int(np.flatnonzero(np.ravel(rest) <= 0.0)[0])
        raise NoSteadySpeedError(
            f"fish {bad}: cycle-mean thrust {float(np.ravel(rest)[bad]):.6g} N at rest, with the "
            "fin's drag: no positive balance speed"
        )
    # Start from the balance without the plate's drag where it has one.
    with np.errstate(divide="ignore", invalid="ignore"):
        without_plate = (2.0 * at_rest) / (np.sqrt(discriminant) - linear)
    high = np.maximum(np.where(usable, without_plate, 0.1), 1e-3)
    high = np.where(moving, high, 1e-3)
    for _ in range(_BRACKET_DOUBLINGS):
        ahead = net(high) > 0.0
        if not ahead.any():
            break
        high = np.where(ahead, 2.0 * high, high)
    else:
        if strict:
            bad = int(np.flatnonzero(np.ravel(net(high)) > 0.0)[0])
            raise NoSteadySpeedError(
                f"fish {bad}: the thrust outgrows the drag at every speed up to "
                f"{float(np.ravel(high)[bad]):.3g} m/s"
            )
        moving = moving & (net(high) <= 0.0)
    speed = _bisect(net, np.zeros_like(high), high)
    return speed if strict else np.where(moving, speed, np.nan)


def _bisect(
    net: Callable[[FloatArray], FloatArray], low: FloatArray, high: FloatArray
) -> FloatArray:
    """The root of ``net`` (> 0 below it, < 0 above) in [low, high], per element.

    The Illinois variant of regula falsi (Dowell and Jarratt 1971): a secant step inside the
    bracket, the stale end's value halved when the same end moves twice, so that it converges
    superlinearly (about a dozen evaluations to rounding, against 64 bisections) and can never
    leave the bracket. Each element stops once its bracket is within 1e-12 of its root, so that
    its result does not depend on the other elements of the batch.
    """
    f_low, f_high = net(low), net(high)
    # Elements without a sign change have no root to refine (the caller says what they mean).
    bracketed = (f_low > 0.0) & (f_high <= 0.0)
    side = np.zeros(np.shape(low))
    for _ in range(_BISECTIONS):
        width = high - low
        active = bracketed & (width > _ROOT_TOLERANCE * np.maximum(np.abs(high), _ROOT_FLOOR_M_S))
        if not np.any(active):
            break
        with np.errstate(invalid="ignore", divide="ignore"):
            secant = high - f_high * width / (f_high - f_low)
        # Outside the open bracket (rounding, or equal values): bisect instead.
        inside = (secant > low) & (secant < high)
        middle = np.where(inside, secant, 0.5 * (low + high))
        f_middle = net(middle)
        # A converged element stays where it is: its root does not depend on the others'.
        above = np.where(active, f_middle > 0.0, False)
        f_middle = np.where(active, f_middle, f_high)
        middle = np.where(active, middle, high)
        # The root lies above ``middle``: it becomes the low end; the high end's value is
        # halved when the high end stayed for a second time in a row (Illinois).
        low, f_low = np.where(above, middle, low), np.where(above, f_middle, f_low)
        high, f_high = np.where(above, high, middle), np.where(above, f_high, f_middle)
        f_high = np.where(above & (side > 0.0), 0.5 * f_high, f_high)
        f_low = np.where(active & ~above & (side < 0.0), 0.5 * f_low, f_low)
        side = np.where(active, np.where(above, 1.0, -1.0), side)
    return np.asarray(np.where(np.abs(f_low) < np.abs(f_high), low, high), dtype=float)


class HeldFish(NamedTuple):
    """A fish held still (a bollard test), over one beat: one element per fish."""

    thrust_n: FloatArray  # <F_x> of the tail on the body
    tail_power_w: FloatArray  # the tail's mean power into the water
    fin_drag_power_w: FloatArray  # of which against the fin plate's drag (dissipated)


def held_fish(
    drive: TailDrive,
    fish: FishParameters,
    beat_period_s: npt.ArrayLike,
    samples: int | None = None,
) -> HeldFish:
    """Thrust and tail power of the fish held at rest, u = v = r = 0, over one beat.

    The recoil's mean force and power vanish over a beat (derivatives of periodic quantities).
    ``samples`` per beat: by default :func:`cycle_samples_for` the fish.
    """
    tail = _cycle_samples(drive, beat_period_s, samples or cycle_samples_for(fish))
    zero = np.zeros_like(tail.tip_x)
    flow = _trailing_edge_force(fish, tail, zero, zero, zero)
    plate = fin_drag(fish, tail, zero, zero, zero)
    thrust = (flow.force.x + plate.force.x).mean(axis=0)
    dissipation = fin_drag_tail_power(plate, tail).mean(axis=0)
    power = tail_power(flow.force, tail).mean(axis=0) + dissipation
    return HeldFish(
        np.asarray(thrust, dtype=float),
        np.asarray(power, dtype=float),
        np.asarray(dissipation, dtype=float),
    )
