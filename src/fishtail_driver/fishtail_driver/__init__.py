"""Motor driver of the fishtail tail: simulated motor or motor board, and its ROS 2 node."""
