#!/usr/bin/env python3
"""Check the swimming model against the MSU servo robotic fish: fit on a few runs, predict the rest.

Reads docs/validation/msufish-measurements.csv (written by reduce_msufish.py) and prints, as
markdown, the tables of docs/validation.md between its ``generated`` markers:

* straight runs (bias 0): C_D (``quadratic``) and X_u + C_D (``linear-quadratic``) fitted on the
  runs at 15 and 30 degrees amplitude (both trials), by the cycle-average balance; the runs at 20
  and 25 degrees are predicted; then leave-one-out over all eight straight runs;
* turns: C_D and K_D (``turning``, free body stepped from rest) fitted on those four straight runs
  and the two trials at 15 degrees amplitude, +30 degrees bias; every other turning run's radius
  and speed predicted;
* the same fits and predictions for the fish's unknown dimensions (L, D, fin length, fin span)
  each times 0.7 and 1.4.

Everything goes through the product's own fit machinery (fishtail_swim.offline.fit_*) and the
plant's spheroid hull. The fish's dimensions are NOT known (README-data.md): NOMINAL is an
assumption, said in docs/validation.md. Run from the workspace after ``source tools/env.sh``.
"""

from __future__ import annotations

import contextlib
import math
import re
import sys
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import NamedTuple

import numpy as np

from fishtail_common.parameter_files import load_parameter_file
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_plant.fish.fish import FishParameters, FloatArray
from fishtail_plant.fish.spheroid import crossflow_yaw_damping, prolate_spheroid
from fishtail_swim.offline import fit_problem
from fishtail_swim.offline.fit import FitRefusedError, FitResult
from fishtail_swim.offline.fit_free_body import RunSettings
from fishtail_swim.offline.fit_least_squares import fit_coefficients, run_model
from fishtail_swim.offline.fit_loo import leave_one_out
from fishtail_swim.offline.fit_measurements import Measurements, read_measurements
from fishtail_swim.offline.fit_problem import COEFFICIENT_SETS, SYMBOLS, check_determined
from fishtail_swim.offline.inputs import Swimmer

ROOT = Path(__file__).resolve().parents[2]
MEASUREMENTS = ROOT / "docs" / "validation" / "msufish-measurements.csv"
#: Only to build a Swimmer: the fit's servo runs never use the Cardan tail.
CARDAN_CONFIG = ROOT / "config" / "oscillatory.yaml"
WATER_DENSITY = 1000.0  # fresh water, assumed (msufish-fish.yaml)
#: The targets a reader judges the predictions by.
SPEED_TARGET = 0.10
RADIUS_TARGET = 0.15
#: Training runs, fixed before any prediction was looked at.
TRAIN_AMPLITUDES_DEG = (15, 30)
TURN_TRAINING = (15, 30)  # (amplitude, bias) in degrees, both trials
#: The subset rule, fixed before any prediction was looked at: runs of at least this many logged
#: beats whose last-beat surge rose by at most this fraction over the beat before (nearer steady).
STEADY_MIN_BEATS = 8.0
STEADY_MAX_RISE = 0.10
SCALES = (0.7, 1.4)
#: The product's fit caps K_D at fit_problem.YAW_DAMPING_SPAN (30) times the hull's cross-flow
#: estimate. Where a fit ends on that cap, the sweep repeats it with the cap lifted to this, in
#: this script only (the product is unchanged), so that the variant still has numbers.
LIFTED_YAW_DAMPING_SPAN = 1000.0


class Geometry(NamedTuple):
    """The fish's unknown dimensions [m]."""

    length: float
    diameter: float
    fin_length: float
    fin_span: float
    fin_chord: float


#: ASSUMED (not measured; see docs/validation.md): a small servo robotic fish of this kind.
NOMINAL = Geometry(length=0.20, diameter=0.06, fin_length=0.08, fin_span=0.06, fin_chord=0.04)
GEOMETRY_LABELS = {
    "length": "L", "diameter": "D", "fin_length": "fin length", "fin_span": "fin span",
    "fin_chord": "fin chord",
}  # fmt: skip
#: Hoerner's flat plate normal to the flow at aspect ratio 1-3 (docs/swimming-dynamics.md).
FIN_NORMAL_DRAG = 1.2
#: The model's slender-body sideslip lift (the product's default, written out so that a change
#: of default cannot move these numbers).
LIFT_PER_RAD = 2.0


