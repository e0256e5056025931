"""Bag writer/reader: bulk CDR and MCAP paths equal the rosbags ones byte for byte; damage is salvaged."""

from __future__ import annotations

import zlib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from rosbags.rosbag2 import Reader, StoragePlugin, Writer

from pendulum_accel import __version__
from pendulum_accel.bag import cdr_layout
from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.bag.repair import repair_bag
from pendulum_accel.bag.writer import BagWriter, Stream
from pendulum_accel.errors import BagError

RNG = np.random.default_rng(20261122)


def _layouts() -> list[tuple[str, object, dict[str, np.ndarray]]]:
    """(msgtype, template message, random columns) for every fixed-layout message of the chain."""
    n = 50
    ns = np.sort(RNG.integers(0, 4 * 10**9, n))
    sec, nsec = bm.split_stamp(ns)
    stamp = {"header.stamp.sec": sec, "header.stamp.nanosec": nsec}
    return [
        (
            bm.JOINT_STATE,
            bm.joint_state(0, [bm.PENDULUM_JOINT], [0.0], [0.0]),
            {**stamp, "position[0]": RNG.normal(size=n), "velocity[0]": RNG.normal(size=n)},
        ),
        (
            bm.JOINT_STATE,
            bm.joint_state(0, [bm.STRING_JOINT], [0.0], [0.0], [0.0]),
            {**stamp, "position[0]": RNG.normal(size=n), "effort[0]": RNG.normal(size=n) * 10},
        ),
        (bm.ACCEL_STAMPED, bm.accel_stamped(0, 0.0), {**stamp, "accel.linear.x": RNG.normal(size=n)}),
        (
            bm.ACCEL_WITH_COVARIANCE_STAMPED,
            bm.accel_with_covariance_stamped(0, 0.0, 0.0),
            {**stamp, "accel.accel.linear.x": RNG.normal(size=n), "accel.covariance[0]": RNG.random(n)},
        ),
        (bm.CLOCK, bm.clock(0), {"clock.sec": sec, "clock.nanosec": nsec}),
    ]


@pytest.mark.parametrize("case", range(5))
def test_bulk_cdr_equals_typestore_byte_for_byte(case: int) -> None:
    """Layout.encode rows == typestore.serialize_cdr of the same message; decode inverts both."""
    msgtype, template, columns = _layouts()[case]
    layout = cdr_layout.Layout.of(template, msgtype)
    n = len(next(iter(columns.values())))
    rows = layout.encode(n, columns)
    for i in range(n):
        msg = bm.deserialize(bm.serialize(template, msgtype), msgtype)
        for path, col in columns.items():
            cdr_layout._set_leaf(msg, path, col[i].item())
        assert rows[i].tobytes() == bm.serialize(msg, msgtype)
    decoded = layout.decode(rows)
    for path, col in columns.items():
        np.testing.assert_array_equal(decoded[path], col)
    assert layout.matches(rows).all()


@pytest.mark.parametrize("case", range(5))
def test_matches_is_the_bytewise_shape_test(case: int) -> None:
    """Layout.matches (8-byte words) == its definition, byte by byte: a row matches when every non-field
    byte equals the template's. One row per byte position with that byte flipped, plus an intact row and
    rows one byte short: exactly the flips of non-field bytes fail."""
    msgtype, template, columns = _layouts()[case]
    layout = cdr_layout.Layout.of(template, msgtype)
    base = layout.encode(1, {path: col[:1] for path, col in columns.items()})[0]
    flipped = np.repeat(base[None, :], layout.size + 1, axis=0)
    positions = np.arange(layout.size)
    flipped[positions, positions] ^= RNG.integers(1, 256, layout.size).astype(np.uint8)
    bytewise = np.all(flipped[:, layout.mask] == layout.template[layout.mask], axis=1)
    np.testing.assert_array_equal(layout.matches(flipped), bytewise)
    np.testing.assert_array_equal(bytewise[:-1], ~layout.mask)
    assert bytewise[-1]
    # A view with a row stride other than its width (columns of a wider matrix) gives the same answer.
    wide = np.zeros((flipped.shape[0], layout.size + 3), dtype=np.uint8)
    wide[:, 1 : 1 + layout.size] = flipped
    np.testing.assert_array_equal(layout.matches(wide[:, 1 : 1 + layout.size]), bytewise)
    assert not layout.matches(flipped[:, :-1]).any()


