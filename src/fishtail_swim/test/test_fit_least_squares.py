"""``fishtail-swim fit`` by least squares: runs made with known coefficients fit back.

Servo and Cardan runs give back C_D, X_u and K_D; leave-one-out predicts noisy runs to the noise;
under-determined and degenerate fits and bad files are refused in one line; the written fish file
is one ``steady --fish`` takes.
"""

import csv
import dataclasses
import io
from pathlib import Path

import numpy as np
import pytest

from fishtail_common.parameter_files import load_parameter_file
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_plant.fish.figures import beat_means, steady_surge_speed
from fishtail_plant.fish.integrator import simulate
from fishtail_plant.fish.model import SwimModel
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed, servo_drive
from fishtail_plant.values import load_fish_parameters, read_fish_values
from fishtail_swim.offline.fit import FitRefusedError
from fishtail_swim.offline.fit_free_body import RunSettings
from fishtail_swim.offline.fit_least_squares import fit_coefficients, refuse_degenerate, run_model
from fishtail_swim.offline.fit_loo import leave_one_out
from fishtail_swim.offline.fit_measurements import Measurements
from fishtail_swim.offline.fit_problem import COEFFICIENT_SETS, Bounds, check_determined
from fishtail_swim.offline.inputs import Swimmer

CONFIG = Path(__file__).resolve().parents[3] / "config"
OSCILLATORY = CONFIG / "oscillatory.yaml"
FISH = CONFIG / "fish.yaml"
TOOL = ("--config", OSCILLATORY, "--fish", FISH)
FIN = 0.2
#: The measured fish: not the file's (C_D 0.3, X_u 0, K_D 0.104).
TRUE = {"drag_coefficient": 0.2, "surge_linear_damping_kg_s": 0.05, "yaw_damping_kg_m2": 0.3}
#: Servo runs at three amplitudes and two frequencies, some with a bias (they turn).
AMPLITUDE = np.array([0.2, 0.3, 0.4, 0.2, 0.3, 0.4])
FREQUENCY = np.array([1.0, 1.0, 1.0, 2.0, 2.0, 2.0])
BIAS = np.array([0.0, 0.1, -0.15, 0.0, 0.12, -0.1])
CARRIERS = np.array([3.0, 5.0, 8.0, 13.0])
#: Short, coarse free-body runs: the synthetic turns are made with the same.
QUICK = RunSettings(beats=20, steps_per_beat=16)


@pytest.fixture(scope="module")
def swimmer():
    geometry = geometry_from_parameters(geometry_parameters_in(load_parameter_file(OSCILLATORY)))
    return Swimmer(load_fish_parameters(FISH), make_tail(geometry))


def true_fish(swimmer, names):
    return dataclasses.replace(swimmer.fish, **{name: TRUE[name] for name in names})


def servo_speeds(swimmer, names):
    """Speeds of the servo runs by the balance with the true coefficients."""
    drive = servo_drive({"servo_fin_length_m": FIN, "servo_amplitude_rad": AMPLITUDE,
                         "servo_bias_rad": BIAS, "servo_frequency_hz": FREQUENCY})  # fmt: skip
    return steady_surge_speed(drive, true_fish(swimmer, names), 1.0 / FREQUENCY)


def servo_turns(swimmer, names):
    """Speeds and mean yaw rates of the free servo fish with the true coefficients.

    Stepped per frequency with QUICK's runs, by the library's calls, not the fit's code path.
    """
    fish = true_fish(swimmer, names)
    speed, yaw = np.empty(AMPLITUDE.size), np.empty(AMPLITUDE.size)
    for frequency in np.unique(FREQUENCY):
        group = np.flatnonzero(FREQUENCY == frequency)
        drive = servo_drive({"servo_fin_length_m": FIN, "servo_amplitude_rad": AMPLITUDE[group],
                             "servo_bias_rad": BIAS[group],
                             "servo_frequency_hz": FREQUENCY[group]})  # fmt: skip
        period = 1.0 / frequency
        trajectory = simulate(
            SwimModel(fish, drive), group.size, period / QUICK.steps_per_beat,
            QUICK.beats * QUICK.steps_per_beat,
        )  # fmt: skip
        means = beat_means(trajectory, period, 2)
        speed[group], yaw[group] = means.mean_speed_m_s, means.mean_yaw_rate_rad_s
    return speed, yaw


