"""Offline tools on top of the engine: the command lines, recording analysis, plots, animation.

May use matplotlib and rosbags, never rclpy.
"""