class Run(NamedTuple):
    """One measured run as the reduction describes it in the comment above its row."""

    amplitude_deg: int
    bias_deg: int
    trial: int
    beats: float
    rise: float

    @property
    def label(self) -> str:
        """Amplitude/bias and trial, e.g. ``15/+30 t1``."""
        return f"{self.amplitude_deg}/{self.bias_deg:+d} t{self.trial}"

    @property
    def steady(self) -> bool:
        """In the nearer-steady subset (the rule above)."""
        return self.beats >= STEADY_MIN_BEATS and self.rise <= STEADY_MAX_RISE


_COMMENT = re.compile(
    r"# Amp(\d+)Bias(-?\d+) trial (\d+): ([\d.]+) beats, .*rise over last beat ([+-]?\d+)%"
)


def read_runs(path: Path) -> list[Run]:
    """The runs' labels, beats and rise, in the order of the measurement rows."""
    runs = []
    for line in path.read_text().splitlines():
        match = _COMMENT.match(line)
        if match:
            a, b, n, beats, rise = match.groups()
            runs.append(Run(int(a), int(b), int(n), float(beats), float(rise) / 100.0))
    return runs


def fish_of(geometry: Geometry) -> FishParameters:
    """The fish: spheroid hull of L x D, fin pivot at the hull's end, a flat-plate fin.

    Every parameter is set here, none left to the product's defaults; the fitted ones (C_D, X_u,
    K_D) start from these values.
    """
    body = prolate_spheroid(geometry.length, geometry.diameter, WATER_DENSITY)
    return FishParameters(
        water_density_kg_m3=WATER_DENSITY,
        body_length_m=geometry.length,
        body_diameter_m=geometry.diameter,
        body_mass_kg=body.mass_kg,
        body_yaw_inertia_kg_m2=body.yaw_inertia_kg_m2,
        added_mass_surge_kg=body.added_mass_surge_kg,
        added_mass_sway_kg=body.added_mass_sway_kg,
        added_yaw_inertia_kg_m2=body.added_yaw_inertia_kg_m2,
        drag_coefficient=0.3,
        lift_coefficient_per_rad=LIFT_PER_RAD,
        yaw_damping_kg_m2=crossflow_yaw_damping(geometry.length, geometry.diameter, WATER_DENSITY),
        surge_linear_damping_kg_s=0.0,
        sway_linear_damping_kg_s=0.0,
        sway_quadratic_damping_kg_m=0.0,
        yaw_linear_damping_kg_m2_s=0.0,
        reference_area_m2=math.pi * geometry.diameter**2 / 4.0,
        tail_origin_offset_m=geometry.length / 2.0,
        fin_span_m=geometry.fin_span,
        fin_chord_m=geometry.fin_chord,
        fin_normal_drag_coefficient=FIN_NORMAL_DRAG if geometry.fin_chord > 0.0 else 0.0,
    )


def swimmer_of(geometry: Geometry) -> Swimmer:
    """The fit's Swimmer: the fish and a Cardan tail the servo runs do not use."""
    values = geometry_parameters_in(load_parameter_file(CARDAN_CONFIG))
    return Swimmer(fish_of(geometry), make_tail(geometry_from_parameters(values)))


class Fit(NamedTuple):
    """A fit's coefficients and the model's speed and yaw rate of every run (NaN: refused)."""

    names: tuple[str, ...]
    values: FloatArray
    errors: FloatArray
    speed: FloatArray
    yaw: FloatArray
    refused: str = ""


