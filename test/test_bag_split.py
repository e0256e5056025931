"""A recording split into several MCAP files (``ros2 bag record --max-bag-size``) is one bag.

The same messages read from one file and from three (test.split_recording: rosbag2's names and
metadata, the mcap library's writer, channel ids that differ between files) must give the same topics,
counts, times, payloads and decoded columns, through the scan and through the chunk index the player
streams with. A file the metadata lists that is missing, and a damaged chunk in one of the files, are
named with the file; repair rewrites the rest as one file and says what was lost.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import SeekingReader, make_reader

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.errors import NotIndexedError
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.bag.repair import CUSTOM_REPAIRED, repair_bag
from pendulum_accel.bag.stream import StreamedBag
from pendulum_accel.cli.info import info_lines
from pendulum_accel.errors import BagError
from pendulum_accel.recording.generate import generate_bag
from test.conftest import PYTHON, REPO, cli
from test.split_recording import split_recording

PARTS = 3


@pytest.fixture(scope="module")
def recordings(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """(one-file bag, the same split into PARTS files) of step_start over 4 s."""
    root = tmp_path_factory.mktemp("split")
    whole = root / "whole"
    generate_bag("step_start", whole, duration=4.0)
    split_recording(whole, root / "rec", PARTS)
    return whole, root / "rec"


def _copy(src: Path, tmp_path: Path) -> Path:
    """A copy of bag directory ``src`` to damage."""
    dst = tmp_path / src.name
    shutil.copytree(src, dst)
    return dst


@pytest.mark.parametrize("stream", [True, False])
def test_a_split_recording_reads_as_its_one_file(recordings: tuple[Path, Path], stream: bool) -> None:
    whole_path, split_path = recordings
    whole, split = read_bag(whole_path, stream=stream), read_bag(split_path, stream=stream)
    assert len(split.mcap_paths) == PARTS and [p.name for p in split.mcap_paths] == [
        f"rec_{i}.mcap" for i in range(PARTS)
    ]
    assert split.problem is None and split.complete
    assert split.topics == whole.topics
    assert (split.start_ns, split.end_ns, split.message_count) == (
        whole.start_ns,
        whole.end_ns,
        whole.message_count,
    )
    assert split.custom_data == whole.custom_data
    for topic in whole.topics:
        t_whole, p_whole = whole.raw(topic)
        t_split, p_split = split.raw(topic)
        assert np.array_equal(t_split, t_whole) and p_split == p_whole, topic
    for topic in (bm.TOPIC_JOINT_STATES, bm.TOPIC_ACCEL_ESTIMATE, bm.TOPIC_IMU):
        a, b = whole.decode(topic), split.decode(topic)
        assert np.array_equal(a.log_time_ns, b.log_time_ns)
        assert a.fields.keys() == b.fields.keys()
        for name in a.fields:
            assert np.array_equal(a[name], b[name]), (topic, name)
        # A topic is one channel across the files, in log-time order: it streams in batches, in order.
        batches = list(split.decode_batches(topic, rows=100))
        assert len(batches) > 1
        assert np.array_equal(np.concatenate([x.log_time_ns for x in batches]), a.log_time_ns)


def test_info_counts_every_file_and_calls_the_split_recording_complete(recordings: tuple[Path, Path]) -> None:
    whole_path, split_path = recordings
    lines, note = info_lines(str(split_path))
    assert note is None
    assert lines[0].endswith("[complete]"), lines[0]
    assert f"{PARTS} files, rec_0.mcap to rec_{PARTS - 1}.mcap" in lines[1]
    whole_lines, _ = info_lines(str(whole_path))
    # The split files were written by the mcap library (split_recording), the whole one by our writer:
    # each says so; duration, counts, scene, plan, topics and rates are alike.
    (i,) = [k for k, line in enumerate(lines) if line.startswith("written by")]
    assert whole_lines[i].startswith("written by pendulum_accel-")
    assert lines[i] == "written by test split_recording"
    assert lines[2:i] + lines[i + 1 :] == whole_lines[2:i] + whole_lines[i + 1 :]


def test_files_are_taken_in_recording_order_without_metadata(tmp_path: Path) -> None:
    """rosbag2 numbers its files from 0: file 10 comes after file 9, not after file 1."""
    generate_bag("step_start", tmp_path / "whole", duration=3.0)
    split = tmp_path / "rec"
    split_recording(tmp_path / "whole", split, 11, chunk_size=4096)
    (split / "metadata.yaml").unlink()
    bag = read_bag(split)
    assert [p.name for p in bag.mcap_paths] == [f"rec_{i}.mcap" for i in range(11)]
    whole = read_bag(tmp_path / "whole")
    for topic in whole.topics:
        assert np.array_equal(bag.raw(topic)[0], whole.raw(topic)[0]), topic
    assert bag.topics[bm.TOPIC_JOINT_STATES].count == whole.topics[bm.TOPIC_JOINT_STATES].count


def test_the_player_streams_a_split_recording_as_its_one_file(recordings: tuple[Path, Path]) -> None:
    whole_path, split_path = recordings
    whole, split = StreamedBag(whole_path), StreamedBag(split_path)
    try:
        assert split.topics == whole.topics
        assert (split.start_ns, split.end_ns) == (whole.start_ns, whole.end_ns)
        topics = sorted(whole.topics)
        span = whole.end_ns - whole.start_ns
        for first, last in (
            (whole.start_ns, whole.end_ns),
            (whole.start_ns + span // 3, whole.end_ns - span // 5),
        ):
            expected = list(whole.messages(topics, first, last))
            assert list(split.messages(topics, first, last)) == expected
            assert split.count(topics, first, last) == whole.count(topics, first, last) == len(expected)
    finally:
        whole.close()
        split.close()


def test_a_missing_file_is_named_and_the_rest_is_read(recordings: tuple[Path, Path], tmp_path: Path) -> None:
    _, split_path = recordings
    copy = _copy(split_path, tmp_path)
    kept = read_bag(split_path)
    (copy / "rec_1.mcap").unlink()
    bag = read_bag(copy)
    assert bag.missing_files == ("rec_1.mcap",)
    assert bag.problem is not None and "metadata.yaml lists 3 files and rec_1.mcap is missing" in bag.problem
    assert 0 < bag.message_count < kept.message_count
    with pytest.raises(BagError, match=r"rec_1\.mcap is missing"):
        read_bag(copy, salvage=False)
    lines, note = info_lines(str(copy))
    assert "[DAMAGED: rec_1.mcap missing]" in lines[0], lines[0]
    assert note is not None and "rec_1.mcap is missing" in note
    # The player cannot stream a bag with a hole: the whole-bag reader reads what is there.
    with pytest.raises(NotIndexedError, match=r"rec_1\.mcap is missing"):
        StreamedBag(copy)
    result = repair_bag(copy)
    # Both files left were read whole: kept as intact, not as damaged.
    assert result.rewritten and sorted(p.name for p in result.backups) == [
        "rec_0.mcap.orig",
        "rec_2.mcap.orig",
    ]
    fixed = read_bag(copy, salvage=False)
    assert fixed.mcap_paths == [copy / "rec.mcap"] and fixed.message_count == bag.message_count
    assert fixed.custom_data[CUSTOM_REPAIRED] == "rec_1.mcap, listed in metadata.yaml, was missing"
    lines, _ = info_lines(str(copy))
    assert "[repaired: rec_1.mcap, listed in metadata.yaml, was missing]" in lines[0], lines[0]
    assert kept.message_count > fixed.message_count


def test_damage_in_one_file_names_that_file(recordings: tuple[Path, Path], tmp_path: Path) -> None:
    _, split_path = recordings
    copy = _copy(split_path, tmp_path)
    target = copy / "rec_2.mcap"
    data = bytearray(target.read_bytes())
    intact = read_bag(copy)
    with target.open("rb") as stream:
        summary = SeekingReader(stream).get_summary()
    assert summary is not None
    first = min(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    # A byte of the first chunk's records: its CRC no longer matches.
    data[first.chunk_start_offset + first.chunk_length - 10] ^= 0xFF
    target.write_bytes(bytes(data))
    bag = read_bag(copy)
    assert bag.problem is not None and "rec_2.mcap" in bag.problem
    assert bag.damage and all(d.file == "rec_2.mcap" for d in bag.damage)
    lines, _ = info_lines(str(copy))
    assert "DAMAGED: rec_2.mcap chunk 1," in lines[0], lines[0]
    assert bag.message_count <= intact.message_count
    assert bag.damaged_files == [target]
    result = repair_bag(copy)
    assert result.rewritten and len(result.backups) == PARTS
    # Only the file with the flipped byte is kept as damaged; the others are the intact originals.
    assert sorted(p.name for p in result.backups) == [
        "rec_0.mcap.orig",
        "rec_1.mcap.orig",
        "rec_2.mcap.damaged",
    ]
    assert read_bag(copy, salvage=False).problem is None
    # The kept originals still read as the recording they were, bit for bit.
    assert (copy / "rec_0.mcap.orig").read_bytes() == (split_path / "rec_0.mcap").read_bytes()


def _float_bag(path: Path, kind: str) -> Path:
    """Ten std_msgs/Float64 on /x written by rosbags as ``kind``: rosbag2 MCAP compressed whole ('file')
    or message by message ('message'), rosbag2 SQLite ('sqlite'), or a ROS 1 bag ('ros1')."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS1_NOETIC if kind == "ros1" else Stores.ROS2_HUMBLE)
    msgtype = "std_msgs/msg/Float64"
    writer: Any
    if kind == "ros1":
        writer = Writer1(path)
    else:
        plugin = StoragePlugin.SQLITE3 if kind == "sqlite" else StoragePlugin.MCAP
        writer = Writer(path, version=9, storage_plugin=plugin)
        if kind in ("file", "message"):
            mode = CompressionMode.FILE if kind == "file" else CompressionMode.MESSAGE
            writer.set_compression(mode, CompressionFormat.ZSTD)
    with writer:
        conn = writer.add_connection("/x", msgtype, typestore=store)
        for i in range(10):
            msg = store.types[msgtype](float(i))
            raw = store.serialize_ros1(msg, msgtype) if kind == "ros1" else store.serialize_cdr(msg, msgtype)
            writer.write(conn, 10_000_000 * (i + 1), raw)
    return path


