"""The ROS 2 nodes: thin rclpy shells around the engine (kinematics, monitor, RViz markers)."""