def fit_and_predict(
    swimmer: Swimmer,
    data: Measurements,
    train: Sequence[int],
    predict: Sequence[int],
    coefficients: str,
    fin_length: float,
) -> Fit:
    """Fit the set on rows ``train``; the model's values for rows ``predict`` with them."""
    names = COEFFICIENT_SETS[coefficients]
    nan = np.full(data.rows, np.nan)
    settings = RunSettings()
    training = data.take(train)
    try:
        check_determined(names, training)
        result = fit_coefficients(swimmer, training, names, fin_length, settings)
    except FitRefusedError as error:
        return Fit(names, np.full(len(names), np.nan), np.full(len(names), np.nan), nan, nan,
                   str(error))  # fmt: skip
    point = np.array([value.value for value in result.fitted])
    model = run_model(swimmer, data, names, fin_length, settings)
    rows = np.asarray(predict, dtype=int)
    speed, yaw = model.values(rows, np.tile(point, (rows.size, 1)))
    all_speed, all_yaw = nan.copy(), nan.copy()
    all_speed[rows], all_yaw[rows] = speed, yaw
    errors = np.array([value.standard_error for value in result.fitted])
    return Fit(names, point, errors, all_speed, all_yaw)


def straight_loo(
    swimmer: Swimmer, data: Measurements, rows: Sequence[int], coefficients: str, fin: float
) -> FloatArray:
    """Leave-one-out predicted speeds of ``rows`` (NaN where refused or not predicted)."""
    names = COEFFICIENT_SETS[coefficients]
    subset = data.take(rows)
    out = np.full(data.rows, np.nan)
    try:
        result: FitResult = fit_coefficients(swimmer, subset, names, fin)
    except FitRefusedError:
        return out
    model = run_model(swimmer, subset, names, fin, RunSettings())
    out[np.asarray(rows)] = leave_one_out(model, subset, result).speed_m_s
    return out


@contextlib.contextmanager
def lifted_yaw_damping_cap() -> Iterator[None]:
    """The product's K_D cap raised to LIFTED_YAW_DAMPING_SPAN while the block runs."""
    cap = fit_problem.YAW_DAMPING_SPAN
    fit_problem.YAW_DAMPING_SPAN = LIFTED_YAW_DAMPING_SPAN
    try:
        yield
    finally:
        fit_problem.YAW_DAMPING_SPAN = cap


class Study(NamedTuple):
    """Every fit and prediction for one geometry."""

    geometry: Geometry
    quadratic: Fit
    linear: Fit
    turning: Fit
    loo_quadratic: FloatArray
    loo_linear: FloatArray
    #: Why the product's turning fit was refused ("" if it was not; then ``turning`` is it).
    turning_refused: str = ""


class Split(NamedTuple):
    """Which rows train and which are predicted."""

    straight: list[int]
    straight_train: list[int]
    straight_test: list[int]
    turn_train: list[int]
    turn_test: list[int]


def split(runs: Sequence[Run]) -> Split:
    """The training and test rows (fixed by the constants above)."""
    straight = [i for i, run in enumerate(runs) if run.bias_deg == 0]
    train = [i for i in straight if runs[i].amplitude_deg in TRAIN_AMPLITUDES_DEG]
    test = [i for i in straight if i not in train]
    turning = [i for i, run in enumerate(runs) if run.bias_deg != 0]
    turn_train = [i for i in turning if (runs[i].amplitude_deg, runs[i].bias_deg) == TURN_TRAINING]
    turn_test = [i for i in turning if i not in turn_train]
    return Split(straight, train, test, train + turn_train, turn_test)


def study(geometry: Geometry, data: Measurements, rows: Split, lift_cap: bool = False) -> Study:
    """Fit and predict with the fish of ``geometry`` (``lift_cap``: see LIFTED_YAW_DAMPING_SPAN)."""
    swimmer = swimmer_of(geometry)
    fin = geometry.fin_length
    quadratic = fit_and_predict(swimmer, data, rows.straight_train, rows.straight, "quadratic", fin)
    linear = fit_and_predict(
        swimmer, data, rows.straight_train, rows.straight, "linear-quadratic", fin
    )
    everything = list(range(data.rows))
    turning = fit_and_predict(swimmer, data, rows.turn_train, everything, "turning", fin)
    refused = turning.refused
    if refused and lift_cap:
        with lifted_yaw_damping_cap():
            turning = fit_and_predict(swimmer, data, rows.turn_train, everything, "turning", fin)
    return Study(
        geometry, quadratic, linear, turning,
        straight_loo(swimmer, data, rows.straight, "quadratic", fin),
        straight_loo(swimmer, data, rows.straight, "linear-quadratic", fin), refused,
    )  # fmt: skip


