"""ROS 2 nodes: thin shells that convert messages and call the ROS-free core.

``simulator_node`` (pendulum_sim), ``estimator_node`` (accel_estimator), ``recorder_node``
(bag_recorder) and ``player_node`` (bag_player). Importing this package does not import rclpy;
each node module does.
"""
