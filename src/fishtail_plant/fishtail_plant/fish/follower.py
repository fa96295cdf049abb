"""One fish following a sampled carrier angle: RK4 between samples, swimming figures per beat.

The swimming simulator node's library (no ROS here): it feeds every accepted
``motor/joint_state`` sample to :meth:`SwimFollower.follow`, which integrates the fish over the
interval on the linearly interpolated carrier (the engine's tail solved at every RK4 stage) and
closes a beat, with its :class:`BeatFigures`, at each revolution. How samples, gaps, restarts and
beats are handled: docs/swimming-dynamics.md ("The simulator node").
"""

from __future__ import annotations

import copy
import math
from typing import NamedTuple

import numpy as np

from fishtail_kinematics.engine.carrier_profile import DEFAULT_TOP_SPEED_RAD_S
from fishtail_kinematics.engine.input_guard import JUMP_SPEED_MARGIN, plausible_advance_rad
from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_plant.errors import SwimInputError
from fishtail_plant.fish.beats import BeatAccumulator, BeatFigures
from fishtail_plant.fish.figures import tail_thrust_and_power
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.integrator import Stepper
from fishtail_plant.fish.model import PSI, STATE_SIZE, SURGE, SwimModel, X, Y
from fishtail_plant.fish.sampled_carrier import LinearCarrier, RecordedCarrier
from fishtail_plant.fish.tail_drive import EngineTailDrive

TWO_PI = 2.0 * math.pi
# Sub-intervals shorter than this are not integrated (a beat boundary that coincides with a
# sample up to rounding): far below any step, far above the rounding of times of a long run.
_MIN_SEGMENT_S = 1e-12
#: Largest carrier advance in one sub-step [rad]: 16 steps a beat, the fewest the library's checks
#: use, whatever the sample spacing and ``max_step_s``.
MAX_STEP_ANGLE_RAD = TWO_PI / 16
#: Default cap on the sub-steps of one sample: the work per sample is bounded (a few ms compiled).
DEFAULT_MAX_SUB_STEPS = 1000
#: The tail's figures (thrust, power, tip) of a beat's sub-steps are computed this many at a time,
#: and at the beat's end: one vectorised call instead of one per sample, the simulator's main cost.
DEFERRED_STEPS = 64
#: The most beats of history given to a fish that joins a carrier already turning: a fish from
#: rest is in its periodic state to 1e-6 after about 60 beats, whatever the speed.
JOIN_HISTORY_BEATS = 100
#: RK4 steps per beat of that history (the library's checks use 16 to 48).
JOIN_STEPS_PER_BEAT = 32
#: The history stops early once a beat changes the body velocities by less than this, relatively.
JOIN_CONVERGED = 1e-9


class StampNotIncreasingError(ValueError):
    """A sample stamped at or before the previous one: the fish's time cannot go back."""


class CarrierJumpError(SwimInputError):
    """The carrier advanced further than the motor can turn since the previous sample."""

    def __init__(self, advance_rad: float, elapsed_s: float, max_speed_rad_s: float) -> None:
        """The jump's advance over ``elapsed_s`` against the limit ``max_speed_rad_s``."""
        super().__init__(
            f"carrier jumped {advance_rad:.6g} rad in {elapsed_s:.6g} s "
            f"(the motor turns at most {max_speed_rad_s:g} rad/s)"
        )
        self.advance_rad = advance_rad
        self.elapsed_s = elapsed_s


class _Steps(NamedTuple):
    """Sub-steps integrated whose tail figures are not yet in the beat: times, states, carrier."""

    times_s: FloatArray
    states: FloatArray
    angles_rad: FloatArray
    speeds_rad_s: FloatArray


