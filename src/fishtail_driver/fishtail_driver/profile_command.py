"""The carrier command the driver follows: a speed profile over the carrier angle, checked.

:class:`CarrierCommand` holds the profile in force (``motor/cmd_profile``, or the flat profile of
``motor/cmd_speed``) and gives the speed to command at every measured carrier angle, so that the
modulation stays in step with the carrier. A profile it cannot run is refused, never clipped (the
fish would steer by an amount nobody asked for), with what it could run instead. Plain Python.
The law, the refusals and what the motor follows: docs/serial.md ("Speed profiles").

>>> command = CarrierCommand(max_speed_rad_s=20.0)
>>> command.set_profile(6.0, 0.5, 0.0)
>>> round(command.follow(0.0), 3), round(command.follow(math.pi), 3)  # (1 +- 0.5) 6 / sqrt(0.75)
(10.392, 3.464)
>>> try:
...     command.set_profile(15.0, 0.5, 0.0)
... except CommandRefusedError as refusal:
...     print(refusal)  # doctest: +NORMALIZE_WHITESPACE
profile refused (mean 15 rad/s, depth 0.5, phase 0 rad): its peak speed 25.98 rad/s exceeds
max_speed_rad_s = 20 rad/s; achievable: depth 0.28 at mean 15 rad/s, or mean 11.55 rad/s at
depth 0.5
>>> command.profile.mean_speed_rad_s  # the one in force stays
6.0
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from fishtail_kinematics.engine.carrier_profile import MAX_DEPTH, CarrierSpeedProfile
from fishtail_kinematics.engine.errors import CarrierProfileError

#: The profile of a stopped motor.
STOPPED = CarrierSpeedProfile(0.0)
#: A peak this little above the limit is the limit (what a sender computed from the limit itself).
_PEAK_TOLERANCE = 1e-9


class CommandRefusedError(ValueError):
    """A command the driver refuses: the reason, and what it could do instead.

    ``achievable`` holds the nearest commands the driver would accept, by diagnostic key
    (``achievable_depth``, ``achievable_mean_speed_rad_s``); empty where nothing near is
    meaningful (a NaN, a negative speed).
    """

    def __init__(self, reason: str, achievable: Mapping[str, float] | None = None) -> None:
        """The reason (the message) and the achievable values."""
        super().__init__(reason)
        self.reason = reason
        self.achievable = dict(achievable or {})


def deepest_depth(mean_speed_rad_s: float, max_speed_rad_s: float) -> float:
    """The deepest modulation whose peak stays within ``max_speed_rad_s`` at this mean speed.

    The peak is Omega sqrt((1 + delta) / (1 - delta)); at most MAX_DEPTH; 0 when even the mean
    is above the limit.
    """
    if mean_speed_rad_s <= 0.0:
        return MAX_DEPTH
    ratio_squared = (max_speed_rad_s / mean_speed_rad_s) ** 2
    if ratio_squared <= 1.0:
        return 0.0
    return min(MAX_DEPTH, (ratio_squared - 1.0) / (ratio_squared + 1.0))


def highest_mean_speed(depth: float, max_speed_rad_s: float) -> float:
    """The highest mean speed whose peak at ``depth`` stays within ``max_speed_rad_s``."""
    return max_speed_rad_s * math.sqrt((1.0 - depth) / (1.0 + depth))


def _achievable(mean: float, depth: float, max_speed: float) -> dict[str, float]:
    """The deepest modulation at this mean and the fastest mean at this depth, where meaningful.

    Nothing for a field that is not a number, nor a depth for a mean that is too fast flat.
    """
    achievable: dict[str, float] = {}
    if not (math.isfinite(mean) and math.isfinite(depth)) or mean < 0.0:
        return achievable
    # A depth below 0 is nearest to 0, one above MAX_DEPTH to the deepest allowed.
    nearest_depth = min(max(depth, 0.0), MAX_DEPTH)
    if mean <= max_speed:
        achievable["achievable_depth"] = min(nearest_depth, deepest_depth(mean, max_speed))
    fastest = highest_mean_speed(nearest_depth, max_speed)
    if mean > fastest:
        achievable["achievable_mean_speed_rad_s"] = fastest
    return achievable


def check_profile(
    mean_speed_rad_s: float, depth: float, phase_rad: float, max_speed_rad_s: float
) -> CarrierSpeedProfile:
    """The profile these fields describe, if the driver can run it.

    Raises:
        CommandRefusedError: a field that is not finite, a negative mean, a depth outside
            [0, MAX_DEPTH] (the engine's reason), or a peak above ``max_speed_rad_s``; with the
            achievable values.
    """
    asked = f"mean {mean_speed_rad_s:g} rad/s, depth {depth:g}, phase {phase_rad:g} rad"
    try:
        profile = CarrierSpeedProfile(mean_speed_rad_s, depth, phase_rad)
    except CarrierProfileError as error:
        problem = str(error)
    else:
        peak = profile.peak_speed_rad_s
        if peak <= max_speed_rad_s * (1.0 + _PEAK_TOLERANCE):
            return profile
        problem = (
            f"its peak speed {peak:.4g} rad/s exceeds max_speed_rad_s = {max_speed_rad_s:g} rad/s"
        )
    achievable = _achievable(mean_speed_rad_s, depth, max_speed_rad_s)
    offers = []
    if "achievable_depth" in achievable:
        offers.append(
            f"depth {achievable['achievable_depth']:.3g} at mean {mean_speed_rad_s:g} rad/s"
        )
    if "achievable_mean_speed_rad_s" in achievable:
        nearest_depth = min(max(depth, 0.0), MAX_DEPTH)
        offers.append(
            f"mean {achievable['achievable_mean_speed_rad_s']:.4g} rad/s at depth {nearest_depth:g}"
        )
    hint = f"; achievable: {', or '.join(offers)}" if offers else ""
    raise CommandRefusedError(f"profile refused ({asked}): {problem}{hint}", achievable)


class CarrierCommand:
    """The profile in force, the speed it asks for at the last angle measured, and the counts."""

    def __init__(self, max_speed_rad_s: float) -> None:
        """Stopped; profiles may peak at ``max_speed_rad_s``, faster speed commands are clamped."""
        self.max_speed_rad_s = max_speed_rad_s
        self.profile = STOPPED
        #: Whether the speed depends on the angle (then it must follow every sample).
        self.modulated = False
        #: The speed last asked of the motor [rad/s].
        self.commanded_speed_rad_s = 0.0
        self.last_angle_rad = 0.0
        self.rejected_commands = 0
        self.clamped_commands = 0
        self.refused_profiles = 0
        #: The latest refusal of a profile, while no command has been accepted after it.
        self.pending_refusal: CommandRefusedError | None = None
        #: The latest refusal of a profile, kept for diagnostics.
        self.last_refusal: CommandRefusedError | None = None

    @property
    def moving(self) -> bool:
        """Whether the profile in force turns the carrier at all."""
        return self.profile.mean_speed_rad_s > 0.0

    def follow(self, angle_rad: float) -> float | None:
        """At a measured carrier angle: the speed to command now, or None if it has not changed.

        A flat profile's speed was commanded when it was accepted; a modulated one's is the
        profile's speed at this angle.
        """
        self.last_angle_rad = angle_rad
        if not self.modulated:
            return None
        speed = self.profile.speed_at(angle_rad)
        self.commanded_speed_rad_s = speed
        return speed

    def set_speed(self, speed_rad_s: float) -> str | None:
        """A flat profile at ``speed_rad_s``; returns a note to log if it was clamped to the limit.

        Raises:
            CommandRefusedError: a speed that is not finite or is negative (nothing changes).
        """
        if not math.isfinite(speed_rad_s) or speed_rad_s < 0.0:
            self.rejected_commands += 1
            raise CommandRefusedError(
                f"refused speed command {speed_rad_s!r} rad/s: the motor turns one way, "
                "commands must be finite and >= 0"
            )
        note = None
        if speed_rad_s > self.max_speed_rad_s:
            self.clamped_commands += 1
            note = (
                f"speed command {speed_rad_s:g} rad/s clamped to max_speed_rad_s = "
                f"{self.max_speed_rad_s:g}"
            )
            speed_rad_s = self.max_speed_rad_s
        self._accept(CarrierSpeedProfile(speed_rad_s))
        return note

    def set_profile(self, mean_speed_rad_s: float, depth: float, phase_rad: float) -> None:
        """Make this profile the one in force.

        Raises:
            CommandRefusedError: as :func:`check_profile`; the profile in force stays.
        """
        try:
            profile = check_profile(mean_speed_rad_s, depth, phase_rad, self.max_speed_rad_s)
        except CommandRefusedError as refusal:
            self.refused_profiles += 1
            self.pending_refusal = self.last_refusal = refusal
            raise
        self._accept(profile)

    def _accept(self, profile: CarrierSpeedProfile) -> float:
        """``profile`` in force from now; the speed it asks for at the last angle measured."""
        self.profile = profile
        self.modulated = profile.depth > 0.0 and profile.mean_speed_rad_s > 0.0
        self.pending_refusal = None
        self.commanded_speed_rad_s = profile.speed_at(self.last_angle_rad)
        return self.commanded_speed_rad_s

    def stop(self) -> None:
        """Stopped (the watchdog, the node's exit)."""
        self._accept(STOPPED)

    def status_values(self) -> dict[str, str]:
        """The profile in force, the speed asked, the counts and the latest refusal."""
        profile = self.profile
        values = {
            "commanded_speed_rad_s": f"{self.commanded_speed_rad_s:.4f}",
            "profile_mean_speed_rad_s": f"{profile.mean_speed_rad_s:.4f}",
            "profile_depth": f"{profile.depth:.4f}",
            "profile_phase_rad": f"{profile.phase_rad:.4f}",
            "rejected_commands": str(self.rejected_commands),
            "clamped_commands": str(self.clamped_commands),
            "refused_profiles": str(self.refused_profiles),
            "last_refused_profile": "" if self.last_refusal is None else self.last_refusal.reason,
        }
        if self.last_refusal is not None:
            for key, value in self.last_refusal.achievable.items():
                values[key] = f"{value:.4g}"
        return values
