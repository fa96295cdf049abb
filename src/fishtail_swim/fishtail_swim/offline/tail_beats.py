"""The tail a command swims, one beat per fish of a batch: its drive, beat period and labels.

:class:`CardanBeats` is the engine's Cardan-gear linkage at constant carrier speeds (one carrier
revolution a beat), :class:`ServoBeats` the servo tail of
:data:`~fishtail_plant.fish.tail_drive.SERVO_TAIL_PARAMETERS` (a rigid fin, θ = α0 + α_a sin ωt).
The tables, runs and figures ask a :class:`TailBeats` for what they need and nothing else.

>>> beats = ServoBeats.of({"servo_frequency_hz": [0.5, 2.0], "servo_amplitude_rad": 0.3})
>>> beats.beat_period_s.tolist(), beats.label(1), beats.rate_text(0)
([2.0, 0.5], 'servo, 2 Hz, amplitude 0.3 rad, bias 0 rad', '0.5 Hz')
>>> [column.csv_name for column in beats.table_columns()]
['beat_frequency_hz', 'amplitude_rad']
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Protocol

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.fish.tail_drive import (
    SERVO_TAIL_PARAMETERS,
    EngineTailDrive,
    SinusoidalTailDrive,
    TailDrive,
    constant_carrier_speed,
    servo_drive,
)
from fishtail_swim.offline.tables import Column

#: Which rows of a batch: a slice or indices.
Rows = slice | Sequence[int]


class TailBeats(Protocol):
    """A tail beating one way per fish of a batch (a table's rows, a run's fish)."""

    @property
    def drive(self) -> TailDrive:
        """The tail motion of every fish, from t = 0."""

    @property
    def beat_period_s(self) -> FloatArray:
        """One beat of each fish (the figures are over whole beats)."""

    #: The option that sets a run's beat, for messages (``--speed``).
    rate_flag: str

    def rate_text(self, index: int) -> str:
        """The beat's rate of fish ``index`` with its unit: ``4 rad/s``, ``1 Hz``."""

    def label(self, index: int) -> str:
        """Fish ``index``'s tail in a few words, for figure titles."""

    def subset(self, rows: Rows) -> TailBeats:
        """The same tail for the fish ``rows`` only."""

    def key_columns(self) -> list[Column]:
        """The columns that tell the rows apart (the swept values)."""

    def table_columns(self) -> list[Column]:
        """The key columns and the beat frequency, in the steady table's order."""

    def run_columns(self, time_s: FloatArray) -> list[tuple[str, FloatArray]]:
        """CSV columns of fish 0 at ``time_s`` that only this kind of tail has (name, values)."""


def _index(rows: Rows) -> slice | list[int]:
    # A tuple would index several axes.
    return rows if isinstance(rows, slice) else list(rows)


def _frequency_column(period_s: FloatArray) -> Column:
    return Column("f [Hz]", 1.0 / period_s, ".4f", "beat_frequency_hz")


class CardanBeats:
    """The engine's linkage turned at a constant carrier speed per fish (one revolution a beat)."""

    rate_flag = "--speed"

    def __init__(self, tail: Tail, carrier_speed_rad_s: npt.ArrayLike) -> None:
        """Keep the tail and the speeds.

        Raises:
            SwimParameterError: a non-finite speed.
        """
        self.tail = tail
        self.carrier_speed_rad_s = np.atleast_1d(np.asarray(carrier_speed_rad_s, dtype=float))
        self._drive = EngineTailDrive(tail, constant_carrier_speed(self.carrier_speed_rad_s))

    @property
    def drive(self) -> EngineTailDrive:
        """The engine's tail at φ = φ̇ t."""
        return self._drive

    @property
    def beat_period_s(self) -> FloatArray:
        """2 pi / carrier speed."""
        return 2.0 * np.pi / self.carrier_speed_rad_s

    def rate_text(self, index: int) -> str:
        """The carrier speed: ``4 rad/s``."""
        return f"{float(self.carrier_speed_rad_s[index]):g} rad/s"

    def label(self, index: int) -> str:
        """``oscillatory, 4 rad/s``."""
        return f"{self.tail.name}, {self.rate_text(index)}"

    def subset(self, rows: Rows) -> CardanBeats:
        """The same linkage at the speeds of ``rows``."""
        return CardanBeats(self.tail, self.carrier_speed_rad_s[_index(rows)])

    def key_columns(self) -> list[Column]:
        """The carrier speed."""
        return [Column("carrier [rad/s]", self.carrier_speed_rad_s, ".4g", "carrier_speed_rad_s")]

    def table_columns(self) -> list[Column]:
        """The carrier speed, then the beat frequency."""
        return [*self.key_columns(), _frequency_column(self.beat_period_s)]

    def run_columns(self, time_s: FloatArray) -> list[tuple[str, FloatArray]]:
        """The carrier angle φ."""
        angle, _, _ = self._drive.carrier(np.asarray(time_s, dtype=float)[:, None])
        return [("carrier_angle_rad", angle[:, 0])]


class ServoBeats:
    """A servo-driven rigid fin, θ = α0 + α_a sin ωt, with its own values per fish."""

    rate_flag = "--servo-frequency-hz"

    def __init__(self, values: Mapping[str, FloatArray]) -> None:
        """Keep one array per servo parameter, all of one length (see :meth:`of`).

        Raises:
            SwimParameterError: a value the drive refuses.
        """
        self.values = dict(values)
        self._drive = servo_drive(self.values)

    @classmethod
    def of(cls, values: Mapping[str, npt.ArrayLike]) -> ServoBeats:
        """Values (floats or per-fish sequences) broadcast to one length; absent ones default.

        Raises:
            SwimParameterError: a value the drive refuses.
        """
        given = {
            spec.name: np.atleast_1d(np.asarray(values.get(spec.name, spec.default), dtype=float))
            for spec in SERVO_TAIL_PARAMETERS
        }
        return cls(dict(zip(given, np.broadcast_arrays(*given.values()), strict=True)))

    @property
    def drive(self) -> SinusoidalTailDrive:
        """The fin's sinusoid."""
        return self._drive

    @property
    def beat_period_s(self) -> FloatArray:
        """1 / f."""
        return 1.0 / self.values["servo_frequency_hz"]

    def _value(self, name: str, index: int) -> float:
        return float(self.values[name][index])

    def rate_text(self, index: int) -> str:
        """The beat frequency: ``1 Hz``."""
        return f"{self._value('servo_frequency_hz', index):g} Hz"

    def label(self, index: int) -> str:
        """``servo, 1 Hz, amplitude 0.3 rad, bias 0 rad``."""
        return (
            f"servo, {self.rate_text(index)}, amplitude "
            f"{self._value('servo_amplitude_rad', index):g} rad, bias "
            f"{self._value('servo_bias_rad', index):g} rad"
        )

    def subset(self, rows: Rows) -> ServoBeats:
        """The fins of ``rows``."""
        index = _index(rows)
        return ServoBeats({name: value[index] for name, value in self.values.items()})

    def key_columns(self) -> list[Column]:
        """The beat frequency and the amplitude."""
        return [
            _frequency_column(self.beat_period_s),
            Column("amplitude [rad]", self.values["servo_amplitude_rad"], ".4g", "amplitude_rad"),
        ]

    def table_columns(self) -> list[Column]:
        """As :meth:`key_columns` (the frequency is a key)."""
        return self.key_columns()

    def run_columns(self, time_s: FloatArray) -> list[tuple[str, FloatArray]]:
        """None: the fin angle, which every run writes, is the servo's command."""
        return []
