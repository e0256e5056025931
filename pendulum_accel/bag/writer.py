"""rosbag2 bag writer (metadata.yaml v9 + one MCAP file, ros2 profile, cdr) that survives SIGKILL.

Built on ``rosbags.rosbag2.Writer`` with the MCAP storage plugin. That plugin keeps the open chunk
(up to 1 MiB) in memory, so a killed process would lose all of it: :class:`BagWriter` closes the
chunk and flushes the file at least every ``flush_interval`` seconds of wall time, and writes a
provisional metadata.yaml (topics, QoS, custom_data) before the first message, which ``close``
replaces with the final one. ``write_sorted`` is the bulk path for whole recordings (``generate``):
it lays out the MCAP message records of many messages at once with numpy and hands them to the same
storage object, producing the very bytes per-message ``write`` calls would (test_bag_io.py compares
the file with a plain rosbags Writer's). Two storage steps are replaced by equivalents: the message
index is packed by numpy (``_close_chunk``), and the metadata YAML is dumped by libyaml.
"""

from __future__ import annotations

import shutil
import time
import types
from collections import defaultdict
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from io import BytesIO
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from numpy.lib.stride_tricks import as_strided
from numpy.typing import NDArray
from rosbags.interfaces import Connection, Qos
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer, WriterError
from rosbags.rosbag2.metadata import dump_qos_v9
from rosbags.rosbag2.storage_mcap import (
    McapWriter,
    PendingChunk,
    write_record,
    write_string,
    write_uint16,
    write_uint32,
    write_uint64,
)

from pendulum_accel import __version__
from pendulum_accel.bag.messages import TYPESTORE, qos_profile
from pendulum_accel.errors import BagError

CUSTOM_SCENE = "pendulum_accel.scene"
CUSTOM_PLAN = "pendulum_accel.plan"
CUSTOM_VERSION = "pendulum_accel.version"

# rosbags' MCAP storage closes a chunk once its buffer exceeds this many bytes; the bulk path
# splits chunks at the same place so both paths produce identical files.
_ROSBAGS_CHUNK_BYTES = 2**20
_MCAP_MESSAGE_OPCODE = 0x05
_MESSAGE_HEADER = np.dtype(
    [("op", "u1"), ("length", "<u8"), ("channel", "<u2"), ("sequence", "<u4"), ("log", "<u8"), ("pub", "<u8")]
)


@dataclass(frozen=True)
class Stream:
    """Messages of one topic for ``write_sorted``: log times (ns) and CDR payloads (rows or bytes)."""

    topic: str
    log_time_ns: NDArray[np.int64]
    payloads: NDArray[np.uint8] | Sequence[bytes]


def _is_bag_dir(path: Path) -> bool:
    """True for an empty directory or one holding only rosbag2 files (metadata.yaml, *.mcap, *.db3)."""
    return path.is_dir() and all(
        p.name == "metadata.yaml" or p.suffix in {".mcap", ".db3", ".damaged", ".tmp"} for p in path.iterdir()
    )


def prepare_output(path: Path, overwrite: bool) -> None:
    """Refuse an existing ``path`` unless ``overwrite``; then delete it only if it holds nothing but a bag."""
    if not path.exists() and not path.is_symlink():
        return
    if not overwrite:
        raise BagError(f"{path} exists already; pass --overwrite to replace it")
    if not _is_bag_dir(path):
        raise BagError(f"{path} exists and is not a bag directory; refusing to delete it")
    shutil.rmtree(path)


