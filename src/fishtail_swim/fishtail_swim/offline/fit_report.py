"""The report of ``fishtail-swim fit``: each run measured, modelled and predicted, then the values.

One row per run (its tail, the measured and model speeds and residuals, each row's C_D for the
closed form, the measured and model turns, the leave-one-out prediction errors), then the fitted
values with their standard errors and previous values, the RMS residuals and the RMS
leave-one-out errors. Aligned text, or CSV (the rows, a blank line, the parameters).
"""

from __future__ import annotations

import csv
import math
from typing import TextIO

import numpy as np

from fishtail_plant.fish.fish import FloatArray
from fishtail_swim.offline.fit import FitResult
from fishtail_swim.offline.fit_loo import LeaveOneOut
from fishtail_swim.offline.fit_measurements import (
    CARRIER_COLUMN,
    SERVO_COLUMNS,
    SPEED_COLUMN,
    YAW_RATE_COLUMN,
    Measurements,
)
from fishtail_swim.offline.tables import Column, write_table


def _optional(heading: str, values: FloatArray, form: str, csv_name: str, as_csv: bool) -> Column:
    # A column with gaps: "-" in the table, an empty cell in CSV (as in the measurements file).
    texts = [
        ("" if as_csv else "-") if not math.isfinite(value)
        else (f"{value:.12g}" if as_csv else format(value, form))
        for value in values
    ]  # fmt: skip
    return Column(heading, np.array(texts, dtype=object), "s", csv_name)


def _tail_columns(measurements: Measurements) -> list[Column]:
    if measurements.carrier_speed_rad_s is not None:
        return [Column("carrier [rad/s]", measurements.carrier_speed_rad_s, ".4g", CARRIER_COLUMN)]
    headings = ("amplitude [rad]", "bias [rad]", "f [Hz]")
    values = (measurements.amplitude_rad, measurements.bias_rad, measurements.frequency_hz)
    return [
        Column(heading, np.asarray(column, dtype=float), ".4g", name)
        for heading, column, name in zip(headings, values, SERVO_COLUMNS, strict=True)
    ]


def write_fit_report(
    result: FitResult,
    measurements: Measurements,
    loo: LeaveOneOut,
    out: TextIO,
    as_csv: bool,
) -> None:
    """The rows (measured, model, residuals, leave-one-out errors), then the values and RMS.

    CSV: the rows' table, a blank line, then ``parameter,value,standard_error,previous``.
    """
    measured = measurements.speed_m_s
    residual = result.model_speed_m_s - measured
    loo_percent = 100.0 * (loo.speed_m_s / measured - 1.0)
    columns = [
        *_tail_columns(measurements),
        Column("U measured [m/s]", measured, ".4f", SPEED_COLUMN),
        Column("U model [m/s]", result.model_speed_m_s, ".4f", "model_speed_m_s"),
        Column("residual [m/s]", residual, "+.4f", "speed_residual_m_s"),
        Column("residual [%]", 100.0 * residual / measured, "+.2f", "speed_residual_percent"),
    ]
    if result.row_drag_coefficient is not None:
        columns.append(
            Column("row's C_D", result.row_drag_coefficient, ".4g", "row_drag_coefficient")
        )
    yaw, model_yaw = measurements.turning_yaw_rate_rad_s(), result.model_yaw_rate_rad_s
    if model_yaw is not None:
        columns += [
            _optional("r measured [rad/s]", yaw, ".3e", YAW_RATE_COLUMN, as_csv),
            Column("r model [rad/s]", model_yaw, ".3e", "model_yaw_rate_rad_s"),
            _optional(
                "r residual [rad/s]", model_yaw - yaw, "+.2e", "yaw_rate_residual_rad_s", as_csv
            ),
        ]
    columns.append(_optional("LOO U [%]", loo_percent, "+.2f", "loo_speed_error_percent", as_csv))
    if loo.yaw_rate_rad_s is not None:
        columns.append(
            _optional(
                "LOO r [rad/s]",
                loo.yaw_rate_rad_s - yaw,
                "+.2e",
                "loo_yaw_rate_error_rad_s",
                as_csv,
            )  # fmt: skip
        )
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
    out.write(
        f"RMS speed residual {100.0 * _rms(residual / measured):.3g} % ({_rms(residual):.3g} m/s) "
        f"over {measured.size} rows\n"
    )
    turned = np.isfinite(yaw)
    if model_yaw is not None and turned.any():
        out.write(f"RMS yaw rate residual {_rms((model_yaw - yaw)[turned]):.3g} rad/s\n")
    if any(math.isnan(value.standard_error) for value in result.fitted):
        out.write("(no standard error: as many rows as fitted parameters)\n")
    _write_loo_summary(loo, measurements, out)


def _write_loo_summary(loo: LeaveOneOut, measurements: Measurements, out: TextIO) -> None:
    predicted = loo.predicted
    if not predicted.any():
        out.write(
            "leave-one-out: no run can be predicted from the others (without any one run the "
            "rest cannot determine the coefficients)\n"
        )
        return
    error = loo.speed_m_s[predicted] - measurements.speed_m_s[predicted]
    relative = error / measurements.speed_m_s[predicted]
    line = (
        f"leave-one-out RMS speed prediction error {100.0 * _rms(relative):.3g} % "
        f"({_rms(error):.3g} m/s) over {int(predicted.sum())} of {predicted.size} runs"
    )
    if loo.yaw_rate_rad_s is not None:
        yaw = measurements.turning_yaw_rate_rad_s()
        turned = predicted & np.isfinite(yaw)
        if turned.any():
            yaw_error = _rms((loo.yaw_rate_rad_s - yaw)[turned])
            line += f", yaw rate {yaw_error:.3g} rad/s over {int(turned.sum())}"
    out.write(line + "\n")


def _rms(values: FloatArray) -> float:
    return float(np.sqrt(np.mean(values * values)))
