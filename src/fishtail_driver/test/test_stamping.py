"""The monotonic-to-ROS clock mapping and the strictly increasing stamps (pure, no ROS)."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fishtail_driver.stamping import STEP_NS, ClockMapping, IncreasingStamps

MS = 1_000_000
OFFSET = 1_700_000_000 * 10**9  # ROS time minus monotonic time


def observe(mapping: ClockMapping, monotonic: int, offset: int = OFFSET, bracket: int = 10_000,
            ros_late: int = 0) -> None:  # fmt: skip
    """The ROS clock read in the middle of a ``bracket`` ns monotonic bracket (plus ros_late)."""
    half = bracket // 2
    mapping.observe(monotonic - half, monotonic + offset + ros_late, monotonic + half)


def test_one_offset_maps_every_sample():
    """Tight observations of a steady clock: stamp = monotonic time + offset."""
    mapping = ClockMapping()
    for k in range(5):
        observe(mapping, 10**12 + k * MS)
    assert mapping.to_ros_ns(10**12 + 3 * MS) == 10**12 + 3 * MS + OFFSET


def test_a_preempted_observation_is_not_used():
    """The ROS clock read 28 ms late within a wide bracket (preempted): the offset stays."""
    mapping = ClockMapping()
    observe(mapping, 10**12)
    observe(mapping, 10**12 + 40 * MS, bracket=30 * MS, ros_late=14 * MS)
    assert mapping.rejected == 1
    assert mapping.to_ros_ns(10**12 + 40 * MS) == 10**12 + 40 * MS + OFFSET


def test_small_differences_are_slewed_in():
    """A 2 ms offset change moves in by at most 5 % of the elapsed time, then fully."""
    mapping = ClockMapping()
    observe(mapping, 0)
    observe(mapping, 10 * MS, offset=OFFSET + 2 * MS)
    assert mapping.offset_ns == OFFSET + 10 * MS // 20
    observe(mapping, 110 * MS, offset=OFFSET + 2 * MS)
    assert mapping.offset_ns == OFFSET + 2 * MS and mapping.steps == 0


def test_clock_steps_are_followed_at_once():
    """Forward and backward steps of the ROS clock (>= STEP_NS) are followed and counted."""
    mapping = ClockMapping()
    observe(mapping, 0)
    observe(mapping, MS, offset=OFFSET + 3600 * 10**9)
    assert mapping.to_ros_ns(2 * MS) == 2 * MS + OFFSET + 3600 * 10**9
    observe(mapping, 3 * MS, offset=OFFSET - STEP_NS)
    assert mapping.to_ros_ns(4 * MS) == 4 * MS + OFFSET - STEP_NS
    assert mapping.steps == 2


def test_a_backward_step_drops_stamps_until_the_clock_catches_up():
    """Never a stamp at or before the previous one: dropped (counted) until time passes it."""
    mapping, stamps = ClockMapping(), IncreasingStamps()
    published = []
    for k in range(400):
        monotonic = k * MS
        # The ROS clock is set back by 200 ms at sample 100.
        observe(mapping, monotonic, offset=OFFSET - (200 * MS if k >= 100 else 0))
        stamp = stamps.admit(mapping.to_ros_ns(monotonic))
        if stamp is not None:
            published.append(stamp)
    assert all(b > a for a, b in zip(published, published[1:], strict=False))
    assert stamps.dropped == 200  # samples 100..299 would have been stamped before sample 99
    assert len(published) == 200


def test_increasing_stamps_refuses_equal_zero_and_negative():
    """Only stamps after the last passed one, and after 0."""
    stamps = IncreasingStamps()
    assert stamps.admit(0) is None and stamps.admit(-5) is None
    assert stamps.admit(7) == 7
    assert stamps.admit(7) is None and stamps.admit(6) is None
    assert stamps.admit(8) == 8 and stamps.dropped == 4


def test_bad_use_is_refused():
    """Settings out of range, brackets out of order, a stamp before any observation."""
    with pytest.raises(ValueError):
        ClockMapping(slew_fraction=1.5)
    mapping = ClockMapping()
    with pytest.raises(RuntimeError):
        mapping.to_ros_ns(0)
    with pytest.raises(ValueError):
        mapping.observe(10, 0, 5)


@pytest.mark.slow
@settings(max_examples=200, deadline=None)
@given(
    gaps=st.lists(st.integers(MS, 50 * MS), min_size=2, max_size=200),
    delays=st.lists(st.integers(0, 2 * MS), min_size=200, max_size=200),
    noise=st.lists(st.integers(-MS // 2, MS // 2), min_size=200, max_size=200),
    brackets=st.lists(st.integers(0, 3 * MS), min_size=200, max_size=200),
)
def test_estimation_noise_never_turns_a_stamp_back(gaps, delays, noise, brackets):
    """Estimation noise alone never costs a sample.

    Samples >= 1 ms apart, observed 0-2 ms after they were read, the ROS clock read with
    +-0.5 ms noise (some brackets too wide): stamps strictly increase without a drop.
    """
    mapping, stamps = ClockMapping(), IncreasingStamps()
    monotonic = 10**12
    for k, gap in enumerate(gaps):
        monotonic += gap
        observe(mapping, monotonic + delays[k], bracket=brackets[k], ros_late=noise[k])
        assert stamps.admit(mapping.to_ros_ns(monotonic)) is not None
    assert stamps.dropped == 0
