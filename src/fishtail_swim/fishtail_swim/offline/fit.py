"""Fit the fish's drag C_D (and, with turning rates, its yaw damping K_D) to measured speeds.

``fishtail-swim fit``: the measurements file (``carrier_speed_rad_s,speed_m_s[,yaw_rate_rad_s]``),
C_D from speeds alone by the cycle-average balance in closed form, the report and the fitted fish
file; with yaw rates the free body is stepped in time (:mod:`.fit_free_body`). The file, the
relative residuals, the closed form and the refusals: docs/swimming-dynamics.md (``fit``).

>>> text = ["# two runs", "carrier_speed_rad_s,speed_m_s", "", "4,0.17", "8,0.35  # calm water"]
>>> rows = parse_measurements(text, "m.csv")
>>> rows.carrier_speed_rad_s.tolist(), rows.speed_m_s.tolist(), rows.yaw_rate_rad_s
([4.0, 8.0], [0.17, 0.35], None)
"""

from __future__ import annotations

import csv
import dataclasses
import math
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import NamedTuple, TextIO

import numpy as np

from fishtail_plant.errors import SwimError
from fishtail_plant.fish.figures import cycle_mean_tail_force, steady_surge_speed
from fishtail_plant.fish.fish import (
    FISH_PARAMETERS,
    FISH_PARAMETERS_BY_NAME,
    FishParameters,
    FloatArray,
)
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed
from fishtail_swim.offline.inputs import Swimmer
from fishtail_swim.offline.tables import Column, write_table

CARRIER_COLUMN = "carrier_speed_rad_s"
SPEED_COLUMN = "speed_m_s"
YAW_RATE_COLUMN = "yaw_rate_rad_s"
MEASUREMENT_COLUMNS = (CARRIER_COLUMN, SPEED_COLUMN, YAW_RATE_COLUMN)
DRAG = "drag_coefficient"
YAW_DAMPING = "yaw_damping_kg_m2"
# Relative step of the central difference dC_D/ds (error ~ step², far below the spread's).
_SLOPE_STEP = 1e-4
#: A fit the model contradicts: its cruising speed is the carrier speed times s(C_D), so the
#: measured U/phi-dot must agree. An RMS relative speed residual above this (a timed run's errors
#: are a few %), or a C_D standard error above MAX_DRAG_RELATIVE_ERROR of C_D, is refused.
MAX_RELATIVE_RESIDUAL = 0.2
MAX_DRAG_RELATIVE_ERROR = 0.5


class MeasurementError(SwimError):
    """A measurements file that cannot be used: one line naming the file, the line and why."""


class FitRefusedError(SwimError):
    """No parameter value inside its range reproduces the measurements."""


class FitContradictedError(FitRefusedError):
    """The model contradicts the measurements: its fit leaves them unexplained.

    ``reason`` is the message without the hint to --force (for the warning --force gives).
    """

    def __init__(self, reason: str) -> None:
        """The error for ``reason``, its message with the hint to --force."""
        super().__init__(f"{reason} (--force reports and writes the fit anyway)")
        self.reason = reason


class Measurements(NamedTuple):
    """The measured rows: carrier speed, cruising speed and (optionally) mean yaw rate."""

    carrier_speed_rad_s: FloatArray
    speed_m_s: FloatArray
    yaw_rate_rad_s: FloatArray | None

    @property
    def fitted_names(self) -> tuple[str, ...]:
        """The parameters these measurements determine: C_D, and K_D with yaw rates."""
        return (DRAG,) if self.yaw_rate_rad_s is None else (DRAG, YAW_DAMPING)


class FittedValue(NamedTuple):
    """A fitted parameter, its standard error and the value the fish had before the fit.

    The standard error comes from the residuals' spread: NaN with as many rows as parameters.
    """

    name: str
    value: float
    standard_error: float
    previous: float


class FitResult(NamedTuple):
    """The fitted fish and, per measured row, the model's values with it."""

    fish: FishParameters
    fitted: tuple[FittedValue, ...]
    model_speed_m_s: FloatArray
    model_yaw_rate_rad_s: FloatArray | None
    #: How the model's values were found, in words, for the output.
    method: str
    #: Each row's own balancing C_D (speeds only), else None.
    row_drag_coefficient: FloatArray | None = None
    #: Warnings the output must show (e.g. a fit that stopped before converging).
    warnings: tuple[str, ...] = ()


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
    except UnicodeDecodeError:
        raise MeasurementError(f"{path}: not UTF-8 text") from None
    except OSError as error:
        raise MeasurementError(f"{path}: cannot read: {error.strerror or error}") from None


