"""Motor files: the format, its checks, the catalogue in config/motors and the default motor."""

from __future__ import annotations

import copy
import math
from pathlib import Path

import pytest
import yaml

from fishtail_plant.errors import MotorFileError, MotorSpecError
from fishtail_plant.motor.dc_motor import DcMotorParameters
from fishtail_plant.motor.motor_file import (
    GEARBOX_OUTPUT,
    motor_spec_from_document,
    read_motor_file,
    write_motor_file,
)

MOTORS = Path(__file__).resolve().parents[3] / "config" / "motors"
CATALOGUE = sorted(MOTORS.glob("*.yaml"))
DEFAULT = MOTORS / "pololu-37d-12v.yaml"
RPM = 2.0 * math.pi / 60.0
#: The 37D datasheet's no-load speeds times their ratios span 9,900 to 10,500 rpm (units measured
#: one by one); the model's one motor is within this of each (70:1, 150 rpm against 141.5).
SCATTER = 0.06


def document(path=DEFAULT):
    return yaml.safe_load(path.read_text(encoding="utf-8"))


def write(tmp_path, content, name="motor.yaml"):
    path = tmp_path / name
    text = content if isinstance(content, str) else yaml.safe_dump(content, sort_keys=False)
    path.write_text(text, encoding="utf-8")
    return path


def rpm(motor: DcMotorParameters) -> float:
    return motor.no_load_speed_rad_s / RPM


def half_unit(figure: float) -> float:
    """Half a unit of a published figure's last significant digit (330 -> 0.5, 1.3729 -> 5e-5)."""
    text = f"{figure:g}"
    if "." in text:
        return 0.5 * 10.0 ** -len(text.split(".")[1])
    return 0.5 * 10.0 ** (len(text) - len(text.rstrip("0")))


# ---- the default motor and the catalogue


def test_the_default_file_is_the_suites_default_motor():
    spec = read_motor_file(DEFAULT)
    assert spec.parameters() == DcMotorParameters()
    assert spec.parameters(30.0) == DcMotorParameters()
    assert spec.default_gear_ratio == 30.0
    assert spec.peak_current_a == 5.5
    assert spec.continuous_current_a == pytest.approx(0.25 * 5.5)


def test_the_catalogue_has_three_to_five_motors_and_a_readme_listing_them():
    assert 3 <= len(CATALOGUE) <= 5
    readme = (MOTORS / "README.md").read_text(encoding="utf-8")
    for path in CATALOGUE:
        assert path.name in readme


@pytest.mark.parametrize("path", CATALOGUE, ids=lambda path: path.stem)
def test_each_catalogue_motor_gives_its_published_figures(path):
    spec = read_motor_file(path)
    assert spec.source.strip() and spec.name.strip()
    assert spec.continuous_current_a <= spec.peak_current_a
    figures = spec.motor.figures
    # The ratio the motor's own figures (or, for constants, the default) were read at.
    reference = figures.gear_ratio if figures is not None else spec.default_gear_ratio
    checked = 0
    for entry in spec.gearbox.ratios:
        motor = spec.parameters(entry.ratio)
        if entry.stall_torque_n_m is not None:
            # Each derived efficiency returns the stall torque; the 37D's rounded 0.76 at 30:1
            # returns 1.3743 N m for the datasheet's 140 kg mm (1.3729): within its last digit.
            assert motor.stall_torque_n_m == pytest.approx(entry.stall_torque_n_m, rel=2e-3)
            checked += 1
        if entry.no_load_speed_rpm is not None:
            published = entry.no_load_speed_rpm
            if entry.ratio == reference:
                assert rpm(motor) == pytest.approx(published, abs=half_unit(published))
            else:
                assert rpm(motor) == pytest.approx(published, rel=SCATTER)
            checked += 1
    if figures is not None and figures.shaft == GEARBOX_OUTPUT:
        motor = spec.parameters(figures.gear_ratio)
        speed = figures.no_load_speed_rpm
        assert rpm(motor) == pytest.approx(speed, abs=half_unit(speed))
        torque = figures.stall_torque_n_m
        assert motor.stall_torque_n_m == pytest.approx(torque, abs=half_unit(torque))
        assert motor.stall_current_a == pytest.approx(figures.stall_current_a, rel=1e-12)
        checked += 2
    assert checked >= 2