def servo_measurements(speed, yaw=None, radius=None):
    return Measurements(None, speed, yaw, radius, AMPLITUDE, BIAS, FREQUENCY)


def fitted_values(result):
    return {value.name: value.value for value in result.fitted}


@pytest.mark.parametrize("choice", ["quadratic", "linear-quadratic"])
def test_servo_speeds_give_back_the_drag_coefficients(swimmer, choice):
    names = COEFFICIENT_SETS[choice]
    speeds = servo_speeds(swimmer, names)
    result = fit_coefficients(swimmer, servo_measurements(speeds), names, FIN)
    assert fitted_values(result) == pytest.approx({name: TRUE[name] for name in names}, rel=1e-6)
    np.testing.assert_allclose(result.model_speed_m_s, speeds, rtol=1e-9)
    assert result.model_yaw_rate_rad_s is None and not result.warnings


def test_cardan_speeds_give_back_linear_and_quadratic_drag(swimmer):
    names = COEFFICIENT_SETS["linear-quadratic"]
    drive = EngineTailDrive(swimmer.tail, constant_carrier_speed(CARRIERS))
    speeds = steady_surge_speed(drive, true_fish(swimmer, names), 2.0 * np.pi / CARRIERS)
    result = fit_coefficients(swimmer, Measurements(CARRIERS, speeds), names, FIN)
    assert fitted_values(result) == pytest.approx({name: TRUE[name] for name in names}, rel=1e-6)


@pytest.mark.parametrize("choice", ["turning", "linear-turning"])
def test_servo_turns_give_back_the_yaw_damping(swimmer, choice):
    names = COEFFICIENT_SETS[choice]
    speed, yaw = servo_turns(swimmer, names)
    # Half the runs give a yaw rate, the other half a turning radius (U/R), one neither.
    yaw_column = np.where(np.arange(yaw.size) % 2 == 0, yaw, np.nan)
    radius = np.where(np.arange(yaw.size) % 2 == 1, speed / yaw, np.nan)
    radius[-1] = np.nan
    result = fit_coefficients(
        swimmer, servo_measurements(speed, yaw_column, radius), names, FIN, QUICK
    )
    assert fitted_values(result) == pytest.approx({name: TRUE[name] for name in names}, rel=1e-6)
    np.testing.assert_allclose(result.model_yaw_rate_rad_s, yaw, rtol=1e-6, atol=1e-9)


def test_leave_one_out_predicts_noisy_runs_to_the_noise(swimmer):
    names = COEFFICIENT_SETS["linear-quadratic"]
    # Nine runs: three amplitudes at three frequencies, speeds with 2 % relative noise.
    amplitude = np.tile([0.2, 0.3, 0.4], 3)
    frequency = np.repeat([0.8, 1.4, 2.0], 3)
    bias = np.zeros(9)
    drive = servo_drive({"servo_fin_length_m": FIN, "servo_amplitude_rad": amplitude,
                         "servo_frequency_hz": frequency})  # fmt: skip
    exact = steady_surge_speed(drive, true_fish(swimmer, names), 1.0 / frequency)
    noise = 0.02
    speeds = exact * (1.0 + noise * np.random.default_rng(7).standard_normal(9))
    measurements = Measurements(None, speeds, None, None, amplitude, bias, frequency)
    result = fit_coefficients(swimmer, measurements, names, FIN)
    loo = leave_one_out(run_model(swimmer, measurements, names, FIN, QUICK), measurements, result)
    assert loo.predicted.all() and loo.converged
    errors = loo.speed_m_s / speeds - 1.0
    residuals = result.model_speed_m_s / speeds - 1.0
    rms = float(np.sqrt(np.mean(errors**2)))
    # Predictions miss by about the noise; the fit's own residuals are smaller than that.
    assert 0.5 * noise < rms < 2.0 * noise
    assert np.sqrt(np.mean(residuals**2)) < rms
    # The fit to the others is a fit: without noise, every run is predicted exactly.
    exact_runs = measurements._replace(speed_m_s=exact)
    exact_result = fit_coefficients(swimmer, exact_runs, names, FIN)
    model = run_model(swimmer, exact_runs, names, FIN, QUICK)
    np.testing.assert_allclose(leave_one_out(model, exact_runs, exact_result).speed_m_s, exact,
                               rtol=1e-6)  # fmt: skip


