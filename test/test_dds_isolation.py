"""Two separate processes over real DDS, isolated in this session's private domain."""

from __future__ import annotations

import os

import pytest

from test.conftest import PYTHON, REPO, SPARE_DOMAIN_ID, Spawn

pytestmark = [
    pytest.mark.ros,
]


def test_session_uses_private_domain_and_localhost() -> None:
    assert os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert 1 <= int(os.environ["ROS_DOMAIN_ID"]) <= 101
    # The spare domain is this process's own too (a parallel worker holds another pair).
    assert int(os.environ["ROS_DOMAIN_ID"]) + 1 == SPARE_DOMAIN_ID


def test_every_message_crosses_between_processes(spawn: Spawn) -> None:
    count = 500
    peer = str(REPO / "test" / "dds_peer.py")
    listener = spawn([PYTHON, peer, "listen", "/isolation_check", str(count)])
    assert listener.stdout is not None
    assert listener.stdout.readline().strip() == "ready"
    talker = spawn([PYTHON, peer, "talk", "/isolation_check", str(count)])
    out, err = listener.communicate(timeout=60)
    assert out.strip() == f"got {count} ordered True unique {count}", err
    t_out, t_err = talker.communicate(timeout=30)
    assert talker.returncode == 0, t_err
    assert t_out.strip() == f"sent {count}"


def test_other_domain_does_not_receive(spawn: Spawn) -> None:
    """A listener in another domain must see nothing of this session's traffic."""
    peer = str(REPO / "test" / "dds_peer.py")
    other = dict(os.environ, ROS_DOMAIN_ID=str(SPARE_DOMAIN_ID))  # no other test process's domain
    # A talker only starts sending once it sees a subscriber, so pair each with one
    # in its own domain, and check the foreign listener's count stays at zero.
    listener_here = spawn([PYTHON, peer, "listen", "/leak_check", "50"])
    foreign = spawn([PYTHON, "-c", _FOREIGN_LISTENER], env=other)
    assert listener_here.stdout is not None and foreign.stdout is not None
    assert listener_here.stdout.readline().strip() == "ready"
    assert foreign.stdout.readline().strip() == "ready"
    spawn([PYTHON, peer, "talk", "/leak_check", "50"])
    out, _ = listener_here.communicate(timeout=60)
    assert out.strip().startswith("got 50")
    foreign_out, _ = foreign.communicate(timeout=30)
    assert foreign_out.strip() == "foreign got 0"


_FOREIGN_LISTENER = """
import time, rclpy
from rclpy.node import Node
from sensor_msgs.msg import JointState
rclpy.init(); n = Node('foreign'); got = []
n.create_subscription(JointState, '/leak_check', got.append, 10)
print('ready', flush=True)
end = time.monotonic() + 6.0
while time.monotonic() < end:
    rclpy.spin_once(n, timeout_sec=0.05)
print('foreign got', len(got), flush=True)
n.destroy_node(); rclpy.try_shutdown()
"""
