"""The pilot's control law: a velocity command or a goal in, carrier and pivot commands out.

Plain Python (no rclpy; :mod:`fishtail_pilot.node` wires it to the topics), so that the law runs
and is tested in closed loop without ROS. It steers by the fish's speed and heading averaged over
the last beat (:class:`BeatAverage`), since both wiggle within every beat: speed by feed-forward
and PI feedback, heading by a yaw-per-beat demand that a :class:`Steering` means turns into its
actuator's input. Times are the caller's, in seconds. The law, its gains and its measured
responses: docs/steering.md ("The pilot").
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections import deque
from typing import NamedTuple, Protocol

from fishtail_common.parameters import ParameterSpec
from fishtail_kinematics.engine.carrier_profile import (
    DEFAULT_TOP_SPEED_RAD_S,
    CarrierSpeedProfile,
)

TWO_PI = 2.0 * math.pi


def goal_distance_text(distance_m: float) -> str:
    """How far the goal is, or that the fish's position is not known yet.

    >>> goal_distance_text(2.5), goal_distance_text(math.nan)
    ('2.500 m to go', 'distance unknown until the first odometry')
    """
    if math.isnan(distance_m):
        return "distance unknown until the first odometry"
    return f"{distance_m:.3f} m to go"


def wrap_angle(angle_rad: float) -> float:
    """``angle_rad`` brought into (-pi, pi]: the turn the short way, left at exactly half a turn.

    >>> round(wrap_angle(3 * math.pi / 2), 6), wrap_angle(-math.pi) == math.pi
    (-1.570796, True)
    """
    wrapped = (angle_rad + math.pi) % TWO_PI - math.pi
    return math.pi if wrapped == -math.pi else wrapped


class BeatAverage:
    """The time-weighted mean of a signal over a sliding window (the last beat).

    Samples are held for the window's length; the mean is the trapezoid integral over them divided
    by their time span. A window shorter than the samples' spacing gives the latest value.

    >>> average = BeatAverage()
    >>> for t in range(5):
    ...     average.add(float(t), float(t))
    >>> average.mean(2.0)  # samples at 2, 3, 4
    3.0
    """

    def __init__(self) -> None:
        """Empty."""
        self._samples: deque[tuple[float, float]] = deque()
        self._integral = 0.0

    def add(self, time_s: float, value: float) -> None:
        """Append a sample (times increasing)."""
        samples = self._samples
        if samples:
            last_time, last_value = samples[-1]
            self._integral += 0.5 * (value + last_value) * (time_s - last_time)
        samples.append((time_s, value))

    def mean(self, window_s: float) -> float:
        """The mean over the last ``window_s`` seconds of samples (NaN before the first sample)."""
        samples = self._samples
        if not samples:
            return math.nan
        latest_time, latest_value = samples[-1]
        while len(samples) > 1 and latest_time - samples[1][0] >= window_s:
            (first_time, first_value), (second_time, second_value) = samples[0], samples[1]
            self._integral -= 0.5 * (first_value + second_value) * (second_time - first_time)
            samples.popleft()
        span = latest_time - samples[0][0]
        if span <= 0.0:
            return latest_value
        return self._integral / span

    def clear(self) -> None:
        """Forget every sample."""
        self._samples.clear()
        self._integral = 0.0


class SteeringCommand(NamedTuple):
    """What a steering means asks of the actuators for one yaw-per-beat demand."""

    depth: float  # modulation depth of the carrier's speed (0: constant speed)
    phase_rad: float  # carrier angle of the fastest point
    pivot_shift_m: float | None  # None: this means has no pivot actuator
    yaw_per_beat_rad: float  # what the command achieves, r / f (the demand, or the limit)


class Steering(Protocol):
    """A steering means, mapping a wanted yaw per beat (r / f, rad) to its actuator's input."""

    name: str

    @property
    def yaw_per_beat_range_rad(self) -> tuple[float, float]:
        """The most negative (rightward) and most positive (leftward) r / f it can give."""

    def command(self, yaw_per_beat_rad: float) -> SteeringCommand:
        """The input that gives ``yaw_per_beat_rad`` (at the range's end beyond it)."""

    def input_for(self, yaw_per_beat_rad: float) -> float:
        """The actuator's input that gives ``yaw_per_beat_rad``."""

    def turning_radius_at(self, steering_input: float) -> float:
        """The signed radius of the steady circle at ``steering_input`` (m, > 0 left)."""


