"""Settings of the serial backend and their checks: what cannot work is refused with the reason."""

from __future__ import annotations

import dataclasses

from fishtail_driver.protocol import CHANNELS, MAX_REPLY_BYTES, ProfileTuning, encode_update_pid
from fishtail_plant.motor.board_units import Scale


@dataclasses.dataclass(frozen=True)
class SerialConfig:
    """Serial backend settings; times in seconds.

    Args:
        port: device path (``/dev/ttyACM0``, ``/dev/serial/by-id/...``) or a pyserial URL.
        baud: line rate; must match the firmware's BAUDRATE.
        read_timeout_s: longest wait for one reply.
        channel: motor channel of the tail, "left" or "right" (the other one gets 0).
        counts_per_revolution: encoder counts per motor-shaft turn, as the board counts them.
        gear_ratio: motor-shaft turns per carrier turn.
        pid_rate_hz: the firmware's PID_RATE (the frame is ``1000 // pid_rate_hz`` ms).
        poll_rate_hz: encoder polls per second.
        resend_period_s: re-send the current non-zero ``m`` this often (< 2 s auto-stop).
        max_speed_rad_s: carrier speed limit; twice it bounds a plausible encoder step.
        handshake_timeout_s: how long the board may take to answer after the port opens.
        stale_timeout_s: no valid reply for this long while connected: the link is lost.
        reconnect_min_s: first reconnect backoff (doubles per failure ...).
        reconnect_max_s: ... up to this.
        max_line_bytes: longer reply lines are discarded as oversized.
        velocity_window_s: time span of the velocity estimate.
        fault_hold_s: status() is WARN for this long after a transient fault.
        pid_gains: optional (kp, kd, ki, ko) sent with ``u`` after every connect.
        command_hold_s: re-send a non-zero speed only while the last set_speed() call is at most
            this old (None: keep re-sending it until it changes); see
            :meth:`~fishtail_driver.serial_backend.SerialBackend.set_command_hold`.
        phase_warn_s: status() is WARN for this long after the angle was re-based.
        profile_on_board: on the project's firmware, let the board follow speed profiles (one
            ``f``); False: the host follows them with ``m`` on any firmware.
        profile_tuning: on the project's firmware with the profile on board, the ``k`` sent
            after ``v`` at every connect and board reset (None: not sent, its default loop).

    Raises:
        ValueError: a setting that cannot work (naming it and its bound), e.g. a resend period
            that would not beat the board's 2 s auto-stop.
    """

    port: str
    baud: int = 57600
    read_timeout_s: float = 0.1
    channel: str = "left"
    counts_per_revolution: int = 2048
    gear_ratio: float = 1.0
    pid_rate_hz: int = 30
    poll_rate_hz: float = 100.0
    resend_period_s: float = 0.5
    max_speed_rad_s: float = 20.0
    handshake_timeout_s: float = 5.0
    stale_timeout_s: float = 1.0
    reconnect_min_s: float = 0.1
    reconnect_max_s: float = 2.0
    max_line_bytes: int = MAX_REPLY_BYTES
    velocity_window_s: float = 0.1
    fault_hold_s: float = 2.0
    pid_gains: tuple[int, int, int, int] | None = None
    command_hold_s: float | None = None
    phase_warn_s: float = 10.0
    profile_on_board: bool = True
    profile_tuning: ProfileTuning | None = None

    def __post_init__(self) -> None:
        """Reject settings that cannot work, with the reason."""
        checks = (
            (isinstance(self.port, str) and self.port != "", "port must be a non-empty string"),
            (self.baud > 0, f"baud must be > 0, got {self.baud}"),
            (self.channel in CHANNELS, f"channel must be 'left' or 'right', got {self.channel!r}"),
            (0.0 < self.read_timeout_s <= 10.0,
             f"read_timeout_s must be in (0, 10], got {self.read_timeout_s}"),
            (0.0 < self.poll_rate_hz <= 10000.0,
             f"poll_rate_hz must be in (0, 10000], got {self.poll_rate_hz}"),
            (0.0 < self.resend_period_s <= 1.5,
             f"resend_period_s must be in (0, 1.5] to beat the board's 2 s auto-stop, "
             f"got {self.resend_period_s}"),
            (self.max_speed_rad_s > 0.0,
             f"max_speed_rad_s must be > 0, got {self.max_speed_rad_s}"),
            (self.handshake_timeout_s > 0.0,
             f"handshake_timeout_s must be > 0, got {self.handshake_timeout_s}"),
            (self.stale_timeout_s >= 2.0 * self.read_timeout_s,
             f"stale_timeout_s ({self.stale_timeout_s}) must be >= 2 x read_timeout_s "
             f"({self.read_timeout_s})"),
            (0.0 < self.reconnect_min_s <= self.reconnect_max_s,
             "need 0 < reconnect_min_s <= reconnect_max_s"),
            (self.max_line_bytes >= 32, f"max_line_bytes must be >= 32, got {self.max_line_bytes}"),
            (self.velocity_window_s > 0.0, "velocity_window_s must be > 0"),
            (self.command_hold_s is None or self.command_hold_s > 0.0,
             f"command_hold_s must be > 0 or None, got {self.command_hold_s}"),
            (self.phase_warn_s >= 0.0, f"phase_warn_s must be >= 0, got {self.phase_warn_s}"),
        )  # fmt: skip
        for ok, reason in checks:
            if not ok:
                raise ValueError(reason)
        # Validates counts_per_revolution, gear_ratio and pid_rate_hz.
        Scale(self.counts_per_revolution, self.gear_ratio, self.pid_rate_hz)
        if self.pid_gains is not None:
            encode_update_pid(*self.pid_gains)

    @property
    def scale(self) -> Scale:
        """The encoder's and the PID frame's units."""
        return Scale(self.counts_per_revolution, self.gear_ratio, self.pid_rate_hz)

    @property
    def byte_s(self) -> float:
        """Line time of one byte (start bit, 8 data bits, stop bit) [s]."""
        return 10.0 / self.baud

    @property
    def is_url(self) -> bool:
        """Whether ``port`` is a pyserial URL rather than a device path."""
        return "://" in self.port