def test_under_determined_sets_are_refused():
    one_motion = Measurements(None, np.array([0.2, 0.21, 0.19]), None, None,
                              np.full(3, 0.3), np.array([0.0, 0.1, -0.1]), np.ones(3))  # fmt: skip
    with pytest.raises(FitRefusedError, match="needs runs at 2 or more different tail motions"):
        check_determined(COEFFICIENT_SETS["linear-quadratic"], one_motion)
    check_determined(COEFFICIENT_SETS["quadratic"], one_motion)
    with pytest.raises(FitRefusedError, match="needs a measured turn"):
        check_determined(COEFFICIENT_SETS["turning"], one_motion)
    straight = one_motion._replace(yaw_rate_rad_s=np.array([0.0, np.nan, 0.0]))
    with pytest.raises(FitRefusedError, match="every measured yaw rate is 0"):
        check_determined(COEFFICIENT_SETS["turning"], straight)
    with pytest.raises(FitRefusedError, match="needs at least 3 measured rows, got 2"):
        check_determined(COEFFICIENT_SETS["linear-turning"], one_motion.take([0, 1]))


def test_a_fit_on_a_bound_or_with_a_singular_jacobian_is_refused(swimmer):
    # Speeds with no linear drag at all: X_u ends on 0.
    names = COEFFICIENT_SETS["linear-quadratic"]
    speeds = servo_speeds(swimmer, ("drag_coefficient",))
    with pytest.raises(FitRefusedError, match="the fit ends on X_u = 0, its lower bound"):
        fit_coefficients(swimmer, servo_measurements(speeds), names, FIN)
    bounds = Bounds(np.zeros(2), np.full(2, 100.0), np.ones(2))
    parallel = np.array([[1.0, 2.0], [2.0, 4.0], [3.0, 6.0 + 1e-12]])
    with pytest.raises(FitRefusedError, match="the runs cannot separate X_u, C_D: .* condition"):
        refuse_degenerate(np.array([1.0, 1.0]), parallel, bounds, names)


def write_servo(path, speeds, extra=""):
    lines = ["# servo pool runs", "amplitude_rad,bias_rad,frequency_hz,speed_m_s" + extra]
    for i, speed in enumerate(speeds):
        row = (AMPLITUDE[i], BIAS[i], FREQUENCY[i], speed)
        lines.append(",".join(repr(float(value)) for value in row))
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_the_command_line_fits_servo_runs_and_writes_a_fish_steady_takes(
    swimmer, swim_cli, tmp_path
):
    names = COEFFICIENT_SETS["linear-quadratic"]
    noise = np.array([1.01, 0.99, 1.005, 0.995, 1.0, 1.01])
    path = write_servo(tmp_path / "servo.csv", servo_speeds(swimmer, names) * noise)
    fitted_file = tmp_path / "fitted.yaml"
    status, out, err = swim_cli("fit", path, *TOOL, "--coefficients", "linear-quadratic",
                                "--servo-fin-length-m", FIN, "--output", fitted_file)  # fmt: skip
    assert status == 0, err
    assert "leave-one-out RMS speed prediction error" in out and "over 6 of 6 runs" in out
    assert "surge_linear_damping_kg_s = " in out and f"wrote {fitted_file}" in out
    values = read_fish_values(fitted_file)
    assert values["surge_linear_damping_kg_s"] == pytest.approx(0.05, rel=0.3)
    assert values["drag_coefficient"] == pytest.approx(0.2, rel=0.1)
    status, out, err = swim_cli("steady", "--config", OSCILLATORY, "--fish", fitted_file, "--csv")
    assert status == 0, err
    assert len(list(csv.DictReader(io.StringIO(out)))) == 5
    # CSV: the leave-one-out errors are a column of the rows.
    status, out, err = swim_cli("fit", path, *TOOL, "--coefficients", "linear-quadratic", "--csv")
    assert status == 0, err
    rows = list(csv.DictReader(io.StringIO(out.split("\n\n")[0])))
    assert all(abs(float(row["loo_speed_error_percent"])) < 5.0 for row in rows)


