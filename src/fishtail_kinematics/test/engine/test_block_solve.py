"""Blocked, threaded and out= evaluation of the tails: the unblocked results to the last bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fishtail_kinematics.engine import block_solve, blocks
from fishtail_kinematics.engine.blocks import BLOCK_SAMPLES, run_blocks
from fishtail_kinematics.engine.errors import InvalidInputError, SolverError
from fishtail_kinematics.engine.geometry import OscillatoryGeometry, UndulatoryGeometry
from fishtail_kinematics.engine.mechanisms import OscillatoryTail, Tail, UndulatoryTail

TAILS = {
    "mechanism 1": OscillatoryTail(OscillatoryGeometry(phase_rad=0.3)),
    "mechanism 2": UndulatoryTail(UndulatoryGeometry()),
}


@pytest.fixture(params=sorted(TAILS))
def tail(request: pytest.FixtureRequest) -> Tail:
    return TAILS[request.param]


def unblocked(tail: Tail, angle: object, speed: object, monkeypatch: pytest.MonkeyPatch) -> list:
    """The whole batch in one evaluation of the array path (the path before blocks)."""
    with monkeypatch.context() as patch:
        patch.setattr(block_solve, "BLOCK_SAMPLES", 10**9)
        return [np.asarray(value) for value in tail.solve(angle, speed)]


def assert_bitwise_equal(state: tuple, expected: list) -> None:
    assert len(state) == len(expected)
    for value, reference in zip(state, expected, strict=True):
        value = np.asarray(value)
        assert value.shape == reference.shape
        # Equal bits (NaN would never compare equal here: the inputs are finite).
        assert np.array_equal(value.view(np.uint64), reference.view(np.uint64))


def angles(size: int) -> np.ndarray:
    return np.linspace(-3.0, 40.0 * math.pi, size)


@pytest.mark.parametrize(
    "size", [1, 2, BLOCK_SAMPLES - 1, BLOCK_SAMPLES, BLOCK_SAMPLES + 1, 3 * BLOCK_SAMPLES + 7]
)
@pytest.mark.parametrize("workers", [1, 2])
def test_blocks_give_the_unblocked_bits(
    tail: Tail, size: int, workers: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    phi = angles(size)
    speed = np.linspace(-7.0, 9.0, size)
    expected = unblocked(tail, phi, speed, monkeypatch)
    assert_bitwise_equal(tail.solve(phi, speed, workers=workers), expected)
    out = tail.empty_state(size)
    assert tail.solve(phi, speed, out=out, workers=workers) is out
    assert_bitwise_equal(out, expected)


def test_more_threads_give_the_bits_of_one(tail: Tail) -> None:
    phi = angles(5 * BLOCK_SAMPLES + 11)
    one = tail.solve(phi, 4.0, workers=1)
    assert_bitwise_equal(tail.solve(phi, 4.0, workers=2), [np.asarray(v) for v in one])
    assert_bitwise_equal(tail.solve(phi, 4.0, workers=4), [np.asarray(v) for v in one])
    assert_bitwise_equal(tail.solve(phi, 4.0), [np.asarray(v) for v in one])


def test_zero_dimensional_in_zero_dimensional_out(tail: Tail) -> None:
    state = tail.solve(np.array(0.7), np.array(3.0))
    assert all(np.shape(value) == () for value in state)
    scalar = tail.solve(0.7, 3.0)
    np.testing.assert_allclose([float(v) for v in state], list(scalar), rtol=0, atol=1e-12)
    out = tail.empty_state(())
    assert tail.solve(0.7, 3.0, out=out) is out  # floats with out= take the array path
    assert_bitwise_equal(out, [np.asarray(v) for v in state])


def test_two_dimensional_and_broadcast_inputs(
    tail: Tail, monkeypatch: pytest.MonkeyPatch
) -> None:
    phi = angles(2 * BLOCK_SAMPLES + 5).reshape(-1, 1)
    speed = np.array([-2.0, 0.0, 5.0])  # (3,): broadcast to (N, 3)
    expected = unblocked(tail, phi, speed, monkeypatch)
    state = tail.solve(phi, speed)
    assert state.theta1.shape == (phi.size, 3)
    assert_bitwise_equal(state, expected)
    out = tail.empty_state((phi.size, 3))
    assert_bitwise_equal(tail.solve(phi, speed, out=out), expected)
    grid = angles(6 * 4000).reshape(6, 4000)  # 2-d angles, scalar speed
    assert_bitwise_equal(tail.solve(grid, 1.5), unblocked(tail, grid, 1.5, monkeypatch))


def test_inputs_are_not_copied_without_out(tail: Tail) -> None:
    phi = angles(2 * BLOCK_SAMPLES)
    state = tail.solve(phi, 2.0)
    assert state.motor_angle is phi
    assert np.shape(state.motor_velocity) == phi.shape
    assert not state.motor_velocity.flags.writeable  # a broadcast view of the 0-d speed


def test_out_of_a_column_view_is_written(tail: Tail) -> None:
    phi = angles(BLOCK_SAMPLES + 3)
    table = np.zeros((len(tail.state_fields), phi.size, 2))
    out = tail.state_type._make(table[:, :, 1])  # strided 1-d columns
    tail.solve(phi, 1.0, out=out)
    np.testing.assert_array_equal(out.theta2, tail.solve(phi, 1.0).theta2)
    assert not table[:, :, 0].any()


def test_wrong_out_is_refused_with_a_reason(tail: Tail) -> None:
    phi = angles(100)
    with pytest.raises(InvalidInputError, match=r"out.motor_angle has shape \(99,\).*\(100,\)"):
        tail.solve(phi, 1.0, out=tail.empty_state(99))
    with pytest.raises(InvalidInputError, match="must be a"):
        tail.solve(phi, 1.0, out=tuple(tail.empty_state(100)))  # type: ignore[arg-type]
    other = OscillatoryTail if isinstance(tail, UndulatoryTail) else UndulatoryTail
    with pytest.raises(InvalidInputError, match="must be a"):
        tail.solve(phi, 1.0, out=other.empty_state(100))
    single = tail.empty_state(100)._replace(theta1=np.empty(100, dtype=np.float32))
    with pytest.raises(InvalidInputError, match="out.theta1 must be a float64 array"):
        tail.solve(phi, 1.0, out=single)
    shared = np.empty(100)
    twice = tail.empty_state(100)._replace(theta1=shared, theta2=shared)
    with pytest.raises(InvalidInputError, match="out.theta2 and out.theta1 share memory"):
        tail.solve(phi, 1.0, out=twice)
    into_input = tail.empty_state(100)._replace(theta1=phi)
    with pytest.raises(InvalidInputError, match="out.theta1 shares memory with the motor_angle"):
        tail.solve(phi, 1.0, out=into_input)
    transposed = np.empty((4, 100)).T  # (100, 4), not one flat C-order run
    with pytest.raises(InvalidInputError, match="one flat run"):
        tail.solve(
            np.zeros((100, 4)), 1.0, out=tail.empty_state((100, 4))._replace(theta1=transposed)
        )
    read_only = np.empty(100)
    read_only.flags.writeable = False
    with pytest.raises(InvalidInputError, match="read-only"):
        tail.solve(phi, 1.0, out=tail.empty_state(100)._replace(theta1=read_only))


def test_an_input_may_be_its_own_output(tail: Tail) -> None:
    phi = angles(BLOCK_SAMPLES + 9)
    expected = tail.solve(phi.copy(), 1.0)
    out = tail.empty_state(phi.size)._replace(motor_angle=phi)
    tail.solve(phi, 1.0, out=out)
    np.testing.assert_array_equal(out.theta1, expected.theta1)
    np.testing.assert_array_equal(phi, expected.motor_angle)


def test_non_finite_input_is_still_refused(tail: Tail) -> None:
    phi = angles(2 * BLOCK_SAMPLES)
    phi[BLOCK_SAMPLES + 1] = np.nan
    with pytest.raises(InvalidInputError, match=f"flat index {BLOCK_SAMPLES + 1}"):
        tail.solve(phi, 1.0, out=tail.empty_state(phi.size))


def test_mechanism_2_results_do_not_depend_on_the_batch() -> None:
    # Each sample's Newton steps stop at its own residual, so a sample solved alone and in a
    # batch gives the same bits.
    tail = TAILS["mechanism 2"]
    phi = angles(5000)
    batch = tail.solve(phi, 3.0)
    for index in (0, 1234, 4999):
        alone = tail.solve(phi[index : index + 1], 3.0)
        assert alone.slider_a_distance[0] == batch.slider_a_distance[index]
        assert alone.theta5[0] == batch.theta5[index]


def test_a_failing_block_raises_after_every_thread_stopped() -> None:
    done: list[int] = []

    def task(block: slice) -> None:
        if block.start == 3:
            raise SolverError("block 3 does not close")
        done.append(block.start)

    with pytest.raises(SolverError, match="block 3"):
        run_blocks(task, 10, workers=2, block_samples=1)
    with pytest.raises(ValueError, match="workers must be at least 1"):
        run_blocks(task, 10, workers=0)
    assert blocks.default_workers() >= 1
