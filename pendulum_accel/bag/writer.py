"""rosbag2 bag writer (metadata.yaml v9 + one MCAP file, ros2 profile, cdr) that survives SIGKILL.

The MCAP file is written by :class:`~pendulum_accel.bag.mcap_file.McapFile` in the layout rosbag2's
writers use, with message definitions and RIHS01 type hashes from the rosbags typestore's public API.
:class:`BagWriter` closes the open chunk and flushes the file at least every ``flush_interval``
seconds of wall time, and writes a provisional metadata.yaml (topics, QoS, custom_data) before the
first message, which ``close`` replaces with the final one. ``write_sorted`` is the bulk path for
whole recordings (``generate``): it lays out the MCAP message records of many messages at once with
numpy, producing the very bytes per-message ``write`` calls would (test_bag_io.py compares the file
with a plain rosbags Writer's).
"""

from __future__ import annotations

import shutil
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.lib.stride_tricks import as_strided
from numpy.typing import NDArray
from rosbags.interfaces import Qos

from pendulum_accel import __version__
from pendulum_accel.bag.errors import WriterError
from pendulum_accel.bag.lock import LOCK_NAME, BagLock, holder, writer_of
from pendulum_accel.bag.mcap_file import CHUNK_BYTES, MESSAGE_HEADER, OP_MESSAGE, IndexEntries, McapFile
from pendulum_accel.bag.messages import TYPESTORE, qos_profile
from pendulum_accel.bag.metadata import TopicRecord, dump_yaml, metadata_document, qos_text, write_metadata

CUSTOM_SCENE = "pendulum_accel.scene"
CUSTOM_PLAN = "pendulum_accel.plan"
CUSTOM_VERSION = "pendulum_accel.version"
CUSTOM_ESTIMATOR = "pendulum_accel.estimator"
"""custom_data key: the estimator method that produced /car/accel/estimate."""
LIBRARY = f"pendulum_accel-{__version__}"
"""The MCAP header's library field."""

_MESSAGE_HEADER = np.dtype(
    [("op", "u1"), ("length", "<u8"), ("channel", "<u2"), ("sequence", "<u4"), ("log", "<u8"), ("pub", "<u8")]
)
assert _MESSAGE_HEADER.itemsize == MESSAGE_HEADER.size


@dataclass(frozen=True)
class Stream:
    """Messages of one topic for ``write_sorted``: log times (ns) and CDR payloads (rows or bytes)."""

    topic: str
    log_time_ns: NDArray[np.int64]
    payloads: NDArray[np.uint8] | Sequence[bytes]


@dataclass(frozen=True)
class _Topic:
    """A topic added to the bag: its MCAP channel id and what metadata.yaml lists for it."""

    channel_id: int
    name: str
    msgtype: str
    type_hash: str
    qos: list[Qos]


def _is_bag_dir(path: Path) -> bool:
    """True for an empty directory or one holding only rosbag2 files (metadata.yaml, *.mcap, *.db3), what
    repair keeps of them (*.damaged, *.mcap.orig) and the lock a writer left (recording.lock)."""
    return path.is_dir() and all(
        p.name in ("metadata.yaml", LOCK_NAME)
        or p.suffix in {".mcap", ".db3", ".damaged", ".tmp"}
        or p.name.endswith(".mcap.orig")
        for p in path.iterdir()
    )