class BagWriter:
    """Write a rosbag2 bag; at most ``flush_interval`` s of messages sit in memory at any time.

    ``add_topic(name, msgtype, qos)`` then ``write(topic, log_time_ns, cdr)`` (or ``write_sorted``
    for whole recordings), ``close()``. ``counts`` maps topic -> messages written.
    """

    def __init__(
        self,
        path: Path | str,
        *,
        overwrite: bool = False,
        custom_data: Mapping[str, str] | None = None,
        flush_interval: float | None = 0.5,
        compression: str | None = None,
    ) -> None:
        """Create the bag directory ``path``; BagError if it exists and ``overwrite`` is false."""
        self.path = Path(path)
        if flush_interval is not None and not flush_interval > 0.0:
            raise BagError(f"flush_interval must be > 0 s, got {flush_interval!r}")
        if compression not in (None, "", "none", "zstd"):
            raise BagError(f"unknown compression {compression!r}; use 'zstd' or none")
        prepare_output(self.path, overwrite)
        self.flush_interval = flush_interval
        self._writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        if compression == "zstd":
            self._writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        data = {CUSTOM_VERSION: __version__, **dict(custom_data or {})}
        for key, value in data.items():
            self._writer.set_custom_data(key, str(value))
        try:
            self._writer.open()
        except (WriterError, OSError) as err:
            raise BagError(f"cannot create bag {self.path}: {err}") from None
        storage = self._storage_unchecked()
        storage.close_chunk = types.MethodType(_close_chunk, storage)  # type: ignore[method-assign]
        self._connections: dict[str, Connection] = {}
        self._last_flush = time.monotonic()
        self._closed = False
        self._metadata_stale = True
        self._write_provisional_metadata()

    def _storage_unchecked(self) -> McapWriter:
        """The rosbags MCAP storage object, or BagError once closed."""
        storage = self._writer.storage
        if storage is None:
            raise BagError(f"bag {self.path} is closed")
        assert isinstance(storage, McapWriter)
        return storage

    @property
    def _storage(self) -> McapWriter:
        """The rosbags MCAP storage object (open while the bag is)."""
        if self._closed:
            raise BagError(f"bag {self.path} is closed")
        return self._storage_unchecked()

    @property
    def mcap_path(self) -> Path:
        """Path of the .mcap file inside the bag directory."""
        return self.path / f"{self.path.name}.mcap"

    @property
    def counts(self) -> dict[str, int]:
        """Messages written so far, per topic."""
        return {topic: self._writer.counts[conn.id] for topic, conn in self._connections.items()}

    def add_topic(self, name: str, msgtype: str, qos: Qos | Sequence[Qos] | None = None) -> None:
        """Register topic ``name`` of ``msgtype`` with its offered QoS (default: reliable, depth 1000)."""
        if name in self._connections:
            raise BagError(f"topic {name} is already in bag {self.path}")
        if msgtype not in TYPESTORE.types:
            raise BagError(f"unknown message type {msgtype!r} for topic {name}")
        profiles = [qos_profile()] if qos is None else ([qos] if isinstance(qos, Qos) else list(qos))
        self._storage  # noqa: B018 - raises when closed
        self._connections[name] = self._writer.add_connection(
            name, msgtype, typestore=TYPESTORE, offered_qos_profiles=profiles
        )
        self._metadata_stale = True

    def _connection(self, topic: str) -> Connection:
        """Connection of a registered topic; BagError naming it otherwise."""
        try:
            return self._connections[topic]
        except KeyError:
            raise BagError(f"topic {topic} was not added to bag {self.path}") from None

    def write(self, topic: str, log_time_ns: int, data: bytes | memoryview) -> None:
        """Append one CDR message at log time ``log_time_ns``; flushes when the flush interval is due."""
        if log_time_ns < 0:
            raise BagError(f"log time must be >= 0 ns, got {log_time_ns}")
        self._storage  # noqa: B018 - raises when closed
        if self._metadata_stale:
            self._write_provisional_metadata()
        self._writer.write(self._connection(topic), int(log_time_ns), data)
        if self.flush_interval is not None and time.monotonic() - self._last_flush >= self.flush_interval:
            self.flush()

    def flush_due(self) -> bool:
        """True when the last flush is older than ``flush_interval`` (never without an interval)."""
        return self.flush_interval is not None and time.monotonic() - self._last_flush >= self.flush_interval

    def flush(self) -> None:
        """Close the open MCAP chunk (if it holds messages) and push the file to the OS: SIGKILL-safe."""
        storage = self._storage
        if self._metadata_stale:
            self._write_provisional_metadata()
        if storage.chunk.msgs:
            storage.close_chunk()
        storage.bio.flush()
        self._last_flush = time.monotonic()

    def write_sorted(self, streams: Sequence[Stream]) -> None:
        """Write many topics' messages merged by log time (ties: stream order), in bulk.

        The same file results as ``write`` per message in that order (flushing aside): records are
        laid out with numpy, chunks split where the rosbags storage would split them.
        """
        storage = self._storage
        if self._metadata_stale:
            self._write_provisional_metadata()
        groups = [g for s in streams for g in _groups(s, self._connection(s.topic))]
        if not groups:
            return
        conns = [g[0] for g in groups]
        rows_list = [g[1] for g in groups]
        times = [g[2] for g in groups]
        all_t = np.concatenate(times)
        which = np.concatenate([np.full(t.size, i, dtype=np.int64) for i, t in enumerate(times)])
        index = np.concatenate([np.arange(t.size) for t in times])
        order = np.lexsort((which, all_t))
        all_t, which, index = all_t[order], which[order], index[order]
        sizes = np.array([_MESSAGE_HEADER.itemsize + rows.shape[1] for rows in rows_list], dtype=np.int64)
        ends = np.cumsum(sizes[which])
        start = 0
        n = all_t.size
        while start < n:
            # rosbags closes the chunk after the first message that takes it past 1 MiB.
            room = _ROSBAGS_CHUNK_BYTES - storage.chunk.bio.tell() + (int(ends[start - 1]) if start else 0)
            stop = min(n, int(np.searchsorted(ends, room, side="right")) + 1)
            stop = max(stop, start + 1)
            self._append_records(
                storage, conns, rows_list, all_t[start:stop], which[start:stop], index[start:stop]
            )
            if storage.chunk.bio.tell() > _ROSBAGS_CHUNK_BYTES:
                storage.close_chunk()
            start = stop
        if self.flush_interval is not None:
            self.flush()

    def _append_records(
        self,
        storage: McapWriter,
        conns: Sequence[Connection],
        rows_list: Sequence[NDArray[np.uint8]],
        t: NDArray[np.int64],
        which: NDArray[np.int64],
        index: NDArray[np.int64],
    ) -> None:
        """Append MCAP message records (opcode, length, channel, sequence 0, log = publish time, data)."""
        head_size = _MESSAGE_HEADER.itemsize
        widths = np.array([head_size + rows.shape[1] for rows in rows_list], dtype=np.int64)
        rec_size = widths[which]
        n = t.size
        head = np.zeros(n, dtype=_MESSAGE_HEADER)
        head["op"] = _MCAP_MESSAGE_OPCODE
        head["length"] = rec_size - 9
        head["channel"] = np.array([c.id for c in conns], dtype=np.uint16)[which]
        head["log"] = t
        head["pub"] = t
        local = np.concatenate(([0], np.cumsum(rec_size)[:-1])).astype(np.int64)
        buf = np.empty(int(rec_size.sum()), dtype=np.uint8)
        _scatter_rows(buf, local, head.view(np.uint8).reshape(n, head_size))
        for i, rows in enumerate(rows_list):
            sel = np.flatnonzero(which == i)
            if sel.size and rows.shape[1]:
                lo, hi = int(index[sel[0]]), int(index[sel[-1]])
                # A stream's messages arrive in order, so its rows are usually one slice: no copy.
                part = rows[lo : hi + 1] if hi - lo + 1 == sel.size else rows[index[sel]]
                _scatter_rows(buf, local[sel] + head_size, part)
        offsets = storage.chunk.bio.tell() + local
        cids = head["channel"].astype(np.int64)
        # Message-index entries per channel in file order, new channels in order of first
        # appearance: what per-message writes would have appended.
        present, first = np.unique(cids, return_index=True)
        for cid in present[np.argsort(first)].tolist():
            sel = np.flatnonzero(cids == cid)
            block = np.empty((sel.size, 2), dtype=np.uint64)
            block[:, 0] = t[sel]
            block[:, 1] = offsets[sel]
            storage.chunk.msgs[cid].append(block)  # type: ignore[arg-type]
            storage.channel_stats[cid] += int(sel.size)
            self._writer.counts[cid] += int(sel.size)
        storage.chunk.bio.write(buf.data)
        t_min, t_max = int(t.min()), int(t.max())
        storage.chunk.message_start_time = min(t_min, storage.chunk.message_start_time)
        storage.chunk.message_end_time = max(t_max, storage.chunk.message_end_time)
        storage.message_start_time = min(t_min, storage.message_start_time)
        storage.message_end_time = max(t_max, storage.message_end_time)
        self._writer.min_timestamp = min(t_min, self._writer.min_timestamp)
        self._writer.max_timestamp = max(t_max, self._writer.max_timestamp)

    def _write_provisional_metadata(self) -> None:
        """metadata.yaml as of now (counts 0): keeps topics and custom_data if the process dies.

        Written at open and again before the first message after topics were added.
        """
        self._metadata_stale = False
        topics = [
            TopicRecord(c.topic, c.msgtype, c.digest, _qos_of(c), 0) for c in self._connections.values()
        ]
        doc = metadata_document(
            mcap_name=self.mcap_path.name,
            topics=topics,
            start_ns=0,
            end_ns=0,
            custom_data=dict(self._writer.custom_data),
        )
        write_metadata(self.path, doc)

    def close(self) -> dict[str, int]:
        """Write the MCAP summary and the final metadata.yaml; returns the per-topic counts."""
        if self._closed:
            return self.counts
        counts = self.counts
        storage = self._storage
        writer = self._writer
        count = sum(writer.counts.values())
        start = writer.min_timestamp if count else 0
        end = writer.max_timestamp if count else 0
        topics = [
            TopicRecord(c.topic, c.msgtype, c.digest, _qos_of(c), writer.counts[c.id])
            for c in self._connections.values()
        ]
        doc = metadata_document(
            mcap_name=self.mcap_path.name,
            topics=topics,
            start_ns=start,
            end_ns=end,
            custom_data=dict(writer.custom_data),
        )
        # What rosbags' Writer.close does, with libyaml instead of ruamel (10x faster dumps).
        storage.close(9, dump_yaml(doc["rosbag2_bagfile_information"]).strip())
        writer.storage = None
        write_metadata(self.path, doc)
        self._closed = True
        return counts

    def __enter__(self) -> BagWriter:
        """Context manager: the bag is closed (summary + metadata) on exit, even after an error."""
        return self

    def __exit__(self, *exc: object) -> None:
        """close()."""
        self.close()


