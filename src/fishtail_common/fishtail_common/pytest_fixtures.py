"""pytest fixtures every package's ROS tests share: a ROS domain of the test's own, a probe.

A conftest.py imports the fixtures it uses by name (``from fishtail_common.pytest_fixtures
import ros, ros_domain``), which registers them for its tests.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from fishtail_common.testing import (
    WIDENING_VARIABLES,
    Probe,
    claim_domain,
    isolated_ros_environment,
)

#: Ids handed out in this run: tried last, as their processes may still hold ports.
_domains_used_in_this_run: set[int] = set()


@pytest.fixture
def ros_domain(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Iterator[int]:
    """This test's ROS_DOMAIN_ID, with localhost discovery and logs in tmp_path.

    Set in this process's environment, so node processes started by the test inherit it.
    """
    lock = claim_domain(avoid=_domains_used_in_this_run)
    _domains_used_in_this_run.add(lock.domain)
    log_dir = tmp_path / "ros_log"
    log_dir.mkdir()
    for name, value in isolated_ros_environment(lock.domain, log_dir).items():
        monkeypatch.setenv(name, value)
    for name in WIDENING_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    with lock:
        yield lock.domain


@pytest.fixture
def ros(ros_domain: int) -> Iterator[Probe]:
    """This test's probe node on the test's domain."""
    probe = Probe(ros_domain)
    try:
        yield probe
    finally:
        probe.close()
