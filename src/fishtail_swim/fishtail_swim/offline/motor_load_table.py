"""The carrier's torque and power over a revolution at constant speeds: a table for motor sizing.

For each carrier speed, in air, in water held at rest and in water swimming: the peak and RMS
torque and the mean power (:class:`~fishtail_plant.linkage_load.carrier_load.CarrierLoadModel`,
:func:`~fishtail_plant.linkage_load.water.carrier_load_in_water`). The cases, the columns and the
table for the report's geometry: docs/motor-load.md ("Worked example: the report's geometry").

>>> import io
>>> from fishtail_kinematics.engine.geometry import OscillatoryGeometry
>>> from fishtail_plant.linkage_load.link_inertia import LinkInertia
>>> from fishtail_kinematics.engine.mechanisms import OscillatoryTail
>>> rows = motor_load_rows(
...     OscillatoryTail(OscillatoryGeometry()), LinkInertia(), FishParameters(), [4.0, 8.0])
>>> [round(float(value), 4) for value in rows.air_peak_torque_n_m]
[0.002, 0.0081]
"""

from __future__ import annotations

from typing import Any, NamedTuple, TextIO

import numpy as np
import numpy.typing as npt

from fishtail_kinematics.engine.mechanisms import Tail
from fishtail_plant.fish.figures import steady_surge_speed
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed
from fishtail_plant.linkage_load.carrier_load import CarrierLoad, CarrierLoadModel
from fishtail_plant.linkage_load.link_inertia import LinkInertia
from fishtail_plant.linkage_load.water import carrier_load_in_water
from fishtail_swim.offline.tables import Column, write_table

#: Carrier angles per revolution: the means are those of a periodic trapezoid rule (spectrally
#: accurate); the peaks are sampled, within ~(pi/samples)^2 of the true peak.
SAMPLES_PER_REVOLUTION = 2048


class MotorLoadRows(NamedTuple):
    """One element per carrier speed; torques [N m], powers [W], speeds [rad/s, m/s]."""

    carrier_speed_rad_s: FloatArray
    air_peak_torque_n_m: FloatArray
    air_rms_torque_n_m: FloatArray
    rest_peak_torque_n_m: FloatArray
    rest_rms_torque_n_m: FloatArray
    rest_mean_power_w: FloatArray
    swimming_speed_m_s: FloatArray
    swimming_peak_torque_n_m: FloatArray
    swimming_rms_torque_n_m: FloatArray
    swimming_mean_power_w: FloatArray
    swimming_peak_power_w: FloatArray


def _peak(values: npt.NDArray[np.floating[Any]]) -> FloatArray:
    return np.asarray(np.abs(values).max(axis=0), dtype=float)


def _rms(values: npt.NDArray[np.floating[Any]]) -> FloatArray:
    return np.asarray(np.sqrt(np.mean(values * values, axis=0)), dtype=float)


def _mean(values: npt.NDArray[np.floating[Any]]) -> FloatArray:
    return np.asarray(values.mean(axis=0), dtype=float)


def motor_load_rows(
    tail: Tail,
    inertia: LinkInertia,
    fish: FishParameters,
    carrier_speeds_rad_s: npt.ArrayLike,
    samples: int = SAMPLES_PER_REVOLUTION,
) -> MotorLoadRows:
    """The table's figures at each constant carrier speed (all speeds at once, no loop)."""
    speeds = np.atleast_1d(np.asarray(carrier_speeds_rad_s, dtype=float))
    angles = (np.arange(samples) * (2.0 * np.pi / samples))[:, None]
    model = CarrierLoadModel(tail, inertia)
    air: CarrierLoad = model.load(angles, speeds)
    rest = carrier_load_in_water(model, fish, angles, speeds)
    drive = EngineTailDrive(tail, constant_carrier_speed(speeds))
    surge = np.broadcast_to(steady_surge_speed(drive, fish, 2.0 * np.pi / speeds), speeds.shape)
    swimming = carrier_load_in_water(model, fish, angles, speeds, surge_speed_m_s=surge)
    return MotorLoadRows(
        speeds,
        _peak(air.torque_n_m), _rms(air.torque_n_m),
        _peak(rest.torque_n_m), _rms(rest.torque_n_m), _mean(rest.power_w),
        np.asarray(surge, dtype=float),
        _peak(swimming.torque_n_m), _rms(swimming.torque_n_m), _mean(swimming.power_w),
        _peak(swimming.power_w),
    )  # fmt: skip


def motor_load_columns(rows: MotorLoadRows) -> list[Column]:
    """The rows as columns of a text table (torques in N m, powers in W)."""
    headings = (
        ("phi_dot [rad/s]", ".0f", "carrier_speed_rad_s"),
        ("air peak", ".4f", "air_peak_torque_n_m"),
        ("air RMS", ".4f", "air_rms_torque_n_m"),
        ("rest peak", ".4f", "rest_peak_torque_n_m"),
        ("rest RMS", ".4f", "rest_rms_torque_n_m"),
        # Without a fin plate zero but for rounding (no "-0.0000"); with one, its dissipation.
        ("rest P", ".1e", "rest_mean_power_w"),
        ("U [m/s]", ".3f", "swimming_speed_m_s"),
        ("swim peak", ".4f", "swimming_peak_torque_n_m"),
        ("swim RMS", ".4f", "swimming_rms_torque_n_m"),
        ("swim P", ".3f", "swimming_mean_power_w"),
        ("swim P peak", ".3f", "swimming_peak_power_w"),
    )
    return [
        Column(heading, np.asarray(getattr(rows, field), dtype=float), form, field)
        for heading, form, field in headings
    ]


def write_motor_load_table(rows: MotorLoadRows, out: TextIO, as_csv: bool = False) -> None:
    """Write the table: aligned text (torques [N m], mean powers [W]) or CSV with field names."""
    write_table(motor_load_columns(rows), out, as_csv)