def _scatter_rows(buf: NDArray[np.uint8], starts: NDArray[np.int64], rows: NDArray[np.uint8]) -> None:
    """buf[s : s + w] = row for each start s and (n, w) row: row copies through a window view."""
    width = rows.shape[1]
    windows = as_strided(buf, shape=(buf.size - width + 1, width), strides=(1, 1), writeable=True)
    windows[starts] = rows


def _close_chunk(self: McapWriter) -> None:
    """rosbags 0.11.9 ``McapWriter.close_chunk`` with the message-index entries packed by numpy.

    Same records, same bytes (test_bag_writer compares whole files with a plain rosbags Writer);
    the original packs two uint64 per message in Python, which dominated bulk writing.
    """
    rec = BytesIO()
    write_uint64(rec, self.chunk.message_start_time)
    write_uint64(rec, self.chunk.message_end_time)
    write_uint64(rec, self.chunk.bio.tell())
    write_uint32(rec, 0)
    compressed = self.compressor(self.chunk.bio.getvalue())
    write_string(rec, self.compression)
    write_uint64(rec, len(compressed))
    rec.write(compressed)
    chunk_start = self.bio.tell()
    write_record(self.bio, 0x06, rec)
    chunk_end = self.bio.tell()
    offsets: list[tuple[int, int]] = []
    for cid, msgs in self.chunk.msgs.items():
        offsets.append((cid, self.bio.tell()))
        entries = _index_entries(msgs)
        rec = BytesIO()
        write_uint16(rec, cid)
        write_uint32(rec, entries.shape[0] * 16)
        rec.write(entries.tobytes())
        write_record(self.bio, 0x07, rec)
    rec = BytesIO()
    write_uint64(rec, self.chunk.message_start_time)
    write_uint64(rec, self.chunk.message_end_time)
    write_uint64(rec, chunk_start)
    write_uint64(rec, chunk_end - chunk_start)
    write_uint32(rec, len(offsets) * 10)
    for cid, offset in offsets:
        write_uint16(rec, cid)
        write_uint64(rec, offset)
    write_uint64(rec, self.bio.tell() - chunk_end)
    write_string(rec, self.compression)
    write_uint64(rec, len(compressed))
    write_uint64(rec, self.chunk.bio.tell())
    self.chunks.append(rec)
    self.chunk = PendingChunk(2**63 - 1, 0, BytesIO(), defaultdict(list))


