"""What the serial backend's board should run: the node's command, as ``m`` or ``f``, and its ack.

Shared by the node's threads (:meth:`CommandState.set_profile`, never blocking) and the
backend's I/O thread (:meth:`CommandState.pending`, :meth:`CommandState.acknowledge`) under a
lock of its own. On the project's firmware (a :class:`~fishtail_driver.board_profile.BoardMode`
on board) a profile becomes one ``f`` (:class:`~fishtail_driver.board_profile.ProfileFields`),
sent again only when it changes and as a keep-alive; otherwise the speed at the last angle becomes
``m`` ticks per frame, as the node follows the profile. A stop is always ``m 0 0``. A non-zero
command is re-sent only while the node's last call is at most the hold old, so that the board's
auto-stop takes over if the node hangs. Behaviour: docs/serial.md.
"""

from __future__ import annotations

import dataclasses
import math
import threading

from fishtail_driver.board_profile import NOT_CONNECTED, BoardMode, ProfileFields
from fishtail_driver.profile_command import STOPPED
from fishtail_driver.status_counters import StatusCounters
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
from fishtail_plant.motor.board_units import Scale

#: What the board is asked to run: ticks per frame (``m``; 0 stops) or a profile (``f``).
BoardCommand = int | ProfileFields


@dataclasses.dataclass(frozen=True)
class Pending:
    """The I/O thread's view of the command at one moment."""

    command: BoardCommand
    acked: BoardCommand | None
    acked_at: float
    #: May go out now: a stop always, motion while the node's last call is within the hold.
    sendable: bool


class CommandState:
    """The node's latest command, who follows it, and what the board acknowledged last."""

    def __init__(self, scale: Scale, counters: StatusCounters, hold_s: float | None) -> None:
        """Stopped, nothing acknowledged, the firmware not known yet."""
        self.scale = scale
        self._counters = counters
        self._lock = threading.Lock()
        self._speed = 0.0
        self._ticks = 0
        self._profile = STOPPED  # the command in force, as a profile (flat for set_speed)
        self._mode = NOT_CONNECTED  # who follows profiles: the board or the host
        self._acked: BoardCommand | None = None
        self._acked_at = -math.inf
        self._set_at = -math.inf  # time of the node's last call
        self._hold_s = hold_s
        self._resends_paused = False

    # --- the node's side -------------------------------------------------------------------

    def set_profile(self, profile: CarrierSpeedProfile, speed_rad_s: float, now: float) -> bool:
        """``profile`` in force, its speed at the last angle ``speed_rad_s``; whether it is new.

        Raises:
            ValueError: a speed that is not finite.
        """
        ticks, clamped = self.scale.ticks_per_frame(speed_rad_s)
        if clamped:
            self._counters.count("clamped_commands")
        with self._lock:
            # Called at every sample while the host follows a profile: new only when there is
            # something new to send.
            new = ticks != self._ticks or profile != self._profile or self._resends_paused
            self._speed, self._ticks, self._profile = speed_rad_s, ticks, profile
            self._set_at = now
        return new

    def stop(self) -> None:
        """Stopped (the backend closing): the final ``m 0 0`` is sent by the I/O thread."""
        with self._lock:
            self._speed, self._ticks, self._profile = 0.0, 0, STOPPED

    @property
    def on_board(self) -> bool:
        """Whether the board follows the profile in force (the node need not follow it)."""
        with self._lock:
            return self._mode.follows(self._profile)

    @property
    def hold_s(self) -> float | None:
        """How long a non-zero command stays alive after the node's last call (None: forever)."""
        with self._lock:
            return self._hold_s

    @hold_s.setter
    def hold_s(self, hold_s: float | None) -> None:
        with self._lock:
            self._hold_s = hold_s

    # --- the I/O thread's side -------------------------------------------------------------

    def set_mode(self, mode: BoardMode) -> None:
        """Who follows profiles on the board just connected (or reset: ``k`` again)."""
        if mode.tuning_acknowledged:
            self._counters.count("profile_tunings")
        with self._lock:
            self._mode = mode

    @property
    def mode(self) -> BoardMode:
        """Who follows profiles on the board connected now."""
        with self._lock:
            return self._mode

    def forget_ack(self) -> None:
        """Nothing acknowledged (a connect, a board reset): the command goes out again now."""
        with self._lock:
            self._acked = None

    def acknowledge(self, command: BoardCommand, now: float) -> None:
        """The board answered ``OK`` to ``command`` at ``now``."""
        with self._lock:
            self._acked = command
            self._acked_at = now

    @property
    def driven(self) -> bool:
        """Whether the board was last acknowledged forward motion."""
        with self._lock:
            acked = self._acked
        return isinstance(acked, ProfileFields) or (acked is not None and acked > 0)

    def pending(self, now: float, zero_count: int | None) -> Pending:
        """What the board should run now, what it acknowledged, whether it may go out.

        ``zero_count``: the board's count at carrier angle 0 (sets ``f``'s phase; None before
        the first reading, when a profile is sent at phase 0 and again once a reading came).
        """
        with self._lock:
            command: BoardCommand = self._ticks
            fields = self._mode.fields(self._profile, zero_count or 0)
            if fields is not None:
                command = fields
            return Pending(command, self._acked, self._acked_at, self._sendable(command, now))

    def _sendable(self, command: BoardCommand, now: float) -> bool:
        """A stop always, motion while fresh (lock held); notes (and counts once) a pause."""
        hold = self._hold_s
        if command == 0 or hold is None or now - self._set_at <= hold:
            self._resends_paused = False
            return True
        if not self._resends_paused:
            self._resends_paused = True
            self._counters.count("resend_pauses")
        return False

    def change_due(self, pending: Pending) -> float:
        """When the command may replace the acknowledged one: a PID frame after a running one."""
        if pending.command == 0 or pending.acked is None or pending.acked == 0:
            return -math.inf  # a stop, a start, or nothing acknowledged since connecting
        return pending.acked_at + self.scale.frame_s

    # --- status ----------------------------------------------------------------------------

    def status_values(self) -> dict[str, str]:
        """The command, what was acknowledged, the firmware."""
        with self._lock:
            acked, mode = self._acked, self._mode
            values = {
                "target_speed_rad_s": f"{self._speed:.4f}",
                "target_ticks_per_frame": str(self._ticks),
                "resends_paused": str(self._resends_paused).lower(),
            }
        capabilities = mode.capabilities
        values["acked_ticks_per_frame"] = str(acked) if isinstance(acked, int) else ""
        profile = acked.encode().decode("ascii").strip() if isinstance(acked, ProfileFields) else ""
        values["acked_profile"] = profile
        values["firmware"] = mode.firmware
        values["profile_tuning"] = mode.tuning
        frame_ms = "" if capabilities is None else str(capabilities.pid_frame_ms)
        values["board_pid_frame_ms"] = frame_ms
        return values
