"""``fishtail-swim fit``: measurements made with the model give back its C_D (and K_D).

Noisy ones leave residuals, the written fish file is usable, bad files are refused.
"""

import csv
import io
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.optimize import minimize_scalar

from fishtail_common.parameter_files import load_parameter_file
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_kinematics.engine.parameters import geometry_from_parameters, geometry_parameters_in
from fishtail_plant.fish.figures import beat_means, steady_surge_speed
from fishtail_plant.fish.fish import FISH_PARAMETERS, FishParameters
from fishtail_plant.fish.tail_drive import EngineTailDrive, constant_carrier_speed
from fishtail_plant.values import load_fish_parameters, read_fish_values
from fishtail_swim.offline.fit import fish_file_text, fit_drag
from fishtail_swim.offline.fit_free_body import RunSettings, fit_drag_and_yaw_damping
from fishtail_swim.offline.fit_measurements import parse_measurements, read_measurements
from fishtail_swim.offline.inputs import Swimmer
from fishtail_swim.offline.time_run import run_from_rest

CONFIG = Path(__file__).resolve().parents[3] / "config"
OSCILLATORY = CONFIG / "oscillatory.yaml"
FISH = CONFIG / "fish.yaml"
CARRIERS = np.array([3.0, 5.0, 8.0, 13.0])
#: The measured fish's drag and yaw damping: not the file's (0.3, 0.104).
TRUE_DRAG = 0.2
TRUE_DAMPING = 0.3
#: Short, coarse runs for the K_D fit: the synthetic measurements use the same, so the fit must
#: find the parameters to the solver's accuracy.
QUICK = RunSettings(beats=20, steps_per_beat=16)
TOOL = ("--config", OSCILLATORY, "--fish", FISH)


@pytest.fixture(scope="module")
def swimmer():
    geometry = geometry_from_parameters(geometry_parameters_in(load_parameter_file(OSCILLATORY)))
    return Swimmer(load_fish_parameters(FISH), make_tail(geometry))


def balance_speeds(swimmer, drag, carriers=CARRIERS):
    fish = FishParameters.from_values({**swimmer.fish.values(), "drag_coefficient": drag})
    drive = EngineTailDrive(swimmer.tail, constant_carrier_speed(carriers))
    return steady_surge_speed(drive, fish, 2.0 * np.pi / carriers)


def write_measurements(path, carriers, speeds, yaw_rates=None):
    header = "carrier_speed_rad_s,speed_m_s" + ("" if yaw_rates is None else ",yaw_rate_rad_s")
    lines = ["# synthetic measurements", header, ""]
    for i, carrier in enumerate(carriers):
        extra = "" if yaw_rates is None else f",{float(yaw_rates[i])!r}"
        lines.append(f"{float(carrier)!r},{float(speeds[i])!r}{extra}  # row {i}")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def csv_tables(text):
    """The fit's CSV output: the rows' table and the parameters' table."""
    rows, parameters = text.strip().split("\n\n")
    return list(csv.DictReader(io.StringIO(rows))), list(csv.DictReader(io.StringIO(parameters)))


def column(rows, name):
    return np.array([float(row[name]) for row in rows])


def test_speeds_made_at_a_known_drag_are_fitted_back(swimmer, tmp_path):
    speeds = balance_speeds(swimmer, TRUE_DRAG)
    measurements = read_measurements(write_measurements(tmp_path / "m.csv", CARRIERS, speeds))
    result = fit_drag(swimmer, measurements)
    (fitted,) = result.fitted
    assert fitted.name == "drag_coefficient"
    assert fitted.previous == pytest.approx(0.3)
    assert fitted.value == pytest.approx(TRUE_DRAG, rel=1e-9)
    assert fitted.standard_error < 1e-9
    np.testing.assert_allclose(result.model_speed_m_s, speeds, rtol=1e-9)
    np.testing.assert_allclose(result.row_drag_coefficient, TRUE_DRAG, rtol=1e-9)
    assert float(result.fish.drag_coefficient) == fitted.value


