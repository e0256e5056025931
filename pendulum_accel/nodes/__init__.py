"""ROS 2 nodes: thin shells that convert messages and call the ROS-free core.

``simulator_node`` (pendulum_sim), ``estimator_node`` (accel_estimator), ``recorder_node``
(bag_recorder) and ``player_node`` (bag_player). Importing this package does not import rclpy;
each node module does.

``python -m pendulum_accel.nodes.<module> --help`` is answered here, from the parameter tables,
before the node module (and rclpy) is imported: Python imports this package first.
"""

import sys

if "-m" in sys.orig_argv and any(flag in sys.orig_argv for flag in ("-h", "--help")):
    from pendulum_accel.nodes.node_help import answer_module_help

    answer_module_help(sys.orig_argv)
