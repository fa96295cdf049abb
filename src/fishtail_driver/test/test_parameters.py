"""The driver's parameter table, the backend it makes, and the shared status counters."""

from __future__ import annotations

import doctest
import math

import pytest

from fishtail_common.parameters import ParameterValueError
from fishtail_driver import status_counters
from fishtail_driver.backends import SimBackend
from fishtail_driver.parameters import (
    DRIVER_PARAMETERS,
    SPECS,
    make_backend,
    pivot_limits,
    pivot_refusal,
)


def defaults(**changes) -> dict:
    """Every parameter at its default, with ``changes``."""
    return {**{spec.name: spec.default for spec in DRIVER_PARAMETERS}, **changes}


def test_every_default_passes_its_own_check_and_names_are_unique():
    assert len(SPECS) == len(DRIVER_PARAMETERS)
    for spec in DRIVER_PARAMETERS:
        assert spec.check(spec.default) == spec.default


def test_run_time_changes_are_checked_with_the_reason():
    with pytest.raises(ParameterValueError, match="joint_name must not be empty"):
        SPECS["joint_name"].check("  ")
    with pytest.raises(ParameterValueError, match="serial_channel must be one of left, right"):
        SPECS["serial_channel"].check("middle")


def test_backends_made_from_the_values_say_what_they_need_of_the_node(tmp_path):
    sim = make_backend(defaults())
    assert isinstance(sim, SimBackend) and sim.max_sample_rate_hz == math.inf
    assert sim.watchdog_refusal(0.0) is None
    serial = make_backend(defaults(backend="serial", serial_port=str(tmp_path / "tty"),
                                   serial_poll_rate_hz=50.0))  # fmt: skip
    assert serial.name == "serial" and serial.max_sample_rate_hz == 50.0
    assert serial.watchdog_refusal(0.5) is None
    assert "cmd_timeout_sec must be > 0 with backend serial" in serial.watchdog_refusal(0.0)


def test_status_counters_doctests():
    result = doctest.testmod(status_counters)
    assert result.failed == 0 and result.attempted >= 3


def test_the_pivot_actuator_is_simulated_beside_the_simulated_motor_only():
    assert pivot_refusal(defaults()) is None
    assert pivot_refusal(defaults(pivot_actuator="sim")) is None
    assert pivot_refusal(defaults(backend="serial")) is None  # none: nothing to refuse
    reason = pivot_refusal(defaults(backend="serial", pivot_actuator="sim"))
    assert "pivot_actuator sim needs backend sim (got backend serial)" in reason
    assert "docs/serial.md" in reason
    limits = pivot_limits(defaults(pivot_stroke_m=0.05, pivot_speed_m_s=0.02))
    assert (limits.stroke_m, limits.speed_m_s) == (0.05, 0.02)
    assert (SPECS["pivot_stroke_m"].default, SPECS["pivot_speed_m_s"].default) == (0.03, 0.01)
    with pytest.raises(ParameterValueError, match="pivot_actuator must be one of none, sim"):
        SPECS["pivot_actuator"].check("serial")
    with pytest.raises(ParameterValueError, match=r"pivot_speed_m_s = 0.0 is outside"):
        SPECS["pivot_speed_m_s"].check(0.0)


def test_a_malformed_profile_tuning_is_refused_at_start_up_with_any_backend():
    from fishtail_driver.parameters import make_backend

    assert SPECS["serial_profile_tuning"].default == ""
    for backend in ("sim", "serial"):
        with pytest.raises(ValueError) as error:
            make_backend(defaults(backend=backend, serial_profile_tuning="8:5955:1889"))
        message = str(error.value)
        assert message.startswith("serial_profile_tuning: '8:5955:1889' is not LEAD:KV:KA:KS")
        assert "\n" not in message
    with pytest.raises(ValueError, match=r"serial_profile_tuning: KS = 256 is outside \[0, 255\]"):
        make_backend(defaults(backend="sim", serial_profile_tuning="8:5955:1889:256"))
    backend = make_backend(defaults(backend="serial", serial_profile_tuning="8:5955:1889:5:690"))
    assert backend.config.profile_tuning.argument == "8:5955:1889:5:690"  # type: ignore[attr-defined]
