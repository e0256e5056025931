"""QoS profiles shared by every node of the chain, so publishers and subscribers always match."""

from __future__ import annotations

from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

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


def qos_for(topic: str) -> QoSProfile:
    """QoS of ``topic``: DIAGNOSTICS_QOS for /diagnostics, DATA_QOS for everything else."""
    return DIAGNOSTICS_QOS if topic == "/diagnostics" else DATA_QOS
