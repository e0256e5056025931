"""Checksummed bags: what the writer writes, the mcap library checks; what is damaged, info reports, analyze
refuses and repair salvages record by record; a chain cut short by a dead node is never [complete].

Ground truth comes from the file itself, walked here with plain struct reads and the mcap library's
summary, never from our reader: a message is "intact" in a cut-off file when its whole record lies
before the cut.
"""

from __future__ import annotations

import dataclasses
import os
import re
import shutil
import signal
import struct
import time
import zlib
from pathlib import Path

import numpy as np
import pytest
import yaml
from mcap.reader import NonSeekingReader, SeekingReader, make_reader
from mcap.records import Chunk, DataEnd, Message, MessageIndex
from mcap.stream_reader import CRCValidationError, StreamReader
from rosbags.rosbag2 import Reader

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.bag.repair import CUSTOM_REPAIRED, repair_bag
from pendulum_accel.cli.info import info_lines
from pendulum_accel.cli.main import main
from pendulum_accel.recording.generate import generate_bag
from pendulum_accel.scene import Scene, load_scene
from test.chain_helpers import child_pids, start_chain
from test.conftest import Spawn
from test.figures import assert_figure
from test.split_recording import split_recording
from test.test_bag_io import _write_chain_bag

CHUNK_HEAD = struct.Struct("<QQQII")  # message start, end, uncompressed size, CRC, compression length


@dataclasses.dataclass(frozen=True)
class ChunkInfo:
    """One chunk of a file: record offset and length, message times, and its message records
    as (file offset of the record, record length) in order."""

    at: int
    length: int
    start_ns: int
    end_ns: int
    messages: list[tuple[int, int]]


def chunks_of(mcap: Path) -> list[ChunkInfo]:
    """Every chunk of an uncompressed MCAP file, from the mcap library's chunk index and a struct walk."""
    data = mcap.read_bytes()
    with mcap.open("rb") as handle:
        summary = make_reader(handle).get_summary()
    assert summary is not None
    out = []
    for index in sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset):
        at = index.chunk_start_offset
        _, _, size, _, clen = CHUNK_HEAD.unpack_from(data, at + 9)
        records = at + 9 + CHUNK_HEAD.size + clen + 8
        messages, pos = [], records
        while pos < records + size:
            op, length = struct.unpack_from("<BQ", data, pos)
            if op == 0x05:
                messages.append((pos, 9 + length))
            pos += 9 + length
        out.append(
            ChunkInfo(at, index.chunk_length, index.message_start_time, index.message_end_time, messages)
        )
    return out


def at_1khz(duration: float) -> Scene:
    """The lecture_constant scene sampled at 1 kHz for ``duration`` s (~1.2 MB of bag per second)."""
    scene = load_scene("lecture_constant")
    return dataclasses.replace(
        scene, sensor=dataclasses.replace(scene.sensor, rate_hz=1000.0), duration=duration
    )


@pytest.fixture(scope="module")
def multi_chunk_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A generated chain bag at 1 kHz over 6.9 s: 8 chunks of ~1 MiB (0.9 s each), uncompressed."""
    scene = at_1khz(6.9)
    path = tmp_path_factory.mktemp("integrity") / "multi"
    generate_bag(scene, path)
    return path


@pytest.fixture(scope="module")
def short_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A generated chain bag of 5 s at the scene's 100 Hz: one chunk."""
    path = tmp_path_factory.mktemp("integrity") / "short"
    generate_bag(dataclasses.replace(load_scene("lecture_constant"), duration=5.0), path)
    return path


def copy_bag(src: Path, dst: Path) -> Path:
    """A copy of bag directory ``src`` at ``dst`` (named like it: the .mcap inside keeps its name)."""
    shutil.copytree(src, dst)
    return dst


def mcap_of(bag: Path) -> Path:
    """The bag's .mcap file."""
    (found,) = bag.glob("*.mcap")
    return found


def flip(path: Path, at: int) -> None:
    """Flip every bit of the byte at offset ``at``."""
    data = bytearray(path.read_bytes())
    data[at] ^= 0xFF
    path.write_bytes(bytes(data))


# --- the writer's CRCs, checked by the mcap library ---------------------------------------------