def test_encode_refuses_nan() -> None:
    """A NaN field is a one-line BagError, never written."""
    layout = cdr_layout.Layout.of(bm.accel_stamped(0, 0.0), bm.ACCEL_STAMPED)
    with pytest.raises(BagError, match="NaN"):
        layout.encode(2, {"accel.linear.x": [1.0, np.nan]})


def _chain_streams(n: int) -> tuple[list[Stream], dict[str, str]]:
    """Streams like a 1 kHz recording: clock, joint states, truth, estimate, diagnostics with 2 sizes."""
    ns = bm.seconds_to_ns(np.arange(n) * 1e-3)
    sec, nsec = bm.split_stamp(ns)
    stamp = {"header.stamp.sec": sec, "header.stamp.nanosec": nsec}
    js = cdr_layout.Layout.of(bm.joint_state(0, [bm.PENDULUM_JOINT], [0.0], [0.0]), bm.JOINT_STATE)
    tr = cdr_layout.Layout.of(bm.accel_stamped(0, 0.0), bm.ACCEL_STAMPED)
    est = cdr_layout.Layout.of(
        bm.accel_with_covariance_stamped(0, 0.0, 0.0), bm.ACCEL_WITH_COVARIANCE_STAMPED
    )
    ck = cdr_layout.Layout.of(bm.clock(0), bm.CLOCK)
    theta = RNG.normal(size=n) * 0.1
    diag_ns = ns[::500]
    diag = [
        bm.serialize(
            bm.diagnostic_array(int(t), 0, "accel_estimator", "OK" if i % 2 else "warming up"),
            bm.DIAGNOSTIC_ARRAY,
        )
        for i, t in enumerate(diag_ns)
    ]
    streams = [
        Stream(bm.TOPIC_CLOCK, ns, ck.encode(n, {"clock.sec": sec, "clock.nanosec": nsec})),
        Stream(bm.TOPIC_JOINT_STATES, ns, js.encode(n, {**stamp, "position[0]": theta})),
        Stream(bm.TOPIC_ACCEL_TRUTH, ns, tr.encode(n, {**stamp, "accel.linear.x": np.tan(theta) * 9.8})),
        Stream(bm.TOPIC_ACCEL_ESTIMATE, ns, est.encode(n, {**stamp, "accel.accel.linear.x": theta})),
        Stream(bm.TOPIC_DIAGNOSTICS, diag_ns, diag),
    ]
    return streams, {s.topic: bm.TOPIC_TYPES[s.topic] for s in streams}


def _merged(streams: list[Stream]) -> list[tuple[int, int, str, bytes]]:
    """Messages of all streams in (log time, stream order) order, as per-message writes see them."""
    out = []
    for k, s in enumerate(streams):
        payloads = s.payloads if isinstance(s.payloads, list) else [bytes(r) for r in s.payloads]
        out += [(int(t), k, s.topic, p) for t, p in zip(s.log_time_ns, payloads, strict=True)]
    return sorted(out, key=lambda m: (m[0], m[1]))