class SwimFollower:
    """One fish, from rest at the origin, swimming with the carrier's sampled motion."""

    def __init__(
        self,
        tail: Tail,
        fish: FishParameters,
        max_step_s: float,
        max_interval_s: float = math.inf,
        max_speed_rad_s: float = DEFAULT_TOP_SPEED_RAD_S,
        max_sub_steps: int = DEFAULT_MAX_SUB_STEPS,
    ) -> None:
        """Follow ``tail`` on ``fish`` (one fish: float parameters) with sub-steps <= max_step_s.

        A sub-step also turns the carrier by at most :data:`MAX_STEP_ANGLE_RAD`.
        ``max_interval_s``: a longer interval between samples is a gap, not integrated; so is one
        that would take more than ``max_sub_steps`` sub-steps. ``max_speed_rad_s``: the motor's top
        speed (default the driver's); a sample further ahead is a jump (:class:`CarrierJumpError`).

        Raises:
            ValueError: ``max_step_s`` not finite and positive, ``max_interval_s`` or
                ``max_speed_rad_s`` not positive, or ``max_sub_steps`` below 1.
        """
        if not (math.isfinite(max_step_s) and max_step_s > 0.0):
            raise ValueError(f"max_step_s must be finite and positive, got {max_step_s!r}")
        if not max_interval_s > 0.0:
            raise ValueError(f"max_interval_s must be positive, got {max_interval_s!r}")
        if not max_speed_rad_s > 0.0:
            raise ValueError(f"max_speed_rad_s must be positive, got {max_speed_rad_s!r}")
        if max_sub_steps < 1:
            raise ValueError(f"max_sub_steps must be at least 1, got {max_sub_steps!r}")
        self.fish = fish
        self.max_step_s = max_step_s
        self.max_interval_s = max_interval_s
        self.max_speed_rad_s = max_speed_rad_s
        self.max_sub_steps = max_sub_steps
        self.carrier = LinearCarrier()
        self._recorded = RecordedCarrier()
        self._use_tail(tail)
        self._body_length_m = float(fish.body_length_m)
        #: (1, 6): X, Y, psi in world; u, v, r in the body frame.
        self.state: FloatArray = np.zeros((1, STATE_SIZE))
        #: Seconds since the first sample (None before it).
        self.time_s: float | None = None
        self.angle_rad = 0.0
        #: Stamp of the first sample: the fish's time 0.
        self.first_stamp_ns = 0
        self._last_stamp_ns = 0
        self._next_boundary_rad = 0.0
        self._beat: BeatAccumulator | None = None
        #: Sub-steps of the beat in progress whose figures are still to be added to it.
        self._deferred: tuple[_Steps, ...] = ()
        self.beats_completed = 0
        self.sub_steps = 0
        self.restarts = 0
        #: Carrier advance [rad] and time [s] integrated so far (restarts and gaps excluded).
        self.integrated_rad = 0.0
        self.integrated_s = 0.0
        #: Beats completed since the last :meth:`take_beats`.
        self.finished: list[BeatFigures] = []

    @property
    def started(self) -> bool:
        """True once a sample has been followed."""
        return self.time_s is not None

    @property
    def last_stamp_ns(self) -> int:
        """Stamp of the last sample followed (0 before the first)."""
        return self._last_stamp_ns

    def sub_steps_for(self, duration_s: float, advance_rad: float) -> int:
        """An upper bound on the sub-steps of an interval (its beat boundaries included)."""
        by_time = math.ceil(duration_s / self.max_step_s)
        by_angle = math.ceil(max(advance_rad, 0.0) / MAX_STEP_ANGLE_RAD)
        # Each beat boundary may add one sub-step to either count.
        return by_time + by_angle + math.ceil(max(advance_rad, 0.0) / TWO_PI) + 1

    def follow(self, stamp_ns: int, angle_rad: float, speed_rad_s: float = 0.0) -> bool:
        """Integrate up to the sample at ``stamp_ns`` (after the previous one) with its angle.

        The first sample starts the fish at the origin, at rest unless the carrier is already
        turning: with ``speed_rad_s`` (the sample's velocity) above 0 and a positive angle, the
        fish starts with the body velocities it would have had the carrier turned at that speed
        since its angle was 0 (:meth:`joined_state`), so that when this follower starts, late or
        early, changes little. Later samples ignore ``speed_rad_s``.

        All or nothing: when the engine or the dynamics raise within the interval, the follower
        is left as it was, so the next sample integrates from the last one that succeeded. The
        state is a function of the (stamp, angle) samples only; a jump is held the same way, and
        an interval longer than ``max_interval_s`` or than ``max_sub_steps`` allow is a gap.

        Returns False for a sample held as too soon: within the encoder's slack of the last one
        but at a carrier speed over the margin (stamps microseconds apart); the next sample
        integrates from the last one taken, so no accepted interval turns the carrier faster
        than ``JUMP_SPEED_MARGIN`` x ``max_speed_rad_s``. True when the sample was taken.

        Raises:
            ValueError: a non-finite angle.
            StampNotIncreasingError: a stamp not after the previous sample's (the node's input
                guard drops both before).
            CarrierJumpError: the angle is further ahead than ``max_speed_rad_s`` allows (the
                follower is left as it was).
            FishtailKinematicsError: the engine refused the carrier's motion.
            SwimError: the dynamics refused the state.
        """
        if not math.isfinite(angle_rad):
            raise ValueError(f"carrier angle {angle_rad!r} is not finite")
        if self.time_s is None:
            self.state = self.joined_state(angle_rad, speed_rad_s)
            self.first_stamp_ns = self._last_stamp_ns = stamp_ns
            self.time_s = 0.0
            self.angle_rad = angle_rad
            self._next_boundary_rad = TWO_PI * math.ceil(angle_rad / TWO_PI)
            return True
        if stamp_ns <= self._last_stamp_ns:
            raise StampNotIncreasingError(
                f"stamp {stamp_ns} ns is not after the previous {self._last_stamp_ns}"
            )
        start_time, start_angle = self.time_s, self.angle_rad
        end_time = (stamp_ns - self.first_stamp_ns) * 1e-9
        duration = end_time - start_time
        advance = angle_rad - start_angle
        if advance > plausible_advance_rad(duration, self.max_speed_rad_s):
            raise CarrierJumpError(advance, duration, self.max_speed_rad_s)
        if abs(advance) > JUMP_SPEED_MARGIN * self.max_speed_rad_s * duration:
            return False
        if (
            duration > self.max_interval_s
            or self.sub_steps_for(duration, advance) > self.max_sub_steps
        ):
            self._last_stamp_ns = stamp_ns
            self._restart(end_time, angle_rad)
            return True
        speed = advance / duration
        carrier = self.carrier
        previous_carrier = (carrier.start_time_s, carrier.start_angle_rad, carrier.speed_rad_s)
        carrier.set(start_time, start_angle, speed)
        # Everything below works on local copies; the follower takes them only once the whole
        # interval is integrated, so a failure part-way cannot leave a half-advanced fish.
        try:
            state = self.state
            beat = copy.copy(self._beat)  # its sums grow in place
            deferred = self._deferred
            next_boundary = self._next_boundary_rad
            finished: list[BeatFigures] = []
            steps = 0
            segment_start = start_time
            # Beat boundaries crossed in this interval become sub-step boundaries.
            while speed > 0.0 and angle_rad >= next_boundary:
                crossing = start_time + (next_boundary - start_angle) / speed
                crossing = min(max(crossing, segment_start), end_time)
                state, segment_steps, deferred = self._integrate(
                    state, beat, deferred, segment_start, crossing
                )
                steps += segment_steps
                segment_start = crossing
                next_boundary += TWO_PI
                if beat is not None:
                    self._settle(beat, deferred)
                    index = self.beats_completed + len(finished)
                    finished.append(beat.figures(index, state, self._body_length_m))
                deferred = ()
                beat = BeatAccumulator(crossing, state, *self._tail_figures_now(crossing, state))
            state, segment_steps, deferred = self._integrate(
                state, beat, deferred, segment_start, end_time
            )
            steps += segment_steps
            if beat is not None and sum(len(d.times_s) for d in deferred) >= DEFERRED_STEPS:
                self._settle(beat, deferred)
                deferred = ()
        except BaseException:
            carrier.set(*previous_carrier)
            raise
        self.state = state
        self._beat = beat
        self._deferred = deferred
        self._next_boundary_rad = next_boundary
        self.finished.extend(finished)
        self.beats_completed += len(finished)
        self.sub_steps += steps
        self.integrated_rad += advance
        self.integrated_s += duration
        self._last_stamp_ns = stamp_ns
        self.time_s, self.angle_rad = end_time, angle_rad
        return True

    def joined_state(self, angle_rad: float, speed_rad_s: float) -> FloatArray:
        """The fish's state (1, 6) at the origin when it joins a carrier at ``speed_rad_s``.

        At rest unless the carrier turns (at most at its top speed) and ``angle_rad`` is
        positive; then the body velocities (u, v, r) of a fish that started from rest when the
        carrier's angle was 0 and has turned at ``speed_rad_s`` since (at most
        :data:`JOIN_HISTORY_BEATS` beats back; fewer once the beats repeat). Pose at the origin.

        Raises:
            SwimInputError: the dynamics diverged over that history.
        """
        state = np.zeros((1, STATE_SIZE))
        if not (0.0 < speed_rad_s <= self.max_speed_rad_s and angle_rad > 0.0):
            return state
        history_rad = min(angle_rad, JOIN_HISTORY_BEATS * TWO_PI)
        start_s = -history_rad / speed_rad_s
        self.carrier.set(start_s, angle_rad - history_rad, speed_rad_s)
        step_s = TWO_PI / JOIN_STEPS_PER_BEAT / speed_rad_s
        # A part beat first, then whole beats: each ends at the joining sample's phase, so that
        # two in a row can be compared for the periodic state.
        steps_left = math.ceil(history_rad / TWO_PI * JOIN_STEPS_PER_BEAT - 1e-9)
        chunk = steps_left % JOIN_STEPS_PER_BEAT or JOIN_STEPS_PER_BEAT
        records = np.empty((2, 1, STATE_SIZE))
        time_s = start_s
        previous = state[0, SURGE:]
        while steps_left > 0:
            state = self._stepper.advance(state, time_s, 0, chunk, step_s, chunk, records)
            if not np.isfinite(state).all():
                raise SwimInputError("the integration diverged over the carrier's history")
            time_s += chunk * step_s
            steps_left -= chunk
            chunk = JOIN_STEPS_PER_BEAT
            change = float(np.abs(state[0, SURGE:] - previous).max())
            if change <= JOIN_CONVERGED * float(np.abs(state[0, SURGE:]).max()):
                break
            previous = state[0, SURGE:]
        state = state.copy()
        state[0, [X, Y, PSI]] = 0.0
        return state

    def warm_up(self) -> None:
        """Compile now (or load from numba's cache) what following needs; the state is untouched.

        A throwaway fish with the same tail follows one beat: the first samples of a stream
        must not wait seconds for the compiler while later ones pile up and are lost.
        """
        rehearsal = SwimFollower(self.tail, self.fish, self.max_step_s)
        speed = 0.5 * self.max_speed_rad_s
        rehearsal.follow(0, TWO_PI, speed)
        for stamp_ns in (1_000_000, round(TWO_PI / speed * 1e9)):
            rehearsal.follow(stamp_ns, TWO_PI + speed * stamp_ns * 1e-9)

    def restart(self, stamp_ns: int, angle_rad: float, speed_rad_s: float = 0.0) -> None:
        """Follow the carrier afresh from this sample, whatever its stamp and angle.

        For a stream that restarted (a restarted driver, a replayed recording): the carrier's
        phase relative to the previous samples is unknown, so nothing is integrated up to this
        sample and the beat in progress is abandoned, as after a gap; the fish keeps its state.
        A stamp at or before the previous one moves the fish's time 0 (``first_stamp_ns``) by as
        much, so the fish's time stands still across the restart instead of going back.
        Before the first sample it is that sample (:meth:`follow`, with ``speed_rad_s``).

        Raises:
            ValueError: a non-finite angle.
        """
        if not math.isfinite(angle_rad):
            raise ValueError(f"carrier angle {angle_rad!r} is not finite")
        if self.time_s is None:
            self.follow(stamp_ns, angle_rad, speed_rad_s)
            return
        if stamp_ns <= self._last_stamp_ns:
            self.first_stamp_ns += stamp_ns - self._last_stamp_ns
        self._last_stamp_ns = stamp_ns
        self._restart((stamp_ns - self.first_stamp_ns) * 1e-9, angle_rad)

    def set_tail(self, tail: Tail) -> None:
        """Swim with ``tail`` from the next sample on; the fish's state and beat carry on.

        For a tail whose geometry changes slowly while it swims (the pivot actuator moving S):
        the change takes effect at a sample, a step in the tail's motion no larger than the
        actuator's travel in one sample interval.
        """
        if self._beat is not None:
            self._settle(self._beat, self._deferred)
        self._deferred = ()
        self._use_tail(tail)

    def _use_tail(self, tail: Tail) -> None:
        self.tail = tail
        self.model = SwimModel(self.fish, EngineTailDrive(tail, self.carrier))
        self._figures_model = SwimModel(self.fish, EngineTailDrive(tail, self._recorded))
        self._stepper = Stepper(self.model, 1)

    def take_beats(self) -> list[BeatFigures]:
        """The beats completed since the last call, oldest first."""
        finished, self.finished = self.finished, []
        return finished

    def _restart(self, time_s: float, angle_rad: float) -> None:
        self.restarts += 1
        self._beat = None
        self._deferred = ()
        self.time_s, self.angle_rad = time_s, angle_rad
        self._next_boundary_rad = TWO_PI * math.ceil(angle_rad / TWO_PI)

    def _tail_figures_now(self, time_s: float, state: FloatArray) -> tuple[float, float, float]:
        """Thrust F_T,x, tail power and the tip's body-frame y at ``time_s`` for ``state``."""
        thrust, power, tip_y = self._tail_figures(np.array([time_s]), state)
        return float(thrust[0]), float(power[0]), float(tip_y[0])

    def _tail_figures(
        self, time_s: FloatArray, states: FloatArray, model: SwimModel | None = None
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Thrust, tail power and tip y at each of ``time_s`` (K,) for ``states`` (K, 1, 6)."""
        # The library's figures (figures.tail_figures) sample by sample: plate and recoil too.
        push, power, tail = tail_thrust_and_power(model or self.model, time_s[:, None], states)
        return push[:, 0], power[:, 0], np.broadcast_to(tail.tip_y, power.shape)[:, 0]

    def _settle(self, beat: BeatAccumulator, deferred: tuple[_Steps, ...]) -> None:
        """Add the deferred sub-steps' figures to ``beat``, all in one call."""
        if not deferred:
            return
        times = np.concatenate([steps.times_s for steps in deferred])
        self._recorded.record(
            times,
            np.concatenate([steps.angles_rad for steps in deferred]),
            np.concatenate([steps.speeds_rad_s for steps in deferred]),
        )
        states = np.concatenate([steps.states for steps in deferred])
        figures = self._tail_figures(times, states, self._figures_model)
        for end, thrust, power, tip_y in zip(times.tolist(), *(f.tolist() for f in figures),
                                             strict=True):  # fmt: skip
            beat.add(end, thrust, power, tip_y)

    def _integrate(
        self,
        state: FloatArray,
        beat: BeatAccumulator | None,
        deferred: tuple[_Steps, ...],
        start_s: float,
        end_s: float,
    ) -> tuple[FloatArray, int, tuple[_Steps, ...]]:
        """``state`` integrated from ``start_s`` to ``end_s``, the steps, and ``deferred``.

        While a beat is in progress the steps join ``deferred``: :meth:`_settle` adds their
        figures to the beat later, many steps in one call.
        """
        length = end_s - start_s
        if length < _MIN_SEGMENT_S:
            return state, 0, deferred
        # A step a rounding error longer than max_step_s (stamps are whole nanoseconds) is one step.
        turned = abs(self.carrier.speed_rad_s) * length
        steps = max(
            1,
            math.ceil(length / self.max_step_s - 1e-6),
            math.ceil(turned / MAX_STEP_ANGLE_RAD - 1e-6),
        )
        step = length / steps
        states = np.empty((steps + 1, 1, STATE_SIZE))
        states[0] = state
        state = self._stepper.advance(state, start_s, 0, steps, step, 1, states)
        if not np.isfinite(state).all():
            raise SwimInputError(
                f"the integration diverged (non-finite state) from t = {start_s:.6f} s"
            )
        if beat is not None:
            ends: FloatArray = start_s + np.arange(1, steps + 1, dtype=np.float64) * step
            ends[-1] = end_s
            angles, speeds, _ = self.carrier(ends)
            deferred = (*deferred, _Steps(ends, states[1:], angles, speeds))
        return state, steps, deferred
