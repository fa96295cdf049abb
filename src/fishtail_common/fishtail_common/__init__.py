"""What every fishtail package shares; it uses none of them.

- :mod:`fishtail_common.interface`: topic names and types, QoS kinds, joint and frame names, the
  node list (plain Python, importable without ROS);
- :mod:`fishtail_common.parameters`: the parameter-specification type (plain Python);
- :mod:`fishtail_common.parameter_files`: the one reader of ROS 2 parameter files;
- :mod:`fishtail_common.bag_reading`: the one reader of rosbag2 bags (rosbags);
- :mod:`fishtail_common.package_front`: package fronts whose names load on first use;
- :mod:`fishtail_common.ros`: the rclpy side: QoS profiles, parameter descriptors, diagnostics,
  the node runtime (stop on SIGINT/SIGTERM, spin, ``main``);
- :mod:`fishtail_common.testing`, :mod:`fishtail_common.pytest_fixtures`: ROS domains, node
  processes and a probe for every package's tests.
"""