@pytest.mark.parametrize("compression", [None, "zstd"])
def test_written_bags_pass_the_mcap_library_crc_checks(tmp_path: Path, compression: str | None) -> None:
    """Chunk CRCs (make_reader, SeekingReader, NonSeekingReader), the data section CRC (StreamReader)
    and the summary CRC (recomputed here as the spec defines it) are written, non-zero and right."""
    counts = generate_bag(at_1khz(3.0), tmp_path / "b", compression=compression).counts
    mcap = mcap_of(tmp_path / "b")
    total = sum(counts.values())
    with mcap.open("rb") as handle:
        assert sum(1 for _ in make_reader(handle, validate_crcs=True).iter_messages()) == total
    for reader_class in (SeekingReader, NonSeekingReader):
        with mcap.open("rb") as handle:
            reader = reader_class(handle, validate_crcs=True)
            assert sum(1 for _ in reader.iter_messages()) == total
    with mcap.open("rb") as handle:  # checks every chunk CRC and the data section CRC
        streamed = list(StreamReader(handle, validate_crcs=True).records)
    assert sum(type(r).__name__ == "Message" for r in streamed) == total
    with mcap.open("rb") as handle:
        records = list(StreamReader(handle, validate_crcs=True, emit_chunks=True).records)
    chunks = [r for r in records if isinstance(r, Chunk)]
    data_end = next(r for r in records if isinstance(r, DataEnd))
    assert len(chunks) >= 2 and all(c.uncompressed_crc != 0 for c in chunks)
    assert data_end.data_section_crc != 0
    data = mcap.read_bytes()
    # Footer: opcode, length, summary start, summary offset start, summary CRC; then the magic.
    footer_at = len(data) - 8 - 29
    summary_start, _, summary_crc = struct.unpack_from("<QQI", data, footer_at + 9)
    assert summary_crc == zlib.crc32(data[summary_start : footer_at + 25]) != 0
    # DataEnd (13 bytes) ends where the summary starts; its CRC covers everything before it.
    assert data[summary_start - 13] == 0x0F
    assert data_end.data_section_crc == zlib.crc32(data[: summary_start - 13])


# --- a flipped byte: reported, refused, detected by the library, salvaged ------------------------


