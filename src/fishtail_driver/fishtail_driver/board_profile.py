"""The carrier speed profile on the project's firmware: who follows it, and the ``f`` it takes.

At every connect the serial backend asks the board ``v``; :func:`board_mode` turns the answer
into a :class:`BoardMode`: on the project's firmware (firmware/CHANGES.md) the board follows the
profile itself and the driver sends it as one ``f`` (:meth:`BoardMode.fields`); on the stock
firmware, or when ``v`` failed, or when the encoder's revolution is not a whole number of counts
the firmware can hold, the driver follows it on the host with ``m`` as before. With the profile
on the board, :func:`tune_board` sends ``serial_profile_tuning`` as ``k`` and notes what became of
it (the exchange is passed in: no I/O of its own, no threads). docs/serial.md ("The project's
firmware").

>>> from fishtail_driver.protocol import BoardCapabilities
>>> from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
>>> from fishtail_plant.motor.board_units import Scale
>>> mode = board_mode(BoardCapabilities(1, 30, 33, True), True, Scale(64, 30.0))
>>> mode.firmware
'fishtail 1 (profile on board)'
>>> mode.fields(CarrierSpeedProfile(2 * math.pi, 0.5, 0.0), zero_count=-100)
ProfileFields(mean_q6=4055, depth_milli=500, phase_counts=1820, revolution=1920)
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

from fishtail_driver.protocol import (
    PROFILE_DEPTH_UNIT,
    PROFILE_MEAN_MAX,
    PROFILE_MEAN_SHIFT,
    PROFILE_REVOLUTION_MAX,
    BoardCapabilities,
    ProfileTuning,
    ReplyError,
    encode_profile,
    parse_accepted,
)
from fishtail_kinematics.engine.carrier_profile import CarrierSpeedProfile
from fishtail_plant.motor.board_units import Scale

STOCK_FIRMWARE = "stock ROSArduinoBridge"
ON_BOARD = "profile on board"
ON_HOST = "profile on host"
#: ``profile_tuning`` in /diagnostics when ``serial_profile_tuning`` is empty.
TUNING_NOT_SET = "not set (the board's default loop)"
ACKNOWLEDGED = "(acknowledged)"


@dataclasses.dataclass(frozen=True)
class ProfileFields:
    """``f MEAN:DEPTH:PHASE:REV`` in the firmware's integers."""

    #: Mean speed in 1/64 encoder ticks per PID frame.
    mean_q6: int
    #: Depth in thousandths.
    depth_milli: int
    #: The fastest point as the board's encoder count, in [0, revolution).
    phase_counts: int
    #: Encoder counts per carrier revolution.
    revolution: int

    def encode(self) -> bytes:
        """The command's bytes."""
        return encode_profile(self.mean_q6, self.depth_milli, self.phase_counts, self.revolution)


def board_revolution(scale: Scale) -> int | str:
    """Encoder counts per carrier revolution as the firmware takes them, or why it cannot.

    The board evaluates the law at its own count modulo a whole number of counts (1..65535).
    """
    counts = scale.counts_per_carrier_rev
    whole = round(counts)
    if abs(counts - whole) > 1e-9 * max(1.0, counts) or whole < 1:
        return (
            f"a carrier revolution is {counts:g} encoder counts, not a whole number "
            "(encoder_counts_per_revolution x gear_ratio)"
        )
    if whole > PROFILE_REVOLUTION_MAX:
        return f"a carrier revolution is {whole} encoder counts, over {PROFILE_REVOLUTION_MAX}"
    return whole


