"""The package's Fast DDS profile: applied only when Fast DDS is the RMW and no profile file is chosen; the
shared-memory ports a killed process left half-made, cleared before a node starts."""

from __future__ import annotations

import os
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from pendulum_accel.nodes import shm_ports
from pendulum_accel.nodes.dds_profile import LOOPBACK_PROFILE, PROFILE, use_package_profile

NS = {"dds": "http://www.eprosima.com"}


@pytest.mark.parametrize("profile", [PROFILE, LOOPBACK_PROFILE])
def test_profile_sets_a_10_ms_writer_heartbeat_as_default_profile(profile: Path) -> None:
    root = ET.parse(profile).getroot()
    writer = root.find("dds:profiles/dds:data_writer", NS)
    assert writer is not None and writer.get("is_default_profile") == "true"
    period = writer.find("dds:times/dds:heartbeat_period", NS)
    assert period is not None
    assert (period.findtext("dds:sec", namespaces=NS), period.findtext("dds:nanosec", namespaces=NS)) == (
        "0",
        "10000000",
    )


@pytest.mark.parametrize("rmw", [None, "rmw_fastrtps_cpp"])
@pytest.mark.parametrize("discovery", [None, "LOCALHOST"])
def test_loopback_by_default_for_fast_dds(rmw: str | None, discovery: str | None) -> None:
    env = {} if rmw is None else {"RMW_IMPLEMENTATION": rmw}
    if discovery is not None:
        env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = discovery
    assert use_package_profile(env)
    assert env["FASTDDS_DEFAULT_PROFILES_FILE"] == str(LOOPBACK_PROFILE)
    assert env["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "SUBNET"  # multicast, on the loopback interface only


@pytest.mark.parametrize(
    "env", [{"PENDULUM_ACCEL_NETWORK": "1"}, {"ROS_AUTOMATIC_DISCOVERY_RANGE": "SUBNET"}]
)
def test_network_profile_by_choice(env: dict[str, str]) -> None:
    assert use_package_profile(env)
    assert env["FASTDDS_DEFAULT_PROFILES_FILE"] == str(PROFILE)


def test_loopback_profile_allows_only_the_loopback_interface() -> None:
    root = ET.parse(LOOPBACK_PROFILE).getroot()
    names = [i.get("name") for i in root.iterfind(".//dds:allowlist/dds:interface", NS)]
    assert names == ["lo"]
    participant = root.find("dds:profiles/dds:participant", NS)
    assert participant is not None and participant.get("is_default_profile") == "true"
    assert participant.findtext("dds:rtps/dds:useBuiltinTransports", namespaces=NS) == "false"


@pytest.mark.parametrize(
    "env",
    [
        {"FASTDDS_DEFAULT_PROFILES_FILE": "/mine.xml"},
        {"FASTRTPS_DEFAULT_PROFILES_FILE": "/legacy.xml"},
        {"RMW_IMPLEMENTATION": "rmw_cyclonedds_cpp"},
    ],
)
def test_a_users_choice_is_left_alone(env: dict[str, str]) -> None:
    before = dict(env)
    assert not use_package_profile(env)
    assert env == before


def test_profile_is_installed_with_the_package() -> None:
    import importlib.resources

    assert importlib.resources.files("pendulum_accel.nodes").joinpath("fastdds_profile.xml").is_file()


def test_only_an_old_empty_shm_port_is_cleared(tmp_path: Path) -> None:
    """clear_stale_ports removes an empty port older than STALE_EMPTY_S (a killed process's: it would hang
    every later participant that opens it), and keeps a young empty one (being made now), a sized one
    (alive) and Fast DDS's lock files."""
    names = ["fastdds_port65001", "fastdds_port65002", "fastdds_port65003", "fastdds_port65001_el"]
    for name in names:
        (tmp_path / name).touch()
    (tmp_path / "fastdds_port65003").write_bytes(b"\0" * 64)
    now = time.time()
    old = now - 10 * shm_ports.STALE_EMPTY_S
    for name in ("fastdds_port65001", "fastdds_port65003", "fastdds_port65001_el"):
        os.utime(tmp_path / name, (old, old))
    assert shm_ports.clear_stale_ports(tmp_path, now) == ["fastdds_port65001"]
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(names[1:])
    assert shm_ports.clear_stale_ports(tmp_path / "missing", now) == []  # no /dev/shm: nothing to do
