"""What every fishtail package shares.

- :mod:`fishtail_common.interface`: topic names and types, QoS kinds, joint and frame names, the
  node list (plain Python, importable without ROS);
- :mod:`fishtail_common.parameters`: the parameter-specification type (plain Python);
- :mod:`fishtail_common.diagnostics`: diagnostic levels (plain) and the DiagnosticArray builder;
- :mod:`fishtail_common.ros`: the rclpy side: QoS profiles, parameter descriptors, the node
  runtime (stop on SIGINT/SIGTERM, spin, ``main``);
- :mod:`fishtail_common.bag_types`: fishtail_msgs definitions for rosbags' typestore.
"""