def test_the_37d_efficiencies_fall_with_the_gearbox_stages():
    spec = read_motor_file(DEFAULT)
    efficiencies = dict(spec.gear_ratio_efficiencies)
    assert spec.gear_ratios == (6.25, 10.0, 18.75, 30.0, 50.0, 70.0, 102.08, 131.25, 150.0)
    assert efficiencies[30.0] == 0.76
    assert efficiencies[6.25] == pytest.approx(0.781, abs=1e-3)
    assert efficiencies[150.0] == pytest.approx(0.531, abs=1e-3)
    assert all(0.5 < efficiency < 0.8 for efficiency in efficiencies.values())


# ---- the derivations, by hand


def test_figures_at_the_gearbox_output_give_r_k_friction_and_efficiency_as_the_docs_derive():
    content = document(MOTORS / "pololu-25d-hp-12v.yaml")
    spec = motor_spec_from_document(content)
    r = 12.0 / 5.0
    motor_speed = 220.0 * RPM * 46.85
    k = (12.0 - r * 0.3) / motor_speed
    coulomb = 0.5 * k * 0.3
    assert spec.resistance_ohm == pytest.approx(r, rel=1e-12)
    assert spec.torque_constant_n_m_a == pytest.approx(k, rel=1e-12)
    assert spec.coulomb_friction_n_m == pytest.approx(coulomb, rel=1e-12)
    assert spec.viscous_friction_n_m_s == pytest.approx(coulomb / motor_speed, rel=1e-12)
    assert spec.efficiency(46.85) == pytest.approx(1.471 / (46.85 * (k * 5.0 - coulomb)), rel=1e-12)


def motor_shaft_document():
    """A motor given at its own shaft, behind a gearbox of a continuous range."""
    return {
        "name": "a coreless motor with a planetary gearhead",
        "source": "made-up figures for the test",
        "supply_voltage_v": 12.0,
        "motor": {
            "figures": {"shaft": "motor", "no_load_speed_rpm": 9900.0, "stall_current_a": 0.876,
                        "stall_torque_n_m": 0.0099},
            "no_load_current_a": 0.0105,
            "rotor_inertia_kg_m2": 6.7e-8,
            "friction": {"no_load_coulomb_share": 1.0},
        },
        "gearbox": {"range": {"min_ratio": 10, "max_ratio": 300, "efficiency": 0.7},
                    "default_ratio": 100},
        "current": {"continuous_a": 0.19},
    }  # fmt: skip


def test_figures_at_the_motor_shaft_and_a_range_of_ratios():
    spec = motor_spec_from_document(motor_shaft_document())
    r = 12.0 / 0.876
    k = (12.0 - r * 0.0105) / (9900.0 * RPM)
    assert spec.torque_constant_n_m_a == pytest.approx(k, rel=1e-12)
    assert spec.coulomb_friction_n_m == pytest.approx(k * 0.0105, rel=1e-12)
    assert spec.viscous_friction_n_m_s == 0.0
    assert spec.gear_ratios == () and spec.gear_ratio_range == (10.0, 300.0)
    assert spec.peak_current_a == pytest.approx(0.876, rel=1e-12)  # the stall current
    motor = spec.parameters(123.4)
    assert (motor.gear_ratio, motor.gearbox_efficiency) == (123.4, 0.7)
    assert spec.parameters() == spec.parameters(100.0)
    # All the no-load current is friction: the model's no-load speed is the published one.
    assert motor.no_load_speed_rad_s * 123.4 / RPM == pytest.approx(9900.0, rel=1e-12)
    with pytest.raises(
        MotorSpecError, match="gear ratio 400 is not offered: its range is 10 to 300"
    ):
        spec.parameters(400.0)