SERVO_HEADER = "amplitude_rad,bias_rad,frequency_hz,speed_m_s"
BAD = {
    "mixed tails": ("carrier_speed_rad_s,amplitude_rad,speed_m_s\n4,0.3,0.2\n",
                    "both a Cardan tail (carrier_speed_rad_s) and a servo tail (amplitude_rad)"),
    "unknown column": ("carrier_speed_rad_s,speed_m_s,turn_radius\n4,0.2,3\n",
                       "unknown column 'turn_radius'"),
    "no tail": ("speed_m_s\n0.2\n", "missing column carrier_speed_rad_s"),
    "servo column missing": ("amplitude_rad,frequency_hz,speed_m_s\n0.3,1,0.2\n",
                             "missing column bias_rad"),
    "not a number": (f"{SERVO_HEADER}\n0.3,0,1,0.2\n0.3,0,one,0.2\n",
                     "line 3: frequency_hz is not a number: 'one'"),
    "nan": (f"{SERVO_HEADER},yaw_rate_rad_s\n0.3,0,1,0.2,nan\n",
            "line 2: yaw_rate_rad_s is not a finite number"),
    "negative speed": (f"{SERVO_HEADER}\n0.3,0,1,-0.2\n", "line 2: speed_m_s must be > 0"),
    "missing speed column": ("amplitude_rad,bias_rad,frequency_hz\n0.3,0,1\n",
                             "missing column speed_m_s"),
    "missing speed": (f"{SERVO_HEADER}\n# a run\n0.3,0,1,\n", "line 3: missing speed_m_s"),
    "amplitude out of range": (f"{SERVO_HEADER}\n4,0,1,0.2\n",
                               "line 2: amplitude_rad = 4 is outside the servo tail's range"),
    "zero radius": (f"{SERVO_HEADER},turning_radius_m\n0.3,0,1,0.2,0\n",
                    "line 2: turning_radius_m must not be 0"),
    "one motion": (f"{SERVO_HEADER}\n0.3,0,1,0.2\n0.3,0.1,1,0.19\n",
                   "needs runs at 2 or more different tail motions"),
    "no turns": (f"{SERVO_HEADER},yaw_rate_rad_s\n0.3,0,1,0.2,\n0.2,0,2,0.3,\n",
                 "needs a measured turn"),
}  # fmt: skip
SETS = {"one motion": "linear-quadratic", "no turns": "turning"}


@pytest.mark.parametrize("name", sorted(BAD))
def test_bad_files_and_fits_are_refused_in_one_line(swim_cli, tmp_path, name):
    text, words = BAD[name]
    path = tmp_path / "runs.csv"
    path.write_text(text, encoding="utf-8")
    output = tmp_path / "fish.yaml"
    choice = ("--coefficients", SETS[name]) if name in SETS else ()
    status, out, err = swim_cli("fit", path, *TOOL, *choice, "--output", output)
    assert status == 2 and out == ""
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("fishtail-swim: error: "), err
    assert words in lines[0]
    if "line" in words:
        assert f"{path} line" in lines[0]
    assert not output.exists()
