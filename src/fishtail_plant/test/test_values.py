"""The tail as the simulated DC motor's load: built from parameter values, refused with reasons."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from fishtail_driver.parameters import DRIVER_PARAMETERS, SPECS, load_refusal
from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.linkage_load.link_inertia import LinkInertia
from fishtail_plant.linkage_load.surroundings import SURROUNDINGS
from fishtail_plant.linkage_load.tail_load import TailLoad
from fishtail_plant.values import LOAD_PARAMETERS, tail_load_from_files
from fishtail_plant.values import read_only_load_parameters as load_parameters
from fishtail_plant.values import tail_load_from_values as tail_load

CONFIG = Path(__file__).resolve().parents[3] / "config"
#: Angles over more than a turn, both signs; speeds both ways.
ANGLES = np.linspace(-7.0, 7.0, 61)
SPEEDS = (-3.0, 0.0, 4.0, 12.0)


def driver_values(**changes: object) -> dict[str, object]:
    """Every driver parameter at its default, with ``changes``."""
    return {**{spec.name: spec.default for spec in DRIVER_PARAMETERS}, **changes}


def declared_values(**changes: object) -> dict[str, object]:
    """What the driver declares for the load, at the defaults, with ``changes``."""
    return {**{spec.name: spec.default for spec in load_parameters()}, **changes}


def same_load(built: TailLoad, by_hand: TailLoad) -> None:
    """The two loads give the same torque and inertia everywhere."""
    for phi in ANGLES:
        assert built.inertia(phi) == by_hand.inertia(phi)
        for omega in SPEEDS:
            assert built.torque(phi, omega) == by_hand.torque(phi, omega)
    assert built.speed_per_carrier_speed_m_rad == by_hand.speed_per_carrier_speed_m_rad


def test_the_choices_are_the_surroundings_of_the_load():
    assert SPECS["motor_load"].choices == SURROUNDINGS
    assert SPECS["motor_load"].default == "none" and SPECS["motor_load"].read_only


def test_the_load_parameters_are_the_specs_themselves_read_only():
    """One home for each default: the engine's and the fish's specs, only made read-only."""
    declared = load_parameters()
    assert [spec.name for spec in declared] == [spec.name for spec in LOAD_PARAMETERS]
    for spec, original in zip(declared, LOAD_PARAMETERS, strict=True):
        assert spec.read_only
        assert (spec.default, spec.minimum, spec.maximum, spec.choices) == (
            original.default, original.minimum, original.maximum, original.choices,
        )  # fmt: skip
    # Declared beside the driver's own: no name may be both.
    assert not {spec.name for spec in declared} & set(SPECS)


def test_the_load_from_parameter_values_is_the_one_built_by_hand():
    values = declared_values(
        mechanism="undulatory",
        fin_link_m=0.22,
        fin_link_mass_kg=0.07,
        fin_span_m=0.12,
        drag_coefficient=0.4,
        # The other mechanism's lengths and links are declared too, and ignored.
        tail_link_m=0.3,
        tail_link_mass_kg=0.5,
    )
    built = tail_load(values, "water_swimming")
    by_hand = TailLoad(
        make_tail(UndulatoryGeometry(fin_link_m=0.22)),
        LinkInertia(fin_link_mass_kg=0.07),
        FishParameters(fin_span_m=0.12, drag_coefficient=0.4),
        "water_swimming",
    )
    same_load(built, by_hand)
    assert built.torque(0.3, 8.0) != 0.0


@pytest.mark.parametrize("surroundings", ["air", "water_held"])
def test_the_default_files_give_the_report_tail(surroundings):
    """No file named: config/oscillatory.yaml and config/fish.yaml (the report's tail, the fish)."""
    default = tail_load_from_files(surroundings)
    same_load(
        default,
        tail_load_from_files(surroundings, CONFIG / "oscillatory.yaml", CONFIG / "fish.yaml"),
    )
    # The files hold the specs' defaults, the masses' moments of inertia rounded to 12 digits.
    by_hand = TailLoad(
        make_tail(OscillatoryGeometry(rocker_link_m=0.23392597023416575)),
        LinkInertia(),
        FishParameters(),
        surroundings,
    )
    for phi in ANGLES:
        assert default.inertia(phi) == pytest.approx(by_hand.inertia(phi), rel=1e-9)
        assert default.torque(phi, 5.0) == pytest.approx(by_hand.torque(phi, 5.0), rel=1e-9)
    undulatory = tail_load_from_files(
        surroundings, CONFIG / "undulatory.yaml", CONFIG / "fish.yaml"
    )
    assert undulatory.model.tail.name == "undulatory"


def test_a_load_without_the_dc_motor_is_refused_with_the_reason():
    assert load_refusal(driver_values()) is None
    assert load_refusal(driver_values(motor_model="dc", motor_load="water_held")) is None
    reason = load_refusal(driver_values(motor_load="water_held"))
    assert reason.startswith("motor_load water_held needs backend sim with motor_model dc")
    assert "motor_model first_order" in reason
    reason = load_refusal(driver_values(backend="serial", motor_model="dc", motor_load="air"))
    assert "got backend serial" in reason


def test_an_infeasible_geometry_is_refused_with_the_engines_reason():
    with pytest.raises(ValueError, match=r"^motor_load air: linkage cannot assemble over"):
        tail_load(declared_values(crank_link_m=0.01), "air")


def test_a_fin_with_chord_adds_its_added_mass_in_water_only():
    chord = declared_values(fin_chord_m=0.02)
    in_air, in_water = tail_load(chord, "air"), tail_load(chord, "water_held")
    assert in_water.inertia(0.3) > in_air.inertia(0.3) > 0.0
    no_chord = declared_values(fin_chord_m=0.0)
    assert tail_load(no_chord, "water_held").inertia(0.3) == in_air.inertia(0.3)
    # The default fin's 0.06 m chord: three times the added mass of 0.02 m's, and more.
    default = tail_load(declared_values(), "water_held")
    assert default.inertia(0.3) > in_water.inertia(0.3)


def test_missing_and_refused_files_are_named(tmp_path):
    with pytest.raises(ValueError, match="no parameter file .*nowhere.yaml"):
        tail_load_from_files("air", tmp_path / "nowhere.yaml")
    with pytest.raises(ValueError, match="unknown fish parameter 'mechanism'"):
        tail_load_from_files("air", fish=CONFIG / "oscillatory.yaml")


def test_a_driver_without_a_load_loads_no_swimming_dynamics():
    """The node, the fake board and unloaded backends start without the dynamics (nor numba)."""
    script = textwrap.dedent(
        """
        import sys

        import fishtail_boards.fake_board
        import fishtail_driver.node
        from fishtail_driver.parameters import DC_MOTOR_ENCODER, DRIVER_PARAMETERS, make_backend

        values = {spec.name: spec.default for spec in DRIVER_PARAMETERS}
        make_backend({**values, "motor_model": "first_order"}).read()
        make_backend({**values, "motor_model": "dc", **DC_MOTOR_ENCODER}).read()
        heavy = [name for name in sys.modules
                 if name == "numba" or name.startswith("fishtail_plant.linkage_load.tail_load")]
        print("loaded:", heavy)
        """
    )
    completed = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60
    )
    assert completed.stdout.strip() == "loaded: []", completed.stderr