def test_bulk_write_equals_plain_rosbags_writer(tmp_path: Path) -> None:
    """write_sorted produces the same .mcap bytes as a plain rosbags Writer fed message by message
    (the header aside: it names the writing library; rosbags writes no topic_type_hash in its channels)."""
    streams, types = _chain_streams(12_000)  # > 1 MiB: several chunks
    custom = {"pendulum_accel.scene": "name: x\n", "pendulum_accel.plan": "rigid/DOP853"}
    writer = BagWriter(
        tmp_path / "a" / "bag", custom_data=custom, flush_interval=None, type_hash_in_channels=False
    )
    with writer as w:
        for topic, msgtype in types.items():
            w.add_topic(topic, msgtype)
        w.write_sorted(streams)
    plain = Writer(tmp_path / "b" / "bag", version=9, storage_plugin=StoragePlugin.MCAP)
    for key, value in {"pendulum_accel.version": "0.1.0", **custom}.items():
        plain.set_custom_data(key, value)
    plain.open()
    conns = {
        t: plain.add_connection(t, m, typestore=bm.TYPESTORE, offered_qos_profiles=[bm.qos_profile()])
        for t, m in types.items()
    }
    for t, _, topic, payload in _merged(streams):
        plain.write(conns[topic], t, payload)
    plain.close()
    ours, theirs = (_mcap_parts(tmp_path / w / "bag" / "bag.mcap") for w in "ab")
    # Schemas, channels, chunks and message indexes: same bytes after the header, which names the library,
    # but for the chunk CRCs, which rosbags leaves 0 and ours fills with crc32 of the chunk's records.
    ours_chunks, theirs_chunks = ours[2][2], theirs[2][2]
    assert isinstance(ours_chunks, tuple) and isinstance(theirs_chunks, tuple)
    ours_crcs, ours_data = _chunk_crcs(ours[0], ours_chunks)
    theirs_crcs, theirs_data = _chunk_crcs(theirs[0], theirs_chunks)
    assert ours_data == theirs_data
    assert set(theirs_crcs) == {0}
    assert ours_crcs == [zlib.crc32(records) for records in _chunk_records(ours[0], ours_chunks)]
    assert len(ours[0]) > 2 * 2**20
    assert ours[3] == f"pendulum_accel-{__version__}" and theirs[3].startswith("rosbags-")
    # The rosbag2 metadata record holds the same YAML document (dumped by libyaml, not ruamel)...
    # but ros_distro: ours names the distribution in use, a plain rosbags Writer writes "rosbags".
    assert _distro_apart(ours[1]) == _distro_apart(theirs[1], "rosbags")
    # ...and the summary indexes the same chunks, channels and counts.
    assert ours[2] == theirs[2]
    assert _distro_apart((tmp_path / "a/bag/metadata.yaml").read_text()) == _distro_apart(
        (tmp_path / "b/bag/metadata.yaml").read_text(), "rosbags"
    )


def _chunk_crcs(data: bytes, chunks: tuple[tuple[int, int, int], ...]) -> tuple[list[int], bytes]:
    """(uncompressed_crc of each chunk at (offset, length, start time) in ``data``, data with them 0)."""
    out = bytearray(data)
    crcs = []
    for offset, _, _ in chunks:
        at = offset + 9 + 24  # opcode, record length, then message start/end times and uncompressed size
        crcs.append(int.from_bytes(out[at : at + 4], "little"))
        out[at : at + 4] = bytes(4)
    return crcs, bytes(out)


def _chunk_records(data: bytes, chunks: tuple[tuple[int, int, int], ...]) -> list[bytes]:
    """Records of each uncompressed chunk at (offset, length, start time) in ``data``."""
    out = []
    for offset, length, _ in chunks:
        compression_length = int.from_bytes(data[offset + 37 : offset + 41], "little")
        records_at = offset + 41 + compression_length + 8
        out.append(data[records_at : offset + length])
    return out


def _distro_apart(text: str, distro: str | None = None) -> dict[str, Any]:
    """The rosbag2 metadata document without its ros_distro, after checking it is ``distro`` (default:
    the distribution in use, pendulum_accel.bag.metadata.ros_distro())."""
    from pendulum_accel.bag.metadata import ros_distro

    document: dict[str, Any] = yaml.safe_load(text)
    info = document.get("rosbag2_bagfile_information", document)  # metadata.yaml nests it, the record not
    assert info.pop("ros_distro") == (distro or ros_distro())
    return document


def _mcap_parts(path: Path) -> tuple[bytes, str, tuple[object, ...], str]:
    """(bytes between the header and the metadata record, its serialized_metadata, summary statistics
    and indexes with offsets counted from the header's end, the header's library field)."""
    with path.open("rb") as handle:
        reader = make_reader(handle)
        summary = reader.get_summary()
        library = reader.get_header().library
    assert summary is not None and summary.statistics is not None
    start = summary.metadata_indexes[0].offset
    data = path.read_bytes()
    header_end = 8 + 9 + int.from_bytes(data[9:17], "little")  # magic, then opcode + length + body
    with path.open("rb") as handle:
        meta = next(make_reader(handle).iter_metadata())
    stats = summary.statistics
    chunks = tuple(
        (c.chunk_start_offset - header_end, c.chunk_length, c.message_start_time)
        for c in summary.chunk_indexes
    )
    counts = tuple(sorted(stats.channel_message_counts.items()))
    parts = (stats.message_count, counts, chunks)
    return data[header_end:start], meta.metadata["serialized_metadata"], parts, library