@dataclasses.dataclass(frozen=True)
class PilotSettings:
    """Gains and limits of the pilot (the node's parameters, with their units)."""

    #: U / f of straight swimming: the distance covered per beat (m).
    speed_per_beat_m: float
    #: The driver's highest carrier speed (rad/s): the profile's peak stays within it.
    max_carrier_speed_rad_s: float = DEFAULT_TOP_SPEED_RAD_S
    #: Carrier speed per m/s of beat-mean speed error, as a fraction of the feed-forward's slope.
    speed_gain: float = 2.0
    #: Integral action of the speed loop (1/s): the fraction of the error added per second. Slow:
    #: the feed-forward holds the cruising speed, and what the integral gathers while the fish
    #: accelerates it overshoots by afterwards (0.2 left the default fish 11 % over for 4 beats).
    speed_integral_per_s: float = 0.1
    #: Heading error to yaw demand per beat (rad per beat per rad of error). Per beat, not per
    #: second: the fish answers its steering within a beat at any beat frequency (the default
    #: fish's fin plate damps its yaw: 93 % of a step's turn in the first beat). With the beat
    #: mean half a beat old, a gain near 1 or above makes the heading hunt from side to side
    #: through the deepest modulation; 0.7 settles.
    heading_gain_per_beat: float = 0.7
    #: Speed towards a goal (m/s); the carrier's limit caps it.
    cruise_speed_m_s: float = 0.3
    #: Within this distance of a goal the speed falls in proportion to the distance (m).
    slow_down_distance_m: float = 1.0
    #: A goal this close is reached: the carrier stops (m).
    goal_tolerance_m: float = 0.2
    #: How far the motor's speed lags its command (s): the modulation's phase is asked that much
    #: of a revolution early, so that the carrier is fastest where the steering table wants it.
    #: The DC gear motor under the firmware's 30 Hz loop lags 80-100 ms (docs/serial.md).
    motor_lag_s: float = 0.1
    #: The beat-mean window before the carrier turns (s); after that, one beat.
    idle_window_s: float = 1.0


_DEFAULTS = PilotSettings(speed_per_beat_m=1.0)

#: The pilot's gains and limits as parameters (the node's; defaults from PilotSettings).
CONTROL_PARAMETERS: tuple[ParameterSpec, ...] = (
    ParameterSpec("speed_gain", _DEFAULTS.speed_gain,
                  "speed feedback, as a multiple of the feed-forward's carrier speed per m/s", "",
                  0.0, 20.0),
    ParameterSpec("speed_integral_per_s", _DEFAULTS.speed_integral_per_s,
                  "integral action of the speed loop", "1/s", 0.0, 10.0),
    ParameterSpec("heading_gain_per_beat", _DEFAULTS.heading_gain_per_beat,
                  "yaw per beat asked per radian of heading error", "1/beat", 0.0, 10.0),
    ParameterSpec("cruise_speed_m_s", _DEFAULTS.cruise_speed_m_s,
                  "speed towards a goal", "m/s", 0.0, 10.0),
    ParameterSpec("slow_down_distance_m", _DEFAULTS.slow_down_distance_m,
                  "within this distance of a goal the speed falls with the distance", "m",
                  0.01, 100.0),
    ParameterSpec("goal_tolerance_m", _DEFAULTS.goal_tolerance_m,
                  "a goal this close is reached and the carrier stops", "m", 0.01, 10.0),
    ParameterSpec("max_carrier_speed_rad_s", _DEFAULTS.max_carrier_speed_rad_s,
                  "the driver's top carrier speed: the profile's peak stays within it", "rad/s",
                  0.1, 1000.0),
    ParameterSpec("motor_lag_s", _DEFAULTS.motor_lag_s,
                  "how far the motor's speed lags its command: the modulation is asked that much "
                  "early (bench/bench_profile_following.py measures it)", "s", 0.0, 1.0),
)  # fmt: skip
#: A goal this close is reached (the console's route uses it too).
GOAL_TOLERANCE = next(spec for spec in CONTROL_PARAMETERS if spec.name == "goal_tolerance_m")