def prepare_output(path: Path, overwrite: bool) -> None:
    """Refuse an existing ``path`` unless ``overwrite``; then delete it only if it holds nothing but a bag
    that no process is writing (its lock, bag/lock.py, or another process with its file open to write)."""
    if not path.exists() and not path.is_symlink():
        return
    if not overwrite:
        raise WriterError(f"{path} exists already; pass --overwrite to replace it")
    if not _is_bag_dir(path):
        raise WriterError(f"{path} exists and is not a bag directory; refusing to delete it")
    writer = holder(path) if path.is_dir() and not path.is_symlink() else None
    if writer is None and path.is_dir() and not path.is_symlink():
        # A recorder of another make takes no lock of ours: the file it has open for writing says it.
        writer = writer_of(sorted(path.glob("*.mcap")))
    if writer is not None and writer.live:
        raise WriterError(f"bag {path} is being recorded by {writer.describe()}; refusing to replace it")
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
        type_hash_in_channels: bool = True,
        program: str | None = None,
    ) -> None:
        """Create the bag directory ``path``; BagError if it exists and ``overwrite`` is false.

        ``type_hash_in_channels`` puts each topic's RIHS01 hash in its MCAP channel's metadata
        (``topic_type_hash``, as rosbag2's MCAP storage writes it); False gives rosbags' channel layout.
        The bag's lock (recording.lock, bag/lock.py), naming ``program`` (default: this process's), is
        held until ``close``.
        """
        self.path = Path(path)
        if flush_interval is not None and not flush_interval > 0.0:
            raise WriterError(f"flush_interval must be > 0 s, got {flush_interval!r}")
        if compression not in (None, "", "none", "zstd"):
            raise WriterError(f"unknown compression {compression!r}; use 'zstd' or none")
        prepare_output(self.path, overwrite)
        self.flush_interval = flush_interval
        self.type_hash_in_channels = type_hash_in_channels
        self.custom_data = {
            CUSTOM_VERSION: __version__,
            **{k: str(v) for k, v in (custom_data or {}).items()},
        }
        try:
            self.path.mkdir(mode=0o755, parents=True)
        except OSError as err:
            raise WriterError(f"cannot create bag {self.path}: {err}") from None
        # Locked before the MCAP file exists: a reader never finds the file of a live bag unlocked.
        try:
            self._lock = BagLock(self.path, program)
        except OSError as err:
            raise WriterError(f"cannot create bag {self.path}: {err}") from None
        try:
            self._file: McapFile | None = McapFile(
                self.mcap_path, library=LIBRARY, compression="zstd" if compression == "zstd" else ""
            )
        except OSError as err:
            self._lock.release()
            raise WriterError(f"cannot create bag {self.path}: {err}") from None
        self._topics: dict[str, _Topic] = {}
        self._schemas: dict[str, int] = {}
        self._final_counts: dict[int, int] = {}
        self._last_flush = time.monotonic()
        self._metadata_stale = True
        self._write_provisional_metadata()

    @property
    def _mcap(self) -> McapFile:
        """The open MCAP file, or BagError once closed."""
        if self._file is None:
            raise WriterError(f"bag {self.path} is closed")
        return self._file

    @property
    def mcap_path(self) -> Path:
        """Path of the .mcap file inside the bag directory."""
        return self.path / f"{self.path.name}.mcap"

    @property
    def counts(self) -> dict[str, int]:
        """Messages written so far, per topic."""
        counts = self._file.counts if self._file is not None else self._final_counts
        return {name: counts[t.channel_id] for name, t in self._topics.items()}

    def add_topic(self, name: str, msgtype: str, qos: Qos | Sequence[Qos] | None = None) -> None:
        """Register topic ``name`` of ``msgtype`` with its offered QoS (default: reliable, depth 1000)."""
        if name in self._topics:
            raise WriterError(f"topic {name} is already in bag {self.path}")
        if msgtype not in TYPESTORE.types:
            raise WriterError(f"unknown message type {msgtype!r} for topic {name}")
        profiles = [qos_profile()] if qos is None else ([qos] if isinstance(qos, Qos) else list(qos))
        mcap = self._mcap
        if msgtype not in self._schemas:
            msgdef, _ = TYPESTORE.generate_msgdef(msgtype, ros_version=2)
            encoding = "ros2idl" if msgdef.startswith("=" * 80 + "\nIDL: ") else "ros2msg"
            self._schemas[msgtype] = mcap.add_schema(msgtype, encoding, msgdef)
        type_hash = TYPESTORE.hash_rihs01(msgtype)
        metadata = {"offered_qos_profiles": qos_text(profiles)}
        if self.type_hash_in_channels:
            metadata["topic_type_hash"] = type_hash
        channel_id = mcap.add_channel(self._schemas[msgtype], name, "cdr", metadata)
        self._topics[name] = _Topic(channel_id, name, msgtype, type_hash, profiles)
        self._metadata_stale = True

    def _topic(self, name: str) -> _Topic:
        """A registered topic; BagError naming it otherwise."""
        try:
            return self._topics[name]
        except KeyError:
            raise WriterError(f"topic {name} was not added to bag {self.path}") from None

    def write(self, topic: str, log_time_ns: int, data: bytes | memoryview) -> None:
        """Append one CDR message at log time ``log_time_ns``; flushes when the flush interval is due."""
        if log_time_ns < 0:
            raise WriterError(f"log time must be >= 0 ns, got {log_time_ns}")
        mcap = self._mcap
        if self._metadata_stale:
            self._write_provisional_metadata()
        mcap.write_message(self._topic(topic).channel_id, int(log_time_ns), data)
        if self.flush_due():
            self.flush()

    def flush_due(self) -> bool:
        """True when the last flush is older than ``flush_interval`` (never without an interval)."""
        return self.flush_interval is not None and time.monotonic() - self._last_flush >= self.flush_interval

    def flush(self) -> None:
        """Close the open MCAP chunk (if it holds messages) and push the file to the OS: SIGKILL-safe."""
        mcap = self._mcap
        if self._metadata_stale:
            self._write_provisional_metadata()
        mcap.flush()
        self._last_flush = time.monotonic()

    def write_sorted(self, streams: Sequence[Stream]) -> None:
        """Write many topics' messages merged by log time (ties: stream order), in bulk.

        The same file results as ``write`` per message in that order (flushing aside): records are
        laid out with numpy, chunks split where per-message writes would split them.
        """
        mcap = self._mcap
        if self._metadata_stale:
            self._write_provisional_metadata()
        groups = [g for s in streams for g in _groups(s, self._topic(s.topic).channel_id)]
        if not groups:
            return
        channels = np.array([g[0] for g in groups], dtype=np.uint16)
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
            # A chunk is closed after the first message that takes it past CHUNK_BYTES.
            room = CHUNK_BYTES - mcap.chunk_size + (int(ends[start - 1]) if start else 0)
            stop = min(n, int(np.searchsorted(ends, room, side="right")) + 1)
            stop = max(stop, start + 1)
            records, entries = _records(
                channels, rows_list, all_t[start:stop], which[start:stop], index[start:stop]
            )
            mcap.append(records, entries)
            if mcap.chunk_size > CHUNK_BYTES:
                mcap.close_chunk()
            start = stop
        if self.flush_interval is not None:
            self.flush()

    def _topic_records(self, counts: Mapping[int, int] | None) -> list[TopicRecord]:
        """metadata.yaml's topic list, with the given per-channel counts (0 without)."""
        return [
            TopicRecord(t.name, t.msgtype, t.type_hash, t.qos, counts[t.channel_id] if counts else 0)
            for t in self._topics.values()
        ]

    def _write_provisional_metadata(self) -> None:
        """metadata.yaml as of now (counts 0): keeps topics and custom_data if the process dies.

        Written at open and again before the first message after topics were added.
        """
        self._metadata_stale = False
        doc = metadata_document(
            mcap_name=self.mcap_path.name,
            topics=self._topic_records(None),
            start_ns=0,
            end_ns=0,
            custom_data=self.custom_data,
        )
        write_metadata(self.path, doc)

    def close(self) -> dict[str, int]:
        """Write the MCAP summary and the final metadata.yaml; returns the per-topic counts."""
        if self._file is None:
            return self.counts
        mcap = self._file
        count = sum(mcap.counts.values())
        doc = metadata_document(
            mcap_name=self.mcap_path.name,
            topics=self._topic_records(mcap.counts),
            start_ns=mcap.start_ns if count else 0,
            end_ns=mcap.end_ns if count else 0,
            custom_data=self.custom_data,
        )
        mcap.close(dump_yaml(doc["rosbag2_bagfile_information"]).strip())
        self._final_counts = dict(mcap.counts)
        self._file = None
        write_metadata(self.path, doc)
        self._lock.release()
        return self.counts

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