def relative(model: FloatArray, measured: FloatArray) -> FloatArray:
    """The relative error, model / measured - 1."""
    return np.asarray(model / measured - 1.0, dtype=float)


def model_radius(fit: Fit) -> FloatArray:
    """The model's turning radius U / r (> 0 left); inf where it does not turn."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(fit.speed / fit.yaw, dtype=float)


def rms(values: FloatArray) -> float:
    """Root mean square of the finite values."""
    finite = values[np.isfinite(values)]
    return float(np.sqrt(np.mean(finite**2))) if finite.size else math.nan


def worst(values: FloatArray) -> float:
    """Largest absolute finite value."""
    finite = values[np.isfinite(values)]
    return float(np.max(np.abs(finite))) if finite.size else math.nan


def within(values: FloatArray, target: float) -> str:
    """``k of n`` finite values within +-target."""
    finite = values[np.isfinite(values)]
    return f"{int(np.sum(np.abs(finite) <= target))} of {finite.size}"


def pct(value: float) -> str:
    """A fraction as a signed percentage with one decimal."""
    return "-" if not math.isfinite(value) else f"{100.0 * value:+.1f}"


def upct(value: float) -> str:
    """A fraction as an unsigned percentage with one decimal."""
    return "-" if not math.isfinite(value) else f"{100.0 * value:.1f}"


def coefficient_text(fit: Fit) -> str:
    """``C_D = 0.123 +- 0.004, X_u = ...`` or why the fit was refused."""
    if fit.refused:
        return f"refused: {fit.refused}"
    parts = []
    for name, value, error in zip(fit.names, fit.values, fit.errors, strict=True):
        spread = f" ± {error:.3g}" if math.isfinite(error) else ""
        parts.append(f"{SYMBOLS[name]} = {value:.4g}{spread}")
    return ", ".join(parts)


def straight_table(runs: Sequence[Run], data: Measurements, rows: Split, s: Study) -> list[str]:
    """Measured and predicted straight speeds, both sets, and leave-one-out."""
    lines = [
        "| run (amp°/bias° trial) | role | beats | rise | U measured [m/s] "
        "| U quadratic [m/s] | error [%] | U lin+quad [m/s] | error [%] "
        "| LOO quadratic [%] | LOO lin+quad [%] |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for i in rows.straight:
        run, measured = runs[i], data.speed_m_s[i]
        role = "fit" if i in rows.straight_train else "**predicted**"
        cells = [
            run.label, role, f"{run.beats:.1f}", f"{100 * run.rise:+.0f} %", f"{measured:.4f}",
            f"{s.quadratic.speed[i]:.4f}", pct(s.quadratic.speed[i] / measured - 1.0),
            f"{s.linear.speed[i]:.4f}", pct(s.linear.speed[i] / measured - 1.0),
            pct(s.loo_quadratic[i] / measured - 1.0), pct(s.loo_linear[i] / measured - 1.0),
        ]  # fmt: skip
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def turning_table(runs: Sequence[Run], data: Measurements, rows: Split, s: Study) -> list[str]:
    """Measured and predicted turning radii and speeds of every turning run."""
    radius = model_radius(s.turning)
    measured_radius = np.asarray(data.turning_radius_m, dtype=float)
    lines = [
        "| run (amp°/bias° trial) | role | beats | R measured [m] | R predicted [m] | error [%] "
        "| U measured [m/s] | U predicted [m/s] | error [%] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for i in rows.turn_train[len(rows.straight_train) :] + rows.turn_test:
        run = runs[i]
        role = "fit" if i in rows.turn_train else ("predicted" if run.steady else "predicted (*)")
        cells = [
            run.label, role, f"{run.beats:.1f}", f"{measured_radius[i]:+.3f}",
            f"{radius[i]:+.3f}", pct(radius[i] / measured_radius[i] - 1.0),
            f"{data.speed_m_s[i]:.4f}", f"{s.turning.speed[i]:.4f}",
            pct(s.turning.speed[i] / data.speed_m_s[i] - 1.0),
        ]  # fmt: skip
        lines.append("| " + " | ".join(cells) + " |")
    return lines


class Headline(NamedTuple):
    """The figures a reader judges the model by, for one geometry."""

    speed_quadratic: FloatArray  # relative errors of the predicted straight runs
    speed_linear: FloatArray
    loo_quadratic: FloatArray
    loo_linear: FloatArray
    radius: FloatArray  # relative errors of the predicted turning radii
    turn_speed: FloatArray
    wrong_way: int


def headline(data: Measurements, rows: Split, s: Study) -> Headline:
    """The prediction errors of one study."""
    test, straight, turns = rows.straight_test, rows.straight, rows.turn_test
    measured_radius = np.asarray(data.turning_radius_m, dtype=float)[turns]
    radius = model_radius(s.turning)[turns]
    return Headline(
        relative(s.quadratic.speed[test], data.speed_m_s[test]),
        relative(s.linear.speed[test], data.speed_m_s[test]),
        relative(s.loo_quadratic[straight], data.speed_m_s[straight]),
        relative(s.loo_linear[straight], data.speed_m_s[straight]),
        relative(radius, measured_radius),
        relative(s.turning.speed[turns], data.speed_m_s[turns]),
        int(np.sum(np.sign(radius) != np.sign(measured_radius))),
    )


def other_trial(runs: Sequence[Run], values: FloatArray, rows: Sequence[int]) -> FloatArray:
    """Each run of ``rows`` "predicted" by the other trial of its setting (the data's scatter)."""
    errors = []
    for i in rows:
        mates = [
            j for j, run in enumerate(runs)
            if j != i and (run.amplitude_deg, run.bias_deg) == (runs[i].amplitude_deg,
                                                                runs[i].bias_deg)
        ]  # fmt: skip
        errors.append(values[mates[0]] / values[i] - 1.0 if mates else math.nan)
    return np.array(errors)


def setting_mean_errors(
    runs: Sequence[Run], measured: FloatArray, rows: Sequence[int], errors: FloatArray
) -> FloatArray:
    """Prediction errors against each setting's mean over its trials (one value per setting)."""
    groups: dict[tuple[int, int], list[int]] = {}
    for k, i in enumerate(rows):
        groups.setdefault((runs[i].amplitude_deg, runs[i].bias_deg), []).append(k)
    out = []
    for ks in groups.values():
        predicted = measured[rows[ks[0]]] * (1.0 + errors[ks[0]])
        out.append(predicted / float(np.mean([measured[rows[k]] for k in ks])) - 1.0)
    return np.array(out)


def summary_lines(rows: Sequence[tuple[str, FloatArray, float]]) -> list[str]:
    """The headline table: errors of the predictions against the targets."""
    lines = [
        "| prediction | RMS error [%] | mean (signed) [%] | median abs. [%] | worst abs. [%] "
        "| within target | target |",
        "|---|---|---|---|---|---|---|",
    ]
    for label, errors, target in rows:
        finite = errors[np.isfinite(errors)]
        median = float(np.median(np.abs(finite))) if finite.size else math.nan
        mean = float(np.mean(finite)) if finite.size else math.nan
        lines.append(
            f"| {label} | {upct(rms(errors))} | {pct(mean)} | {upct(median)} "
            f"| {upct(worst(errors))} | {within(errors, target)} | ±{100 * target:.0f} % |"
        )
    return lines


def headline_rows(
    runs: Sequence[Run], data: Measurements, rows: Split, h: Headline
) -> list[tuple[str, FloatArray, float]]:
    """The headline's rows: the predictions, then the data's own trial-to-trial scatter."""
    steady = np.array([runs[i].steady for i in rows.turn_test])
    radius = np.asarray(data.turning_radius_m, dtype=float)
    turns = [i for i, run in enumerate(runs) if run.bias_deg != 0]
    n_test, n_turn = len(rows.straight_test), h.radius.size
    means = setting_mean_errors(runs, radius, rows.turn_test, h.radius)
    return [
        (f"straight speed, quadratic ({n_test} predicted)", h.speed_quadratic, SPEED_TARGET),
        (f"straight speed, linear+quadratic ({n_test} predicted)", h.speed_linear, SPEED_TARGET),
        (f"straight speed, quadratic, leave-one-out ({h.loo_quadratic.size})", h.loo_quadratic,
         SPEED_TARGET),
        (f"straight speed, linear+quadratic, leave-one-out ({h.loo_linear.size})", h.loo_linear,
         SPEED_TARGET),
        (f"turning radius ({n_turn} predicted)", h.radius, RADIUS_TARGET),
        (f"turning radius, nearer-steady runs ({int(steady.sum())} predicted)", h.radius[steady],
         RADIUS_TARGET),
        (f"turning radius vs the mean of its two trials ({means.size} settings)", means,
         RADIUS_TARGET),
        (f"turning speed ({n_turn} predicted)", h.turn_speed, SPEED_TARGET),
        (f"*data scatter:* straight speed, other trial ({len(rows.straight)})",
         other_trial(runs, data.speed_m_s, rows.straight), SPEED_TARGET),
        (f"*data scatter:* turning radius, other trial ({len(turns)})",
         other_trial(runs, radius, turns), RADIUS_TARGET),
        (f"*data scatter:* turning speed, other trial ({len(turns)})",
         other_trial(runs, data.speed_m_s, turns), SPEED_TARGET),
    ]  # fmt: skip


def bias_lines(runs: Sequence[Run], data: Measurements, rows: Split, s: Study) -> list[str]:
    """Mean |R| measured and predicted per |bias| (all amplitudes, both signs and trials)."""
    radius = np.abs(np.asarray(data.turning_radius_m, dtype=float))
    model = np.abs(model_radius(s.turning))
    lines = [
        "| abs. bias [°] | runs | mean abs. R measured [m] | mean abs. R model [m] "
        "| model / measured |",
        "|---|---|---|---|---|",
    ]
    for bias in sorted({abs(run.bias_deg) for run in runs if run.bias_deg != 0}):
        group = [i for i in rows.turn_test if abs(runs[i].bias_deg) == bias]
        measured, predicted = float(radius[group].mean()), float(model[group].mean())
        lines.append(
            f"| {bias} | {len(group)} | {measured:.3f} | {predicted:.3f} "
            f"| {predicted / measured:.2f} |"
        )
    return lines


def sensitivity_lines(
    data: Measurements, rows: Split, studies: Sequence[tuple[str, Study]]
) -> list[str]:
    """One row per geometry: fitted coefficients and prediction errors."""
    lines = [
        "| fish | C_D (quad.) | X_u [kg/s], C_D (lin+quad) | straight RMS quad. [%] "
        "| straight RMS lin+quad [%] | LOO RMS quad. [%] | LOO RMS lin+quad [%] "
        "| C_D, K_D [kg m²] (turning) | K_D / hull cross-flow | radius RMS [%] "
        "| radius median abs. [%] | radii within 15 % | turning speed RMS [%] |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for label, s in studies:
        h = headline(data, rows, s)
        g = s.geometry
        quad = "refused" if s.quadratic.refused else f"{s.quadratic.values[0]:.3g}"
        lin = "refused" if s.linear.refused else ", ".join(f"{v:.3g}" for v in s.linear.values)
        turn = "refused" if s.turning.refused else ", ".join(f"{v:.3g}" for v in s.turning.values)
        if s.turning_refused:
            turn += " †"
        crossflow = crossflow_yaw_damping(g.length, g.diameter, WATER_DENSITY)
        finite = h.radius[np.isfinite(h.radius)]
        median = float(np.median(np.abs(finite))) if finite.size else math.nan
        cells = [
            label, quad, lin, upct(rms(h.speed_quadratic)), upct(rms(h.speed_linear)),
            upct(rms(h.loo_quadratic)), upct(rms(h.loo_linear)), turn,
            f"{s.turning.values[1] / crossflow:.0f}", upct(rms(h.radius)), upct(median),
            within(h.radius, RADIUS_TARGET), upct(rms(h.turn_speed)),
        ]  # fmt: skip
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def variants() -> list[tuple[str, Geometry]]:
    """The nominal fish and each unknown dimension times each of SCALES."""
    out = [("nominal", NOMINAL)]
    for field in Geometry._fields:
        for scale in SCALES:
            changed = NOMINAL._replace(**{field: getattr(NOMINAL, field) * scale})
            out.append((f"{GEOMETRY_LABELS[field]} ×{scale:g}", changed))
    out.append(("no fin plate (c = 0, Lighthill only)", NOMINAL._replace(fin_chord=0.0)))
    return out


def report(sweep: bool = True) -> str:
    """The markdown of docs/validation.md's generated part."""
    data = read_measurements(MEASUREMENTS)
    runs = read_runs(MEASUREMENTS)
    assert len(runs) == data.rows, (len(runs), data.rows)
    rows = split(runs)
    nominal = study(NOMINAL, data, rows)
    h = headline(data, rows, nominal)
    g = NOMINAL
    crossflow = crossflow_yaw_damping(g.length, g.diameter, WATER_DENSITY)
    out = [
        f"Nominal fish (assumed): L = {g.length} m, D = {g.diameter} m, fin length "
        f"{g.fin_length} m, fin span {g.fin_span} m, fin chord {g.fin_chord} m (C_n "
        f"{FIN_NORMAL_DRAG}); hull cross-flow K_D estimate {crossflow:.3g} kg m².",
        "",
        f"- `quadratic` on {len(rows.straight_train)} straight runs: "
        f"{coefficient_text(nominal.quadratic)}",
        f"- `linear-quadratic` on the same runs: {coefficient_text(nominal.linear)}",
        f"- `turning` on those and {len(rows.turn_train) - len(rows.straight_train)} turning "
        f"runs: {coefficient_text(nominal.turning)} "
        f"({nominal.turning.values[1] / crossflow:.1f} × the hull's cross-flow estimate); "
        "its free body's straight speeds (15, 20, 25, 30°, trial 1) err by "
        + ", ".join(
            pct(nominal.turning.speed[i] / data.speed_m_s[i] - 1.0) + " %"
            for i in rows.straight
            if runs[i].trial == 1
        ),
        "",
        "#### Headline (nominal fish)",
        "",
        *summary_lines(headline_rows(runs, data, rows, h)),
        "",
        f"Predicted turns the wrong way round: {h.wrong_way} of {h.radius.size}.",
        "",
        "#### Straight runs (nominal fish)",
        "",
        *straight_table(runs, data, rows, nominal),
        "",
        "#### Turning radius by bias (nominal fish, predicted runs)",
        "",
        *bias_lines(runs, data, rows, nominal),
        "",
        "#### Turning runs (nominal fish, `turning` fit)",
        "",
        "(*) outside the nearer-steady subset (fewer than "
        f"{STEADY_MIN_BEATS:g} beats or a last-beat rise over {100 * STEADY_MAX_RISE:g} %).",
        "",
        *turning_table(runs, data, rows, nominal),
    ]
    if sweep:
        studies = [("nominal", nominal)] + [
            (label, study(geometry, data, rows, lift_cap=True))
            for label, geometry in variants()[1:]
        ]
        out += [
            "",
            "#### Sensitivity to the unknown dimensions",
            "",
            *sensitivity_lines(data, rows, studies),
        ]
        if any(s.turning_refused for _, s in studies):
            out += [
                "",
                "† `fishtail-swim fit` refuses this turning fit: K_D ends on its cap, "
                f"{fit_problem.YAW_DAMPING_SPAN:g} × the hull's cross-flow estimate; the values "
                f"are the same fit with the cap lifted to {LIFTED_YAW_DAMPING_SPAN:g} × in this "
                "script.",
            ]
    return "\n".join(out) + "\n"


def main(argv: Sequence[str] | None = None) -> None:
    """Print the generated markdown (``--no-sweep``: the nominal fish only)."""
    arguments = sys.argv[1:] if argv is None else list(argv)
    sys.stdout.write(report(sweep="--no-sweep" not in arguments))


if __name__ == "__main__":
    main()