def _index_entries(msgs: Sequence[Any]) -> NDArray[np.uint64]:
    """(n, 2) uint64 (log time, offset) from per-message tuples and bulk (k, 2) blocks, in order."""
    parts: list[NDArray[np.uint64]] = []
    run: list[tuple[int, int]] = []
    for item in msgs:
        if isinstance(item, np.ndarray):
            if run:
                parts.append(np.asarray(run, dtype=np.uint64))
                run = []
            parts.append(item)
        else:
            run.append(item)
    if run:
        parts.append(np.asarray(run, dtype=np.uint64))
    return np.concatenate(parts).astype("<u8") if parts else np.zeros((0, 2), dtype="<u8")


_Group = tuple[Connection, NDArray[np.uint8], NDArray[np.int64]]


def _groups(stream: Stream, conn: Connection) -> list[_Group]:
    """(connection, (n, size) payload rows, log times) per payload size of one stream."""
    t = np.asarray(stream.log_time_ns, dtype=np.int64)
    payloads: Any = stream.payloads
    count = payloads.shape[0] if isinstance(payloads, np.ndarray) else len(payloads)
    if t.ndim != 1 or t.size != count:
        raise BagError(f"topic {stream.topic}: {t.size} log times for {count} payloads")
    if t.size and t.min() < 0:
        raise BagError(f"topic {stream.topic}: log times must be >= 0 ns")
    if isinstance(payloads, np.ndarray):
        if payloads.dtype != np.uint8 or payloads.ndim != 2:
            raise BagError(f"topic {stream.topic}: payload rows must be a 2-D uint8 array")
        return [(conn, payloads, t)] if count else []
    groups = []
    lengths = np.fromiter((len(p) for p in payloads), dtype=np.int64, count=count)
    for size in np.unique(lengths):
        sel = np.flatnonzero(lengths == size)
        rows = np.frombuffer(b"".join(payloads[i] for i in sel), dtype=np.uint8).reshape(sel.size, int(size))
        groups.append((conn, rows, t[sel]))
    return groups