def test_noisy_speeds_leave_residuals_and_a_fit_near_the_drag(swimmer, tmp_path, swim_cli):
    noise = np.array([1.02, 0.985, 1.01, 0.99])
    speeds = balance_speeds(swimmer, TRUE_DRAG) * noise
    path = write_measurements(tmp_path / "m.csv", CARRIERS, speeds)
    status, out, err = swim_cli("fit", path, *TOOL, "--csv")
    assert status == 0, err
    rows, parameters = csv_tables(out)
    (drag,) = parameters
    value, error = float(drag["value"]), float(drag["standard_error"])
    # Speeds about 1 % off move C_D by about 2 %; the standard error covers that spread.
    assert value == pytest.approx(TRUE_DRAG, rel=0.03)
    assert 0.002 < error / value < 0.03
    model = column(rows, "model_speed_m_s")
    np.testing.assert_allclose(column(rows, "speed_m_s"), speeds, rtol=1e-9)
    np.testing.assert_allclose(column(rows, "speed_residual_m_s"), model - speeds, atol=1e-9)
    percent = column(rows, "speed_residual_percent")
    np.testing.assert_allclose(percent, 100.0 * (model / speeds - 1.0), atol=1e-6)
    assert 0.3 < np.abs(percent).min() and np.abs(percent).max() < 3.0
    np.testing.assert_allclose(model, balance_speeds(swimmer, value), rtol=1e-9)


def test_the_closed_form_is_the_least_squares_minimum(swimmer, tmp_path):
    # Cross-check against a plain bounded minimisation of the relative residuals over C_D.
    speeds = balance_speeds(swimmer, TRUE_DRAG) * np.array([1.05, 0.97, 1.0, 0.99])
    measurements = read_measurements(write_measurements(tmp_path / "m.csv", CARRIERS, speeds))

    def cost(drag):
        return float(np.sum((balance_speeds(swimmer, drag) / speeds - 1.0) ** 2))

    direct = minimize_scalar(cost, bounds=(0.05, 1.0), method="bounded", options={"xatol": 1e-9})
    assert fit_drag(swimmer, measurements).fitted[0].value == pytest.approx(direct.x, rel=1e-6)


def test_one_row_fits_without_a_standard_error(swimmer, swim_cli, tmp_path):
    speed = balance_speeds(swimmer, TRUE_DRAG, np.array([6.0]))
    path = write_measurements(tmp_path / "m.csv", [6.0], speed)
    status, out, err = swim_cli("fit", path, *TOOL)
    assert status == 0, err
    assert "drag_coefficient = 0.2 (was 0.3)" in out
    assert "no standard error" in out


def test_duplicate_rows_comments_and_a_byte_order_mark_are_fine(tmp_path):
    text = "\ufeff# pool runs\n\ncarrier_speed_rad_s , speed_m_s # header\n4,0.2\n4,0.2\n 8, 0.41\n"
    path = tmp_path / "m.csv"
    path.write_text(text, encoding="utf-8")
    measurements = read_measurements(path)
    assert measurements.carrier_speed_rad_s.tolist() == [4.0, 4.0, 8.0]
    assert measurements.speed_m_s.tolist() == [0.2, 0.2, 0.41]
    assert measurements.yaw_rate_rad_s is None
    # Columns in any order.
    lines = ["yaw_rate_rad_s,speed_m_s,carrier_speed_rad_s", "0,1,2", "-1e-3,2,4"]
    swapped = parse_measurements(lines, "x")
    assert swapped.carrier_speed_rad_s.tolist() == [2.0, 4.0]
    assert swapped.yaw_rate_rad_s is not None and swapped.yaw_rate_rad_s.tolist() == [0.0, -1e-3]


def free_body_measurements(swimmer, carriers, settings):
    """Speeds and mean yaw rates of the free body with the true C_D and K_D, one run per speed."""
    fish = FishParameters.from_values(
        {**swimmer.fish.values(), "drag_coefficient": TRUE_DRAG, "yaw_damping_kg_m2": TRUE_DAMPING}
    )
    speeds, yaw_rates = [], []
    for carrier in carriers:
        period = 2.0 * np.pi / carrier
        run = run_from_rest(
            Swimmer(fish, swimmer.tail), np.array([carrier]), period / settings.steps_per_beat,
            settings.beats * settings.steps_per_beat,
        )  # fmt: skip
        means = beat_means(run.trajectory, period, 2)
        speeds.append(float(means.mean_speed_m_s[0]))
        yaw_rates.append(float(means.mean_yaw_rate_rad_s[0]))
    return np.array(speeds), np.array(yaw_rates)


