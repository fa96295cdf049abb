"""ROS 2 nodes of the swimming simulator (the only place in fishtail_swim that imports rclpy)."""
