"""The carrier command: profiles checked against the driver's limit, the latest command wins."""

from __future__ import annotations

import doctest
import math

import pytest

from fishtail_driver import profile_command
from fishtail_driver.profile_command import (
    CarrierCommand,
    CommandRefusedError,
    check_profile,
    deepest_depth,
    highest_mean_speed,
)
from fishtail_kinematics.engine.carrier_profile import MAX_DEPTH

MAX_SPEED = 20.0


def refusal(mean: float, depth: float, phase: float = 0.0) -> CommandRefusedError:
    """The refusal of a profile (fails the test if it is accepted)."""
    with pytest.raises(CommandRefusedError) as caught:
        check_profile(mean, depth, phase, MAX_SPEED)
    return caught.value


def test_doctests():
    result = doctest.testmod(profile_command)
    assert result.failed == 0 and result.attempted >= 5


def test_a_profile_within_the_limit_is_the_engines_profile():
    profile = check_profile(6.0, 0.5, 1.0, MAX_SPEED)
    assert (profile.mean_speed_rad_s, profile.depth, profile.phase_rad) == (6.0, 0.5, 1.0)
    assert profile.speed_at(1.0) == pytest.approx(6.0 * 1.5 / math.sqrt(0.75))
    # At the limit exactly (a sender that computed it from the limit): accepted.
    depth = deepest_depth(12.0, MAX_SPEED)
    assert check_profile(12.0, depth, 0.0, MAX_SPEED).peak_speed_rad_s == pytest.approx(MAX_SPEED)
    # Mean 0 is a stopped motor at any depth.
    assert check_profile(0.0, 0.9, 0.0, MAX_SPEED).speed_at(0.0) == 0.0


@pytest.mark.parametrize(("mean", "depth"), [(8.0, 0.8), (12.0, 0.5), (15.0, 0.3), (15.0, 0.5)])
def test_a_peak_above_the_limit_is_refused_with_achievable_profiles_at_the_limit(mean, depth):
    error = refusal(mean, depth)
    assert "exceeds max_speed_rad_s = 20 rad/s" in error.reason
    deepest = error.achievable["achievable_depth"]
    fastest = error.achievable["achievable_mean_speed_rad_s"]
    assert deepest < depth and fastest < mean
    # Each achievable profile is accepted and peaks at the limit: nothing deeper or faster is.
    assert check_profile(mean, deepest, 0.0, MAX_SPEED).peak_speed_rad_s == pytest.approx(MAX_SPEED)
    assert check_profile(fastest, depth, 0.0, MAX_SPEED).peak_speed_rad_s == pytest.approx(
        MAX_SPEED
    )
    assert f"depth {deepest:.3g} at mean {mean:g} rad/s" in error.reason
    assert f"mean {fastest:.4g} rad/s at depth {depth:g}" in error.reason


def test_a_mean_above_the_limit_offers_only_a_slower_mean():
    error = refusal(25.0, 0.2)
    assert "achievable_depth" not in error.achievable
    assert error.achievable["achievable_mean_speed_rad_s"] == pytest.approx(
        highest_mean_speed(0.2, MAX_SPEED)
    )


def test_a_depth_outside_its_range_is_refused_with_the_nearest_depth():
    error = refusal(6.0, 0.95)
    assert "depth = 0.95: must be in [0, 0.9]" in error.reason  # the engine's own reason
    # 0.9 would peak at 26 rad/s: the deepest at 6 rad/s is what the limit allows.
    assert error.achievable["achievable_depth"] == pytest.approx(deepest_depth(6.0, MAX_SPEED))
    assert error.achievable["achievable_depth"] < MAX_DEPTH
    assert refusal(2.0, 0.95).achievable["achievable_depth"] == MAX_DEPTH
    assert refusal(6.0, -0.1).achievable == {"achievable_depth": 0.0}


@pytest.mark.parametrize(
    "fields",
    [(math.nan, 0.5, 0.0), (6.0, math.nan, 0.0), (6.0, 0.5, math.nan), (math.inf, 0.0, 0.0),
     (6.0, 0.5, -math.inf), (-1.0, 0.0, 0.0)],
)  # fmt: skip
def test_not_a_number_or_a_negative_mean_is_refused_with_nothing_achievable(fields):
    error = refusal(*fields)
    assert error.reason.startswith("profile refused (")
    if not math.isfinite(fields[0]) or not math.isfinite(fields[1]) or fields[0] < 0.0:
        assert error.achievable == {}


def test_the_latest_command_of_either_kind_wins_and_a_refused_one_changes_nothing():
    command = CarrierCommand(MAX_SPEED)
    assert not command.moving and command.follow(1.0) is None
    command.set_profile(6.0, 0.5, 2.0)
    assert command.moving and command.modulated
    # Fastest at the commanded phase, slowest opposite it.
    assert command.follow(2.0) == pytest.approx(6.0 * 1.5 / math.sqrt(0.75))
    assert command.follow(2.0 + math.pi) == pytest.approx(6.0 * 0.5 / math.sqrt(0.75))
    assert command.commanded_speed_rad_s == pytest.approx(6.0 * 0.5 / math.sqrt(0.75))
    with pytest.raises(CommandRefusedError):
        command.set_profile(15.0, 0.5, 0.0)
    assert command.profile.mean_speed_rad_s == 6.0 and command.refused_profiles == 1
    assert command.pending_refusal is not None
    values = command.status_values()
    assert values["achievable_depth"] == "0.28" and values["achievable_mean_speed_rad_s"] == "11.55"
    # A speed command is a flat profile; it is commanded once, not at every sample.
    assert command.set_speed(4.0) is None
    assert command.pending_refusal is None and not command.modulated
    assert command.commanded_speed_rad_s == 4.0 and command.follow(0.3) is None
    assert command.status_values()["profile_depth"] == "0.0000"
    # A profile accepted while the carrier is at 0.3 rad asks for its speed there at once.
    command.set_profile(4.0, 0.2, 0.3)
    assert command.commanded_speed_rad_s == pytest.approx(4.0 * 1.2 / math.sqrt(0.96))
    command.stop()
    assert not command.moving and command.commanded_speed_rad_s == 0.0


def test_speed_commands_keep_their_rules():
    command = CarrierCommand(MAX_SPEED)
    for bad in (-1.0, math.nan, math.inf, -math.inf):
        with pytest.raises(CommandRefusedError, match="the motor turns one way"):
            command.set_speed(bad)
    assert command.rejected_commands == 4 and not command.moving
    assert "clamped to max_speed_rad_s = 20" in command.set_speed(25.0)
    assert command.commanded_speed_rad_s == MAX_SPEED and command.clamped_commands == 1
    # A refused speed is no refused profile: nothing pending for the diagnostics' WARN.
    assert command.pending_refusal is None
