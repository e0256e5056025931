"""Bags open in independent readers: rosbags, mcap-ros2-support's decoder and Foxglove's @mcap/core."""

from __future__ import annotations

import fcntl
import json
import shutil
import subprocess
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.rosbag2 import Reader
from ruamel.yaml import YAML

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.bag.writer import BagWriter
from test.test_bag_io import _chain_streams

# Reads a file with @mcap/core twice: through the summary/index (McapIndexedReader) and as a plain
# record stream (McapStreamReader), and prints what it found as JSON.
MCAP_CORE_SCRIPT = r"""
const fs = require("fs");
const { McapIndexedReader, McapStreamReader } = require("@mcap/core");
const fzstd = require("fzstd");
const decompressHandlers = { zstd: (data, size) => fzstd.decompress(data, new Uint8Array(Number(size))) };
async function main() {
  const buf = fs.readFileSync(process.argv[2]);
  const readable = {
    size: async () => BigInt(buf.length),
    read: async (offset, size) => buf.subarray(Number(offset), Number(offset + size)),
  };
  const reader = await McapIndexedReader.Initialize({ readable, decompressHandlers });
  const counts = {};
  for await (const msg of reader.readMessages()) {
    const topic = reader.channelsById.get(msg.channelId).topic;
    counts[topic] = (counts[topic] || 0) + 1;
  }
  const channels = {};
  for (const ch of reader.channelsById.values()) {
    const schema = reader.schemasById.get(ch.schemaId);
    channels[ch.topic] = {
      messageEncoding: ch.messageEncoding,
      schemaEncoding: schema.encoding,
      schemaName: schema.name,
      qos: ch.metadata.get("offered_qos_profiles") || "",
    };
  }
  const stream = new McapStreamReader({ decompressHandlers });
  stream.append(buf);
  let streamed = 0;
  for (let rec; (rec = stream.nextRecord()); ) {
    if (rec.type === "Message") streamed++;
  }
  const profile = reader.header.profile;
  console.log(JSON.stringify({ profile, counts, channels, streamed, done: stream.done() }));
}
main().catch((err) => { console.error(String(err)); process.exit(1); });
"""


@pytest.fixture(scope="module", params=[None, "zstd"], ids=["plain", "zstd"])
def chain_bag(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> tuple[Path, dict[str, int]]:
    """A multi-chunk bag of the chain's topics written by BagWriter.write_sorted, chunks plain or zstd."""
    path = tmp_path_factory.mktemp("compat") / "chain"
    streams, types = _chain_streams(8000)
    custom = {"pendulum_accel.plan": "compat"}
    with BagWriter(path, custom_data=custom, compression=request.param) as writer:
        for topic, msgtype in types.items():
            writer.add_topic(topic, msgtype)
        writer.write_sorted(streams)
        return path, writer.counts


def test_metadata_and_rosbags_reader(chain_bag: tuple[Path, dict[str, int]]) -> None:
    """metadata.yaml v9 + mcap; rosbags sees the topics, counts, QoS and custom_data."""
    path, counts = chain_bag
    info = YAML(typ="safe").load((path / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["version"] == 9 and info["storage_identifier"] == "mcap"
    assert info["relative_file_paths"] == ["chain.mcap"]
    with Reader(path) as reader:
        assert {c.topic: c.msgcount for c in reader.connections} == counts
        assert all(c.ext.offered_qos_profiles for c in reader.connections)  # type: ignore[union-attr]
        assert reader.message_count == sum(counts.values())
    assert info["custom_data"]["pendulum_accel.plan"] == "compat"


def test_mcap_ros2_support_decodes_every_message(chain_bag: tuple[Path, dict[str, int]]) -> None:
    """mcap-ros2-support parses the ros2msg schemas and decodes each CDR message to our values."""
    path, counts = chain_bag
    seen: dict[str, int] = {}
    theta = []
    with (path / "chain.mcap").open("rb") as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        for schema, channel, _, ros_msg in reader.iter_decoded_messages():
            seen[channel.topic] = seen.get(channel.topic, 0) + 1
            assert schema is not None and schema.encoding == "ros2msg" and channel.message_encoding == "cdr"
            if channel.topic == bm.TOPIC_JOINT_STATES:
                theta.append(ros_msg.position[0])
                assert ros_msg.name == [bm.PENDULUM_JOINT]
    assert seen == counts
    ours = read_bag(path).decode(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)["position[0]"]
    np.testing.assert_array_equal(theta, ours)


def _mcap_core_dir() -> Path:
    """Folder with @mcap/core (and fzstd for zstd chunks) from the npm registry, once per machine."""
    if shutil.which("node") is None or shutil.which("npm") is None:
        pytest.skip("node/npm are not installed: cannot run Foxglove's @mcap/core reader")
    folder = Path(tempfile.gettempdir()) / "pendulum_accel_mcap_core"
    folder.mkdir(exist_ok=True)
    with (folder / ".lock").open("w") as lock:  # parallel test runs install once
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not all((folder / "node_modules" / pkg).is_dir() for pkg in ("@mcap/core", "fzstd")):
            subprocess.run(
                ["npm", "install", "--no-audit", "--no-fund", "--silent", "@mcap/core@2", "fzstd@0"],
                cwd=folder,
                check=True,
                timeout=300,
                capture_output=True,
            )
        (folder / "count.js").write_text(MCAP_CORE_SCRIPT)
    return folder


def _mcap_core_report(mcap: Path) -> dict[str, Any]:
    """What Foxglove's @mcap/core (count.js) reports of one MCAP file: profile, channels, counts."""
    out = subprocess.run(
        ["node", "count.js", str(mcap)],
        cwd=_mcap_core_dir(),
        check=True,
        timeout=120,
        capture_output=True,
        text=True,
    )
    report: dict[str, Any] = json.loads(out.stdout)
    return report


def test_foxglove_mcap_core_reads_the_bag(chain_bag: tuple[Path, dict[str, int]]) -> None:
    """@mcap/core: ros2 profile, ros2msg schemas, cdr, QoS metadata, all messages via index and stream."""
    path, counts = chain_bag
    report = _mcap_core_report(path / "chain.mcap")
    assert report["profile"] == "ros2"
    assert report["counts"] == counts
    assert report["streamed"] == sum(counts.values()) and report["done"]
    for topic, channel in report["channels"].items():
        assert channel["messageEncoding"] == "cdr"
        assert channel["schemaEncoding"] == "ros2msg"
        assert channel["schemaName"] == bm.TOPIC_TYPES[topic]
        assert "reliability: reliable" in channel["qos"]


def test_foxglove_mcap_core_reads_a_golden_bag() -> None:
    """The golden elastic_string bag (all nine topics, zstd chunks) reads fully in @mcap/core."""
    path = Path(__file__).resolve().parent.parent / "bags" / "elastic_string"
    counts = {name: topic.count for name, topic in read_bag(path, salvage=False).topics.items()}
    assert len(counts) == 9  # the contract's six (string included) and the Imu, markers and URDF
    report = _mcap_core_report(path / "elastic_string.mcap")
    assert report["profile"] == "ros2" and report["counts"] == counts
    assert report["streamed"] == sum(counts.values())