def test_yaw_rates_fit_drag_and_yaw_damping_on_the_free_body(swimmer, tmp_path, swim_cli):
    carriers = np.array([4.0, 10.0])
    speeds, yaw_rates = free_body_measurements(swimmer, carriers, QUICK)
    path = write_measurements(tmp_path / "m.csv", carriers, speeds, yaw_rates)
    result = fit_drag_and_yaw_damping(swimmer, read_measurements(path), QUICK)
    drag, damping = result.fitted
    # The runs at other carrier speeds are the fit's run, time-scaled: found to the solver's
    # accuracy.
    assert drag.value == pytest.approx(TRUE_DRAG, rel=1e-6)
    assert damping.value == pytest.approx(TRUE_DAMPING, rel=1e-5)
    assert damping.previous == pytest.approx(0.10416666666666667)
    np.testing.assert_allclose(result.model_speed_m_s, speeds, rtol=1e-8)
    np.testing.assert_allclose(result.model_yaw_rate_rad_s, yaw_rates, rtol=1e-6)
    assert not result.warnings
    # The same through the command line, with its yaw columns.
    status, out, err = swim_cli("fit", path, *TOOL, "--csv", "--beats", QUICK.beats,
        "--steps-per-beat", QUICK.steps_per_beat,
    )  # fmt: skip
    assert status == 0, err
    rows, parameters = csv_tables(out)
    assert [row["parameter"] for row in parameters] == ["drag_coefficient", "yaw_damping_kg_m2"]
    assert float(parameters[1]["value"]) == pytest.approx(TRUE_DAMPING, rel=1e-5)
    np.testing.assert_allclose(column(rows, "yaw_rate_residual_rad_s"), 0.0, atol=1e-9)


def test_yaw_rates_of_the_wrong_sign_are_refused(swimmer, tmp_path, swim_cli):
    # The Cardan tail turns the fish right (r < 0); a left turn cannot be fitted by any K_D.
    path = write_measurements(tmp_path / "m.csv", [4.0, 8.0], [0.2, 0.4], [0.002, 0.004])
    status, out, err = swim_cli("fit", path, *TOOL, "--beats", "6", "--steps-per-beat", "8")
    assert status == 2 and out == ""
    assert err.count("\n") == 1 and "turns right (< 0) at every K_D" in err


def test_the_fish_file_round_trips_through_the_reader_and_steady(swimmer, tmp_path, swim_cli):
    speeds = balance_speeds(swimmer, TRUE_DRAG) * np.array([1.01, 0.99, 1.0, 1.0])
    path = write_measurements(tmp_path / "m.csv", CARRIERS, speeds)
    fitted_file = tmp_path / "fitted_fish.yaml"
    status, out, err = swim_cli("fit", path, *TOOL, "--csv", "--output", fitted_file)
    assert status == 0, err
    assert f"wrote {fitted_file}" in err
    rows, (drag,) = csv_tables(out)
    values = read_fish_values(fitted_file)
    assert list(values) == [spec.name for spec in FISH_PARAMETERS]
    expected = {**swimmer.fish.values(), "drag_coefficient": float(drag["value"])}
    assert values == pytest.approx(expected, rel=1e-11)
    document = yaml.safe_load(fitted_file.read_text(encoding="utf-8"))
    assert list(document) == ["/**"]
    assert all(isinstance(v, float) for v in document["/**"]["ros__parameters"].values())
    speeds_text = ",".join(f"{c:g}" for c in CARRIERS)
    status, out, err = swim_cli("steady", "--config", OSCILLATORY, "--fish", fitted_file, "--csv",
        "--speeds", speeds_text,
    )  # fmt: skip
    assert status == 0, err
    steady = list(csv.DictReader(io.StringIO(out)))
    np.testing.assert_allclose(
        column(steady, "speed_m_s"), column(rows, "model_speed_m_s"), rtol=1e-9
    )


def test_small_values_are_written_as_yaml_floats(swimmer):
    fish = FishParameters.from_values({**swimmer.fish.values(), "fin_chord_m": 1e-5})
    result = fit_drag(swimmer, parse_measurements(["carrier_speed_rad_s,speed_m_s", "4,0.2"], "x"))
    text = fish_file_text(result._replace(fish=fish), "x")
    assert "fin_chord_m: 1.0e-05  #" in text
    assert yaml.safe_load(text)["/**"]["ros__parameters"]["fin_chord_m"] == 1e-5


