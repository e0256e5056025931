"""package.xml's rosdep keys resolve in ros/rosdistro (test/rosdep_keys.py): against the stored snapshot of
what they resolved to, and the resolution rules themselves on a small rosdistro made here."""

from __future__ import annotations

from pathlib import Path

import yaml

from test import rosdep_keys


def test_every_package_xml_key_resolves_in_the_snapshot() -> None:
    """Each key has a rule for Debian and Ubuntu or is a released ROS package; the snapshot lists exactly
    package.xml's keys (a key added or dropped means refreshing it from rosdistro)."""
    snapshot = yaml.safe_load(rosdep_keys.SNAPSHOT.read_text())
    keys = rosdep_keys.package_keys()
    assert rosdep_keys.check(keys, snapshot) == []
    assert set(snapshot["keys"]) == set(keys)
    assert len(snapshot["rosdistro_commit"]) == 40
    for key, entry in snapshot["keys"].items():
        if entry["source"].startswith("rosdep/"):
            assert all(entry[p] for p in rosdep_keys.PLATFORMS), key
    assert rosdep_keys.main([]) == 0


def test_numba_and_rosbags_come_through_their_keys() -> None:
    """numba is Debian's python3-numba, rosbags rosdep's pip rule; mpmath has no key and is not named."""
    snapshot = yaml.safe_load(rosdep_keys.SNAPSHOT.read_text())
    assert snapshot["keys"]["python3-numba"]["ubuntu"] == ["python3-numba"]
    assert snapshot["keys"]["python3-rosbags-pip"]["ubuntu"] == {"pip": {"packages": ["rosbags"]}}
    assert "python3-mpmath" not in rosdep_keys.package_keys()


def test_resolution_rules_on_a_small_rosdistro(tmp_path: Path) -> None:
    """A rule for both platforms resolves, a Debian-only one does not, a released package (listed, or a
    repository without a list) resolves, and an unknown key does not."""
    (tmp_path / "rosdep").mkdir()
    (tmp_path / "kilted").mkdir()
    (tmp_path / "rosdep" / "base.yaml").write_text("zlib:\n  debian: [zlib1g]\n  ubuntu: [zlib1g]\n")
    (tmp_path / "rosdep" / "python.yaml").write_text(
        "python3-numba:\n  debian: [python3-numba]\n  ubuntu: [python3-numba]\n"
        "python3-only-debian:\n  debian: [python3-x]\n"
    )
    (tmp_path / "kilted" / "distribution.yaml").write_text(
        "repositories:\n"
        "  rclpy:\n    release:\n      packages: [rclpy]\n"
        "  common_interfaces:\n    release:\n      packages: [sensor_msgs, std_msgs]\n"
        "  tf2_msgs_repo:\n    release: {version: 1.0.0}\n"
        "  unreleased:\n    source: {type: git}\n"
    )
    keys = ["zlib", "python3-numba", "python3-only-debian", "rclpy", "sensor_msgs", "tf2_msgs_repo"]
    keys += ["unreleased", "python3-mpmath"]
    found = rosdep_keys.resolve(keys, rosdep_keys.Rosdistro(tmp_path), "kilted")
    assert set(found) == {"zlib", "python3-numba", "rclpy", "sensor_msgs", "tf2_msgs_repo"}
    assert found["python3-numba"]["source"] == "rosdep/python.yaml"
    assert found["rclpy"]["source"] == "kilted/distribution.yaml"
    snapshot = {"keys": found}
    assert rosdep_keys.check(keys, snapshot) == ["python3-only-debian", "unreleased", "python3-mpmath"]
