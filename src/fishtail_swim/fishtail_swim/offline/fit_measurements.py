"""The measurements file of ``fishtail-swim fit``: measured runs of a Cardan or a servo tail.

A CSV file with a header row; ``#`` starts a comment, blank lines are skipped. The tail columns
are either ``carrier_speed_rad_s`` (the Cardan tail) or ``amplitude_rad,bias_rad,frequency_hz``
(a servo tail), one kind per file; then ``speed_m_s`` (required in every row) and, optionally,
``yaw_rate_rad_s`` and ``turning_radius_m`` (signed, > 0 a left turn). An empty cell of the
optional columns is a value not measured. The format: docs/swimming-dynamics.md (``fit``).

>>> text = ["# two runs", "carrier_speed_rad_s,speed_m_s", "", "4,0.17", "8,0.35  # calm water"]
>>> rows = parse_measurements(text, "m.csv")
>>> rows.carrier_speed_rad_s.tolist(), rows.speed_m_s.tolist(), rows.yaw_rate_rad_s
([4.0, 8.0], [0.17, 0.35], None)
>>> servo = parse_measurements(["amplitude_rad,bias_rad,frequency_hz,speed_m_s,turning_radius_m",
...                             "0.3,0,1,0.1,", "0.3,0.1,1,0.09,1.5"], "s.csv")
>>> servo.kind, servo.turning_yaw_rate_rad_s().tolist()
('servo', [nan, 0.06])
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np
import numpy.typing as npt

from fishtail_plant.errors import SwimError
from fishtail_plant.fish.fish import FloatArray
from fishtail_plant.fish.tail_drive import SERVO_TAIL_PARAMETERS_BY_NAME

CARRIER_COLUMN = "carrier_speed_rad_s"
SERVO_COLUMNS = ("amplitude_rad", "bias_rad", "frequency_hz")
SPEED_COLUMN = "speed_m_s"
YAW_RATE_COLUMN = "yaw_rate_rad_s"
RADIUS_COLUMN = "turning_radius_m"
MEASUREMENT_COLUMNS = (
    CARRIER_COLUMN, *SERVO_COLUMNS, SPEED_COLUMN, YAW_RATE_COLUMN, RADIUS_COLUMN
)  # fmt: skip
# Columns an empty cell may leave unmeasured.
_OPTIONAL = (YAW_RATE_COLUMN, RADIUS_COLUMN)
# The servo columns' ranges are the servo tail's parameter specs.
_SERVO_SPECS = {
    "amplitude_rad": SERVO_TAIL_PARAMETERS_BY_NAME["servo_amplitude_rad"],
    "bias_rad": SERVO_TAIL_PARAMETERS_BY_NAME["servo_bias_rad"],
    "frequency_hz": SERVO_TAIL_PARAMETERS_BY_NAME["servo_frequency_hz"],
}
CARDAN = "cardan"
SERVO = "servo"


class MeasurementError(SwimError):
    """A measurements file that cannot be used: one line naming the file, the line and why."""


class Measurements(NamedTuple):
    """The measured runs, one element per row; NaN where an optional cell was left empty.

    The tail is a Cardan tail (``carrier_speed_rad_s``) or a servo tail (the three servo arrays);
    the other kind's fields are None, as is an optional column the file does not have.
    """

    carrier_speed_rad_s: FloatArray | None
    speed_m_s: FloatArray
    yaw_rate_rad_s: FloatArray | None = None
    turning_radius_m: FloatArray | None = None
    amplitude_rad: FloatArray | None = None
    bias_rad: FloatArray | None = None
    frequency_hz: FloatArray | None = None

    @property
    def kind(self) -> str:
        """``"cardan"`` or ``"servo"``."""
        return CARDAN if self.carrier_speed_rad_s is not None else SERVO

    @property
    def rows(self) -> int:
        """The number of measured runs."""
        return int(self.speed_m_s.size)

    def carrier_speeds(self) -> FloatArray:
        """The Cardan tail's carrier speeds.

        Raises:
            ValueError: a servo tail's measurements.
        """
        if self.carrier_speed_rad_s is None:
            raise ValueError("the measurements are of a servo tail, not a Cardan one")
        return self.carrier_speed_rad_s

    def tail_columns(self) -> FloatArray:
        """The tail's columns, one row per run: (carrier,) or (amplitude, bias, frequency)."""
        if self.carrier_speed_rad_s is not None:
            return self.carrier_speed_rad_s[:, None]
        servo = (self.amplitude_rad, self.bias_rad, self.frequency_hz)
        return np.column_stack([np.asarray(values, dtype=float) for values in servo])

    @property
    def beat_angular_frequency_rad_s(self) -> FloatArray:
        """2 pi / beat period: the carrier speed (one revolution a beat) or 2 pi f."""
        if self.carrier_speed_rad_s is not None:
            return self.carrier_speed_rad_s
        return 2.0 * np.pi * np.asarray(self.frequency_hz, dtype=float)

    def distinct_motions(self) -> int:
        """How many different tail motions the runs have, the servo's bias not counted.

        Repeats of one motion measure the same thing; a bias steers more than it speeds.
        """
        columns = self.tail_columns()
        if self.kind == SERVO:
            columns = columns[:, [0, 2]]
        return int(np.unique(columns, axis=0).shape[0]) if columns.size else 0

    def turning_yaw_rate_rad_s(self) -> FloatArray:
        """The measured mean yaw rate of each run, NaN where none was measured.

        A row with a turning radius R and no yaw rate counts as turning at U / R, its measured
        speed over R (R > 0: a left turn, r > 0).
        """
        yaw = np.full(self.rows, np.nan)
        if self.turning_radius_m is not None:
            yaw = self.speed_m_s / self.turning_radius_m
        if self.yaw_rate_rad_s is not None:
            yaw = np.where(np.isnan(self.yaw_rate_rad_s), yaw, self.yaw_rate_rad_s)
        return yaw

    @property
    def has_turning(self) -> bool:
        """Whether any run has a measured yaw rate or turning radius."""
        return bool(np.isfinite(self.turning_yaw_rate_rad_s()).any())

    def take(self, rows: npt.ArrayLike) -> Measurements:
        """The measurements of ``rows`` (indices) only."""
        index = np.asarray(rows, dtype=int)

        def kept(values: FloatArray | None) -> FloatArray | None:
            return None if values is None else values[index]

        return Measurements(
            kept(self.carrier_speed_rad_s), self.speed_m_s[index], kept(self.yaw_rate_rad_s),
            kept(self.turning_radius_m), kept(self.amplitude_rad), kept(self.bias_rad),
            kept(self.frequency_hz),
        )  # fmt: skip


