"""QoS profiles shared by every node of the chain, so publishers and subscribers always match."""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from pendulum_accel.bag.messages import ROBOT_DESCRIPTION, TOPIC_DIAGNOSTICS, role_of

# KEEP_ALL on both ends makes a slow reader push back on the writer (publish blocks)
# instead of dropping samples: that is what keeps the as-fast-as-possible chain lossless.
DATA_QOS = QoSProfile(
    depth=1000,
    history=HistoryPolicy.KEEP_ALL,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Reliable, keep-all, volatile: every data topic of the chain (/clock included)."""

DIAGNOSTICS_QOS = QoSProfile(
    depth=100,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.VOLATILE,
)
"""Reliable, keep-last 100: /diagnostics is low-rate status, a backlog is never useful."""


DESCRIPTION_QOS = QoSProfile(
    depth=1,
    history=HistoryPolicy.KEEP_LAST,
    reliability=ReliabilityPolicy.RELIABLE,
    durability=DurabilityPolicy.TRANSIENT_LOCAL,
)
"""robot_description, as robot_state_publisher offers it: reliable, keep last 1, transient local (a late
subscriber still gets the URDF; a volatile subscriber would match but get nothing published before it)."""


def qos_for(topic: str) -> QoSProfile:
    """QoS of ``topic`` by its role under any namespace: DIAGNOSTICS_QOS for /diagnostics,
    DESCRIPTION_QOS for robot_description, DATA_QOS for everything else."""
    role = role_of(topic)
    if role == TOPIC_DIAGNOSTICS:
        return DIAGNOSTICS_QOS
    if role == ROBOT_DESCRIPTION:
        return DESCRIPTION_QOS
    return DATA_QOS
