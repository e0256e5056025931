"""The Imu's frame on /tf_static, where tf2_msgs is installed.

tf2_msgs has no PyPI wheel for ROS 2 Kilted (requirements-ros.txt installs none): with the wheels the
transform is stated in the log instead, as the static_transform_publisher command that publishes it.
With a ROS 2 install, tf2_msgs is there and the node publishes it itself, as static_transform_publisher
does: one TFMessage on the global /tf_static, reliable, transient local, depth 1 (tf2_ros's static
broadcaster QoS), so that a listener started later still gets it. The recorder records /tf_static where
tf2_msgs is installed (its subscription needs the type), transient local as rosbag2 subscribes to a
topic whose publishers all offer it, so it gets the transforms sent before it started.
"""

from __future__ import annotations

import importlib
from typing import Any

from geometry_msgs.msg import TransformStamped
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from pendulum_accel.nodes.qos import TOPIC_TF_STATIC, AnyPublisher

TF_MESSAGE = "tf2_msgs/msg/TFMessage"
STATIC_QOS = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)


# Any: a class of tf2_msgs, a message package, which ships no types.
def tf_message_type() -> Any | None:
    """tf2_msgs' TFMessage class, None where tf2_msgs is not installed."""
    try:
        return importlib.import_module("tf2_msgs.msg").TFMessage
    except ImportError:
        return None


def publish_static_transform(
    node: Node, parent: str, child: str, xyz: tuple[float, float, float]
) -> AnyPublisher | None:
    """Publish child's origin at ``xyz`` (m, no rotation) in ``parent`` on /tf_static; the publisher (keep
    it: transient local serves late listeners while it lives), or None without tf2_msgs (logged)."""
    x, y, z = xyz
    message_type = tf_message_type()
    if message_type is None:
        node.get_logger().info(
            f"{child} at ({x:g}, {y:g}, {z:g}) m in {parent} (tf2_msgs is not installed, so it is not on "
            f"/tf_static): publish it with `ros2 run tf2_ros static_transform_publisher --x {x:g} --y {y:g} "
            f"--z {z:g} --frame-id {parent} --child-frame-id {child}`"
        )
        return None
    transform = TransformStamped()
    transform.header.stamp = node.get_clock().now().to_msg()
    transform.header.frame_id = parent
    transform.child_frame_id = child
    transform.transform.translation.x, transform.transform.translation.y = x, y
    transform.transform.translation.z = z
    transform.transform.rotation.w = 1.0
    publisher = node.create_publisher(message_type, TOPIC_TF_STATIC, STATIC_QOS)
    publisher.publish(message_type(transforms=[transform]))
    node.get_logger().info(f"{child} at ({x:g}, {y:g}, {z:g}) m in {parent}: published on {TOPIC_TF_STATIC}")
    return publisher