@pytest.mark.parametrize(
    ("kind", "says"),
    [
        ("file", "is an MCAP file compressed whole (rosbag2's --compression-mode file)"),
        ("message", "its messages are compressed one by one (rosbag2's --compression-mode message, zstd)"),
        ("sqlite", "uses storage 'bag.db3', not MCAP"),
        ("ros1", "is a ROS 1 bag, not MCAP"),
    ],
)
def test_bags_we_do_not_read_name_the_command_that_converts_them(
    tmp_path: Path, kind: str, says: str
) -> None:
    """A bag written compressed (whole or message by message), in SQLite or by ROS 1: one line says which,
    and gives the rosbags-convert command (installed with rosbags, a dependency) that rewrites it as an
    uncompressed MCAP bag. Run as given, its result reads complete, every message kept."""
    source = _float_bag(tmp_path / ("bag.bag" if kind == "ros1" else "bag"), kind)
    refused = cli("info", str(source))
    line = refused.stderr.strip()
    assert refused.returncode == 2 and "\n" not in line and "Traceback" not in line
    assert says in line, line
    command = line[line.index("rosbags-convert ") :].split()
    assert command[:2] == ["rosbags-convert", "--src"] and command[-2:] == ["--dst-storage", "mcap"]
    tool = Path(PYTHON).parent / "rosbags-convert"  # beside this interpreter, as a user's venv has it
    done = subprocess.run([str(tool), *command[1:]], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert done.returncode == 0, done.stderr
    converted_path = Path(command[command.index("--dst") + 1])
    converted = read_bag(converted_path, salvage=False)
    assert converted.complete and converted.topics["/x"].count == 10
    # info names the writer from the file's MCAP Header (it said "written by pendulum_accel ?" of any bag).
    lines = cli("info", str(converted_path)).stdout.splitlines()
    writer = next(x for x in lines if x.startswith("written by"))
    assert writer.startswith("written by rosbags-"), writer


@pytest.mark.parametrize(("keep", "ending"), [(0, "empty"), (0.6, "cut off before its footer")])
def test_a_killed_recorder_s_last_file_is_named_and_the_rest_is_read(
    recordings: tuple[Path, Path], tmp_path: Path, keep: float, ending: str
) -> None:
    """A recorder killed as it opened its next file (empty), or while writing it (cut off): the bag is
    damaged in that file, named so, and the files before it are read whole."""
    _, split_path = recordings
    copy = _copy(split_path, tmp_path)
    last = copy / "rec_2.mcap"
    data = last.read_bytes()
    last.write_bytes(data[: int(len(data) * keep)])
    before = read_bag(split_path)
    first_two = 0
    for name in ("rec_0.mcap", "rec_1.mcap"):
        with (split_path / name).open("rb") as stream:
            first_two += sum(1 for _ in make_reader(stream).iter_messages())
    bag = read_bag(copy)
    assert bag.endings() == [f"rec_2.mcap {ending}"]
    assert first_two <= bag.message_count < before.message_count
    lines, note = info_lines(str(copy))
    assert lines[0].endswith(f"[DAMAGED: rec_2.mcap {ending}]") or f"; rec_2.mcap {ending}]" in lines[0], (
        lines[0]
    )
    assert note is not None and "rec_2.mcap" in note
    result = repair_bag(copy)
    assert result.rewritten and read_bag(copy, salvage=False).message_count == bag.message_count
