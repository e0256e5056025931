"""Core values ↔ ROS messages; the only place where the nodes build or read message fields."""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable
from typing import Any

import numpy as np
from builtin_interfaces.msg import Time
from numpy.typing import NDArray
from rclpy.duration import Duration
from rclpy.qos import QoSProfile
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from sensor_msgs.msg import JointState

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.cdr_layout import Layout
from pendulum_accel.bag.messages import FRAME_ID, PENDULUM_JOINT
from pendulum_accel.errors import ParameterError
from pendulum_accel.nodes.static_tf import TF_MESSAGE

_NS_PER_S = 1_000_000_000


def time_from_ns(ns: int) -> Time:
    """Time(sec = ns // 1e9, nanosec = ns mod 1e9); ns ≥ 0."""
    sec, nanosec = divmod(int(ns), _NS_PER_S)
    return Time(sec=sec, nanosec=nanosec)


def stamp_seconds(sec: int, nanosec: int) -> float:
    """t = sec + nanosec · 1e-9 (s): the scalar twin of bag.messages.stamp_seconds, same float64 steps,
    so a live estimate and the offline one of the same stamp agree bit for bit."""
    return float(sec) + float(nanosec) * 1e-9


def stamp_offset(msgtype: str) -> int | None:
    """Offset of the leading stamp's ``sec`` in the CDR of ``msgtype`` (learnt by Layout); None for a
    type without a stamp (std_msgs/String) or not of the chain. A MarkerArray's (a TFMessage's) is its
    first marker's (transform's) header stamp."""
    if msgtype == bm.STRING_MSG:
        return None
    if msgtype in (bm.MARKER_ARRAY, TF_MESSAGE):
        # The array's length (4 bytes) follows the 4-byte CDR header; the first marker (transform) starts
        # with its header, whose stamp comes first: offset 8, whatever the array holds.
        return 8
    templates: dict[str, Callable[[], object]] = {
        bm.JOINT_STATE: lambda: bm.joint_state(0, [bm.PENDULUM_JOINT], [0.0], [0.0]),
        bm.ACCEL_STAMPED: lambda: bm.accel_stamped(0, 0.0),
        bm.ACCEL_WITH_COVARIANCE_STAMPED: lambda: bm.accel_with_covariance_stamped(0, 0.0, 0.0),
        bm.CLOCK: lambda: bm.clock(0),
        bm.DIAGNOSTIC_ARRAY: lambda: bm.diagnostic_array(0, 0, "n", "m"),
        bm.IMU: lambda: bm.imu(0, 0.0, 0.0, 0.0, 0.0),
    }
    if msgtype not in templates:  # another type on the graph: logged at its receive time
        return None
    layout = Layout.of(templates[msgtype](), msgtype)
    key = "clock.sec" if msgtype == bm.CLOCK else "header.stamp.sec"
    offset, _ = layout.fields[key]
    nano, _ = layout.fields[key.replace(".sec", ".nanosec")]
    if nano != offset + 4:
        raise ParameterError(f"{msgtype}: stamp fields are not adjacent in CDR")
    return offset


def restamp(rows: NDArray[np.uint8], offset: int, ns: NDArray[np.int64]) -> None:
    """Set the stamp (int32 sec, uint32 nanosec at ``offset``) of every CDR row to ``ns`` in place."""
    sec, nanosec = bm.split_stamp(ns)
    rows[:, offset : offset + 4] = sec.astype("<i4").view(np.uint8).reshape(-1, 4)
    rows[:, offset + 4 : offset + 8] = nanosec.astype("<u4").view(np.uint8).reshape(-1, 4)


def time_to_seconds(stamp: Time) -> float:
    """t = sec + nanosec · 1e-9 for a builtin_interfaces/Time."""
    return stamp_seconds(stamp.sec, stamp.nanosec)


def joint_state(stamp: Time, theta: float, theta_dot: float) -> JointState:
    """JointState(name=[pendulum_joint], position=[θ], velocity=[θ']) in the car frame."""
    msg = JointState()
    msg.header.stamp = stamp
    msg.header.frame_id = FRAME_ID
    msg.name = [PENDULUM_JOINT]
    msg.position = [float(theta)]
    msg.velocity = [float(theta_dot)]
    return msg


def pendulum_angle(msg: JointState, joint: str = PENDULUM_JOINT) -> float:
    """θ = position[index of ``joint``] (or position[0] when the message has no names); NaN if absent."""
    names = list(msg.name)
    index = names.index(joint) if joint in names else 0
    position = msg.position
    return float(position[index]) if len(position) > index else math.nan


def message_class(type_name: str) -> Any:  # Any: a class of a message package, which ships no types
    """The rclpy message class of a ROS 2 type name "pkg/msg/Type"; ParameterError if unknown."""
    parts = type_name.split("/")
    if len(parts) != 3 or parts[1] != "msg":
        raise ParameterError(f"message type {type_name!r} is not of the form pkg/msg/Type")
    try:
        module = importlib.import_module(f"{parts[0]}.msg")
        return getattr(module, parts[2])
    except (ImportError, AttributeError):
        raise ParameterError(f"message type {type_name!r} is not installed") from None


def _qos_time(duration: Duration) -> QosTime:
    """QosTime(sec, nsec) of an rclpy Duration."""
    sec, nsec = divmod(int(duration.nanoseconds), _NS_PER_S)
    return QosTime(sec=sec, nsec=nsec)


def bag_qos(profile: QoSProfile) -> Qos:
    """The rosbags Qos (what metadata.yaml and MCAP channel metadata store) of an rclpy QoSProfile."""
    return Qos(
        history=QosHistory(int(profile.history)),
        depth=int(profile.depth),
        reliability=QosReliability(int(profile.reliability)),
        durability=QosDurability(int(profile.durability)),
        deadline=_qos_time(profile.deadline),
        lifespan=_qos_time(profile.lifespan),
        liveliness=QosLiveliness(int(profile.liveliness)),
        liveliness_lease_duration=_qos_time(profile.liveliness_lease_duration),
        avoid_ros_namespace_conventions=bool(profile.avoid_ros_namespace_conventions),
    )