#: The profile's peak stays this fraction below the carrier's top speed.
PEAK_MARGIN = 1e-9
#: The longest step the speed loop's integral takes (s): after a gap in the odometry, the loop
#: resumes instead of jumping by the whole gap's error.
MAX_CONTROL_STEP_S = 0.2
#: The lowest carrier speed while a speed is wanted, as a share of the feed-forward's.
MIN_FEED_FORWARD_SHARE = 0.5
#: A steering turns both ways when its strongest turn each way is at least this share of its
#: strongest turn the other way; below, it turns one way only. The pivot shift turns right at
#: most a tenth as strongly as left (no more than the Cardan tail's own curve), the modulation
#: both ways alike: any share between serves.
BOTH_WAYS_SHARE = 0.5
#: A goal further than this from the world origin in x or y is refused (m): a fish in a tank or
#: a pond swims metres, and a goal kilometres off is a mistake (a unit or a garbled message).
MAX_GOAL_COORDINATE_M = 1000.0


class Mode(enum.Enum):
    """What the pilot is doing."""

    IDLE = "idle"  # carrier stopped: no command, the watchdog fired, or a goal was reached
    VELOCITY = "velocity"  # following cmd_vel
    GOAL = "goal"  # swimming to goal_pose


class PilotCommand(NamedTuple):
    """The commands to send: the carrier's profile and the pivot's position (None: no pivot)."""

    carrier: CarrierSpeedProfile
    pivot_shift_m: float | None


class LimitReport(NamedTuple):
    """A command beyond what the fish can do: what was asked and what it can do instead."""

    quantity: str  # "speed" or "yaw_rate"
    requested: float
    achievable: float
    unit: str
    reason: str


