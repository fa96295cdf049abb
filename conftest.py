"""The test tiers of the whole workspace (every package's test/ and the integration tests in test/).

``make check`` runs the tests with neither marker (``-m "not integration and not slow"``),
``make test`` runs them all. The markers are registered in pyproject.toml.
"""

from __future__ import annotations

from pathlib import Path

import pytest

INTEGRATION_DIR = Path(__file__).resolve().parent / "test"
#: Fixtures that start processes (nodes, boards, the firmware's simulator) or join a ROS domain.
PROCESS_FIXTURES = frozenset({"ros_domain", "board_process", "firmware_build"})


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Mark the integration tests.

    The rule: a test is ``integration`` when it lives under test/ or uses one of
    PROCESS_FIXTURES, directly or through another fixture (``ros``, ``start_node``,
    ``driver_run`` ... all rest on ``ros_domain``); a process started otherwise is marked where it
    starts (``either_board``'s firmware board). ``slow`` is marked by hand on the tests without
    processes that take over about 3 s (``--durations`` shows them).
    """
    for item in items:
        if item.path.is_relative_to(INTEGRATION_DIR) or PROCESS_FIXTURES.intersection(
            getattr(item, "fixturenames", ())
        ):
            item.add_marker(pytest.mark.integration)
