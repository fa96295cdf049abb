"""Kinematics of the fishtail tail mechanisms, with their ROS 2 nodes and command line."""
