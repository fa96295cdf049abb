"""The kinematics engine: linkages, parameters, design, symmetry, swimming, input checks, markers.

Plain Python and numpy (no rclpy, no plotting, no bag I/O; ``ruff.toml`` here enforces it), used
by the nodes and by the offline tools alike.
"""