def test_reader_matches_rosbags_deserializer(tmp_path: Path) -> None:
    """Bulk-decoded columns equal rosbags Reader + deserialize_cdr field by field; counts, custom_data."""
    streams, types = _chain_streams(3000)
    with BagWriter(tmp_path / "bag", custom_data={"pendulum_accel.plan": "p"}) as w:
        for topic, msgtype in types.items():
            w.add_topic(topic, msgtype)
        w.write_sorted(streams)
        counts = w.counts
    bag = read_bag(tmp_path / "bag")
    assert bag.problem is None and bag.complete
    assert {n: t.count for n, t in bag.topics.items()} == counts
    assert bag.custom_data["pendulum_accel.plan"] == "p"
    js = bag.decode(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)
    est = bag.decode(bm.TOPIC_ACCEL_ESTIMATE, bm.ACCEL_WITH_COVARIANCE_STAMPED)
    ref_theta, ref_stamp, ref_est = [], [], []
    with Reader(tmp_path / "bag") as reader:
        for conn, _, raw in reader.messages():
            msg: Any = bm.TYPESTORE.deserialize_cdr(raw, conn.msgtype)
            if conn.topic == bm.TOPIC_JOINT_STATES:
                ref_theta.append(msg.position[0])
                ref_stamp.append(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)
            elif conn.topic == bm.TOPIC_ACCEL_ESTIMATE:
                ref_est.append(msg.accel.accel.linear.x)
    np.testing.assert_array_equal(js["position[0]"], ref_theta)
    # sec + nanosec·1e-9 both ways, maybe grouped differently: ≤ 2 roundings of t (< 10 s here: 3.6e-15)
    np.testing.assert_allclose(js.stamp, ref_stamp, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(est["accel.accel.linear.x"], ref_est)
    # The variable-size diagnostics fall back to shape groups; iter_raw is time-ordered.
    diag = bag.decode(bm.TOPIC_DIAGNOSTICS)
    assert len(diag) == counts[bm.TOPIC_DIAGNOSTICS]
    times = [t for _, t, _ in bag.iter_raw()]
    assert times == sorted(times) and len(times) == sum(counts.values())


def test_raw_payloads_equal_rosbags_in_any_order_of_use(tmp_path: Path) -> None:
    """Payloads left in their chunk until asked for: raw() equals rosbags' bytes per topic whether the
    topic was decoded first or not, and decoding after raw() gives the same columns."""
    streams, types = _chain_streams(3000)
    with BagWriter(tmp_path / "bag") as w:
        for topic, msgtype in types.items():
            w.add_topic(topic, msgtype)
        w.write_sorted(streams)
    expected: dict[str, list[tuple[int, bytes]]] = {}
    with Reader(tmp_path / "bag") as reader:
        for conn, log_time, raw in reader.messages():
            expected.setdefault(conn.topic, []).append((log_time, bytes(raw)))
    decoded_first, raw_first = read_bag(tmp_path / "bag"), read_bag(tmp_path / "bag")
    before = decoded_first.decode(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)
    for bag in (decoded_first, raw_first):
        for topic, messages in expected.items():
            times, payloads = bag.raw(topic)
            assert times.tolist() == [t for t, _ in messages]
            assert payloads == [d for _, d in messages]
    after = raw_first.decode(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)
    for path, column in before.fields.items():
        np.testing.assert_array_equal(after[path], column)


def test_never_overwrites(tmp_path: Path) -> None:
    """An existing bag is a BagError unless overwrite=True; a non-bag folder is never deleted."""
    BagWriter(tmp_path / "bag").close()
    with pytest.raises(BagError, match="exists already"):
        BagWriter(tmp_path / "bag")
    BagWriter(tmp_path / "bag", overwrite=True).close()
    (tmp_path / "notes").mkdir()
    (tmp_path / "notes" / "thesis.tex").write_text("precious")
    with pytest.raises(BagError, match="not a bag directory"):
        BagWriter(tmp_path / "notes", overwrite=True)
    assert (tmp_path / "notes" / "thesis.tex").read_text() == "precious"


def _write_chain_bag(path: Path, n: int = 6000) -> dict[str, int]:
    """A multi-chunk bag of the chain's topics; returns its counts."""
    streams, types = _chain_streams(n)
    with BagWriter(path, custom_data={"pendulum_accel.plan": "plan line"}) as w:
        for topic, msgtype in types.items():
            w.add_topic(topic, msgtype)
        w.write_sorted(streams)
        return w.counts


def test_truncated_bag_is_salvaged_and_repaired(tmp_path: Path) -> None:
    """Cut the file mid-way: clear BagError when strict, the complete chunks before the cut otherwise."""
    counts = _write_chain_bag(tmp_path / "bag")
    mcap = tmp_path / "bag" / "bag.mcap"
    data = mcap.read_bytes()
    mcap.write_bytes(data[: int(len(data) * 0.6)])
    with pytest.raises(BagError, match="truncated"):
        read_bag(tmp_path / "bag", salvage=False)
    bag = read_bag(tmp_path / "bag")
    assert bag.problem is not None and "truncated" in bag.problem
    kept = bag.topics[bm.TOPIC_JOINT_STATES].count
    assert 0.3 * counts[bm.TOPIC_JOINT_STATES] < kept < counts[bm.TOPIC_JOINT_STATES]
    js = bag.decode(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)
    np.testing.assert_allclose(js.stamp, np.arange(kept) * 1e-3, atol=1e-9)  # a prefix, in order
    result = repair_bag(tmp_path / "bag")
    assert result.rewritten and result.counts[bm.TOPIC_JOINT_STATES] == kept
    assert len(result.backups) == 1 and result.backups[0].exists()
    assert result.backups[0].name == "bag.mcap.damaged"  # the cut-off file
    fixed = read_bag(tmp_path / "bag", salvage=False)
    assert fixed.custom_data["pendulum_accel.plan"] == "plan line"
    with Reader(tmp_path / "bag") as reader:
        assert reader.message_count == fixed.message_count
        assert sum(1 for _ in reader.messages()) == fixed.message_count
    assert not repair_bag(tmp_path / "bag").rewritten


def test_corrupt_bytes_skip_only_the_damaged_chunk(tmp_path: Path) -> None:
    """Garbage over the middle of the file: the records before and after it are kept, the problem named."""
    _write_chain_bag(tmp_path / "bag")
    mcap = tmp_path / "bag" / "bag.mcap"
    data = bytearray(mcap.read_bytes())
    middle = len(data) // 2
    data[middle : middle + 4096] = b"\xff" * 4096
    mcap.write_bytes(bytes(data))
    bag = read_bag(tmp_path / "bag")
    assert bag.problem is not None and "damaged chunk" in bag.problem
    js = bag.decode(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)
    assert len(js) > 0
    ms = np.round(js.stamp * 1e3)
    np.testing.assert_allclose(js.stamp, ms * 1e-3, atol=1e-9)  # on the sample grid, in order
    assert np.all(np.diff(ms) > 0)
    assert ms[-1] > middle / len(data) * ms.size  # messages after the damage are kept


def test_not_a_bag_and_wrong_type(tmp_path: Path) -> None:
    """Not an MCAP file, a missing path, a topic of another type: one-line BagErrors naming the cause."""
    (tmp_path / "junk").mkdir()
    (tmp_path / "junk" / "junk.mcap").write_bytes(b"this is not an mcap file")
    with pytest.raises(BagError, match="not an MCAP file"):
        read_bag(tmp_path / "junk")
    with pytest.raises(BagError, match="does not exist"):
        read_bag(tmp_path / "nothing")
    _write_chain_bag(tmp_path / "bag", n=100)
    bag = read_bag(tmp_path / "bag")
    with pytest.raises(
        BagError, match=r"/car/accel/truth .* has type geometry_msgs/msg/AccelStamped, expected"
    ):
        bag.decode(bm.TOPIC_ACCEL_TRUTH, bm.JOINT_STATE)
    with pytest.raises(BagError, match="has no topic /nope"):
        bag.decode("/nope")
    with pytest.raises(BagError, match="no field 'effort\\[0\\]'"):
        bag.decode(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE, fields=["effort[0]"])


def without_crcs(data: bytearray) -> bytearray:
    """The MCAP file ``data`` with its chunk and data section CRCs set to 0 ("not computed", as rosbags
    writes them), walking its top-level records."""
    pos = 8
    while pos + 9 <= len(data):
        op, length = data[pos], int.from_bytes(data[pos + 1 : pos + 9], "little")
        if op == 0x06:  # Chunk: start, end, uncompressed size, then the CRC
            data[pos + 9 + 24 : pos + 9 + 28] = bytes(4)
        elif op == 0x0F:  # DataEnd: the data section CRC
            data[pos + 9 : pos + 13] = bytes(4)
        pos += 9 + length
    return data


def test_damaged_payload_is_skipped_not_fatal(tmp_path: Path) -> None:
    """A message whose CDR no longer decodes is dropped from its topic and named in bag.problem, in a
    file without CRCs (with them, the chunk is reported damaged: test_bag_integrity.py)."""
    counts = _write_chain_bag(tmp_path / "bag", n=500)
    mcap = tmp_path / "bag" / "bag.mcap"
    data = bytearray(mcap.read_bytes())
    name = bm.PENDULUM_JOINT.encode()
    at = -1
    for _ in range(3):  # the third joint state's name: break its string length
        at = data.index(name, at + 1)
    data[at - 4 : at] = b"\xff\xff\xff\x7f"
    mcap.write_bytes(bytes(without_crcs(data)))
    bag = read_bag(tmp_path / "bag")
    js = bag.decode(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)
    assert len(js) == counts[bm.TOPIC_JOINT_STATES] - 1
    assert bag.problem is not None and "skipped 1 damaged" in bag.problem
    np.testing.assert_allclose(np.delete(np.arange(500) * 1e-3, 2), js.stamp, atol=1e-9)


def test_layout_reader_and_writer_per_message() -> None:
    """reader: our shape's fields by struct, None for any other shape; writer: the serializer's bytes."""
    joint = cdr_layout.Layout.of(bm.joint_state(0, [bm.PENDULUM_JOINT], [0.0], [0.0]), bm.JOINT_STATE)
    read = joint.reader(["header.stamp.sec", "header.stamp.nanosec", "position[0]"])
    ours = bm.serialize(bm.joint_state(2_000_000_007, [bm.PENDULUM_JOINT], [-0.25], [1.5]), bm.JOINT_STATE)
    assert read(ours) == (2, 7, -0.25)
    nan = read(bm.serialize(bm.joint_state(0, [bm.PENDULUM_JOINT], [float("nan")], [0.0]), bm.JOINT_STATE))
    assert nan is not None and np.isnan(nan[2])
    others = [
        bm.joint_state(0, ["other", bm.PENDULUM_JOINT], [0.1, 0.2], [0.0, 0.0]),  # two joints
        bm.joint_state(0, ["pendulum_jnt"], [0.1], [0.0]),  # another name, same length
        bm.joint_state(0, [bm.PENDULUM_JOINT], [0.1], []),  # no velocity
    ]
    for msg in others:
        assert read(bm.serialize(msg, bm.JOINT_STATE)) is None
    estimate = cdr_layout.Layout.of(
        bm.accel_with_covariance_stamped(0, 0.0, 0.0), bm.ACCEL_WITH_COVARIANCE_STAMPED
    )
    write = estimate.writer(
        ["header.stamp.sec", "header.stamp.nanosec", "accel.accel.linear.x", "accel.covariance[0]"]
    )
    expected = bm.accel_with_covariance_stamped(3_000_000_009, 2.5, 0.04)
    assert write(3, 9, 2.5, 0.04) == bm.serialize(expected, bm.ACCEL_WITH_COVARIANCE_STAMPED)
    with pytest.raises(BagError, match=r"no numeric field 'accel\.linear\.y'"):
        estimate.writer(["accel.linear.y"])


def test_a_stored_topic_map_names_the_chain_topics_of_a_remapped_bag(tmp_path: Path) -> None:
    """The recorder's topic map in custom_data: read_bag and the player's stored_choice (metadata only)
    find the remapped angles by it; a malformed map is ignored, leaving the names to speak."""
    from pendulum_accel.bag.reader import stored_choice

    def bag_with(name: str, custom: dict[str, str]) -> Path:
        path = tmp_path / name
        with BagWriter(path, custom_data=custom) as writer:
            writer.add_topic("/angle", bm.JOINT_STATE)
            writer.write(
                "/angle",
                0,
                bm.serialize(bm.joint_state(0, [bm.PENDULUM_JOINT], [0.1], [0.0]), bm.JOINT_STATE),
            )
        return path

    mapped = bag_with("mapped", {bm.CUSTOM_TOPICS: '{"pendulum/joint_states": "/angle"}'})
    assert read_bag(mapped).find_topic(bm.JOINT_STATES) == "/angle"
    assert bm.find_topic(["/angle"], bm.JOINT_STATES, stored_choice(mapped)) == "/angle"
    for text in ("not json", "[1, 2]", '{"pendulum/joint_states": 3, "nonsense": "/angle"}'):
        broken = bag_with(f"broken{len(text)}", {bm.CUSTOM_TOPICS: text})
        assert read_bag(broken).find_topic(bm.JOINT_STATES) is None, text