def parse_measurements(lines: Iterable[str], source: str) -> Measurements:
    """Parse measurement lines (header first; ``#`` comments and blank lines skipped).

    Raises:
        MeasurementError: no header, an unknown, repeated or missing column, a field that is not a
            finite number, a speed <= 0, or fewer rows than parameters to fit.
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
    expected = ",".join(MEASUREMENT_COLUMNS[:2]) + f"[,{YAW_RATE_COLUMN}]"
    if header is None:
        raise MeasurementError(f"{source}: no header line (expected {expected})")
    measurements = Measurements(
        np.array(columns[CARRIER_COLUMN]),
        np.array(columns[SPEED_COLUMN]),
        np.array(columns[YAW_RATE_COLUMN]) if YAW_RATE_COLUMN in columns else None,
    )
    rows, names = measurements.speed_m_s.size, measurements.fitted_names
    if rows < len(names):
        need = " and ".join(names)
        raise MeasurementError(
            f"{source}: fitting {need} needs at least {len(names)} measured rows, got {rows}"
        )
    return measurements


def _checked_header(fields: Sequence[str], source: str) -> list[str]:
    for name in fields:
        if name not in MEASUREMENT_COLUMNS:
            raise MeasurementError(
                f"{source}: unknown column {name!r} (the columns are "
                f"{', '.join(MEASUREMENT_COLUMNS)}; notes go in # comments)"
            )
        if fields.count(name) > 1:
            raise MeasurementError(f"{source}: column {name} appears twice")
    for name in MEASUREMENT_COLUMNS[:2]:
        if name not in fields:
            raise MeasurementError(
                f"{source}: missing column {name} (the header is {','.join(fields)})"
            )
    return list(fields)


def _measured_value(name: str, field: str, where: str) -> float:
    try:
        value = float(field)
    except ValueError:
        raise MeasurementError(f"{where}: {name} is not a number: {field!r}") from None
    if not math.isfinite(value):
        raise MeasurementError(f"{where}: {name} is not a finite number: {field!r}")
    if name != YAW_RATE_COLUMN and value <= 0.0:
        raise MeasurementError(f"{where}: {name} must be > 0, got {field}")
    return value


def best_speed_ratio(measurements: Measurements) -> tuple[float, float]:
    """s* = U/w minimising the relative speed residuals, and its standard error (NaN: 1 row).

    Residual of row i: s x_i - 1 with x_i = w_i / U_i, linear in s.
    """
    x = measurements.carrier_speed_rad_s / measurements.speed_m_s
    ratio = float(x.sum() / (x * x).sum())
    if x.size < 2:
        return ratio, math.nan
    residuals = ratio * x - 1.0
    variance = float((residuals * residuals).sum()) / (x.size - 1)
    return ratio, math.sqrt(variance / float((x * x).sum()))


def drag_range() -> tuple[float, float]:
    """The range of drag_coefficient's spec."""
    spec = FISH_PARAMETERS_BY_NAME[DRAG]
    low = -math.inf if spec.minimum is None else spec.minimum
    high = math.inf if spec.maximum is None else spec.maximum
    return low, high


class BalanceFit(NamedTuple):
    """The held-body balance's C_D (not yet checked against its range) and each row's."""

    drag_coefficient: float
    standard_error: float
    row_drag_coefficient: FloatArray


def balance_drag_coefficient(swimmer: Swimmer, measurements: Measurements) -> BalanceFit:
    """C_D from the speeds by the cycle-average balance, in closed form.

    The derivation: docs/swimming-dynamics.md (``fit``, "Speeds only").
    """
    carriers, speeds = measurements.carrier_speed_rad_s, measurements.speed_m_s
    ratio, ratio_error = best_speed_ratio(measurements)
    # The balance's speed is proportional to the carrier speed: any reference speed gives the
    # same C_D; the median keeps the tail's samples at a measured speed's scale.
    reference = float(np.median(carriers))
    fitted_speed = ratio * reference * np.array([1.0, 1.0 - _SLOPE_STEP, 1.0 + _SLOPE_STEP])
    all_carriers = np.concatenate([carriers, np.full(3, reference)])
    all_speeds = np.concatenate([speeds, fitted_speed])
    drive = EngineTailDrive(swimmer.tail, constant_carrier_speed(all_carriers))
    thrust = cycle_mean_tail_force(drive, swimmer.fish, all_speeds, 2.0 * np.pi / all_carriers)
    fish = swimmer.fish
    dynamic_area = 0.5 * float(fish.water_density_kg_m3) * float(fish.reference_area_m2)
    balancing = thrust / (dynamic_area * all_speeds * all_speeds)
    slope = (balancing[-1] - balancing[-2]) / (2.0 * _SLOPE_STEP * ratio)
    return BalanceFit(
        float(balancing[-3]), abs(float(slope)) * ratio_error, balancing[: carriers.size]
    )


