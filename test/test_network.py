"""Network exposure and the chain across hosts.

* By default every node binds the loopback interface only (the package's loopback Fast DDS profile):
  checked on a running node with ``ss -uanp``.
* Across "hosts": two network namespaces joined by a veth pair, simulator in one, estimator and
  recorder in the other, 10 % of packets dropped each way (iptables statistic) and a 2 s link cut.
  Reliable topics lose nothing, the estimator reports STALE during the cut and recovers, the bag is
  complete. Needs root (CI runs as root): without it the test fails, it does not skip.
"""

from __future__ import annotations

import ipaddress
import os
import re
import shutil
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.nodes.launcher import node_command
from pendulum_accel.overrides import apply_overrides
from pendulum_accel.scene import load_scene
from test.chain_helpers import Output, run_probe, start_node
from test.conftest import Spawn

pytestmark = pytest.mark.ros

SCENE = "lecture_constant"


def bound_udp_addresses(pid: int) -> list[str]:
    """Local addresses of the UDP sockets of process ``pid`` (``ss -uanp``)."""
    out = subprocess.run(["ss", "-uanp"], capture_output=True, text=True, check=True).stdout
    found = []
    for line in out.splitlines():
        if f"pid={pid}," not in line:
            continue
        local = line.split()[3]
        found.append(local.rsplit(":", 1)[0].strip("[]"))
    return found


def test_nodes_bind_only_the_loopback_interface_by_default(spawn: Spawn) -> None:
    """Every UDP socket of a running node is on 127.0.0.0/8 (or a multicast group joined on lo)."""
    if shutil.which("ss") is None:
        pytest.fail("ss (iproute2) is missing: `make setup` installs it", pytrace=False)
    env = {k: v for k, v in os.environ.items() if k not in ("FASTDDS_DEFAULT_PROFILES_FILE",)}
    node = Output(spawn(node_command("estimator_node", {"scene": SCENE}), env=env))
    node.wait_for(r"estimating with", timeout=60)
    time.sleep(1.0)  # discovery sockets are all open once the node spins
    addresses = bound_udp_addresses(node.proc.pid)
    assert addresses, "the node bound no UDP socket at all: ss sees nothing"
    for text in addresses:
        address = ipaddress.ip_address(text)
        assert address.is_loopback or address.is_multicast, f"bound to {text}: {addresses}"


# --- the chain across two network namespaces ----------------------------------------------------

_UDP_ONLY_PROFILE = """<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns="http://www.eprosima.com"><profiles>
  <transport_descriptors><transport_descriptor>
    <transport_id>udp_only</transport_id><type>UDPv4</type>
  </transport_descriptor></transport_descriptors>
  <participant profile_name="udp_only" is_default_profile="true"><rtps>
    <userTransports><transport_id>udp_only</transport_id></userTransports>
    <useBuiltinTransports>false</useBuiltinTransports>
  </rtps></participant>
  <data_writer profile_name="writer" is_default_profile="true"><times>
    <heartbeat_period><sec>0</sec><nanosec>10000000</nanosec></heartbeat_period>
  </times></data_writer>
</profiles></dds>
"""
"""The package's network profile without shared memory: two namespaces share /dev/shm, and Fast DDS
would otherwise carry the data through it, around the veth link under test."""


def _ip(*args: str) -> None:
    """Run one ``ip`` (or ``ip netns exec NS …``) command; CalledProcessError with its stderr."""
    subprocess.run(["ip", *args], check=True, capture_output=True, text=True)