@dataclasses.dataclass(frozen=True)
class BoardMode:
    """Who follows the profile on the board connected now, and why (immutable: shared as is)."""

    #: For /diagnostics and the log, e.g. ``fishtail 1 (profile on board)``.
    firmware: str
    #: The board's capabilities (None: stock firmware, or not known).
    capabilities: BoardCapabilities | None = None
    #: Counts per carrier revolution, when the board follows the profile (None: the host does).
    revolution: int | None = None
    #: What became of ``serial_profile_tuning`` on this board (:func:`tune_board`).
    tuning: str = TUNING_NOT_SET

    @property
    def tuning_acknowledged(self) -> bool:
        """Whether the board acknowledged ``k`` (:func:`tune_board`)."""
        return self.tuning.endswith(ACKNOWLEDGED)

    @property
    def on_board(self) -> bool:
        """Whether profiles go to the board as ``f``."""
        return self.revolution is not None

    def mean_q6(self, mean_speed_rad_s: float) -> int | None:
        """``f``'s MEAN for this mean speed; None when the host follows or it exceeds 32767."""
        if self.revolution is None or self.capabilities is None:
            return None
        frame_s = self.capabilities.pid_frame_ms / 1000.0
        ticks = mean_speed_rad_s / (2.0 * math.pi) * self.revolution * frame_s
        mean = round(ticks * (1 << PROFILE_MEAN_SHIFT))
        return mean if 0 <= mean <= PROFILE_MEAN_MAX else None

    def follows(self, profile: CarrierSpeedProfile) -> bool:
        """Whether the board follows ``profile`` (False: the host does with ``m``, or it stops)."""
        return bool(self.mean_q6(profile.mean_speed_rad_s))

    def fields(self, profile: CarrierSpeedProfile, zero_count: int) -> ProfileFields | None:
        """``f``'s fields for ``profile``; None when the board cannot follow it, or it stops.

        ``zero_count`` is the board's count (on the tail's channel) at the driver's carrier
        angle 0: the host's law is evaluated at angle - phase_rad, the board's at its count -
        PHASE, so PHASE is that count plus the phase in counts, modulo a revolution.
        """
        mean = self.mean_q6(profile.mean_speed_rad_s)
        if not mean or self.revolution is None:
            return None  # too fast for f (the host follows it), or a stop (m 0 0)
        revolution = self.revolution
        depth = round(profile.depth * PROFILE_DEPTH_UNIT)
        phase = (zero_count + round(profile.phase_rad / (2.0 * math.pi) * revolution)) % revolution
        return ProfileFields(mean, depth, phase, revolution)

    def overflow_reason(self, profile: CarrierSpeedProfile) -> str:
        """Why the board cannot follow this (too fast) profile: for the log and diagnostics."""
        return (
            f"mean {profile.mean_speed_rad_s:g} rad/s exceeds f's {PROFILE_MEAN_MAX}/64 ticks per "
            "PID frame: followed on the host"
        )


def board_mode(reply: BoardCapabilities | None | str, enabled: bool, scale: Scale) -> BoardMode:
    """Who follows profiles, from the board's answer to ``v``.

    ``reply``: its capabilities, None for the stock firmware (Invalid Command), or why ``v``
    failed (no reply, garbled: then the host follows, as on the stock firmware). ``enabled``:
    the driver's ``profile_on_board``.
    """
    if isinstance(reply, str):
        return BoardMode(f"unknown: 'v' failed ({reply}) ({ON_HOST})")
    if reply is None:
        return BoardMode(f"{STOCK_FIRMWARE} ({ON_HOST})")
    name = f"fishtail {reply.version}"
    if not reply.profile:
        return BoardMode(f"{name} ({ON_HOST}: the board has no profile)", reply)
    if not enabled:
        return BoardMode(f"{name} ({ON_HOST}: profile_on_board is false)", reply)
    revolution = board_revolution(scale)
    if isinstance(revolution, str):
        return BoardMode(f"{name} ({ON_HOST}: {revolution})", reply)
    return BoardMode(f"{name} ({ON_BOARD})", reply, revolution)


#: Before the first answer to ``v``.
NOT_CONNECTED = BoardMode("not known yet (not connected)")


#: One exchange with the board: the request's bytes and the reply's parser; the serial link's
#: ``exchange`` (an ``Answered`` with ``value``, or a ``Failed`` with ``kind`` and ``reason``).
Exchange = Callable[[bytes, Callable[[bytes], str]], object]


def _tuning_reply(line: bytes) -> str:
    """``OK``, ``ERR`` or ``Invalid Command``: answers, not faults of the link."""
    try:
        return "OK" if parse_accepted(line) else "ERR"
    except ReplyError as error:
        if error.kind == "invalid_command":
            return "Invalid Command"
        raise


def tune_board(mode: BoardMode, tuning: ProfileTuning | None, exchange: Exchange) -> BoardMode:
    """Send ``k`` where the board follows the profile; ``mode`` with what became of it.

    Sent only on the project's firmware with the profile on the board (elsewhere ``k`` would
    mean nothing, or is unknown). A board that answers ``ERR`` or ``Invalid Command`` (the first
    version of the firmware) keeps its default loop; one that did not answer may have taken it
    or not (said so; sent again at the next connect or board reset).
    """
    if tuning is None:
        return dataclasses.replace(mode, tuning=TUNING_NOT_SET)
    command = f"k {tuning.argument}"
    if mode.capabilities is None:
        why = "stock firmware" if mode.firmware.startswith(STOCK_FIRMWARE) else "firmware unknown"
        return dataclasses.replace(mode, tuning=f"{command} not sent ({why})")
    if not mode.on_board:
        return dataclasses.replace(mode, tuning=f"{command} not sent ({ON_HOST})")
    reply = exchange(tuning.encode(), _tuning_reply)
    answer = getattr(reply, "value", None)
    if answer == "OK":
        return dataclasses.replace(mode, tuning=f"{command} {ACKNOWLEDGED}")
    if answer is not None:
        state = f"refused by the board: {command} answered {answer!r}; its default loop"
    else:
        failure = f"{getattr(reply, 'kind', '?')}: {getattr(reply, 'reason', '?')}"
        state = f"not acknowledged: {command} ({failure}); either loop may run"
    return dataclasses.replace(mode, tuning=state)