class Pilot:
    """The control law: commands and odometry in, :class:`PilotCommand` out."""

    def __init__(self, settings: PilotSettings, steering: Steering) -> None:
        """Start idle with the carrier stopped."""
        self.settings = settings
        self.steering = steering
        self.mode = Mode.IDLE
        self.speed_command_m_s = 0.0
        self.yaw_rate_command_rad_s = 0.0
        self.goal: tuple[float, float] | None = None
        self.goal_reached = False
        self._heading_reference: float | None = None
        self._speed = BeatAverage()
        self._heading = BeatAverage()
        self._yaw_rate = BeatAverage()
        self._unwrapped_heading: float | None = None
        self._last_time_s: float | None = None
        self._integral_rad_s = 0.0
        self.mean_speed_m_s = math.nan
        self.mean_heading_rad = math.nan
        self.predicted_heading_rad = math.nan
        self.position_m = (math.nan, math.nan)
        self.command = PilotCommand(CarrierSpeedProfile(0.0), None)
        self.limit_reports: dict[str, LimitReport] = {}
        #: False from a sample with a non-finite value until the next finite one: blind, the
        #: carrier stops (the mode, command and goal stand).
        self.feedback_valid = True
        #: Odometry samples dropped for a non-finite value, since start-up.
        self.dropped_samples = 0
        #: Why the goal was given up while flying it (out of reach from where the fish got to),
        #: until :meth:`pop_refusal` takes it.
        self.refusal: str | None = None
        #: Whether the goal's reach was judged from a known pose (at set_goal or since).
        self._reach_judged = False

    # ------------------------------------------------------------------ commands
    def set_velocity(self, forward_m_s: float, yaw_rate_rad_s: float) -> str | None:
        """Follow a velocity command from now on; the reason if it is refused (NaN, reverse)."""
        if not (math.isfinite(forward_m_s) and math.isfinite(yaw_rate_rad_s)):
            return f"cmd_vel ({forward_m_s!r}, {yaw_rate_rad_s!r}) is not finite"
        if forward_m_s < 0.0:
            return (
                f"cmd_vel linear.x = {forward_m_s:g} m/s: the fish cannot swim backwards "
                "(achievable: 0 and above)"
            )
        if self.mode is not Mode.VELOCITY:
            self._integral_rad_s = 0.0
        if self.mode is not Mode.VELOCITY or yaw_rate_rad_s != self.yaw_rate_command_rad_s:
            # A new turn starts from the heading the fish has, owing nothing from the last one.
            self._heading_reference = None
        self.mode = Mode.VELOCITY
        self.goal = None
        self.speed_command_m_s = forward_m_s
        self.yaw_rate_command_rad_s = yaw_rate_rad_s
        return None

    def set_goal(self, x_m: float, y_m: float) -> str | None:
        """Swim to (x, y) in the world frame; the reason if it is refused.

        A goal that is not finite, beyond :data:`MAX_GOAL_COORDINATE_M` of the world origin in
        x or y, or out of the steering's reach from the fish's pose (:meth:`reach_refusal`), is
        refused and the pilot goes on as before. Before the first odometry the reach is judged
        on the first sample: a goal out of reach then is given up (:attr:`refusal`).
        """
        if not (math.isfinite(x_m) and math.isfinite(y_m)):
            return f"goal_pose ({x_m!r}, {y_m!r}) is not finite"
        if max(abs(x_m), abs(y_m)) > MAX_GOAL_COORDINATE_M:
            return (
                f"goal_pose ({x_m:g}, {y_m:g}) m refused: goals lie within "
                f"{MAX_GOAL_COORDINATE_M:g} m of the world origin in x and y"
            )
        repeated = self.mode is Mode.GOAL and self.goal == (x_m, y_m)
        if not repeated:
            # A goal sent again (fishtail-run does every second) is the one being flown: its
            # reach is the flight's to judge (_steer_to_goal).
            reason = self.reach_refusal(x_m, y_m)
            if reason is not None:
                return reason
            self._reach_judged = all(map(math.isfinite, self.position_m))
        if self.mode is not Mode.GOAL:
            self._integral_rad_s = 0.0
        self.mode = Mode.GOAL
        self.goal = (x_m, y_m)
        self.goal_reached = False
        self.yaw_rate_command_rad_s = 0.0
        return None

    def stop(self) -> PilotCommand:
        """Stop the carrier (the watchdog, an odometry loss); the pivot keeps its position."""
        self.mode = Mode.IDLE
        self.speed_command_m_s = 0.0
        self.yaw_rate_command_rad_s = 0.0
        self._integral_rad_s = 0.0
        self.limit_reports.clear()
        self.command = PilotCommand(CarrierSpeedProfile(0.0), self.command.pivot_shift_m)
        return self.command

    # ------------------------------------------------------------------ odometry
    def observe(
        self,
        time_s: float,
        x_m: float,
        y_m: float,
        yaw_rad: float,
        surge_m_s: float,
        yaw_rate_rad_s: float,
    ) -> PilotCommand:
        """One odometry sample (pose in world, surge and yaw rate): the commands for now.

        A sample with a non-finite value (a tracker's NaN) is dropped and counted
        (``dropped_samples``): until a finite one comes, ``feedback_valid`` is False and the
        carrier is stopped, as for lost odometry; the mode, command and goal stand.
        """
        if not all(map(math.isfinite, (time_s, x_m, y_m, yaw_rad, surge_m_s, yaw_rate_rad_s))):
            self.dropped_samples += 1
            self.feedback_valid = False
            return PilotCommand(CarrierSpeedProfile(0.0), self.command.pivot_shift_m)
        self.feedback_valid = True
        if self._unwrapped_heading is None:
            unwrapped = yaw_rad
        else:
            unwrapped = self._unwrapped_heading + wrap_angle(yaw_rad - self._unwrapped_heading)
        self._unwrapped_heading = unwrapped
        self._speed.add(time_s, surge_m_s)
        self._heading.add(time_s, unwrapped)
        window = self._window_s()
        self.mean_speed_m_s = self._speed.mean(window)
        self.mean_heading_rad = self._heading.mean(window)
        # That mean is the heading of half a beat ago. Swimming to a goal, whose bearing swings
        # fast as the fish nears it, the pilot steers on it brought up to now with the beat's mean
        # yaw rate; following cmd_vel it steers on the mean itself, whose lag costs nothing there
        # and which is free of the noise the estimate adds.
        self._yaw_rate.add(time_s, yaw_rate_rad_s)
        self.predicted_heading_rad = self.mean_heading_rad + 0.5 * window * self._yaw_rate.mean(
            window
        )
        self.position_m = (x_m, y_m)
        dt = 0.0 if self._last_time_s is None else time_s - self._last_time_s
        dt = min(max(dt, 0.0), MAX_CONTROL_STEP_S)
        self._last_time_s = time_s
        if self.mode is Mode.IDLE:
            return self.command
        if self.mode is Mode.GOAL:
            self._steer_to_goal()
            if self.mode is Mode.IDLE:
                return self.command
        self.command = self._control(dt)
        return self.command

    def _window_s(self) -> float:
        mean_speed = self.command.carrier.mean_speed_rad_s
        if mean_speed <= 0.0:
            return self.settings.idle_window_s
        return TWO_PI / mean_speed

    def distance_to_goal_m(self) -> float:
        """From the fish's centre of mass to the goal (NaN without a goal)."""
        if self.goal is None:
            return math.nan
        return math.hypot(self.goal[0] - self.position_m[0], self.goal[1] - self.position_m[1])

    def _steer_to_goal(self) -> None:
        assert self.goal is not None
        distance = self.distance_to_goal_m()
        if distance <= self.settings.goal_tolerance_m:
            self.goal_reached = True
            self.stop()
            return
        # Judged in full once the pose is known; in flight only once the fish has passed it: the
        # heading swings while the tail starts and within every beat, and a goal a hair beyond
        # the reach ahead may still be passed within the tolerance.
        reason = self.reach_refusal(*self.goal, passed_only=self._reach_judged)
        self._reach_judged = True
        if reason is not None:
            # Flown on, a goal the fish cannot turn to would be swum away from for ever.
            self.refusal = reason
            self.goal = None
            self.stop()
            return
        settings = self.settings
        self.speed_command_m_s = settings.cruise_speed_m_s * min(
            1.0, distance / settings.slow_down_distance_m
        )
        bearing = math.atan2(self.goal[1] - self.position_m[1], self.goal[0] - self.position_m[0])
        error = wrap_angle(bearing - self.predicted_heading_rad)
        if self._inside_turning_circle(error):
            # Turning towards it would circle the goal for ever: swim straight on until the
            # goal lies outside the tightest circle on that side, then turn.
            error = 0.0
        elif settings.heading_gain_per_beat > 0.0:
            # Near the goal the heading gain alone turns the fish too little: the steady turn
            # through the goal, 2 sin(error) / distance a metre, grows as the distance shrinks,
            # and a fish that turns less passes the goal on the outside, to loop back to it.
            # So the pilot asks for that turn when it is the larger.
            through = 2.0 * math.sin(error) * settings.speed_per_beat_m / distance
            needed = through / settings.heading_gain_per_beat
            if abs(needed) > abs(error):
                error = needed
        # The control law compares the reference with the mean heading.
        self._heading_reference = self.mean_heading_rad + error

    def _inside_turning_circle(self, bearing_error_rad: float) -> bool:
        # Inside by more than the goal tolerance: the tightest turn passes within the tolerance
        # of a goal less deep inside. The circle is the steering table's own: the default fish
        # answers its steering within a beat, and a wider circle sends it straight on past a goal
        # on its tightest circle, as a square's next corner is, to loop back from metres away.
        # A one-way steering flies no goal inside its circle (reach_refusal), and on its other
        # side its widest turn comes closest.
        assert self.goal is not None
        radius = self.min_turning_radius_m(bearing_error_rad)
        heading = self.predicted_heading_rad
        if self.one_way() != 0.0 or not (math.isfinite(radius) and math.isfinite(heading)):
            return False
        side = math.copysign(1.0, bearing_error_rad)
        centre_x = self.position_m[0] - side * radius * math.sin(heading)
        centre_y = self.position_m[1] + side * radius * math.cos(heading)
        depth = radius - math.hypot(self.goal[0] - centre_x, self.goal[1] - centre_y)
        return depth > self.settings.goal_tolerance_m

    def _control(self, dt: float) -> PilotCommand:
        settings = self.settings
        reports: dict[str, LimitReport] = {}
        # Speed: feed-forward carrier speed of the wanted speed, plus PI on the beat mean.
        slope = TWO_PI / settings.speed_per_beat_m  # carrier rad/s per m/s
        top_speed_m_s = settings.max_carrier_speed_rad_s / slope
        wanted = self.speed_command_m_s
        error = wanted - self.mean_speed_m_s if math.isfinite(self.mean_speed_m_s) else 0.0
        mean_speed = slope * wanted + settings.speed_gain * slope * error + self._integral_rad_s
        if wanted > top_speed_m_s:
            reports["speed"] = LimitReport(
                "speed", wanted, top_speed_m_s, "m/s",
                f"the carrier's top speed {settings.max_carrier_speed_rad_s:g} rad/s",
            )  # fmt: skip
        # Heading: the yaw demand as yaw per beat at the beat frequency the speed loop asks for.
        if self.mode is Mode.VELOCITY:
            self._advance_reference(dt)
        heading_error = 0.0
        if self._heading_reference is not None and math.isfinite(self.mean_heading_rad):
            heading_error = self._heading_reference - self.mean_heading_rad
        low, high = self.steering.yaw_per_beat_range_rad
        beat_hz = max(mean_speed, 0.0) / TWO_PI
        yaw_per_beat = settings.heading_gain_per_beat * heading_error
        if beat_hz > 0.0:
            yaw_per_beat += self.yaw_rate_command_rad_s / beat_hz
        steering = self.steering.command(yaw_per_beat if beat_hz > 0.0 else 0.0)
        # The profile's peak must stay within the carrier's top speed: a deep modulation costs
        # mean speed.
        depth = steering.depth
        # A hair below the limit, so that rounding cannot put the peak above the driver's.
        ceiling = (
            settings.max_carrier_speed_rad_s
            * math.sqrt((1.0 - depth) / (1.0 + depth))
            * (1.0 - PEAK_MARGIN)
        )
        # The carrier never drops below half the feed-forward while a speed is wanted: a stopped
        # tail cannot steer, and, held off the axis, it is a rudder that turns the gliding fish.
        floor_speed = wanted
        if self.mode is Mode.GOAL and math.isfinite(self.mean_speed_m_s):
            # Nearing a goal the wanted speed falls, but the fish glides on (drag is its one
            # brake) while it steers hardest: a carrier slowed below the fish's own speed turns
            # it less per metre and it passes the goal, to circle back. So the floor follows the
            # fish's speed too.
            floor_speed = max(wanted, self.mean_speed_m_s)
        floor = min(MIN_FEED_FORWARD_SHARE * slope * floor_speed, ceiling)
        pushing_up = mean_speed >= ceiling and error > 0.0
        pushing_down = mean_speed <= floor and error < 0.0
        if not (pushing_up or pushing_down):
            # Integrate only while the carrier can still act on the error (no wind-up).
            self._integral_rad_s += (
                settings.speed_integral_per_s * settings.speed_gain * slope * (error * dt)
            )
        mean_speed = min(max(mean_speed, floor), ceiling)
        wanted_yaw = self.yaw_rate_command_rad_s
        beat_hz_wanted = slope * wanted / TWO_PI
        if wanted_yaw != 0.0:
            reach = (high if wanted_yaw > 0.0 else low) * min(
                beat_hz_wanted, settings.max_carrier_speed_rad_s / TWO_PI
            )
            if abs(wanted_yaw) > abs(reach):
                reports["yaw_rate"] = LimitReport(
                    "yaw_rate", wanted_yaw, reach, "rad/s",
                    f"{self.steering.name} steering turns at most {abs(reach):.4g} rad/s at "
                    f"{min(wanted, top_speed_m_s):.3g} m/s (a turning radius of at least "
                    f"{self.min_turning_radius_m(wanted_yaw):.3g} m at any speed)",
                )  # fmt: skip
        self.limit_reports = reports
        # The motor reaches each speed a lag late, a carrier angle of Omega tau further on.
        phase = steering.phase_rad - mean_speed * settings.motor_lag_s if depth > 0.0 else 0.0
        profile = CarrierSpeedProfile(mean_speed, depth, phase % TWO_PI)
        return PilotCommand(profile, steering.pivot_shift_m)

    @property
    def heading_reference_rad(self) -> float:
        """The heading the pilot steers towards, unwrapped as the beat mean (NaN: none yet)."""
        return math.nan if self._heading_reference is None else self._heading_reference

    def max_heading_lead_rad(self) -> float:
        """How far the reference may run ahead of the beat-mean heading following cmd_vel.

        Half the strongest turn a beat (the beat mean is half a beat old in a steady turn) plus
        the error at which the heading gain alone asks for the strongest turn: more would only
        be a debt of turning to pay after the command ends.
        """
        low, high = self.steering.yaw_per_beat_range_rad
        reach = max(abs(low), abs(high))
        gain = self.settings.heading_gain_per_beat
        return 0.5 * reach + (reach / gain if gain > 0.0 else 0.0)

    def _advance_reference(self, dt: float) -> None:
        if self._heading_reference is None:
            if not math.isfinite(self.mean_heading_rad):
                return
            self._heading_reference = self.mean_heading_rad
        # The reference turns at the commanded rate as far as the steering can turn the fish at
        # the beat frequency it is driven at (none while the carrier is stopped), ...
        low, high = self.steering.yaw_per_beat_range_rad
        beat_hz = max(self.command.carrier.mean_speed_rad_s, 0.0) / TWO_PI
        rate = min(max(self.yaw_rate_command_rad_s, low * beat_hz), high * beat_hz)
        self._heading_reference += rate * dt
        # ... and stays within a saturating lead of the heading, so that the loop does not wind
        # up a debt of turning while the fish is held back.
        lead = self._heading_reference - self.mean_heading_rad
        bound = self.max_heading_lead_rad()
        if abs(lead) > bound:
            self._heading_reference = self.mean_heading_rad + math.copysign(bound, lead)

    def pop_refusal(self) -> str | None:
        """Why the goal was given up while flying it (None: it was not), once."""
        reason, self.refusal = self.refusal, None
        return reason

    def one_way(self) -> float:
        """+1 if the steering turns only left, -1 only right, 0 both ways (or not at all).

        One way only: its strongest turn the other way is under :data:`BOTH_WAYS_SHARE` of its
        strongest turn this way.
        """
        low, high = self.steering.yaw_per_beat_range_rad
        left, right = max(high, 0.0), max(-low, 0.0)
        if right < BOTH_WAYS_SHARE * left:
            return 1.0
        if left < BOTH_WAYS_SHARE * right:
            return -1.0
        return 0.0

    def reach_refusal(self, x_m: float, y_m: float, passed_only: bool = False) -> str | None:
        """Why (x, y) is out of a one-way steering's reach from the fish's pose (None: in reach).

        A steering that turns both ways reaches every goal: one inside its tightest circle it
        passes straight until the goal is outside. One that turns only one way cannot do that
        (the goal would fall to its other side), so it reaches a goal only if the goal lies on
        its way and outside its tightest circle, or ahead on its other way within the widest
        circle it turns that way; within the goal tolerance of either circle counts. Unknown
        (None) before the first odometry. ``passed_only``: a goal ahead of the fish is not
        judged (None).
        """
        way = self.one_way()
        heading = self.predicted_heading_rad
        x0_m, y0_m = self.position_m
        if way == 0.0 or not all(map(math.isfinite, (heading, x0_m, y0_m))):
            return None
        tolerance = self.settings.goal_tolerance_m
        dx, dy = x_m - x0_m, y_m - y0_m
        distance = math.hypot(dx, dy)
        if distance <= tolerance:
            return None
        # The goal in the fish's frame, mirrored so that the steering's one way is to the left.
        ahead = dx * math.cos(heading) + dy * math.sin(heading)
        aside = way * (dy * math.cos(heading) - dx * math.sin(heading))
        if passed_only and ahead >= 0.0:
            return None
        low, high = self.steering.yaw_per_beat_range_rad
        strong, weak = (high, low) if way > 0.0 else (low, high)
        tightest_m = abs(self._turning_radius_m(strong))
        # The weak end's signed radius, > 0 where even it turns the one way.
        weakest_m = way * self._turning_radius_m(weak)
        one, other = ("left", "right") if way > 0.0 else ("right", "left")
        side = one if aside >= 0.0 else other
        angle = abs(math.degrees(math.atan2(aside, ahead)))
        start = (
            f"goal ({x_m:.3f}, {y_m:.3f}) m is out of reach: {self.steering.name} steering "
            f"turns only {one}, tightest radius {tightest_m:.3g} m; the goal lies "
            f"{distance:.3g} m away, {angle:.0f}° to the {side}, "
        )
        end = f" (it reaches goals ahead or to the {one} outside that circle)"
        if tightest_m - math.hypot(ahead, aside - tightest_m) > tolerance:
            return start + "inside that circle" + end
        if aside < 0.0:
            turns_back = weakest_m < 0.0 and math.isfinite(weakest_m)
            if turns_back:
                beyond = math.hypot(ahead, aside - weakest_m) < -weakest_m - tolerance
            else:
                beyond = aside < -tolerance
            if ahead < 0.0 or beyond:
                where = (
                    f"where it turns no tighter than a radius of {-weakest_m:.3g} m"
                    if turns_back
                    else "where it does not turn"
                )
                return start + where + end
        return None

    def _turning_radius_m(self, yaw_per_beat_rad: float) -> float:
        """The steering's signed steady radius at ``yaw_per_beat_rad`` (m, > 0 left)."""
        return self.steering.turning_radius_at(self.steering.input_for(yaw_per_beat_rad))

    def min_turning_radius_m(self, direction: float) -> float:
        """The tightest circle the steering gives turning towards ``direction``'s sign (m)."""
        # The steering's own radius: a deep modulation also swims further a beat than straight
        # swimming does, so its circle is wider than (U/f straight) / (r/f).
        low, high = self.steering.yaw_per_beat_range_rad
        yaw_per_beat = high if direction > 0.0 else low
        if yaw_per_beat == 0.0 or (yaw_per_beat > 0.0) != (direction > 0.0):
            return math.inf
        return abs(self.steering.turning_radius_at(self.steering.input_for(yaw_per_beat)))
