"""Fixtures of the driver's node tests (:mod:`fishtail_testkit.driver_nodes`)."""

from fishtail_testkit.driver_nodes import (  # noqa: F401 - fixtures, registered by name
    driver_process,
    driver_run,
    ros,
    ros_domain,
    ros_probe,
    wait_until,
)