def test_a_discrete_catalogue_offers_only_its_ratios_and_a_range_adds_the_others():
    content = document()
    spec = motor_spec_from_document(content)
    assert not spec.offers(40.0) and spec.offers(102.08)
    with pytest.raises(MotorSpecError, match="gear ratio 40 is not offered: the gearbox's ratios"):
        spec.parameters(40.0)
    content["gearbox"]["range"] = {"min_ratio": 20, "max_ratio": 60, "efficiency": 0.65}
    spec = motor_spec_from_document(content)
    assert spec.parameters(40.0).gearbox_efficiency == 0.65
    assert spec.parameters(30.0).gearbox_efficiency == 0.76  # a ratio sold keeps its own


def test_without_a_default_ratio_one_must_be_chosen():
    content = document()
    del content["gearbox"]["default_ratio"]
    spec = motor_spec_from_document(content)
    assert spec.default_gear_ratio is None
    with pytest.raises(MotorSpecError, match="no default gear ratio: choose one"):
        spec.parameters()
    assert spec.parameters(50.0).gear_ratio == 50.0


# ---- writing


@pytest.mark.parametrize("path", CATALOGUE, ids=lambda path: path.stem)
def test_a_written_file_reads_back_equal(tmp_path, path):
    spec = read_motor_file(path)
    written = tmp_path / "written.yaml"
    write_motor_file(spec, written)
    again = read_motor_file(written)
    assert again == spec
    assert again.parameters() == spec.parameters()


def test_a_range_and_motor_shaft_figures_read_back_equal(tmp_path):
    spec = motor_spec_from_document(motor_shaft_document())
    write_motor_file(spec, tmp_path / "m.yaml")
    assert read_motor_file(tmp_path / "m.yaml") == spec


def test_an_unwritable_path_is_one_line(tmp_path):
    spec = read_motor_file(DEFAULT)
    with pytest.raises(MotorFileError, match=r"^cannot write motor file .*/no/m\.yaml: No such"):
        write_motor_file(spec, tmp_path / "no" / "m.yaml")


# ---- bad files


def changed(change):
    content = copy.deepcopy(document())
    change(content)
    return content


def _set(section, key, value):
    def change(content):
        target = content
        for name in section:
            target = target[name]
        target[key] = value

    return change


def _delete(section, key):
    def change(content):
        target = content
        for name in section:
            target = target[name]
        del target[key]

    return change


