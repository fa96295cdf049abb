"""Counts -> continuous angle: the 32-bit wrap, board resets (re-bases) and corrupt readings."""

from __future__ import annotations

import doctest

from hypothesis import given
from hypothesis import strategies as st

from fishtail_driver import encoder_tracking
from fishtail_driver.encoder_tracking import CountUnwrapper, EncoderTracker
from fishtail_plant.motor.board_units import INT32_MAX, INT32_MIN, Scale, wrap_int32


def test_doctests():
    """The examples in the module documentation hold."""
    result = doctest.testmod(encoder_tracking)
    assert result.failed == 0 and result.attempted >= 5


def test_unwrap_across_the_32_bit_wrap_both_ways():
    """Crossing INT32_MAX -> INT32_MIN is one step forward, and back again one step back."""
    unwrapper = CountUnwrapper()
    unwrapper.update(INT32_MAX - 1)
    assert unwrapper.update(INT32_MIN + 1).total == 3
    assert unwrapper.update(INT32_MAX).total == 1
    assert unwrapper.wraps == 2


def test_unwrap_holds_across_a_reset():
    """A jump larger than max_step (counts back to 0) keeps the continuous count."""
    unwrapper = CountUnwrapper()
    for raw in (100000, 100500, 101000):
        unwrapper.update(raw, max_step=1000)
    step = unwrapper.update(3, max_step=1000)
    assert step.event == "jump" and step.total == 1000
    assert unwrapper.update(503, max_step=1000).total == 1500
    unwrapper.rebase()
    assert unwrapper.update(-7).event == "first" and unwrapper.total == 1500
    assert unwrapper.delta_to(-5) == 2


@given(st.integers(INT32_MIN, INT32_MAX), st.lists(st.integers(-5000, 5000), max_size=60))
def test_unwrap_recovers_the_true_motion(start, steps):
    """For steps smaller than half the counter range, unwrapping is exact."""
    unwrapper = CountUnwrapper()
    true_count = start
    unwrapper.update(wrap_int32(true_count), max_step=6000)
    for step in steps:
        true_count += step
        assert unwrapper.update(wrap_int32(true_count), max_step=6000).event != "jump"
    assert unwrapper.total == true_count - start


def test_plausible_corrupt_reading_is_corrected_not_taken_for_a_reset():
    """A flipped digit that passes as motion, then the true count: a correction, not a re-base.

    Re-basing there would keep the corrupt offset in the angle for good and raise a false phase
    warning.
    """
    tracker = EncoderTracker(Scale(counts_per_revolution=2048), "left", max_speed_rad_s=20.0)
    results = []

    def accept(pair: tuple[int, int], when: float, after_connect: bool = False) -> None:
        # driven: the board acknowledged a forward speed, so the count's direction is known.
        results.append(tracker.accept(pair, when, after_connect, driven=True))

    count_per_poll, when, count = 16, 0.0, 0
    accept((0, 0), when, after_connect=True)
    for _ in range(100):
        when, count = when + 0.01, count + count_per_poll
        accept((count, 0), when)
    # A 70 ms gap (a timed-out poll), then a reading 150 counts too high: plausible after a gap.
    when, count = when + 0.07, count + 7 * count_per_poll
    accept((count + 150, 0), when)
    for _ in range(5):
        when, count = when + 0.01, count + count_per_poll
        accept((count, 0), when)
    rebases = sum(result.rebase is not None for result in results)
    outliers = sum(result.outlier is not None for result in results)
    assert rebases == 0
    assert outliers == 1
    published = tracker.latest.angle_rad / tracker.scale.angle_from_counts(1)
    assert round(published) == count
