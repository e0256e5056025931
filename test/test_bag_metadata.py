"""Metadata fidelity: RIHS01 type hashes in every MCAP channel (as rosbag2's MCAP storage writes them) equal
to rclpy's own, the offered QoS as the chain publishes it (history and depth included), the estimator and the
recorder's counts in custom_data. Metadata read with suspicion: a metadata.yaml naming a file outside its bag
is refused and nothing outside is touched; one of the wrong shape is set aside and the intact MCAP is read."""

from __future__ import annotations

import json
import os
import shutil
import signal
from pathlib import Path

import pytest
import yaml
from mcap.reader import make_reader
from rosbags.interfaces import QosDurability, QosHistory, QosReliability

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.metadata import complete_qos, parse_qos
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.bag.repair import repair_bag
from pendulum_accel.bag.writer import CUSTOM_ESTIMATOR
from pendulum_accel.errors import BagError
from pendulum_accel.nodes.accounting import CUSTOM_ACCOUNTING, Accounting
from pendulum_accel.nodes.launcher import node_command
from pendulum_accel.recording.generate import generate_bag
from test.chain_helpers import Output, start_node
from test.conftest import PYTHON, REPO, Spawn, cli
from test.refusal import one_line_error
from test.test_bag_io import _write_chain_bag

GOLDEN = REPO / "bags" / "step_start"


def _channel_metadata(bag_dir: Path) -> dict[str, dict[str, str]]:
    """{topic: channel metadata} of a bag's MCAP file."""
    with next(bag_dir.glob("*.mcap")).open("rb") as handle:
        summary = make_reader(handle).get_summary()
    assert summary is not None
    return {c.topic: dict(c.metadata) for c in summary.channels.values()}