def read_measurements(path: Path) -> Measurements:
    """The measurements in the CSV file at ``path``.

    Raises:
        MeasurementError: a file that cannot be read or used (names the file, the line and why).
    """
    try:
        with open(path, encoding="utf-8-sig", newline="") as stream:
            return parse_measurements(stream, str(path))
    except FileNotFoundError:
        raise MeasurementError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise MeasurementError(f"{path}: a directory, not a measurements file") from None
    except UnicodeDecodeError:
        raise MeasurementError(f"{path}: not UTF-8 text") from None
    except OSError as error:
        raise MeasurementError(f"{path}: cannot read: {error.strerror or error}") from None


def parse_measurements(lines: Iterable[str], source: str) -> Measurements:
    """Parse measurement lines (header first; ``#`` comments and blank lines skipped).

    Raises:
        MeasurementError: no header, an unknown, repeated or missing column, both tail kinds or
            neither, a field that is not a finite number or out of its range, a speed <= 0, an
            empty cell outside the optional columns, or a row with the wrong number of fields.
    """
    header: list[str] | None = None
    columns: dict[str, list[float]] = {}
    for line_number, line in enumerate(lines, start=1):
        text = line.split("#", 1)[0].strip()
        if not text:
            continue
        fields = [field.strip() for field in next(csv.reader([text]))]
        if header is None:
            header = _checked_header(fields, source)
            columns = {name: [] for name in header}
            continue
        where = f"{source} line {line_number}"
        if len(fields) != len(header):
            raise MeasurementError(f"{where}: {len(fields)} fields, the header has {len(header)}")
        for name, field in zip(header, fields, strict=True):
            columns[name].append(_measured_value(name, field, where))
    if header is None:
        raise MeasurementError(
            f"{source}: no header line (expected {CARRIER_COLUMN} or {','.join(SERVO_COLUMNS)}, "
            f"then {SPEED_COLUMN}[,{YAW_RATE_COLUMN}][,{RADIUS_COLUMN}])"
        )
    arrays = {name: np.array(values, dtype=float) for name, values in columns.items()}
    return Measurements(
        arrays.get(CARRIER_COLUMN), arrays[SPEED_COLUMN], arrays.get(YAW_RATE_COLUMN),
        arrays.get(RADIUS_COLUMN), *(arrays.get(name) for name in SERVO_COLUMNS),
    )  # fmt: skip


def _checked_header(fields: Sequence[str], source: str) -> list[str]:
    for name in fields:
        if name not in MEASUREMENT_COLUMNS:
            raise MeasurementError(
                f"{source}: unknown column {name!r} (the columns are "
                f"{', '.join(MEASUREMENT_COLUMNS)}; notes go in # comments)"
            )
        if fields.count(name) > 1:
            raise MeasurementError(f"{source}: column {name} appears twice")
    servo = [name for name in SERVO_COLUMNS if name in fields]
    if CARRIER_COLUMN in fields and servo:
        raise MeasurementError(
            f"{source}: both a Cardan tail ({CARRIER_COLUMN}) and a servo tail ({servo[0]}): "
            "one tail kind per file"
        )
    required = [SPEED_COLUMN] + (list(SERVO_COLUMNS) if servo else [CARRIER_COLUMN])
    for name in required:
        if name not in fields:
            raise MeasurementError(
                f"{source}: missing column {name} (the header is {','.join(fields)})"
            )
    return list(fields)


def _measured_value(name: str, field: str, where: str) -> float:
    if not field:
        if name in _OPTIONAL:
            return math.nan
        raise MeasurementError(
            f"{where}: missing {name} (only {', '.join(_OPTIONAL)} may be empty)"
        )
    try:
        value = float(field)
    except ValueError:
        raise MeasurementError(f"{where}: {name} is not a number: {field!r}") from None
    if not math.isfinite(value):
        raise MeasurementError(f"{where}: {name} is not a finite number: {field!r}")
    if name in (CARRIER_COLUMN, SPEED_COLUMN, "amplitude_rad") and value <= 0.0:
        raise MeasurementError(f"{where}: {name} must be > 0, got {field}")
    if name == RADIUS_COLUMN and value == 0.0:
        raise MeasurementError(f"{where}: {name} must not be 0 (leave it empty if not measured)")
    spec = _SERVO_SPECS.get(name)
    if spec is not None:
        low = -math.inf if spec.minimum is None else spec.minimum
        high = math.inf if spec.maximum is None else spec.maximum
        if not low <= value <= high or (spec.exclusive_minimum and value == low):
            raise MeasurementError(
                f"{where}: {name} = {field} is outside the servo tail's range [{low:g}, {high:g}]"
            )
    return value