def _records(
    channels: NDArray[np.uint16],
    rows_list: Sequence[NDArray[np.uint8]],
    t: NDArray[np.int64],
    which: NDArray[np.int64],
    index: NDArray[np.int64],
) -> tuple[memoryview, dict[int, IndexEntries]]:
    """MCAP message records (opcode, length, channel, sequence 0, log = publish time, data) of the
    messages (group ``which``, row ``index``, log time ``t``), and their per-channel index entries
    (log time, offset in the records), channels in order of first appearance."""
    head_size = _MESSAGE_HEADER.itemsize
    widths = np.array([head_size + rows.shape[1] for rows in rows_list], dtype=np.int64)
    rec_size = widths[which]
    n = t.size
    head = np.zeros(n, dtype=_MESSAGE_HEADER)
    head["op"] = OP_MESSAGE
    head["length"] = rec_size - 9
    head["channel"] = channels[which]
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
    cids = head["channel"].astype(np.int64)
    entries: dict[int, IndexEntries] = {}
    present, first = np.unique(cids, return_index=True)
    for cid in present[np.argsort(first)].tolist():
        sel = np.flatnonzero(cids == cid)
        block = np.empty((sel.size, 2), dtype=np.uint64)
        block[:, 0] = t[sel]
        block[:, 1] = local[sel]
        entries[int(cid)] = block
    return buf.data, entries


_Group = tuple[int, NDArray[np.uint8], NDArray[np.int64]]


def _groups(stream: Stream, channel_id: int) -> list[_Group]:
    """(channel id, (n, size) payload rows, log times) per payload size of one stream."""
    t = np.asarray(stream.log_time_ns, dtype=np.int64)
    payloads = stream.payloads
    count = payloads.shape[0] if isinstance(payloads, np.ndarray) else len(payloads)
    if t.ndim != 1 or t.size != count:
        raise WriterError(f"topic {stream.topic}: {t.size} log times for {count} payloads")
    if t.size and t.min() < 0:
        raise WriterError(f"topic {stream.topic}: log times must be >= 0 ns")
    if isinstance(payloads, np.ndarray):
        if payloads.dtype != np.uint8 or payloads.ndim != 2:
            raise WriterError(f"topic {stream.topic}: payload rows must be a 2-D uint8 array")
        return [(channel_id, payloads, t)] if count else []
    groups = []
    lengths = np.fromiter((len(p) for p in payloads), dtype=np.int64, count=count)
    for size in np.unique(lengths):
        sel = np.flatnonzero(lengths == size)
        rows = np.frombuffer(b"".join(payloads[i] for i in sel.tolist()), dtype=np.uint8).reshape(
            sel.size, int(size)
        )
        groups.append((channel_id, rows, t[sel]))
    return groups
