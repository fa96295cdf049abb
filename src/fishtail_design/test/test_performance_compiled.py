"""The search tier's figures by the compiled cycle kernel against numpy's, design by design."""

import numpy as np
import pytest

from fishtail_design.linkages import OscillatoryLinkages
from fishtail_design.performance import Performance, performance, towed_cycles
from fishtail_plant.fish import cycle_kernel
from fishtail_plant.fish.fish import FishParameters
from fishtail_plant.motor.dc_motor import DcMotorParameters
from fishtail_plant.motor.duty import MotorConstants

pytestmark = pytest.mark.skipif(
    cycle_kernel.kernel_signature() is None, reason="numba is not installed (or disabled)"
)

MOTOR = DcMotorParameters()


def _designs(count: int, seed: int) -> tuple[OscillatoryLinkages, MotorConstants]:
    """Random designs over report-fish.yaml's ranges (RS free: some do not assemble)."""
    rng = np.random.default_rng(seed)
    linkages = OscillatoryLinkages({
        "ring_radius_m": rng.uniform(0.02, 0.1, count),
        "crank_link_m": rng.uniform(0.02, 0.2, count),
        "rocker_link_m": rng.uniform(0.05, 0.3, count),
        "tail_link_m": rng.uniform(0.08, 0.3, count),
        "pivot_offset_m": rng.uniform(0.05, 0.2, count),
    })  # fmt: skip
    motor = MotorConstants.of(
        MOTOR, rng.choice([6.25, 18.75, 30.0, 50.0, 70.0], count), rng.uniform(0.6, 0.9, count)
    )
    return linkages, motor


def _assert_same(compiled: Performance, numpy_figures: Performance) -> None:
    for name, value, expected in zip(Performance._fields, compiled, numpy_figures, strict=True):
        value, expected = np.asarray(value), np.asarray(expected)
        np.testing.assert_array_equal(np.isnan(value), np.isnan(expected), err_msg=name)
        finite = np.isfinite(expected)
        np.testing.assert_array_equal(value[~finite], expected[~finite], err_msg=name)
        np.testing.assert_allclose(value[finite], expected[finite], rtol=1e-9, atol=0.0,
                                   err_msg=name)  # fmt: skip


@pytest.mark.parametrize("fixed_speed", [False, True], ids=["fastest carrier", "given carrier"])
def test_the_default_fish(fixed_speed):
    linkages, motor = _designs(200, seed=1)
    assembles = linkages.batch.assembles
    assert 20 < assembles.sum() < 180
    speed = np.where(np.arange(200) % 3 == 0, 12.0, 5.0) if fixed_speed else np.full(200, np.nan)
    figures = performance(linkages, FishParameters(), motor, speed, 128)
    _assert_same(figures, performance(linkages, FishParameters(), motor, speed, 128, None, False))
    # A linkage that does not assemble has no figures; one that does swims.
    assert np.isnan(figures.speed_m_s[~assembles]).all()
    assert (figures.speed_m_s[assembles] > 0.0).any()


def test_a_linear_drag_and_a_fish_per_design():
    linkages, motor = _designs(90, seed=2)
    rng = np.random.default_rng(3)
    # The second pass at the carrier's own speed, and every fish value the kernel reads per design.
    fish = FishParameters(
        surge_linear_damping_kg_s=rng.uniform(0.0, 3.0, 90),
        fin_chord_m=rng.uniform(0.0, 0.1, 90),
        fin_normal_drag_coefficient=rng.uniform(0.0, 2.0, 90),
        drag_coefficient=rng.uniform(0.1, 0.5, 90),
        tail_origin_offset_m=rng.uniform(0.0, 0.1, 90),
    )
    # Given speeds: the fastest one of a linkage that does not assemble is NaN, which the second
    # pass's carrier refuses (on either path).
    speed = rng.uniform(3.0, 20.0, 90)
    _assert_same(
        performance(linkages, fish, motor, speed, 64),
        performance(linkages, fish, motor, speed, 64, compiled=False),
    )


def test_the_turning_figure_follows_the_compiled_balance():
    linkages, motor = _designs(12, seed=4)
    speed = np.full(12, 8.0)
    _assert_same(
        performance(linkages, FishParameters(), motor, speed, 64, 0.5),
        performance(linkages, FishParameters(), motor, speed, 64, 0.5, False),
    )


def test_the_towed_cycles_are_the_kernels_for_mechanism_1():
    linkages, _ = _designs(5, seed=5)
    towed = towed_cycles(linkages, FishParameters(), np.ones(5), 32)
    kernel = cycle_kernel.held_cycles(linkages.batch, FishParameters(), np.ones(5), 32)
    assert kernel is not None
    for value, expected in zip(towed, kernel, strict=True):
        np.testing.assert_array_equal(value, expected)
