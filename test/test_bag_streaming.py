"""Bags read chunk by chunk give what a reader holding every message gives.

``read_bag`` leaves each intact chunk's messages in the file and reads them again, chunk by chunk, when a
topic is asked for; ``read_bag(stream=False)`` holds them all from the scan. Both decode the same bytes
with the same code, so their results must be identical, not merely close: every comparison here is
exact. The bags span many 1 MiB chunks, so every read crosses chunk boundaries.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pendulum_accel.bag import export as bag_export
from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.blocks import Lazy
from pendulum_accel.bag.reader import Bag, read_bag
from pendulum_accel.cli import info
from pendulum_accel.cli.info import info_lines
from pendulum_accel.errors import BagError
from pendulum_accel.recording.analyze import analyze_bag
from pendulum_accel.recording.generate import chain_streams, generate_bag, write_chain_bag
from pendulum_accel.scene import load_scene


@pytest.fixture(scope="module")
def chain_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A generated chain bag of stop_and_go (30 s) at 1 kHz: about 20 MB, some 20 chunks of 1 MiB."""
    scene = load_scene("stop_and_go")
    scene = dataclasses.replace(scene, sensor=dataclasses.replace(scene.sensor, rate_hz=1000.0))
    out = tmp_path_factory.mktemp("streaming") / "bag"
    generate_bag(scene, out)
    return out


def _same_bag(streamed: Bag, held: Bag) -> None:
    """Every topic, count, time span, shape, raw payload and decoded column of the two bags are equal."""
    assert streamed.topics == held.topics
    assert (streamed.start_ns, streamed.end_ns) == (held.start_ns, held.end_ns)
    assert (streamed.complete, streamed.damage) == (held.complete, held.damage)
    for topic in held.topics:
        times, payloads = streamed.raw(topic)
        held_times, held_payloads = held.raw(topic)
        assert np.array_equal(times, held_times) and payloads == held_payloads
        assert [count for _, count in streamed.shapes(topic)] == [count for _, count in held.shapes(topic)]
        if held.topics[topic].msgtype in bag_export.BULK_TYPES:
            got, want = streamed.decode(topic), held.decode(topic)
            assert np.array_equal(got.log_time_ns, want.log_time_ns)
            assert got.fields.keys() == want.fields.keys()
            for path, column in want.fields.items():
                assert np.array_equal(got[path], column), f"{topic} {path}"
    assert streamed.problem == held.problem


def test_streamed_bag_equals_the_bag_held_whole(chain_bag: Path) -> None:
    """Topics, counts, spans, shapes, payloads and columns: equal; and the bag really spans many chunks."""
    streamed = read_bag(chain_bag)
    chunks = {b.ref.at for ch in streamed._channels.values() for b in ch.blocks if isinstance(b, Lazy)}
    assert len(chunks) > 10
    _same_bag(streamed, read_bag(chain_bag, stream=False))


def test_batches_concatenate_to_the_whole_decode(chain_bag: Path) -> None:
    """decode_batches in batches smaller than a chunk and larger than one: the concatenation is decode."""
    bag = read_bag(chain_bag)
    for topic in (bm.TOPIC_JOINT_STATES, bm.TOPIC_ACCEL_ESTIMATE, bm.TOPIC_CLOCK):
        whole = bag.decode(topic)
        for rows in (1000, 20_000):
            batches = list(bag.decode_batches(topic, rows=rows))
            # A batch closes at the first block (chunk) end past ``rows``.
            assert len(batches) > 1 or rows >= len(whole)
            assert all(len(b) >= rows for b in batches[:-1])
            assert np.array_equal(np.concatenate([b.log_time_ns for b in batches]), whole.log_time_ns)
            for path, column in whole.fields.items():
                assert np.array_equal(np.concatenate([b[path] for b in batches]), column)


def test_analyze_and_info_equal_on_both_readers(chain_bag: Path) -> None:
    """analyze's series and figures, and info's lines, are those of the bag held whole."""
    streamed = analyze_bag(read_bag(chain_bag))
    held = analyze_bag(read_bag(chain_bag, stream=False))
    for name in ("t", "theta", "accel_true", "accel_est", "variance"):
        assert np.array_equal(getattr(streamed, name), getattr(held, name)), name
    assert streamed.offline_figures.as_dict() == held.offline_figures.as_dict()
    assert streamed.recorded_figures is not None and held.recorded_figures is not None
    assert streamed.recorded_figures.as_dict() == held.recorded_figures.as_dict()
    lines, note = info_lines(str(chain_bag))
    assert note is None and "[complete]" in lines[0]