def check_drag_in_range(drag_coefficient: float, model: str) -> None:
    """Refuse a C_D outside its spec's range, saying which way the measurements point.

    Raises:
        FitRefusedError: ``drag_coefficient`` below or above the range.
    """
    low, high = drag_range()
    if drag_coefficient < low:
        raise FitRefusedError(
            f"the measured speeds are faster than the {model} swims at C_D = {low:g} (they need "
            f"C_D = {drag_coefficient:.4g}): the tail cannot drive this fish that fast; check the "
            "tail geometry, fin_span_m and the fish file"
        )
    if drag_coefficient > high:
        raise FitRefusedError(
            f"the measured speeds are slower than the {model} swims at C_D = {high:g} (they need "
            f"C_D = {drag_coefficient:.4g}): check the carrier speeds and units"
        )


def fit_drag(swimmer: Swimmer, measurements: Measurements) -> FitResult:
    """C_D from cruising speeds by the held-body balance; the model's speeds at every row.

    Raises:
        FitRefusedError: no C_D in its range reproduces the speeds.
    """
    balance = balance_drag_coefficient(swimmer, measurements)
    check_drag_in_range(balance.drag_coefficient, "held-body balance")
    fish = dataclasses.replace(swimmer.fish, drag_coefficient=balance.drag_coefficient)
    # The model's speeds from the library's balance at each measured carrier speed: the closed
    # form above used the speeds' proportionality, this does not.
    carriers = measurements.carrier_speed_rad_s
    drive = EngineTailDrive(swimmer.tail, constant_carrier_speed(carriers))
    model_speed = steady_surge_speed(drive, fish, 2.0 * np.pi / carriers)
    fitted = FittedValue(
        DRAG, balance.drag_coefficient, balance.standard_error, float(swimmer.fish.drag_coefficient)
    )
    return FitResult(
        fish, (fitted,), model_speed, None,
        "cycle-average balance, sway and yaw held (yaw rates give the free body's C_D and K_D)",
        balance.row_drag_coefficient,
    )  # fmt: skip


def check_model_agrees(result: FitResult, measurements: Measurements) -> None:
    """Refuse a fit the model contradicts (MAX_RELATIVE_RESIDUAL, MAX_DRAG_RELATIVE_ERROR).

    The model's cruising speed is proportional to the carrier speed (quadratic drag), so the
    speeds must rise with it; speeds that fall, or scatter far beyond a timed run's errors, leave
    a C_D that describes none of the rows.

    Raises:
        FitContradictedError: the RMS relative speed residual or C_D's relative standard error
            above its limit (the message says which, and whether the speeds fall).
    """
    carriers, speeds = measurements.carrier_speed_rad_s, measurements.speed_m_s
    residual = _rms(result.model_speed_m_s / speeds - 1.0)
    drag = next(value for value in result.fitted if value.name == DRAG)
    error = drag.standard_error / drag.value  # NaN with one row: no spread, no refusal
    over = []
    if residual > MAX_RELATIVE_RESIDUAL:
        over.append(
            f"RMS speed residual {100.0 * residual:.3g} % (limit {100 * MAX_RELATIVE_RESIDUAL:g} %)"
        )
    if error > MAX_DRAG_RELATIVE_ERROR:
        over.append(
            f"C_D = {drag.value:.4g} +- {drag.standard_error:.2g}, a standard error of "
            f"{100.0 * error:.3g} % (limit {100 * MAX_DRAG_RELATIVE_ERROR:g} %)"
        )
    if not over:
        return
    how = "scatter far from"
    if np.ptp(carriers) > 0.0 and np.polyfit(np.log(carriers), np.log(speeds), 1)[0] <= 0.0:
        how = "fall as the carrier speeds up, against"
    raise FitContradictedError(
        f"the model contradicts the measurements: {' and '.join(over)}; the speeds {how} the "
        "model's cruising speed, proportional to the carrier speed: check the carrier speeds, "
        "the rows and their units"
    )