BAD = {
    "missing_column": "carrier_speed_rad_s\n4\n",
    "unknown_column": "carrier_speed_rad_s,speed_m_s,yaw_rate\n4,0.2,0\n",
    "twice": "carrier_speed_rad_s,speed_m_s,speed_m_s\n4,0.2,0.2\n",
    "not_a_number": "carrier_speed_rad_s,speed_m_s\n4,fast\n",
    # An empty turn cell is a turn not measured; an empty speed is refused.
    "empty_field": "carrier_speed_rad_s,speed_m_s,yaw_rate_rad_s\n4,,-0.002\n8,0.4,\n",
    "nan": "carrier_speed_rad_s,speed_m_s\n4,nan\n",
    "infinite": "carrier_speed_rad_s,speed_m_s\ninf,0.2\n",
    "zero_speed": "carrier_speed_rad_s,speed_m_s\n4,0\n",
    "negative_carrier": "carrier_speed_rad_s,speed_m_s\n-4,0.2\n",
    "fields": "carrier_speed_rad_s,speed_m_s\n4,0.2,0.1\n",
    "no_rows": "# nothing measured yet\ncarrier_speed_rad_s,speed_m_s\n",
    "empty": "# only a comment\n\n",
    "one_row_two_parameters": "carrier_speed_rad_s,speed_m_s,yaw_rate_rad_s\n4,0.2,-0.002\n",
    "too_fast": "carrier_speed_rad_s,speed_m_s\n4,2.0\n8,4.0\n",
    "too_slow": "carrier_speed_rad_s,speed_m_s\n4,0.004\n",
    "not_utf8": b"carrier_speed_rad_s,speed_m_s\n4,0.2\xff\n",
    # The model's speed rises in proportion to the carrier speed: fits it contradicts.
    "falling": "carrier_speed_rad_s,speed_m_s\n4,0.4\n8,0.3\n12,0.2\n16,0.1\n",
    "scattered": "carrier_speed_rad_s,speed_m_s\n4,0.2\n8,0.7\n",
}


@pytest.mark.parametrize(
    ("name", "words"),
    [
        ("missing_column", "missing column speed_m_s"),
        ("unknown_column", "unknown column 'yaw_rate'"),
        ("twice", "column speed_m_s appears twice"),
        ("not_a_number", "line 2: speed_m_s is not a number: 'fast'"),
        ("empty_field", "line 2: missing speed_m_s (only yaw_rate_rad_s, turning_radius_m may"),
        ("nan", "line 2: speed_m_s is not a finite number"),
        ("infinite", "carrier_speed_rad_s is not a finite number"),
        ("zero_speed", "line 2: speed_m_s must be > 0"),
        ("negative_carrier", "carrier_speed_rad_s must be > 0"),
        ("fields", "line 2: 3 fields, the header has 2"),
        ("no_rows", "needs at least 1 measured rows, got 0"),
        ("empty", "no header line"),
        ("one_row_two_parameters", "needs at least 2 measured rows, got 1"),
        ("too_fast", "faster than the held-body balance swims at C_D = 0"),
        ("too_slow", "slower than the held-body balance swims at C_D = 100"),
        ("not_utf8", "not UTF-8 text"),
        ("falling", "the speeds fall as the carrier speeds up"),
        ("scattered", "RMS speed residual 26.3 % (limit 20 %)"),
        ("/no/such.csv", "no such file"),
        ("missing_directory", "no directory"),
    ],
)
def test_bad_measurements_are_one_line_and_exit_2(swim_cli, tmp_path, name, words):
    content = BAD.get(name, BAD["too_slow"].replace("0.004", "0.2"))
    path = Path(name) if name.startswith("/") else tmp_path / f"{name}.csv"
    if isinstance(content, bytes):
        path.write_bytes(content)
    elif not name.startswith("/"):
        path.write_text(content, encoding="utf-8")
    output = tmp_path / ("missing" if name == "missing_directory" else "") / "fish.yaml"
    status, out, err = swim_cli("fit", path, *TOOL, "--output", output)
    assert status == 2
    assert out == ""
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("fishtail-swim: error: ")
    assert words in lines[0]
    assert not output.exists()


def test_force_reports_and_writes_a_contradicted_fit_with_a_warning(swim_cli, tmp_path):
    path = tmp_path / "falling.csv"
    path.write_text(BAD["falling"], encoding="utf-8")
    output = tmp_path / "fish.yaml"
    status, out, err = swim_cli("fit", path, *TOOL, "--output", output, "--force")
    assert status == 0, err
    assert err.count("\n") == 1 and err.startswith("fishtail-swim: warning: the model contradicts")
    assert "RMS speed residual 67.2 % (limit 20 %)" in err and "--force" in err
    assert "RMS speed residual 67.2 %" in out and output.exists()


def test_help_works(swim_cli):
    status, out, err = swim_cli("fit", "--help")
    assert status == 0 and err == ""
    assert out.startswith("usage: fishtail-swim fit")
    assert "yaw_rate_rad_s" in out
