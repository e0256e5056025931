"""The package's Fast DDS profile: applied only when Fast DDS is the RMW and no profile file is chosen."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import pytest

from pendulum_accel.nodes.dds_profile import PROFILE, use_package_profile

NS = {"dds": "http://www.eprosima.com"}


def test_profile_sets_a_10_ms_writer_heartbeat_as_default_profile() -> None:
    root = ET.parse(PROFILE).getroot()
    writer = root.find("dds:profiles/dds:data_writer", NS)
    assert writer is not None and writer.get("is_default_profile") == "true"
    period = writer.find("dds:times/dds:heartbeat_period", NS)
    assert period is not None
    assert (period.findtext("dds:sec", namespaces=NS), period.findtext("dds:nanosec", namespaces=NS)) == (
        "0",
        "10000000",
    )


@pytest.mark.parametrize("rmw", [None, "rmw_fastrtps_cpp"])
def test_applied_for_fast_dds(rmw: str | None) -> None:
    env = {} if rmw is None else {"RMW_IMPLEMENTATION": rmw}
    assert use_package_profile(env)
    assert env["FASTDDS_DEFAULT_PROFILES_FILE"] == str(PROFILE)


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