@dataclass(frozen=True)
class TopicRecord:
    """One topic as metadata.yaml lists it: name, type, type hash (RIHS01), offered QoS, count."""

    name: str
    msgtype: str
    type_hash: str
    qos: list[Qos]
    count: int


def _qos_of(conn: Connection) -> list[Qos]:
    """Offered QoS profiles stored with a rosbags connection."""
    return list(getattr(conn.ext, "offered_qos_profiles", []))


def metadata_document(
    *,
    mcap_name: str,
    topics: Sequence[TopicRecord],
    start_ns: int,
    end_ns: int,
    custom_data: Mapping[str, str],
) -> dict[str, Any]:
    """rosbag2 metadata.yaml (version 9, mcap storage) for one file, laid out as rosbags writes it."""
    duration = max(0, end_ns - start_ns)
    count = sum(t.count for t in topics)
    return {
        "rosbag2_bagfile_information": {
            "version": 9,
            "storage_identifier": "mcap",
            "relative_file_paths": [mcap_name],
            "duration": {"nanoseconds": duration},
            "starting_time": {"nanoseconds_since_epoch": start_ns},
            "message_count": count,
            "topics_with_message_count": [
                {
                    "topic_metadata": {
                        "name": t.name,
                        "type": t.msgtype,
                        "serialization_format": "cdr",
                        "offered_qos_profiles": dump_qos_v9(t.qos),
                        "type_description_hash": t.type_hash,
                    },
                    "message_count": t.count,
                }
                for t in topics
            ],
            # rosbags/rosbag2 leave both empty for chunk-level (storage) compression.
            "compression_format": "",
            "compression_mode": "",
            "files": [
                {
                    "path": mcap_name,
                    "starting_time": {"nanoseconds_since_epoch": start_ns},
                    "duration": {"nanoseconds": duration},
                    "message_count": count,
                }
            ],
            "custom_data": dict(custom_data) or None,
            "ros_distro": "rosbags",
        }
    }


def write_metadata(bag_dir: Path, document: Mapping[str, Any]) -> None:
    """Atomically replace bag_dir/metadata.yaml with ``document`` (write to .tmp, rename)."""
    tmp = bag_dir / "metadata.yaml.tmp"
    tmp.write_text(dump_yaml(document), encoding="utf8")
    tmp.replace(bag_dir / "metadata.yaml")


def dump_yaml(document: Mapping[str, Any]) -> str:
    """Block-style YAML in insertion order (libyaml's safe dumper when available)."""
    dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
    text: str = yaml.dump(dict(document), Dumper=dumper, default_flow_style=False, sort_keys=False)
    return text