@pytest.mark.parametrize(
    ("change", "words"),
    [
        (_set((), "colour", "blue"), "unknown key 'colour' (known: name, source,"),
        (_set(("motor",), "resistance", 2.0), "unknown key 'motor.resistance' (known:"),
        (_set(("gearbox",), "ratios", [{"ratio": 30, "eff": 0.7}]),
         "unknown key 'gearbox.ratios[0].eff'"),
        (_delete((), "supply_voltage_v"), "missing key 'supply_voltage_v'"),
        (_delete(("current",), "continuous_a"), "missing key 'current.continuous_a'"),
        (_delete(("motor",), "torque_constant_n_m_a"), "missing key 'motor.torque_constant_n_m_a'"),
        (_delete(("motor", "friction"), "viscous_friction_n_m_s"),
         "missing key 'motor.friction.viscous_friction_n_m_s'"),
        (_set(("motor",), "resistance_ohm", -2.18),
         "motor.resistance_ohm = -2.18 is outside [0.01, 1000.0] ohm"),
        (_set(("motor",), "resistance_ohm", "two"),
         "motor.resistance_ohm must be a number, got 'two'"),
        (_set((), "supply_voltage_v", True), "supply_voltage_v must be a number, got True"),
        (_set(("gearbox",), "default_ratio", 40),
         "gearbox.default_ratio: gear ratio 40 is not offered: the gearbox's ratios are 6.25, 10,"),
        (_set(("gearbox",), "ratios", [{"ratio": 30}]),
         "gearbox.ratios[0] (ratio 30) has no efficiency: give its efficiency or stall_torque_n_m"),
        (_set(("gearbox",), "ratios", [{"ratio": 30, "stall_torque_n_m": 3.0}]),
         "gearbox.ratios[0].stall_torque_n_m = 3.0 N m needs a gearbox efficiency of 1.66 at "
         "ratio 30"),
        (_set(("gearbox",), "ratios", [{"ratio": 30, "efficiency": 0.7}, {"ratio": 30.0}]),
         "gearbox.ratios[1].ratio = 30.0 is listed twice"),
        (_set(("gearbox",), "ratios", 30), "gearbox.ratios must be a list of mappings"),
        (_set((), "gearbox", {"default_ratio": 30}),
         "missing key 'gearbox.ratios' or 'gearbox.range'"),
        (_set(("motor",), "figures", {"shaft": "motor", "no_load_speed_rpm": 9900,
                                      "stall_current_a": 5.5}),
         "motor: give either resistance_ohm and torque_constant_n_m_a or figures, not both"),
        (_set(("motor", "friction"), "no_load_coulomb_share", 0.5),
         "motor.friction: give either no_load_coulomb_share or coulomb_friction_n_m"),
        (_set(("motor",), "no_load_current_a", 6.0),
         "motor.no_load_current_a = 6.0 A is not below the stall current V/R = 5.505 A"),
        (_set(("current",), "peak_a", 1.0), "current.peak_a = 1.0 A is below current.continuous_a"),
        (_set((), "name", ""), "name must be a non-empty string, got ''"),
        (_set(("motor",), "torque_constant_n_m_a", 2.0),
         "motor.torque_constant_n_m_a = 2.0 is outside [0.0001, 1.0] N m/A"),
    ],
)  # fmt: skip
def test_a_bad_file_is_refused_in_one_line_naming_the_file_and_the_key(tmp_path, change, words):
    path = write(tmp_path, changed(change))
    with pytest.raises(MotorFileError) as caught:
        read_motor_file(path)
    message = str(caught.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: ")
    assert words in message


def test_figures_that_give_a_motor_out_of_range_are_refused_naming_them(tmp_path):
    content = document(MOTORS / "pololu-25d-hp-12v.yaml")
    content["motor"]["figures"]["gear_ratio"] = 10_000  # a motor shaft at 2.2 million rpm
    content["gearbox"]["ratios"] = [{"ratio": 46.85, "efficiency": 0.6}]
    words = (
        r"motor\.yaml: at gear ratio 46\.85, motor\.figures \(with supply_voltage_v\) give "
        r"torque_constant_n_m_a = 4\.896\d*e-05 is outside \[0\.0001, 1\.0\] N m/A$"
    )
    with pytest.raises(MotorFileError, match=words):
        read_motor_file(write(tmp_path, content))


@pytest.mark.parametrize(
    ("content", "words"),
    [
        ("name: [unclosed\n", "is not valid YAML: while parsing a flow sequence"),
        ("- a list\n- not a mapping\n", ": the file must be a mapping of keys (name, source,"),
        ("", ": the file must be a mapping of keys"),
    ],
)
def test_a_file_that_is_not_a_motor_file_is_one_line(tmp_path, content, words):
    path = write(tmp_path, content)
    with pytest.raises(MotorFileError) as caught:
        read_motor_file(path)
    message = str(caught.value)
    assert "\n" not in message and message.startswith(str(path))
    assert words in message


def test_a_missing_or_binary_file_is_one_line(tmp_path):
    with pytest.raises(MotorFileError, match=r"^cannot read motor file .*none\.yaml: No such file"):
        read_motor_file(tmp_path / "none.yaml")
    binary = tmp_path / "binary.yaml"
    binary.write_bytes(b"\xff\xfe\x00")
    with pytest.raises(MotorFileError, match=r"binary\.yaml is not UTF-8 text"):
        read_motor_file(binary)
