"""The ``fishtail-swim`` command line: steady-speed tables and time-stepped runs (no ROS)."""