def test_flipped_byte_in_a_chunk_is_reported_refused_and_detected(
    multi_chunk_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = copy_bag(multi_chunk_bag, tmp_path / "multi")
    mcap = mcap_of(bag)
    chunks = chunks_of(mcap)
    assert len(chunks) == 8
    victim = chunks[4]  # chunk 5 of the file
    at, length = victim.messages[len(victim.messages) // 2]
    flip(mcap, at + length - 3)  # a payload byte: the record still frames
    origin = chunks[0].start_ns
    t0, t1 = (victim.start_ns - origin) * 1e-9, (victim.end_ns - origin) * 1e-9

    assert main(["info", str(bag)]) == 1
    out, err = capsys.readouterr()
    # the chunk's span parsed: the same ns differences, scaled to s by the code in its own way (≤ 1 ulp)
    first = out.splitlines()[0]
    assert_figure(first, "[DAMAGED: chunk 5, ", t0, rel=1e-15)
    assert_figure(first, "–", t1, rel=1e-15)
    assert first[first.index("[DAMAGED: chunk 5, ") :].split("]")[0].endswith(" s")
    assert "[complete]" not in out and err.count("\n") == 1 and "CRC mismatch" in err

    assert main(["analyze", str(bag)]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.count("\n") == 1 and "damaged" in err and "--salvage" in err
    assert main(["export", str(bag), "--out", str(tmp_path / "tables")]) == 2
    assert not (tmp_path / "tables").exists()
    assert main(["allan", str(bag)]) == 2
    assert main(["animate", str(bag), "--out", str(tmp_path / "swing.gif")]) == 2
    assert not (tmp_path / "swing.gif").exists()
    err = capsys.readouterr().err
    assert err.count("\n") == 3 and err.count("--salvage") == 3

    with mcap.open("rb") as handle, pytest.raises(CRCValidationError):
        for _ in make_reader(handle, validate_crcs=True).iter_messages():
            pass
    with mcap.open("rb") as handle, pytest.raises(CRCValidationError):
        for _ in StreamReader(handle, validate_crcs=True).records:
            pass

    assert main(["analyze", str(bag), "--salvage"]) == 1
    out, err = capsys.readouterr()
    assert "RMS" in out and err.count("\n") == 1 and "recovered by parsing" in err


def test_damage_between_chunks_fails_the_data_section_crc(multi_chunk_bag: Path, tmp_path: Path) -> None:
    """A flipped byte in a message index (between chunks, no chunk CRC covers it): the data section CRC."""
    bag = copy_bag(multi_chunk_bag, tmp_path / "multi")
    mcap = mcap_of(bag)
    chunk = chunks_of(mcap)[2]
    index_at = chunk.at + chunk.length  # the first message index after the chunk
    assert mcap.read_bytes()[index_at] == 0x07
    flip(mcap, index_at + 9 + 6 + 3)  # inside its first entry's log time
    lines, note = info_lines(str(bag))
    assert "[DAMAGED: outside the chunks]" in lines[0]
    assert note is not None and "data section CRC mismatch" in note
    with mcap.open("rb") as handle, pytest.raises(CRCValidationError):
        for _ in StreamReader(handle, validate_crcs=True).records:
            pass


# --- repair: every intact chunk, every intact record of a damaged or cut-off chunk ---------------


def _intact_before(chunks: list[ChunkInfo], cut: int) -> int:
    """Message records wholly before byte ``cut``."""
    return sum(1 for c in chunks for at, length in c.messages if at + length <= cut)


def test_truncated_in_chunk_4_of_8_keeps_every_intact_record(
    multi_chunk_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = copy_bag(multi_chunk_bag, tmp_path / "multi")
    mcap = mcap_of(bag)
    original = mcap.read_bytes()
    chunks = chunks_of(mcap)
    assert len(chunks) == 8
    cut_chunk = chunks[3]
    cut = cut_chunk.at + cut_chunk.length // 2 + 5  # mid-chunk, most likely mid-record
    mcap.write_bytes(original[:cut])
    intact = _intact_before(chunks, cut)
    in_cut_chunk = _intact_before([cut_chunk], cut)
    assert in_cut_chunk > 0 and intact == sum(len(c.messages) for c in chunks[:3]) + in_cut_chunk

    lines, _ = info_lines(str(bag))
    assert re.search(r"\[DAMAGED: chunk 4, [0-9.]+–[0-9.]+ s; cut off before its footer\]", lines[0])
    assert main(["repair", str(bag)]) == 0
    out = capsys.readouterr().out
    assert f"rebuilt with {intact} messages" in out
    assert "chunk 4, " in out and f"{in_cut_chunk} message records recovered by parsing" in out
    assert "dropped: 1 message records" in out  # the record the cut went through
    # Every intact message, byte for byte, and the repaired bag passes the library's CRC checks.
    with (bag / (mcap.stem + ".mcap.damaged")).open("rb") as handle:
        assert handle.read() == original[:cut]
    kept = [(m.channel_id, m.log_time, m.data) for m in _messages(mcap)]
    assert len(kept) == intact
    records = [(at, length) for c in chunks for at, length in c.messages if at + length <= cut]
    expected = [original[at + 31 : at + length] for at, length in records]  # payloads: past the 31-byte head
    assert sorted(d for _, _, d in kept) == sorted(expected)
    with Reader(bag) as reader:
        assert sum(1 for _ in reader.messages()) == intact


def _messages(mcap: Path) -> list[Message]:
    """Every message of a file through the mcap library with CRC checks."""
    with mcap.open("rb") as handle:
        return [m for _, _, m in make_reader(handle, validate_crcs=True).iter_messages()]


def test_single_chunk_bag_cut_at_half_keeps_its_first_half(
    short_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bag = copy_bag(short_bag, tmp_path / "short")
    mcap = mcap_of(bag)
    chunks = chunks_of(mcap)
    assert len(chunks) == 1
    data = mcap.read_bytes()
    cut = len(data) // 2
    mcap.write_bytes(data[:cut])
    intact = _intact_before(chunks, cut)
    assert intact > 0.4 * len(chunks[0].messages)
    assert main(["repair", str(bag)]) == 0
    assert f"rebuilt with {intact} messages" in capsys.readouterr().out
    assert len(_messages(mcap)) == intact
    fixed = read_bag(bag, salvage=False)
    js = fixed.decode(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)
    assert js.stamp[0] == 0.0 and len(js) > 0.4 * 501


def test_damaged_chunk_keeps_its_intact_records_and_says_so(
    multi_chunk_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two records broken in chunk 3: one's CDR string length (does not decode), one's record length (the
    framing breaks; the message index resyncs). The chunk's other records are kept, the two dropped."""
    bag = copy_bag(multi_chunk_bag, tmp_path / "multi")
    mcap = mcap_of(bag)
    chunks = chunks_of(mcap)
    total = sum(len(c.messages) for c in chunks)
    data = bytearray(mcap.read_bytes())
    victim = chunks[2]
    name = bm.PENDULUM_JOINT.encode()
    js_at = data.index(name, victim.messages[10][0])  # a JointState's joint name, past the 10th record
    data[js_at - 4 : js_at] = b"\xff\xff\xff\x7f"  # its string length: the CDR no longer decodes
    at, _ = victim.messages[-20]
    data[at + 1 : at + 9] = struct.pack("<Q", 2**40)  # a record length past the chunk's end
    mcap.write_bytes(bytes(data))

    bag_read = read_bag(bag)
    (damage,) = bag_read.damage
    assert damage.chunk == 3 and damage.reason == "CRC mismatch"
    assert damage.recovered == len(victim.messages) - 2 and damage.dropped == 2
    assert bag_read.message_count == total - 2
    assert main(["repair", str(bag)]) == 0
    out = capsys.readouterr().out
    assert f"rebuilt with {total - 2} messages" in out
    assert f"{len(victim.messages) - 2} message records recovered by parsing, 2 dropped" in out
    assert "no checksum vouches" in out
    assert len(_messages(mcap)) == total - 2
    lines, note = info_lines(str(bag))
    assert "[repaired: " in lines[0] and "chunk 3" in lines[0] and note is None
    assert CUSTOM_REPAIRED in read_bag(bag).custom_data


@pytest.mark.parametrize("where", ["payload", "framing"])
def test_damage_at_40_percent_keeps_the_chunks_after_it(tmp_path: Path, where: str) -> None:
    counts = _write_chain_bag(tmp_path / "bag", n=20_000)
    mcap = tmp_path / "bag" / "bag.mcap"
    chunks = chunks_of(mcap)
    assert len(chunks) >= 5
    data = bytearray(mcap.read_bytes())
    victim = next(c for c in chunks if c.at + c.length > 0.4 * len(data))
    start, in_chunk = victim.at, len(victim.messages)
    if where == "payload":
        # 10 flipped bytes over the chunk's header (sizes, CRC, compression): its records no longer read.
        at = start + 9 + 20
        data[at : at + 10] = bytes(b ^ 0xFF for b in data[at : at + 10])
    else:
        data[start] = 0x00  # the chunk's opcode: the record framing itself is broken there
    mcap.write_bytes(bytes(data))
    total = sum(counts.values())
    bag = read_bag(tmp_path / "bag")
    assert bag.problem is not None
    assert bag.message_count == total - in_chunk  # every other chunk, before and after the damage
    assert ("chunk index" if where == "framing" else "damaged chunk") in bag.problem
    js = bag.decode(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)
    ms = np.round(js.stamp * 1e3)
    assert ms[-1] == counts[bm.TOPIC_JOINT_STATES] - 1  # the last sample, long after the damage
    assert np.all(np.diff(ms) > 0)
    result = repair_bag(tmp_path / "bag")
    assert result.rewritten and sum(result.counts.values()) == bag.message_count
    assert read_bag(tmp_path / "bag", salvage=False).message_count == bag.message_count


def test_repair_of_a_directory_that_is_no_bag_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    (tmp_path / "photos").mkdir()
    (tmp_path / "photos" / "cat.jpg").write_bytes(b"\xff\xd8")
    assert main(["repair", str(tmp_path / "photos")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is not a bag directory" in err
    assert sorted(p.name for p in (tmp_path / "photos").iterdir()) == ["cat.jpg"]


# --- honest endings: a chain whose simulator died is never [complete] ---------------------------


@pytest.mark.ros
def test_killed_simulator_leaves_an_incomplete_bag(spawn: Spawn, tmp_path: Path) -> None:
    """A real-time 60 s chain, its simulator SIGKILLed after ~2 s of data: info says INCOMPLETE and why."""
    bag = tmp_path / "bag"
    chain = start_chain(spawn, "lecture_constant", "--set", "duration=60", "--record", str(bag))
    chain.wait_for(r"\[pendulum_sim\]: first sample acknowledged by every reader", timeout=60)
    time.sleep(2.0)
    pids = child_pids(chain)
    os.kill(pids["simulator"], signal.SIGKILL)
    assert chain.finish(timeout=60) == 1, chain.text
    lines, note = info_lines(str(bag))
    assert "[complete]" not in lines[0]
    assert "[INCOMPLETE: the chain stopped because the simulator died (killed by SIGKILL)]" in lines[0], lines
    assert note is not None and "simulator died" in note
    recorded = read_bag(bag, salvage=False)  # the recorder closed a valid bag: only its ending is short
    assert 1.0 < recorded.duration_s < 30.0


def _first_chunk_messages(path: Path) -> int:
    """Messages the first chunk of MCAP file ``path`` holds, by its MessageIndex records (mcap library)."""
    chunks = count = 0
    with path.open("rb") as stream:
        for record in StreamReader(stream, emit_chunks=True).records:
            if isinstance(record, Chunk):
                chunks += 1
                if chunks > 1:
                    break
            elif isinstance(record, MessageIndex) and chunks == 1:
                count += len(record.records)
    return count


def test_a_damaged_chunk_holding_the_channel_records_loses_only_its_own_messages(tmp_path: Path) -> None:
    """The mcap library (and rosbag2's MCAP storage) write a channel's record into the chunk of its first
    message, and repeat it in the summary. A damaged first chunk took every channel with it: each later
    chunk's messages named unknown channels, and 0 of 2253 messages were read. The summary's channels
    (its CRC checked) are registered before the scan: only the damaged chunk's messages are lost."""
    generate_bag("step_start", tmp_path / "ours", duration=4.0)
    split_recording(tmp_path / "ours", tmp_path / "theirs", 1)  # rewritten by the mcap library
    mcap_path = tmp_path / "theirs" / "theirs_0.mcap"
    total = read_bag(tmp_path / "theirs").message_count
    lost = _first_chunk_messages(mcap_path)
    with mcap_path.open("rb") as stream:
        summary = SeekingReader(stream).get_summary()
    assert summary is not None
    first = min(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    data = bytearray(mcap_path.read_bytes())
    data[first.chunk_start_offset + first.chunk_length - 10] ^= 0xFF  # inside its compressed records
    mcap_path.write_bytes(bytes(data))
    bag = read_bag(tmp_path / "theirs")
    assert [d.chunk for d in bag.damage] == [1]
    assert 0 < lost < total and bag.message_count == total - lost
    assert all(info.count > 0 for name, info in bag.topics.items() if name != bm.TOPIC_ROBOT_DESCRIPTION)


def _listed(bag_dir: Path, topic: str, count: int) -> None:
    """Set metadata.yaml's message count of ``topic`` (and the total by the same step) to ``count``."""
    meta = yaml.safe_load((bag_dir / "metadata.yaml").read_text(encoding="utf8"))
    info = meta["rosbag2_bagfile_information"]
    for entry in info["topics_with_message_count"]:
        if entry["topic_metadata"]["name"] == topic:
            info["message_count"] += count - entry["message_count"]
            entry["message_count"] = count
    (bag_dir / "metadata.yaml").write_text(yaml.safe_dump(meta, sort_keys=False), encoding="utf8")


def test_fewer_messages_than_metadata_lists_is_not_complete(tmp_path: Path) -> None:
    """metadata.yaml lists 999 /clock messages and the file holds 401 (its framing and checksums intact):
    598 messages were written and are gone, so `info` says INCOMPLETE, names the topic and exits 1
    (it said [complete]). More than listed loses nothing (a recorder killed before rewriting its
    metadata): still complete. `repair` rewrites the metadata from what the file holds."""
    generate_bag("step_start", tmp_path / "bag", duration=4.0)
    held = read_bag(tmp_path / "bag").topics[bm.TOPIC_CLOCK].count
    _listed(tmp_path / "bag", bm.TOPIC_CLOCK, held + 598)
    lines, note = info_lines(str(tmp_path / "bag"))
    expected = f"metadata.yaml lists {held + 598} {bm.TOPIC_CLOCK} messages, the bag holds {held}"
    assert lines[0].endswith(f"[INCOMPLETE: {expected}]") and note == expected
    assert main(["info", str(tmp_path / "bag")]) == 1
    _listed(tmp_path / "bag", bm.TOPIC_CLOCK, held - 1)
    lines, note = info_lines(str(tmp_path / "bag"))
    assert lines[0].endswith("[complete]") and note is None
    result = repair_bag(tmp_path / "bag")
    assert result.rewritten  # the metadata did not match: written anew
    # Its MCAP file read whole: kept as the intact original, not named damaged.
    assert [p.name for p in result.backups] == ["bag.mcap.orig"]
    assert not repair_bag(tmp_path / "bag").rewritten
