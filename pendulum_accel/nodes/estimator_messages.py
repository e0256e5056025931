"""The estimator node's messages at fixed offsets: the angles it reads; the estimate, Imu and marker it
writes.

Per message, our own shapes are read and written in place of a template (``Layout.reader`` and
``Layout.writer``); anything else goes through rclpy's deserializer. No ROS import.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.cdr_layout import Layout
from pendulum_accel.recording import visual

AngleReader = Callable[[bytes], tuple[float, ...] | None]
"""CDR of a JointState ↦ (sec, nanosec, θ) when it has the reader's shape, else None."""

STAMP = ("header.stamp.sec", "header.stamp.nanosec")


def angle_readers(joint: str, joint_frame_id: str, frame_prefix: str) -> list[AngleReader]:
    """Readers of the one-joint JointState (``joint``, position and velocity) in joint_frame_id and in no
    frame, the one a chain sends first: none under a frame prefix (its simulator's, robots' drivers'),
    else joint_frame_id. A message in any other frame goes through the guard's check."""
    frames = ["", joint_frame_id] if frame_prefix else [joint_frame_id, ""]
    return [
        Layout.of(bm.joint_state(0, [joint], [0.0], [0.0], frame_id=frame), bm.JOINT_STATE).reader(
            (*STAMP, "position[0]")
        )
        for frame in dict.fromkeys(frames)
    ]


@dataclass(frozen=True)
class OutputWriters:
    """(sec, nanosec, â, var(â)) ↦ the estimate's and the Imu's CDR; (sec, nanosec, â) ↦ the marker's."""

    estimate: Callable[..., bytes]
    imu: Callable[..., bytes]
    marker: Callable[[int, int, float], bytes]


def output_writers(
    frame: str, imu_frame: str, gravity: float, unmeasured_variance: float, length: float
) -> OutputWriters:
    """Writers of the estimate (in ``frame``), the Imu (in ``imu_frame``: z = gravity, y and z variance
    ``unmeasured_variance``) and the estimate's arrow (a pendulum of ``length``, in ``frame``)."""
    estimate = bm.accel_with_covariance_stamped(0, 0.0, 0.0, frame)
    imu = bm.imu(0, 0.0, gravity, 0.0, unmeasured_variance, imu_frame)
    return OutputWriters(
        Layout.of(estimate, bm.ACCEL_WITH_COVARIANCE_STAMPED).writer(
            (*STAMP, "accel.accel.linear.x", "accel.covariance[0]")
        ),
        Layout.of(imu, bm.IMU).writer((*STAMP, "linear_acceleration.x", "linear_acceleration_covariance[0]")),
        visual.estimate_marker_writer(length, frame),
    )
