"""A tiny DDS talker or listener for the cross-process isolation test.

python test/dds_peer.py talk TOPIC N    publish N JointStates (position = index), reliable QoS
python test/dds_peer.py listen TOPIC N  print 'got K' once K messages arrived, or on timeout
"""

from __future__ import annotations

import sys
import time

import rclpy
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

QOS = QoSProfile(
    depth=1000,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)


def talk(node: Node, topic: str, count: int) -> None:
    """Wait for one subscriber, then publish ``count`` messages."""
    pub = node.create_publisher(JointState, topic, QOS)
    deadline = time.monotonic() + 30.0
    while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    for i in range(count):
        msg = JointState()
        msg.name = ["pendulum_joint"]
        msg.position = [float(i)]
        pub.publish(msg)
        time.sleep(0.001)
    # Let reliable delivery finish before the process exits.
    time.sleep(1.0)
    print("sent", count, flush=True)


def listen(node: Node, topic: str, count: int) -> None:
    """Print the indices received once all arrived (or after 30 s)."""
    got: list[int] = []
    node.create_subscription(JointState, topic, lambda m: got.append(int(m.position[0])), QOS)
    print("ready", flush=True)
    deadline = time.monotonic() + 30.0
    while len(got) < count and time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)
    print("got", len(got), "ordered", got == sorted(got), "unique", len(set(got)), flush=True)


def main() -> None:
    """Run as talker or listener."""
    role, topic, count = sys.argv[1], sys.argv[2], int(sys.argv[3])
    rclpy.init()
    node = Node(f"dds_peer_{role}")
    try:
        (talk if role == "talk" else listen)(node, topic, count)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