def test_generated_bag_stores_type_hashes_and_estimator(tmp_path: Path) -> None:
    out = tmp_path / "bag"
    generate_bag("step_start", out, estimator="period_mean", duration=1.0)
    channels = _channel_metadata(out)
    info = yaml.safe_load((out / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    listed = {t["topic_metadata"]["name"]: t["topic_metadata"] for t in info["topics_with_message_count"]}
    types = {**bm.TOPIC_TYPES, **bm.VIEWER_TOPIC_TYPES}
    assert set(channels) == set(listed) == set(types) - {bm.TOPIC_STRING}
    for topic, meta in channels.items():
        expected = bm.TYPESTORE.hash_rihs01(types[topic])
        assert meta["topic_type_hash"] == listed[topic]["type_description_hash"] == expected
        assert expected.startswith("RIHS01_") and len(expected) == 7 + 64
    assert info["custom_data"][CUSTOM_ESTIMATOR] == "period_mean"


def test_complete_qos_fills_history_and_depth_only_when_the_rest_agrees() -> None:
    published = bm.qos_profile(depth=1000)
    discovered = published._replace(history=QosHistory.UNKNOWN, depth=0)
    assert complete_qos(discovered, published) == published
    other = discovered._replace(reliability=QosReliability.BEST_EFFORT)
    assert complete_qos(other, published) == other  # another publisher's profile: left as discovered
    keep_last = discovered._replace(history=QosHistory.KEEP_LAST, depth=5)
    assert complete_qos(keep_last, published) == keep_last


@pytest.mark.ros
def test_live_recording_stores_published_qos_rclpy_type_hashes_and_counts(
    spawn: Spawn, tmp_path: Path
) -> None:
    """A recorder fed by bag_player: offered QoS as published (keep-all 1000 for data, keep-last 100 for
    /diagnostics), channel hashes equal to what rclpy's endpoints report, received/written counts."""
    out = tmp_path / "recorded"
    topics = [bm.TOPIC_JOINT_STATES, bm.TOPIC_DIAGNOSTICS]
    recorder = start_node(spawn, "recorder_node", {"path": str(out), "topics": topics})
    recorder.wait_for("recording 2 topics", timeout=60)
    player = start_node(spawn, "player_node", {"path": str(GOLDEN), "topics": topics, "rate": 10.0,
                                               "wait_for_recorder": True})  # fmt: skip
    assert player.finish(timeout=120) == 0, player.text
    recorder.proc.send_signal(signal.SIGINT)
    assert recorder.finish(timeout=60) == 0, recorder.text
    bag = read_bag(out)
    golden = read_bag(GOLDEN)
    counts = Accounting.from_json(bag.custom_data[CUSTOM_ACCOUNTING]).recorder
    for topic in topics:
        n = golden.topics[topic].count
        assert counts["received"][topic] == counts["written"][topic] == n and bag.topics[topic].count == n
    joint = parse_qos(bag.topics[bm.TOPIC_JOINT_STATES].offered_qos_profiles)
    diag = parse_qos(bag.topics[bm.TOPIC_DIAGNOSTICS].offered_qos_profiles)
    assert [(q.history, q.depth, q.reliability, q.durability) for q in joint] == [
        (QosHistory.KEEP_ALL, 1000, QosReliability.RELIABLE, QosDurability.VOLATILE)
    ]
    assert [(q.history, q.depth) for q in diag] == [(QosHistory.KEEP_LAST, 100)]
    # rclpy's own hash of each type, as its endpoints report it.
    script = (
        "import rclpy, json\n"
        "from sensor_msgs.msg import JointState\n"
        "from diagnostic_msgs.msg import DiagnosticArray\n"
        "rclpy.init(); n = rclpy.create_node('hash_probe')\n"
        "n.create_publisher(JointState, '/hash_probe/j', 1)\n"
        "n.create_publisher(DiagnosticArray, '/hash_probe/d', 1)\n"
        "print(json.dumps({t: str(n.get_publishers_info_by_topic(t)[0].topic_type_hash)"
        " for t in ('/hash_probe/j', '/hash_probe/d')}))\n"
    )
    proc = spawn([PYTHON, "-c", script])
    stdout, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 0, stderr
    live = json.loads(stdout.strip().splitlines()[-1])
    channels = _channel_metadata(out)
    assert channels[bm.TOPIC_JOINT_STATES]["topic_type_hash"] == live["/hash_probe/j"]
    assert channels[bm.TOPIC_DIAGNOSTICS]["topic_type_hash"] == live["/hash_probe/d"]


@pytest.mark.ros
def test_node_bag_paths_expand_the_home_directory(spawn: Spawn, tmp_path: Path) -> None:
    """``-p path:=~/bags/run``: no shell expands a ``~`` after ``:=``, so the recorder made a directory
    named ``~`` in its working directory, and the player found no bag. Both now read ``~`` as the home
    directory (HOME set to a temporary one here)."""
    home = tmp_path / "home"
    (home / "bags").mkdir(parents=True)
    shutil.copytree(GOLDEN, home / "bags" / "golden")
    env = {**os.environ, "HOME": str(home)}
    topics = [bm.TOPIC_JOINT_STATES]
    recorder = Output(
        spawn(
            node_command("recorder_node", {"path": "~/bags/run", "topics": topics}),
            env=env,
            cwd=str(tmp_path),
        )
    )
    recorder.wait_for("recording 1 topics", timeout=60)
    player = Output(
        spawn(
            node_command(
                "player_node",
                {"path": "~/bags/golden", "topics": topics, "rate": 10.0, "wait_for_recorder": True},
            ),
            env=env,
            cwd=str(tmp_path),
        )
    )
    assert player.finish(timeout=120) == 0, player.text
    recorder.proc.send_signal(signal.SIGINT)
    assert recorder.finish(timeout=60) == 0, recorder.text
    assert not (tmp_path / "~").exists()
    n = read_bag(GOLDEN).topics[bm.TOPIC_JOINT_STATES].count
    assert read_bag(home / "bags" / "run").topics[bm.TOPIC_JOINT_STATES].count == n


@pytest.mark.parametrize("name", ["../external.mcap", "ABSOLUTE", "link.mcap"])
@pytest.mark.parametrize("backup", [True, False])
def test_metadata_naming_a_file_outside_the_bag_is_refused(tmp_path: Path, name: str, backup: bool) -> None:
    _write_chain_bag(tmp_path / "bag", n=200)
    outside = tmp_path / "external.mcap"
    outside.write_bytes((tmp_path / "bag" / "bag.mcap").read_bytes()[:-100])  # damaged: repair would act
    if name == "ABSOLUTE":
        name = str(outside)
    elif name == "link.mcap":
        (tmp_path / "bag" / "link.mcap").symlink_to(outside)
    (tmp_path / "bag" / "bag.mcap").unlink()
    meta = tmp_path / "bag" / "metadata.yaml"
    meta.write_text(meta.read_text().replace("- bag.mcap", f"- {name}", 1))
    before = outside.read_bytes()
    with pytest.raises(BagError, match="outside"):
        repair_bag(tmp_path / "bag", keep_backup=backup)
    with pytest.raises(BagError, match="outside"):
        read_bag(tmp_path / "bag")
    assert outside.read_bytes() == before  # not renamed, not deleted, not rewritten
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag", "external.mcap"]
    one_line_error(cli("repair", str(tmp_path / "bag")), "outside")
    one_line_error(cli("info", str(tmp_path / "bag")), "outside")


@pytest.mark.parametrize("shape", ["rosbag2_bagfile_information: [1, 2, 3]\n", "[]\n", "7\n"])
def test_metadata_of_the_wrong_shape_still_reads_the_intact_mcap(tmp_path: Path, shape: str) -> None:
    counts = _write_chain_bag(tmp_path / "bag", n=300)
    (tmp_path / "bag" / "metadata.yaml").write_text(shape)
    assert read_bag(tmp_path / "bag").message_count == sum(counts.values())
    assert cli("info", str(tmp_path / "bag")).returncode == 0
    result = cli("repair", str(tmp_path / "bag"))
    assert result.returncode == 0 and "Traceback" not in result.stderr
    assert read_bag(tmp_path / "bag", salvage=False).message_count == sum(counts.values())
