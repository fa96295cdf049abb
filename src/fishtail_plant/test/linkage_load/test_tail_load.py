"""The carrier's load for a motor model: the table against the engine, the omega² law, kappa."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import make_tail
from fishtail_plant.errors import SwimInputError
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.linkage_load.link_inertia import LinkInertia
from fishtail_plant.linkage_load.surroundings import SURROUNDINGS
from fishtail_plant.linkage_load.tail_load import TailLoad
from fishtail_swim.offline.inputs import Swimmer
from fishtail_swim.offline.steady_table import steady_rows

GEOMETRIES = [OscillatoryGeometry(), UndulatoryGeometry()]


@pytest.mark.parametrize("geometry", GEOMETRIES, ids=["mechanism 1", "mechanism 2"])
@pytest.mark.parametrize("surroundings", ["air", "water_held", "water_swimming"])
def test_the_table_gives_the_engines_load(geometry: object, surroundings: str) -> None:
    load = TailLoad(make_tail(geometry), LinkInertia(), FishParameters(), surroundings)
    rng = np.random.default_rng(7)
    # Angles over many turns and both signs, speeds both ways: the table is periodic in phi
    # and the law omega² holds for any sign (every term is quadratic in the velocities).
    phi, omega = rng.uniform(-40.0, 40.0, 300), rng.uniform(-20.0, 20.0, 300)
    exact = load.exact(phi, omega)
    torque = np.array([load.torque(a, w) for a, w in zip(phi, omega, strict=True)])
    inertia = np.array([load.inertia(a) for a in phi])
    assert np.abs(torque - exact.torque_n_m).max() < 1e-8 * np.abs(exact.torque_n_m).max()
    assert np.abs(inertia - exact.reduced_inertia_kg_m2).max() < 1e-8 * inertia.max()
    assert load.torque(1.0, 0.0) == 0.0
    # A whole turn later, the same load: the table closes on itself.
    assert load.torque(1.0 + 2.0 * math.pi, 7.0) == pytest.approx(load.torque(1.0, 7.0), rel=1e-12)


@pytest.mark.parametrize("geometry", GEOMETRIES, ids=["mechanism 1", "mechanism 2"])
def test_the_load_is_quadratic_in_the_carrier_speed(geometry: object) -> None:
    # What the table relies on, checked on the engine's exact load.
    load = TailLoad(make_tail(geometry), LinkInertia(), FishParameters(), "water_swimming")
    phi = np.linspace(0.0, 2.0 * math.pi, 50)
    once, twice = load.exact(phi, 3.0).torque_n_m, load.exact(phi, 6.0).torque_n_m
    np.testing.assert_allclose(twice, 4.0 * once, rtol=1e-10, atol=1e-14)


def test_the_towed_fish_swims_at_the_balance_speed() -> None:
    tail, fish = make_tail(OscillatoryGeometry()), FishParameters()
    load = TailLoad(tail, LinkInertia(), fish, "water_swimming")
    rows = steady_rows(Swimmer(fish, tail), np.array([4.0, 12.0]))
    np.testing.assert_allclose(
        rows.speed_m_s / rows.carrier_speed_rad_s, load.speed_per_carrier_speed_m_rad, rtol=1e-9
    )


def test_water_needs_more_than_air_and_none_needs_nothing() -> None:
    tail = make_tail(UndulatoryGeometry())
    loads = {name: TailLoad(tail, LinkInertia(), FishParameters(), name) for name in SURROUNDINGS}
    phi = np.linspace(0.0, 2.0 * math.pi, 200, endpoint=False)
    rms = {
        name: math.sqrt(np.mean([load.torque(a, 8.0) ** 2 for a in phi]))
        for name, load in loads.items()
    }
    assert rms["none"] == 0.0 and loads["none"].inertia(0.4) == 0.0
    assert 0.0 < rms["air"] < rms["water_held"] < rms["water_swimming"]


def test_unknown_surroundings_are_refused_with_the_choices() -> None:
    with pytest.raises(SwimInputError, match="none, air, water_held, water_swimming"):
        TailLoad(make_tail(OscillatoryGeometry()), LinkInertia(), FishParameters(), "vacuum")
