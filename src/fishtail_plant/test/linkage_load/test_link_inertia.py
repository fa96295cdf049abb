"""The links' masses and moments of inertia: specs, defaults, parameter files, refusals."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest

from fishtail_common.parameter_files import load_parameter_file
from fishtail_kinematics.engine.errors import ParameterError
from fishtail_kinematics.engine.mechanisms import TAIL_TYPES, OscillatoryTail, UndulatoryTail
from fishtail_kinematics.engine.parameters import (
    GEOMETRY_PARAMETER_NAMES,
    geometry_from_parameters,
    geometry_parameters_in,
)
from fishtail_plant.errors import InvalidInertiaError
from fishtail_plant.linkage_load.link_inertia import (
    INERTIA_PARAMETERS,
    LINKS,
    TRANSLATING_LINKS,
    LinkInertia,
    inertia_parameter_names,
    inertia_parameters_in,
    link_inertia_from_parameters,
)

CONFIG = Path(__file__).resolve().parents[4] / "config"
# The report's appendix, in grams, and the report's lengths (RS the exact symmetric rocker).
REPORT_GRAMS = {"planet": 67.76, "carrier": 2.6, "crank_link": 2.6, "rocker_link": 6.1,
                "tail_link": 89.1, "fin_link": 89.1}  # fmt: skip
RS = math.sqrt(0.1**2 + 0.2 * math.hypot(0.2, 0.1))


def test_specs_are_the_dataclass_fields_with_their_defaults():
    fields = dataclasses.fields(LinkInertia)
    assert [spec.name for spec in INERTIA_PARAMETERS] == [field.name for field in fields]
    for spec, field in zip(INERTIA_PARAMETERS, fields, strict=True):
        assert spec.default == field.default
        assert spec.minimum == 0.0
        assert spec.unit == ("kg" if spec.name.endswith("_mass_kg") else "kg m^2")
        assert "default:" in spec.description  # says where the number comes from
    # Every link has a mass; every link that turns has a moment of inertia.
    for link in LINKS:
        assert f"{link}_mass_kg" in {spec.name for spec in INERTIA_PARAMETERS}
        has_inertia = f"{link}_inertia_kg_m2" in {spec.name for spec in INERTIA_PARAMETERS}
        assert has_inertia == (link not in TRANSLATING_LINKS)


def test_defaults_are_the_reports_masses_and_uniform_links():
    inertia = LinkInertia()
    for link, grams in REPORT_GRAMS.items():
        assert inertia.mass_and_inertia(link)[0] == pytest.approx(grams / 1000, rel=1e-15)
    bars = {"carrier": 0.05, "crank_link": 0.1, "rocker_link": RS, "tail_link": 0.15,
            "swing_arm": 0.16, "slotted_link": 0.24, "fin_link": 0.2}  # fmt: skip
    for link, length in bars.items():
        mass, moment = inertia.mass_and_inertia(link)
        assert moment == pytest.approx(mass * length**2 / 12, rel=1e-12), link
    mass, moment = inertia.mass_and_inertia("planet")
    assert moment == pytest.approx(0.5 * mass * 0.05**2, rel=1e-12)  # disc of radius R/2
    # SW and AV: RS's mass per length in the report (6.1 g over 0.234 m).
    for link, length in (("swing_arm", 0.16), ("slotted_link", 0.24)):
        assert inertia.mass_and_inertia(link)[0] == pytest.approx(6.1e-3 / 0.234 * length)
    assert inertia.mass_and_inertia("slider") == (0.003, 0.0)


def test_massless_is_all_zeros():
    massless = LinkInertia.massless()
    assert all(value == 0.0 for value in dataclasses.asdict(massless).values())
    assert {massless.mass_and_inertia(link) for link in LINKS} == {(0.0, 0.0)}


@pytest.mark.parametrize("tail_type", [OscillatoryTail, UndulatoryTail])
def test_config_files_hold_each_links_values(tail_type):
    """config/<mechanism>.yaml holds exactly its links' masses and inertias, the defaults."""
    values = load_parameter_file(CONFIG / f"{tail_type.name}.yaml")
    in_file = inertia_parameters_in(values)
    assert tuple(in_file) == inertia_parameter_names(tail_type.links)
    defaults = dataclasses.asdict(LinkInertia())
    for name, value in in_file.items():
        assert value == pytest.approx(defaults[name], rel=1e-11), name
    built = dataclasses.asdict(link_inertia_from_parameters(in_file))
    assert built == pytest.approx(defaults, rel=1e-11)
    # None of them is a geometry parameter, and the file's geometry is the report's.
    assert not set(in_file) & GEOMETRY_PARAMETER_NAMES
    assert geometry_from_parameters(geometry_parameters_in(values)) == tail_type.geometry_type()


def test_every_link_belongs_to_a_mechanism():
    used = {link for tail_type in TAIL_TYPES.values() for link in tail_type.links}
    assert used == set(LINKS)


@pytest.mark.parametrize(
    ("values", "message"),
    [({"tail_link_mass_kg": -0.1}, r"tail_link_mass_kg = -0.1 is outside \[0.0, 1000.0\] kg"),
     ({"planet_inertia_kg_m2": math.nan}, "planet_inertia_kg_m2"),
     ({"slider_mass_kg": "3 g"}, "slider_mass_kg must be a number"),
     ({"slider_mass_kg": True}, "slider_mass_kg must be a number"),
     ({"slider_inertia_kg_m2": 1e-5}, "unknown link inertia parameter 'slider_inertia_kg_m2'"),
     ({"ring_radius_m": 0.1}, "unknown link inertia parameter 'ring_radius_m'")],
)  # fmt: skip
def test_bad_parameters_are_refused_with_the_reason(values, message):
    with pytest.raises(ParameterError, match=message):
        link_inertia_from_parameters(values)


@pytest.mark.parametrize("value", [-1.0, -1e-300, math.nan, -math.inf, math.inf, "1", None])
def test_bad_values_are_refused_by_the_dataclass(value):
    with pytest.raises(InvalidInertiaError, match="fin_link_inertia_kg_m2"):
        LinkInertia(fin_link_inertia_kg_m2=value)


def test_unknown_link():
    with pytest.raises(InvalidInertiaError, match="unknown link 'gearbox'"):
        LinkInertia().mass_and_inertia("gearbox")