def test_export_written_in_batches_equals_the_whole_tables(
    chain_bag: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """CSV and Parquet tables written 7000 rows at a time read back equal to the tables built whole."""
    monkeypatch.setattr(bag_export, "BATCH_ROWS", 7000)
    monkeypatch.setattr(bag_export.topic_frames, "__defaults__", (7000,))
    bag = read_bag(chain_bag)
    for fmt in ("csv", "parquet"):
        paths = bag_export.export_bag(bag, tmp_path / fmt, fmt=fmt)
        assert paths
        for path in paths:
            topic = next(t for t in bag.topics if bag_export.file_stem(t) == path.stem)
            whole = bag_export.topic_table(bag, topic)
            written = pd.read_csv(path) if fmt == "csv" else pd.read_parquet(path)
            # CSV keeps 17 significant digits (float_format %.17g): every float64 reads back exactly.
            pd.testing.assert_frame_equal(written, whole, check_dtype=fmt == "parquet", check_exact=True)


def test_damaged_bag_reads_the_same_streamed(chain_bag: Path, tmp_path: Path) -> None:
    """A chunk with a flipped byte: the same damage, the same recovered records, the same columns."""
    damaged = tmp_path / "damaged"
    damaged.mkdir()
    for part in chain_bag.iterdir():
        (damaged / part.name).write_bytes(part.read_bytes())
    mcap = next(damaged.glob("*.mcap"))
    data = bytearray(mcap.read_bytes())
    data[len(data) // 2] ^= 0xFF
    mcap.write_bytes(bytes(data))
    streamed, held = read_bag(damaged), read_bag(damaged, stream=False)
    assert held.damage and held.problem is not None
    _same_bag(streamed, held)


def test_a_chunk_its_index_misplaces_is_read_again_by_walking(chain_bag: Path, tmp_path: Path) -> None:
    """Chunks the scan found through their message indexes alone are read again through those indexes (the
    wanted channels' entries only); a chunk whose index points one channel's entry at another channel's
    message is walked in the scan and walked again when read. Both: what the bag held whole gives."""
    copy = tmp_path / "bag"
    copy.mkdir()
    for part in chain_bag.iterdir():
        (copy / part.name).write_bytes(part.read_bytes())
    refs = {b.ref for ch in read_bag(copy)._channels.values() for b in ch.blocks if isinstance(b, Lazy)}
    assert refs and all(ref.indexed for ref in refs)  # our writer's chunks: every message indexed
    ref = sorted(refs, key=lambda r: r.at)[len(refs) // 2]
    mcap = next(copy.glob("*.mcap"))
    data = bytearray(mcap.read_bytes())
    (first, _), (second, _) = ref.indexes[:2]
    # MessageIndex body: channel id (2 bytes), entries' byte length (4), then (log time, offset) entries.
    offset_at = first + 9 + 6 + 8
    data[offset_at : offset_at + 8] = data[second + 9 + 6 + 8 : second + 9 + 6 + 16]
    mcap.write_bytes(bytes(data))
    streamed = read_bag(copy)
    again = {b.ref.at: b.ref for ch in streamed._channels.values() for b in ch.blocks if isinstance(b, Lazy)}
    assert not again[ref.at].indexed and sum(r.indexed for r in again.values()) == len(again) - 1
    _same_bag(streamed, read_bag(copy, stream=False))


def test_a_bag_changed_after_its_scan_is_refused(chain_bag: Path, tmp_path: Path) -> None:
    """Bytes of a chunk rewritten in place after the scan: reading its topic is a BagError, not other data."""
    copy = tmp_path / "bag"
    copy.mkdir()
    for part in chain_bag.iterdir():
        (copy / part.name).write_bytes(part.read_bytes())
    bag = read_bag(copy)
    mcap = next(copy.glob("*.mcap"))
    with open(mcap, "r+b") as handle:
        handle.seek(os.path.getsize(mcap) // 2)
        byte = handle.read(1)
        handle.seek(-1, os.SEEK_CUR)
        handle.write(bytes([byte[0] ^ 0xFF]))
    with pytest.raises(BagError, match="changed since it was read"):
        for topic in bag.topics:
            bag.raw(topic)


def test_holes_counted_batch_by_batch_equal_the_whole_count(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Estimates missing in runs (a warm-up, three holes, the end): info's merge of the two stamp streams,
    a few hundred stamps at a time, counts what np.isin over the whole arrays counts."""
    t = np.arange(0.0, 20.0, 0.001)
    theta = 0.01 * np.sin(t)
    accel = np.full(t.size, 1.0)
    estimate = accel.copy()
    for start, stop in ((0, 150), (3000, 3400), (9000, 9001), (15000, 17000), (19900, t.size)):
        estimate[start:stop] = np.nan
    streams = chain_streams(
        t, theta, np.cos(t), accel, estimate, np.full(t.size, 0.01), estimator="instant", rate_hz=1000.0
    )
    path = tmp_path / "holes"
    write_chain_bag(path, streams, custom_data={})
    bag = read_bag(path)
    joint, est = bm.TOPIC_JOINT_STATES, bm.TOPIC_ACCEL_ESTIMATE
    expected = 400 + 1 + 2000 + (t.size - 19900)  # after the first estimate: every hole but the warm-up
    assert info._holes_whole(bag, joint, est) == expected
    monkeypatch.setattr(info, "STAMP_BATCH", 700)
    assert info.holes_after_first(bag, joint, est) == expected


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_merged_export_streamed_equals_the_whole_join(
    chain_bag: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, fmt: str
) -> None:
    """--merged written 7000 angles at a time (with the smoother's series) reads back equal to the whole
    join (merged_table, then the derived series merged on t): same columns, dtypes and values, exactly."""
    from pendulum_accel.recording.smoothed import smoothed_estimate

    monkeypatch.setattr(bag_export, "BATCH_ROWS", 7000)
    monkeypatch.setattr(bag_export, "MERGE_ROWS", 7000)
    monkeypatch.setattr(bag_export.topic_frames, "__defaults__", (7000,))
    bag = read_bag(chain_bag)
    smoothed = smoothed_estimate(bag)
    assert smoothed is not None
    derived = {"/car/accel/smoothed": smoothed}
    (path,) = bag_export.export_bag(bag, tmp_path, fmt=fmt, merged=True, derived=derived)
    chosen = [t for t in bag.topics if bm.role_of(t) not in bag_export.VISUAL_ROLES]
    whole = bag_export.merged_table(bag, chosen)
    whole = whole.merge(bag_export.derived_table("/car/accel/smoothed", smoothed), on="t", how="left")
    assert len(whole) == bag.topics[bm.TOPIC_JOINT_STATES].count > 3 * 7000
    if fmt == "csv":
        reference = tmp_path / "whole.csv"
        bag_export.write_csv_table([whole], reference)
        # Both read back by the same parser from 17 significant digits: equal frames, exactly.
        pd.testing.assert_frame_equal(pd.read_csv(path), pd.read_csv(reference), check_exact=True)
    else:
        pd.testing.assert_frame_equal(pd.read_parquet(path), whole, check_exact=True)


def test_merged_export_streamed_with_holes_widens_as_the_whole_join(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Estimates missing in runs (a warm-up, holes, the end) and /diagnostics starting after the first
    batch: the batches joined 700 angles at a time read back equal to the whole join, the estimate's integer
    stamp columns floats (NaN) in every batch as in the whole table."""
    t = np.arange(0.0, 6.0, 0.001)
    estimate = np.full(t.size, 1.0)
    for start, stop in ((0, 150), (3000, 3400), (4000, 4001), (5900, t.size)):
        estimate[start:stop] = np.nan
    streams = chain_streams(
        t, 0.01 * np.sin(t), np.cos(t), np.ones(t.size), estimate, np.full(t.size, 0.01), estimator="instant",
        rate_hz=1000.0,
    )  # fmt: skip
    path = tmp_path / "holes"
    write_chain_bag(path, streams, custom_data={})
    monkeypatch.setattr(bag_export, "BATCH_ROWS", 700)
    monkeypatch.setattr(bag_export, "MERGE_ROWS", 700)
    monkeypatch.setattr(bag_export.topic_frames, "__defaults__", (700,))
    bag = read_bag(path)
    chosen = [t for t in bag.topics if bm.role_of(t) not in bag_export.VISUAL_ROLES]
    whole = bag_export.merged_table(bag, chosen)
    assert whole["/car/accel/estimate/header/stamp/sec"].dtype == np.float64
    assert len(list(bag_export.merged_frames(bag, chosen))) > 3
    for fmt in ("csv", "parquet"):
        (written,) = bag_export.export_bag(bag, tmp_path / fmt, fmt=fmt, merged=True)
        if fmt == "parquet":
            pd.testing.assert_frame_equal(pd.read_parquet(written), whole, check_exact=True)
            continue
        reference = tmp_path / "whole.csv"
        bag_export.write_csv_table([whole], reference)
        pd.testing.assert_frame_equal(pd.read_csv(written), pd.read_csv(reference), check_exact=True)
