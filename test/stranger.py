"""A stranger on the graph, as ``ros2 topic echo /pendulum/joint_states`` is: subscribes, counts, spins.

python test/stranger.py NAME   (runs until SIGINT/SIGTERM; prints 'stranger NAME: subscribed' once up)
"""

from __future__ import annotations

import signal
import sys

import rclpy
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState


def main() -> None:
    """Subscribe to the angles (keep-last 10, reliable) and to them again best-effort; spin until stopped."""
    name = sys.argv[1]
    rclpy.init()
    node = Node(name)
    received = [0]

    def count(_msg: JointState) -> None:
        """One more angle seen."""
        received[0] += 1

    node.create_subscription(JointState, "/pendulum/joint_states", count, 10)
    node.create_subscription(JointState, "/pendulum/joint_states", count, qos_profile_sensor_data)
    running = [True]

    def stop(signum: int, frame: object) -> None:
        """End the spin loop."""
        running[0] = False

    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    print(f"stranger {name}: subscribed", flush=True)
    while running[0]:
        rclpy.spin_once(node, timeout_sec=0.05)
    print(f"stranger {name}: received {received[0]}", flush=True)
    node.destroy_node()
    rclpy.try_shutdown()


if __name__ == "__main__":
    main()