def _yaml_float(value: float) -> str:
    # repr round-trips; YAML 1.1 (PyYAML, ROS) reads "1e-05" as a string, so give it a point.
    text = repr(float(value))
    if "e" in text and "." not in text:
        mantissa, exponent = text.split("e")
        text = f"{mantissa}.0e{exponent}"
    return text


def fish_file_text(result: FitResult, measurements_source: str) -> str:
    """A complete fish parameter file (config/fish.yaml's format) with the fitted values."""
    source = " ".join(measurements_source.split())
    names = ", ".join(value.name for value in result.fitted)
    lines = [
        "# The robotic fish for the swimming dynamics (fishtail_swim), in the ROS 2 parameter-file",
        f"# format. Written by `fishtail-swim fit`: {names} fitted to the measurements in",
        f"# {source}; every other value is the one the fit used (docs/swimming-dynamics.md).",
        "/**:",
        "  ros__parameters:",
    ]
    fitted = {value.name: value for value in result.fitted}
    for spec in FISH_PARAMETERS:
        value = float(getattr(result.fish, spec.name))
        if spec.name in fitted:
            error = fitted[spec.name].standard_error
            spread = "" if math.isnan(error) else f" +- {error:.3g}"
            comment = f"fitted{spread} (was {fitted[spec.name].previous:.6g})"
        else:
            comment = spec.text
        lines.append(f"    {spec.name}: {_yaml_float(value)}  # {comment}")
    return "\n".join(lines) + "\n"


def write_fit_report(
    result: FitResult, measurements: Measurements, out: TextIO, as_csv: bool
) -> None:
    """The rows (measured, model, residuals), then the fitted values and the RMS residuals.

    CSV: the rows' table, a blank line, then ``parameter,value,standard_error,previous``.
    """
    measured = measurements.speed_m_s
    residual = result.model_speed_m_s - measured
    columns = [
        Column("carrier [rad/s]", measurements.carrier_speed_rad_s, ".4g", CARRIER_COLUMN),
        Column("U measured [m/s]", measured, ".4f", SPEED_COLUMN),
        Column("U model [m/s]", result.model_speed_m_s, ".4f", "model_speed_m_s"),
        Column("residual [m/s]", residual, "+.4f", "speed_residual_m_s"),
        Column("residual [%]", 100.0 * residual / measured, "+.2f", "speed_residual_percent"),
    ]
    if result.row_drag_coefficient is not None:
        columns.append(
            Column("row's C_D", result.row_drag_coefficient, ".4g", "row_drag_coefficient")
        )
    yaw, model_yaw = measurements.yaw_rate_rad_s, result.model_yaw_rate_rad_s
    if yaw is not None and model_yaw is not None:
        columns += [
            Column("r measured [rad/s]", yaw, ".3e", YAW_RATE_COLUMN),
            Column("r model [rad/s]", model_yaw, ".3e", "model_yaw_rate_rad_s"),
            Column("r residual [rad/s]", model_yaw - yaw, "+.2e", "yaw_rate_residual_rad_s"),
        ]
    if not as_csv:
        out.write(f"model: {result.method}\n\n")
    write_table(columns, out, as_csv)
    out.write("\n")
    if as_csv:
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(["parameter", "value", "standard_error", "previous"])
        for value in result.fitted:
            numbers = (value.value, value.standard_error, value.previous)
            writer.writerow([value.name, *(f"{number:.12g}" for number in numbers)])
        return
    for value in result.fitted:
        spread = "" if math.isnan(value.standard_error) else f" +- {value.standard_error:.2g}"
        out.write(f"{value.name} = {value.value:.6g}{spread} (was {value.previous:.6g})\n")
    relative = residual / measured
    out.write(
        f"RMS speed residual {100.0 * _rms(relative):.3g} % ({_rms(residual):.3g} m/s) over "
        f"{measured.size} rows\n"
    )
    if yaw is not None and model_yaw is not None:
        out.write(f"RMS yaw rate residual {_rms(model_yaw - yaw):.3g} rad/s\n")
    if any(math.isnan(value.standard_error) for value in result.fitted):
        out.write("(no standard error: as many rows as fitted parameters)\n")


def _rms(values: FloatArray) -> float:
    return float(np.sqrt(np.mean(values * values)))