class TwoHosts:
    """Namespaces a and b with veth ends 10.213.N.1 and .2 (N from the pid), loopback up, multicast routed."""

    def __init__(self) -> None:
        """Unique names per run (Linux caps interface names at 15 characters)."""
        tag = f"{os.getpid() % 100000}"
        self.ns = {"a": f"pa{tag}a", "b": f"pa{tag}b"}
        self.dev = {"a": f"pv{tag}a", "b": f"pv{tag}b"}
        self.addr = {"a": f"10.213.{os.getpid() % 250}.1", "b": f"10.213.{os.getpid() % 250}.2"}

    def create(self) -> None:
        """Namespaces, the veth pair between them, addresses, routes."""
        for side in "ab":
            _ip("netns", "add", self.ns[side])
        _ip("link", "add", self.dev["a"], "type", "veth", "peer", "name", self.dev["b"])
        for side in "ab":
            ns, dev = self.ns[side], self.dev[side]
            _ip("link", "set", dev, "netns", ns)
            _ip("netns", "exec", ns, "ip", "addr", "add", f"{self.addr[side]}/24", "dev", dev)
            _ip("netns", "exec", ns, "ip", "link", "set", dev, "up")
            _ip("netns", "exec", ns, "ip", "link", "set", "lo", "up")
            # DDS discovery is multicast (239.255.0.1): route it over the link.
            _ip("netns", "exec", ns, "ip", "route", "add", "224.0.0.0/4", "dev", dev)

    def drop_inbound(self, probability: float) -> None:
        """Drop this fraction of the packets arriving over the link, in each namespace (both directions)."""
        for side in "ab":
            subprocess.run(
                ["ip", "netns", "exec", self.ns[side], "iptables", "-A", "INPUT", "-i", self.dev[side],
                 "-m", "statistic", "--mode", "random", "--probability", f"{probability}", "-j", "DROP"],
                check=True, capture_output=True, text=True,
            )  # fmt: skip

    def link(self, up: bool) -> None:
        """Bring side a's end of the link down or up (cuts both directions)."""
        _ip("netns", "exec", self.ns["a"], "ip", "link", "set", self.dev["a"], "up" if up else "down")

    def command(self, side: str, argv: list[str]) -> list[str]:
        """``argv`` run inside namespace ``side``."""
        return ["ip", "netns", "exec", self.ns[side], *argv]

    def delete(self) -> None:
        """Remove both namespaces (their veth ends and iptables rules go with them)."""
        for side in "ab":
            subprocess.run(["ip", "netns", "del", self.ns[side]], capture_output=True, check=False)


@pytest.fixture
def two_hosts() -> Iterator[TwoHosts]:
    """Two namespaces joined by veth, deleted at teardown whatever happened; FAIL (not skip) without root."""
    missing = [tool for tool in ("ip", "iptables") if shutil.which(tool) is None]
    if missing:
        pytest.fail(
            f"{', '.join(missing)} missing: `make setup` installs iproute2 and iptables", pytrace=False
        )
    hosts = TwoHosts()
    try:
        hosts.create()
    except subprocess.CalledProcessError as err:
        hosts.delete()
        pytest.fail(
            f"cannot create network namespaces ({err.stderr.strip()}): the multi-host test needs root "
            "(CAP_NET_ADMIN), as in CI",
            pytrace=False,
        )
    try:
        yield hosts
    finally:
        hosts.delete()


def _levels(bag_path: Path) -> list[tuple[int, int]]:
    """(log time ns, level) of every recorded /diagnostics status, in log-time order."""
    times, payloads = read_bag(bag_path).raw(bm.TOPIC_DIAGNOSTICS)
    out = []
    for t, data in zip(times.tolist(), payloads, strict=True):
        msg = bm.deserialize(data, bm.DIAGNOSTIC_ARRAY)
        out += [(t, int(status.level)) for status in msg.status]  # type: ignore[attr-defined]
    return out


