"""The independent kinetic energy from the drawn joints (fishtail_testkit.linkage_points_oracle)."""

import pytest

from fishtail_testkit.linkage_points_oracle import FROM_POINTS


@pytest.fixture(scope="session")
def from_points():
    """The independent reduced inertia and kinetic energy."""
    return FROM_POINTS
