"""What ``fishtail-swim motor`` prints and draws: the table, the limits, the verdict, a figure.

matplotlib is imported lazily with the Agg backend (as in :mod:`.swim_figures`), so importing this
module is cheap and works without a display.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from fishtail_plant.motor.full_duty_run import FullDutyRun
from fishtail_swim.offline.held_fish_table import held_fish_columns
from fishtail_swim.offline.motor_sizing import MotorSizing, QuasiStaticRows, torque_at_carrier_n_m
from fishtail_swim.offline.tables import Column, write_table

#: Carrier speeds drawn per curve of the figure.
_CURVE_POINTS = 400


def sizing_columns(rows: QuasiStaticRows) -> list[Column]:
    """The quasi-static rows as table columns (torques at the carrier, currents in the winding)."""
    numbers = (
        ("f [Hz]", ".2f", "beat_frequency_hz"),
        ("carrier [rad/s]", ".2f", "carrier_speed_rad_s"),
        ("peak torque [N m]", ".4f", "peak_torque_n_m"),
        ("RMS torque [N m]", ".4f", "rms_torque_n_m"),
        ("peak I [A]", ".3f", "peak_current_a"),
        ("RMS I [A]", ".3f", "rms_current_a"),
        ("supply [W]", ".3f", "mean_supply_power_w"),
        ("V peak [V]", ".2f", "peak_voltage_v"),
        ("V mean [V]", ".2f", "mean_voltage_v"),
    )
    columns = [
        Column(heading, np.asarray(getattr(rows, field), dtype=float), form, field)
        for heading, form, field in numbers
    ]
    columns.append(Column("constant speed", np.array(rows.verdict), "s", "constant_speed"))
    return columns


def _speed_text(speed_rad_s: float) -> str:
    if not math.isfinite(speed_rad_s):
        return "unbounded (the load drives the carrier)"
    return f"{_hz(speed_rad_s)} Hz ({speed_rad_s:.4g} rad/s)"


def _hz(speed_rad_s: float) -> str:
    """The beat frequency of a carrier speed, three significant figures kept (2.90, 0.413)."""
    return f"{speed_rad_s / (2.0 * math.pi):#.3g}"


def _run_text(run: FullDutyRun) -> str:
    if not run.started:
        return "does not move"
    if run.stopped_at_rad is not None:
        return f"stops at phi = {run.stopped_at_rad % (2.0 * math.pi):.3f} rad"
    text = (
        f"{_speed_text(run.mean_speed_rad_s)}, ripple {run.min_speed_rad_s:.4g} to "
        f"{run.max_speed_rad_s:.4g} rad/s; peak {run.peak_current_a:.3g} A, RMS "
        f"{run.rms_current_a:.3g} A, supply {run.mean_supply_power_w:.3g} W, peak torque "
        f"{run.peak_carrier_torque_n_m:.3g} N m"
    )
    if run.settled:
        return f"{text} (over {run.averaged_revolutions} settled revolutions)"
    return (
        f"{text} (not settled after {run.revolutions} revolutions, {run.simulated_s:.4g} s "
        "simulated: the last revolutions' figures)"
    )


def write_sizing_report(sizing: MotorSizing, tail_text: str, out: TextIO) -> None:
    """The motor, the load, the table at constant speeds, the limits at full duty, the verdict."""
    p = sizing.parameters
    inertia = sizing.load.inertia_kg_m2
    out.write(
        f"motor: {p.supply_voltage_v:g} V, gear {p.gear_ratio:g}:1, efficiency "
        f"{p.gearbox_efficiency:g}; R {p.resistance_ohm:.4g} ohm, k {p.torque_constant_n_m_a:.4g} "
        f"N m/A, rotor {p.rotor_inertia_kg_m2:.3g} kg m^2, friction {p.coulomb_friction_n_m:.3g} "
        f"N m + {p.viscous_friction_n_m_s:.3g} N m s at the shaft\n"
        f"  at the carrier: stall {p.stall_torque_n_m:.4g} N m ({p.stall_current_a:.3g} A), "
        f"no load {_speed_text(p.no_load_speed_rad_s)}\n"
        # In water the inertia is the links' and the fin plate's added mass (TailLoad.exact).
        f"load: {tail_text}; inertia at the carrier {inertia.min():.3g} to "
        f"{inertia.max():.3g} kg m^2\n\n"
        "constant carrier speed (quasi-static), over a revolution at each beat frequency; "
        "torques at the carrier:\n"
    )
    write_table(sizing_columns(sizing.rows), out, as_csv=False)
    if sizing.held is not None:
        out.write(
            "\nthe fish held still (a bollard test), at the same beat frequencies; the tail's "
            "power into the water, and the fin plate's drag's share of it:\n"
        )
        write_table(held_fish_columns(sizing.held), out, as_csv=False)
    constant, mean = (_speed_text(speed) for speed in sizing.limits)
    out.write(
        f"\nhighest beat frequency at full duty ({p.supply_voltage_v:g} V, PWM 255):\n"
        f"  constant speed (V peak = supply):           {constant}\n"
        f"  on the mean (a flywheel carries the peaks): {mean}\n"
        f"  time-stepped (the DC motor model, loaded):  {_run_text(sizing.run)}\n\n"
        f"{sizing.verdict}\n"
    )


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_torque_speed(sizing: MotorSizing, path: Path, title: str) -> Path:
    """The motor's torque-speed line at the carrier, the load's peak and mean, the limits."""
    p = sizing.parameters
    load = sizing.load.per_speed_squared_n_m_s2
    efficiency = p.gearbox_efficiency
    # The mean as the gearbox passes it (see motor_sizing): its crossing with the motor's line
    # is the on-the-mean limit, as the peak's is the constant-speed one.
    paid = float(np.mean(np.where(load > 0.0, load, efficiency**2 * load)))
    peak = float(load.max())
    run = sizing.run
    top_speed = max(p.no_load_speed_rad_s, run.max_speed_rad_s, *sizing.rows.carrier_speed_rad_s)
    speeds = np.linspace(0.0, 1.05 * max(top_speed, 1e-9), _CURVE_POINTS)
    motor = torque_at_carrier_n_m(p, speeds)
    plt = _pyplot()
    figure, axes = plt.subplots(figsize=(7.5, 5))
    driving = motor >= 0.0  # beyond the no-load speed the motor brakes: not drawn
    axes.plot(speeds[driving], motor[driving], color="black", linewidth=1.6,
              label=f"motor at {p.supply_voltage_v:g} V, full duty")  # fmt: skip
    axes.plot(speeds, peak * speeds**2, color="tab:red", linewidth=1.2, label="load, peak")
    axes.plot(speeds, paid * speeds**2, color="tab:blue", linewidth=1.2,
              label="load, mean (back-driven part × η²)")  # fmt: skip
    limits = sizing.limits
    for speed, level, colour, name in (
        (limits.constant_speed_rad_s, peak, "tab:red", "constant speed"),
        (limits.mean_rad_s, paid, "tab:blue", "on the mean"),
    ):
        if math.isfinite(speed) and speed > 0.0:
            axes.plot([speed], [level * speed**2], "o", color=colour,
                      label=f"{name}: {_hz(speed)} Hz")  # fmt: skip
    if run.started and run.stopped_at_rad is None and run.mean_speed_rad_s > 0.0:
        sustained = run.mean_speed_rad_s
        axes.axvspan(run.min_speed_rad_s, run.max_speed_rad_s, color="tab:green", alpha=0.12,
                     label="time-stepped: speed ripple")  # fmt: skip
        axes.axvline(sustained, color="tab:green", linewidth=1.4,
                     label=f"time-stepped: {_hz(sustained)} Hz")  # fmt: skip
    stall = p.stall_torque_n_m
    axes.set_ylim(0.0, 1.15 * max(stall, peak * limits.constant_speed_rad_s**2, 1e-9))
    axes.set_xlim(0.0, speeds[-1])
    axes.set_xlabel("carrier speed [rad/s]")
    axes.set_ylabel("torque at the carrier [N m]")
    top = axes.secondary_xaxis(
        "top", functions=(lambda w: w / (2.0 * math.pi), lambda f: f * 2.0 * math.pi)
    )
    top.set_xlabel("beat frequency [Hz]")
    axes.set_title(title)
    axes.legend(loc="best", fontsize="small")
    axes.grid(True)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)
    return path