def test_chain_across_two_hosts_with_loss_and_a_link_cut(
    spawn: Spawn, two_hosts: TwoHosts, tmp_path: Path
) -> None:
    """Simulator on host a; estimator and recorder on host b; 10 % loss each way; a 2 s cut mid-run."""
    rate, duration = 200.0, 14.0
    overrides = {"rate_hz": rate, "duration": duration}
    scene = apply_overrides(load_scene(SCENE), overrides)
    expected = scene.sensor.sample_count(duration)
    scene_file = tmp_path / "scene.yaml"
    from pendulum_accel.scene import scene_to_yaml

    scene_file.write_text(scene_to_yaml(scene))
    profile = tmp_path / "udp_only.xml"
    profile.write_text(_UDP_ONLY_PROFILE)
    env = dict(os.environ)
    env.update(
        FASTDDS_DEFAULT_PROFILES_FILE=str(profile),
        ROS_AUTOMATIC_DISCOVERY_RANGE="SUBNET",
        PENDULUM_ACCEL_NETWORK="1",
    )
    bag = tmp_path / "bag"
    two_hosts.drop_inbound(0.1)

    def node(side: str, module: str, params: dict[str, object]) -> Output:
        """One node inside a namespace, with the UDP-only network profile."""
        return Output(spawn(two_hosts.command(side, node_command(module, params)), env=env))  # type: ignore[arg-type]

    recorder = node("b", "recorder_node", {"path": str(bag), "scene": str(scene_file)})
    recorder.wait_for(r"recording \d+ topics", timeout=60)
    estimator = node(
        "b", "estimator_node", {"scene": str(scene_file), "recorder_node": "bag_recorder", "stale_after": 0.5}
    )
    simulator = node(
        "a",
        "simulator_node",
        {"scene": str(scene_file), "reader_nodes": ["accel_estimator"], "recorder_node": "bag_recorder"},
    )
    simulator.wait_for(r"first sample acknowledged by every reader", timeout=60)
    time.sleep(4.0)
    cut_at = time.monotonic()
    two_hosts.link(up=False)
    time.sleep(2.0)
    two_hosts.link(up=True)
    cut_s = time.monotonic() - cut_at
    assert simulator.finish(timeout=duration + 60) == 0, simulator.text
    published = int(re.search(r"published (\d+)/", simulator.text).group(1))  # type: ignore[union-attr]
    assert published == expected
    # Let the estimator report recovery (one diagnostics period), then stop b's nodes in data-flow order.
    time.sleep(2.0)
    for out in (estimator, recorder):
        out.proc.send_signal(2)
        assert out.finish(timeout=60) == 0, out.text
    counts = {name: info.count for name, info in read_bag(bag, salvage=False).topics.items()}
    assert counts[bm.TOPIC_JOINT_STATES] == expected, counts
    assert counts[bm.TOPIC_ACCEL_TRUTH] == expected, counts
    assert counts[bm.TOPIC_ACCEL_ESTIMATE] == expected, counts
    stamps = read_bag(bag).decode(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE).stamp
    np.testing.assert_allclose(np.sort(stamps), np.arange(expected) / rate, atol=1e-9)
    levels = _levels(bag)
    # Stamps are simulation time; the stream ends at `duration`, after which STALE is right too.
    during = [(t, level) for t, level in levels if t < duration * 1e9]
    stale = [i for i, (_, level) in enumerate(during) if level == 3]
    assert stale, f"no STALE diagnostic during the {cut_s:.1f} s cut: {levels}"
    assert any(level == 0 for _, level in during[stale[0] + 1 :]), f"no recovery to OK: {levels}"


def test_the_estimator_node_drops_a_foreign_joint_and_says_so(spawn: Spawn) -> None:
    """JointStates naming only elbow_joint: no estimate, ERROR on /diagnostics with the count."""
    estimator = start_node(spawn, "estimator_node", {"scene": SCENE, "diagnostics_period": 0.2})
    estimator.wait_for(r"estimating with", timeout=60)
    result = run_probe(
        spawn,
        {
            "listen": ["/car/accel/estimate", "/diagnostics"],
            "wait_subscribers": 1,
            "joints": ["elbow_joint"],
            "feed": [[0.01 * i, 0.2] for i in range(1, 51)],
            "until_values": [{"dropped_wrong_joint": 50}, 30.0],
            "linger": 1.0,
        },
    )
    assert result["estimates"] == []
    errors = [values for level, _, values in result["diagnostics"] if level == 2]
    assert errors, result["diagnostics"]
    assert int(errors[-1]["dropped_wrong_joint"]) == 50
