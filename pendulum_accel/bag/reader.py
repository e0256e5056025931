"""Read a rosbag2 MCAP bag into numpy arrays, chunk by chunk, salvaging what precedes any damage.

The file is scanned front to back, one record at a time (``os.pread``), after the schemas and channels
its summary repeats are registered (when the footer and the summary's CRC hold: a writer may put a
channel's only other record inside a chunk, which damage can take):
every top-level record is framed (opcode, length) and checked against the file size; Header, Schema,
Channel, Chunk and Metadata records are parsed by the ``mcap`` library; inside a chunk, each message
record's channel, log time and payload slice are taken with one ``struct.unpack_from``. Every chunk's
CRC and the data section CRC are verified (``bag.integrity``). A chunk whose data is damaged (CRC
mismatch, does not inflate, cut off by the end of the file) is listed in ``bag.damage`` and only its
intact message records are kept (``integrity.recover_messages``); the scan goes on with the next
record, since its framing still holds. When the framing itself breaks (a record cut off or
with a damaged opcode or length), the scan stops there, and the chunks after the damage are read
through the chunk index of the MCAP summary when the file still has its footer. A bag whose
recorder was killed (no summary) reads up to its last flushed chunk. Fixed-layout topics are then
decoded column-wise with :class:`pendulum_accel.bag.messages.Layout` (numpy over a chunk's messages at once).

Memory follows what is asked for, not the bag's size. The scan keeps, for each intact chunk, where it
lies in the file, the CRC-32 of its bytes as read, and per channel the chunk's message count and log time
span; the messages stay in the file. A topic is read when asked for (``decode``, ``decode_batches``,
``raw``, ``shapes``), one chunk at a time: the chunk is read again, must hash to the CRC it was verified
with (a file changed since is a BagError, never other data), and its records are taken as in the scan.
``decode`` holds the topic's decoded columns, ``decode_batches`` one batch of them. Messages outside
chunks and the records recovered from damaged chunks are held from the scan. ``read_bag(stream=False)``
holds every message from the scan instead (the reference the streamed reads are tested against).

A recording split into several files (rosbag2's ``--max-bag-size``/``--max-bag-duration``) is one bag:
its files are scanned in the order metadata.yaml lists them (by name without metadata), and a topic's
channels in each file are one channel of the bag, its messages in log-time order across the files.

A metadata.yaml naming a file outside the bag directory (absolute, ``..``, a symlink leading
out) is refused: nothing outside the bag is ever read, renamed or deleted through it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import heapq
import os
import re
import struct
import weakref
import zlib
from collections.abc import Generator, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import yaml
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, ChunkIndex, Footer, Header, Metadata, Schema
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray

from pendulum_accel.bag.integrity import (
    ChunkDamage,
    ChunkHead,
    chunk_head,
    crc32_combine,
    damage_origin,
    inflate_prefix,
    recover_messages,
)
from pendulum_accel.bag.messages import (
    Layout,
    TopicChoice,
    canonical_cdr,
    chain_topic,
    deserialize,
    find_topic,
    rows_from_bytes,
    stamp_seconds,
    stored_roles,
)
from pendulum_accel.errors import BagError
from pendulum_accel.textfile import not_a_file_or_directory

_MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEAD = struct.Struct("<BQ")
_MESSAGE_HEAD = struct.Struct("<BQHIQ")
_MESSAGE_DATA_OFFSET = 31  # opcode 1 + length 8 + channel 2 + sequence 4 + log time 8 + publish time 8
_OPCODES = {int(op) for op in Opcode}
# What a malformed record makes the parsers raise.
_RECORD_ERRORS = (ValueError, struct.error, UnicodeDecodeError, KeyError, IndexError)


@dataclass(frozen=True)
class TopicInfo:
    """One topic of a bag: name, message type, serialization, offered QoS (YAML text), message count."""

    name: str
    msgtype: str
    serialization_format: str
    offered_qos_profiles: str
    count: int


@dataclass(frozen=True)
class TopicArrays:
    """Decoded columns of one topic: ``log_time_ns`` and ``fields[path]`` (e.g. ``position[0]``)."""

    topic: str
    msgtype: str
    log_time_ns: NDArray[np.int64]
    fields: dict[str, NDArray[Any]]

    def __len__(self) -> int:
        """Number of messages."""
        return int(self.log_time_ns.size)

    def __getitem__(self, path: str) -> NDArray[Any]:
        """Column of field ``path``; BagError naming the topic when the messages have no such field."""
        try:
            return self.fields[path]
        except KeyError:
            raise BagError(f"topic {self.topic} ({self.msgtype}) messages have no field {path!r}") from None

    @property
    def stamp(self) -> NDArray[np.float64]:
        """t = header.stamp (or clock for Clock) in seconds; log time when the type has no stamp."""
        for prefix in ("header.stamp", "clock"):
            if f"{prefix}.sec" in self.fields:
                return stamp_seconds(self.fields[f"{prefix}.sec"], self.fields[f"{prefix}.nanosec"])
        return self.log_time_ns.astype(np.float64) * 1e-9


@dataclass(frozen=True)
class _Slices:
    """Equal-size payloads left in their verified chunk: ``data[s : s + size]`` for each start s.

    Copied out into (n, size) rows only when their topic is asked for: a topic nobody reads costs no copy.
    """

    data: NDArray[np.uint8]
    starts: NDArray[np.int64]
    size: int

    @property
    def shape(self) -> tuple[int, int]:
        """(n, size), the shape of ``rows()``."""
        return (int(self.starts.size), self.size)

    def rows(self) -> NDArray[np.uint8]:
        """(n, size) rows, one per payload."""
        return _gather(self.data, self.starts, self.size)


_Payloads = NDArray[np.uint8] | _Slices | list[bytes]
_Block = tuple[NDArray[np.int64], _Payloads]
"""Messages in file order: (log times, payloads as (n, size) rows, slices of a chunk, or a list of bytes)."""


def _first_payload(data: _Payloads) -> bytes | None:
    """A block's first payload (None when it holds none), without copying the others out."""
    if isinstance(data, _Slices):
        start = int(data.starts[0]) if data.starts.size else None
        return None if start is None else data.data[start : start + data.size].tobytes()
    if isinstance(data, np.ndarray):
        return data[0].tobytes() if data.shape[0] else None
    return data[0] if data else None


def _block_payloads(data: _Payloads) -> list[bytes]:
    """A block's payloads as bytes, one per message, in order."""
    if isinstance(data, _Slices):
        data = data.rows()
    return [row.tobytes() for row in data] if isinstance(data, np.ndarray) else data


@dataclass(frozen=True)
class _ChunkRef:
    """Where an intact chunk lies: in the bag's file number ``part``, its Chunk record at file offset ``at``
    (body ``length`` bytes), the (offset, body length) of the MessageIndex records read with it, and the
    CRC-32 of those bodies, in that order, as the scan read and verified them."""

    part: int
    at: int
    length: int
    indexes: tuple[tuple[int, int], ...]
    crc: int


@dataclass(frozen=True)
class _Lazy:
    """The ``count`` messages of channel ``cid`` in one intact chunk, left in the file; log times in
    [t_min, t_max]."""

    ref: _ChunkRef
    cid: int
    count: int
    t_min: int
    t_max: int


@dataclass
class _ChannelData:
    """Messages of one MCAP channel in file order."""

    topic: str
    msgtype: str
    encoding: str
    qos: str
    blocks: list[_Block | _Lazy] = field(default_factory=list)
    # Messages found by walking records one by one, not yet sealed into a block.
    times: list[int] = field(default_factory=list)
    payloads: list[bytes] = field(default_factory=list)
    sealed: int = 0
    """Messages in ``blocks``."""
    ordered: bool = True
    """Log times non-decreasing in file order: file order is log-time order (decode_batches streams)."""
    last_time: int = -1
    track: bool = True
    """Follow ``ordered``: False for the scratch channels a chunk is read into."""
    head: bytes | None = None
    """The channel's first payload in file order, kept by the scan when its chunk is left in the file: what
    a reader needs to see of a message's layout (the pendulum joint's place) without reading it again."""

    def _note(self, times: NDArray[np.int64]) -> None:
        """Follow the file order of log times (``ordered``) over the next ``times``."""
        if self.track and times.size:
            if int(times[0]) < self.last_time or (times.size > 1 and bool(np.any(np.diff(times) < 0))):
                self.ordered = False
            self.last_time = max(self.last_time, int(times[-1]))

    def seal(self) -> None:
        """Move the walked messages into a block (keeps file order with later blocks)."""
        if self.times:
            times = np.array(self.times, dtype=np.int64)
            self._note(times)
            self.blocks.append((times, self.payloads))
            self.sealed += len(self.times)
            self.times, self.payloads = [], []

    def add_block(self, times: NDArray[np.int64], payloads: _Slices | list[bytes]) -> None:
        """Append a bulk-read block after the walked messages so far."""
        self.seal()
        self._note(times)
        self.blocks.append((times, payloads))
        self.sealed += int(times.size)

    def add_lazy(self, lazy: _Lazy, times: NDArray[np.int64]) -> None:
        """Append a chunk's messages left in the file (``times``: their log times, for the order)."""
        self.seal()
        self._note(times)
        self.blocks.append(lazy)
        self.sealed += lazy.count

    @property
    def count(self) -> int:
        """Messages held."""
        return self.sealed + len(self.times)

    def span(self) -> tuple[int, int] | None:
        """(earliest, latest) log time, None without messages."""
        self.seal()
        lows = [b.t_min if isinstance(b, _Lazy) else int(b[0].min()) for b in self.blocks if _size(b)]
        highs = [b.t_max if isinstance(b, _Lazy) else int(b[0].max()) for b in self.blocks if _size(b)]
        return (min(lows), max(highs)) if lows else None


def _size(block: _Block | _Lazy) -> int:
    """Messages in a block."""
    return block.count if isinstance(block, _Lazy) else int(block[0].size)


@dataclass
class _Shape:
    """Messages of one shape: equal outside the numeric fields of ``layout``; ``msg`` the first decoded."""

    layout: Layout
    msg: object
    count: int = 0


@dataclass
class _ShapeBook:
    """What one pass over a topic found: shapes taken in bulk (in the order found), shapes of messages
    decoded one by one (by layout), and the count of messages that do not decode."""

    bulk: list[_Shape] = field(default_factory=list)
    canonical: dict[bytes, _Shape] = field(default_factory=dict)
    skipped: int = 0

    @property
    def shapes(self) -> list[_Shape]:
        """Every shape with messages: the bulk ones, then those decoded one by one."""
        return [s for s in (*self.bulk, *self.canonical.values()) if s.count]


CHUNKS_KEPT = 4
"""Chunks read again that a Bag keeps, so that passes over several topics in step read each chunk once."""
_T = TypeVar("_T")

_Classified = list[tuple[_Shape, NDArray[np.int64], NDArray[np.uint8]]]
"""(shape, indices within the block, rows) of one block's messages that decode."""


class _File:
    """The bag's MCAP file, read by offset (``os.pread``) through a descriptor held open while the Bag
    lives: a chunk read again comes from the same file even when its name was replaced meanwhile."""

    def __init__(self, path: Path) -> None:
        """Open ``path`` for reading; OSError when it cannot be."""
        self.fd = os.open(path, os.O_RDONLY)
        weakref.finalize(self, os.close, self.fd)
        self.size = os.fstat(self.fd).st_size

    def read(self, start: int, stop: int) -> bytes:
        """The file's bytes [start, stop), fewer when the file ends before ``stop``."""
        parts = []
        at = start
        while at < stop:
            got = os.pread(self.fd, stop - at, at)
            if not got:
                break
            parts.append(got)
            at += len(got)
        return parts[0] if len(parts) == 1 else b"".join(parts)


CUT_OFF = "cut off before its footer"
FRAMING_BROKEN = "record framing broken"


class _Part:
    """One MCAP file of a bag (a split recording has several, in recording order): its path, the open
    file, its schemas by id, and its channel ids mapped to the bag's (``cids``). A later file's channel
    of the same topic, type and encoding joins the earlier file's, so a topic stays one channel, in
    log-time order, across the files; an id of its own is ``part << 16 | id`` (MCAP ids are 16-bit)."""

    def __init__(self, index: int, path: Path) -> None:
        """File number ``index`` of the bag, at ``path``; OSError when it cannot be opened."""
        self.index, self.path = index, path
        self.file = _File(path)
        self.schemas: dict[int, Schema] = {}
        self.cids: dict[int, int] = {}
        self.complete = False
        """The scan read this file to its footer."""
        self.ending = FRAMING_BROKEN
        """Why the scan stopped before the footer (when not ``complete``)."""


class Bag:
    """Everything readable in one bag. ``problem`` is None for an intact bag, else one sentence.

    ``topics`` (name -> TopicInfo), ``custom_data``, ``start_ns``/``end_ns``, ``decode(topic)``,
    ``decode_batches(topic)``, ``raw(topic)`` and ``iter_raw()`` (time-ordered (topic, log_time_ns, cdr)
    for replay).
    """

    def __init__(self, path: Path, mcap_paths: Sequence[Path]) -> None:
        """Empty bag for ``path`` made of the MCAP files ``mcap_paths`` (in recording order); filled by
        read_bag."""
        self.path = path
        self.mcap_paths = list(mcap_paths)
        self.problem: str | None = None
        self.metadata: dict[str, Any] | None = None
        self.custom_data: dict[str, str] = {}
        self.damage: list[ChunkDamage] = []
        """Damaged chunks (and damage between chunks) in file order; empty when every CRC matched."""
        self.missing_files: tuple[str, ...] = ()
        """Files of the recording that metadata.yaml lists and that are not there."""
        self.damaged_files: list[Path] = []
        """The MCAP files whose own scan found a problem (cut off, corrupt, a CRC mismatch), in order."""
        self._channels: dict[int, _ChannelData] = {}
        self._parts: list[_Part] = []
        # Chunks read again lately: (file, offset) -> (channels read, their messages), for passes in step.
        self._kept: dict[tuple[int, int], tuple[frozenset[int], dict[int, _ChannelData]]] = {}
        # topic -> the shapes of its last complete pass: the contract check and later decodes share them.
        self._shape_cache: dict[str, _ShapeBook] = {}
        self.choice = TopicChoice()
        """Which topic plays each chain role: the recording's stored map (read_bag), the user's on top."""

    @property
    def mcap_path(self) -> Path:
        """The bag's (first) MCAP file."""
        return self.mcap_paths[0]

    def endings(self) -> list[str]:
        """Why each file the scan did not read to its footer stopped short ('cut off before its footer',
        'record framing broken', 'empty', …), its name first in a bag of several files."""
        split = len(self._parts) > 1
        return [f"{p.path.name} {p.ending}" if split else p.ending for p in self._parts if not p.complete]

    @property
    def complete(self) -> bool:
        """Every file of the bag was read to its footer."""
        return bool(self._parts) and all(p.complete for p in self._parts)

    def chain_topic(self, topic: str) -> str:
        """This bag's name for the chain topic ``topic`` (its root name, /pendulum/joint_states), by
        messages.chain_topic under ``choice``."""
        return chain_topic(self.topics, topic, self.choice)

    def find_topic(self, role: str) -> str | None:
        """This bag's topic playing ``role`` (None: none), by messages.find_topic under ``choice``."""
        return find_topic(self.topics, role, self.choice)

    @property
    def topics(self) -> dict[str, TopicInfo]:
        """name -> TopicInfo for every channel (topics with 0 messages included), in channel order."""
        out: dict[str, TopicInfo] = {}
        for ch in self._channels.values():
            if ch.topic in out:
                prev = out[ch.topic]
                out[ch.topic] = TopicInfo(
                    prev.name,
                    prev.msgtype,
                    prev.serialization_format,
                    prev.offered_qos_profiles,
                    prev.count + ch.count,
                )
            else:
                out[ch.topic] = TopicInfo(ch.topic, ch.msgtype, ch.encoding, ch.qos, ch.count)
        return out

    @property
    def message_count(self) -> int:
        """Total messages read."""
        return sum(ch.count for ch in self._channels.values())

    @property
    def start_ns(self) -> int:
        """Earliest log time (ns), 0 for an empty bag."""
        spans = [s for s in (ch.span() for ch in self._channels.values()) if s is not None]
        return min(s[0] for s in spans) if spans else 0

    @property
    def end_ns(self) -> int:
        """Latest log time (ns), 0 for an empty bag."""
        spans = [s for s in (ch.span() for ch in self._channels.values()) if s is not None]
        return max(s[1] for s in spans) if spans else 0

    @property
    def duration_s(self) -> float:
        """(end − start) in seconds."""
        return (self.end_ns - self.start_ns) * 1e-9

    def _channels_of(self, topic: str, msgtype: str | None) -> list[_ChannelData]:
        """Channels of ``topic``; BagError when it is absent or has another type than ``msgtype``."""
        chans = [ch for ch in self._channels.values() if ch.topic == topic]
        if not chans:
            known = ", ".join(sorted(self.topics)) or "none"
            raise BagError(f"bag {self.path} has no topic {topic} (topics: {known})")
        types = {ch.msgtype for ch in chans}
        if msgtype is not None and types != {msgtype}:
            raise BagError(
                f"topic {topic} in {self.path} has type {', '.join(sorted(types))}, expected {msgtype}"
            )
        if len(types) > 1:
            raise BagError(f"topic {topic} in {self.path} mixes types {', '.join(sorted(types))}")
        for ch in chans:
            if ch.encoding != "cdr":
                raise BagError(f"topic {topic} in {self.path} is {ch.encoding!r}-encoded, expected cdr")
        return chans

    def _load(self, lazy: _Lazy, want: frozenset[int]) -> list[_Block]:
        """The blocks of ``lazy``'s channel in its chunk, read again from the file with those of the
        channels ``want`` (kept for the passes reading those, in step: CHUNKS_KEPT chunks)."""
        key = (lazy.ref.part, lazy.ref.at)
        hit = self._kept.get(key)
        if hit is None or lazy.cid not in hit[0]:
            want = want | {lazy.cid}
            hit = self._kept[key] = (want, self._read_chunk(lazy.ref, want))
            while len(self._kept) > CHUNKS_KEPT:
                del self._kept[next(iter(self._kept))]
        got = hit[1].get(lazy.cid)
        if got is None or got.count != lazy.count:
            raise BagError(
                f"{self._parts[lazy.ref.part].path}: chunk at byte {lazy.ref.at} no longer holds the "
                "messages it held"
            )
        got.seal()
        return [b for b in got.blocks if not isinstance(b, _Lazy)]

    def _read_chunk(self, ref: _ChunkRef, want: frozenset[int]) -> dict[int, _ChannelData]:
        """The messages of channels ``want`` in one intact chunk, read again from the file; BagError when
        the bytes read are not those the scan verified (the file changed since it was read)."""
        part = self._parts[ref.part]
        body = part.file.read(ref.at + 9, ref.at + 9 + ref.length)
        crc = zlib.crc32(body)
        bodies = []
        for offset, length in ref.indexes:
            bodies.append(part.file.read(offset + 9, offset + 9 + length))
            crc = zlib.crc32(bodies[-1], crc)
        head = chunk_head(body) if len(body) == ref.length and crc == ref.crc else None
        if head is None:
            raise BagError(
                f"{part.path} changed since it was read (chunk at byte {ref.at} differs): read it again"
            )
        indexes = [i for i in (_message_index(memoryview(b)) for b in bodies) if i is not None]
        scanner = _Scanner(self, part)
        scanner.sink, scanner.only = {}, want
        # The same bytes as the scan's: the records that preceded an error there precede it here.
        with contextlib.suppress(*_RECORD_ERRORS):
            scanner.chunk(_decompress(head, memoryview(body)[head.records_at :]), indexes)
        return scanner.sink

    def _cids(self, topics: Sequence[str]) -> frozenset[int]:
        """Ids of the channels of ``topics``."""
        return frozenset(cid for cid, ch in self._channels.items() if ch.topic in topics)

    def _iter_blocks(self, chans: list[_ChannelData], want: frozenset[int]) -> Iterator[_Block]:
        """Blocks of ``chans`` in channel then file order; a chunk left in the file is read when reached
        (with the channels ``want``)."""
        for ch in chans:
            ch.seal()
            for block in list(ch.blocks):
                if isinstance(block, _Lazy):
                    yield from self._load(block, want)
                else:
                    yield block

    @staticmethod
    def _in_step(passes: Mapping[str, Generator[None, None, _T]]) -> dict[str, _T]:
        """Run generator ``passes`` a block each in turn, so that they read each chunk once between them;
        {name: what each returned}, in the order given."""
        results: dict[str, _T] = {}
        active = dict(passes)
        while active:
            for name, gen in list(active.items()):
                try:
                    next(gen)
                except StopIteration as stop:
                    results[name] = stop.value
                    del active[name]
        return {name: results[name] for name in passes}

    def raw(self, topic: str, msgtype: str | None = None) -> tuple[NDArray[np.int64], list[bytes]]:
        """(log times ns, CDR payloads) of ``topic``, sorted by log time (stable)."""
        parts: list[NDArray[np.int64]] = []
        payloads: list[bytes] = []
        chans = self._channels_of(topic, msgtype)
        for t, data in self._iter_blocks(chans, self._cids([topic])):
            parts.append(t)
            payloads += _block_payloads(data)
        times = np.concatenate(parts) if parts else np.zeros(0, dtype=np.int64)
        if times.size > 1 and np.any(np.diff(times) < 0):
            order = np.argsort(times, kind="stable")
            return times[order], [payloads[i] for i in order]
        return times, payloads

    def first_payload(self, topic: str, msgtype: str | None = None) -> bytes | None:
        """The first payload in file order of ``topic``'s first channel (of ``msgtype``), read no further
        than the scan kept it (a chunk left in the file is not read again); None when it has none."""
        for ch in self._channels_of(topic, msgtype):
            if ch.head is not None:
                return ch.head
            for block in ch.blocks:
                if not isinstance(block, _Lazy):
                    first = _first_payload(block[1])
                    if first is not None:
                        return first
        return None

    def raw_payloads(self, topic: str, msgtype: str | None = None) -> Iterator[bytes]:
        """raw(topic, msgtype)'s payloads one at a time, in its order; when the topic's log times never go
        back in the file (one channel), file order is that order, and a chunk is read again only when
        its payloads are reached (a caller that stops early reads no further)."""
        chans = self._channels_of(topic, msgtype)
        if len(chans) > 1 or not chans[0].ordered:
            yield from self.raw(topic, msgtype)[1]
            return
        for _, data in self._iter_blocks(chans, self._cids([topic])):
            yield from _block_payloads(data)

    def _pass(
        self, topic: str, msgtype: str | None, want: frozenset[int] | None = None
    ) -> Iterator[tuple[NDArray[np.int64], _Classified]]:
        """(log times, classified rows) of each block of ``topic`` in channel then file order; the shapes
        found are cached once the pass has gone through every block.

        A message is kept when its CDR decodes correctly: the typestore consumes the whole payload, up to
        the 0-3 bytes that pad a CDR stream to 4 (``messages.canonical_cdr``). Rows equal to a shape's
        template outside its numeric fields are taken in bulk; the rest (rclpy leaves padding bytes
        uninitialised and pads the end to 4 bytes, so its bytes need not re-serialise to themselves) are
        decoded one by one and taken as the typestore re-serialises them. Bytes that do not decode are
        skipped and counted.
        """
        chans = self._channels_of(topic, msgtype)
        mtype = chans[0].msgtype
        book = _ShapeBook()
        for times, payloads in self._iter_blocks(chans, self._cids([topic]) if want is None else want):
            yield times, _classify(mtype, book, payloads)
        self._shape_cache[topic] = book

    def _shape_pass(self, topic: str, want: frozenset[int]) -> Generator[None, None, None]:
        """A pass over ``topic`` for its shapes (cached at its end), yielding after each block."""
        for _ in self._pass(topic, None, want):
            yield

    def find_shapes(self, topics: Sequence[str]) -> None:
        """Find the shapes of ``topics`` (those present, not yet known) in one pass over the file."""
        todo = [t for t in dict.fromkeys(topics) if t in self.topics and t not in self._shape_cache]
        want = self._cids(todo)
        self._in_step({t: self._shape_pass(t, want) for t in todo})

    def _book(self, topic: str, msgtype: str | None) -> _ShapeBook:
        """The shapes of ``topic`` (type-checked), from the cache or from a pass over it."""
        self._channels_of(topic, msgtype)
        if topic not in self._shape_cache:
            for _ in self._pass(topic, msgtype):
                pass
        return self._shape_cache[topic]

    def shapes(self, topic: str, msgtype: str | None = None) -> list[tuple[object, int]]:
        """(first decoded message, message count) of each shape of ``topic`` (strings, frame, names, sizes).

        A cheap look at what a topic holds (e.g. which joints a JointState names) without decoding every
        message: a shape is every message equal to the first outside the numeric fields.
        """
        return [(s.msg, s.count) for s in self._book(topic, msgtype).shapes]

    def _note_skipped(self, topic: str) -> None:
        """Name the messages of ``topic`` that do not decode in ``problem`` (once: a topic read twice, as
        export --merged reads its stamps first, names them once)."""
        skipped = self._shape_cache[topic].skipped
        note = f"topic {topic}: skipped {skipped} damaged message(s) that do not decode"
        if skipped and note not in (self.problem or ""):
            self.problem = note if self.problem is None else f"{self.problem}; {note}"

    def decode(
        self, topic: str, msgtype: str | None = None, fields: Sequence[str] | None = None
    ) -> TopicArrays:
        """Numeric columns of ``topic`` (all, or ``fields``) decoded in bulk, one array per field, sorted by
        log time (stable).

        Messages are grouped by shape (strings and sequence lengths); each shape is decoded with numpy
        over a chunk's messages at once. BagError when a requested field is missing from some shape;
        messages whose bytes do not decode are skipped and named in ``problem``.
        """
        return self.decode_topics({topic: (msgtype, fields)})[topic]

    def decode_topics(
        self,
        requests: Mapping[str, tuple[str | None, Sequence[str] | None]],
        shapes: Sequence[str] = (),
    ) -> dict[str, TopicArrays]:
        """decode(topic, msgtype, fields) of each {topic: (msgtype, fields)} in one pass over the file; the
        same pass finds the shapes of the topics ``shapes`` that are not decoded (as find_shapes)."""
        for topic, (msgtype, _) in requests.items():
            self._channels_of(topic, msgtype)
        found = [
            t
            for t in dict.fromkeys(shapes)
            if t in self.topics and t not in self._shape_cache and t not in requests
        ]
        want = self._cids([*requests, *found])
        passes: dict[str, Generator[None, None, TopicArrays | None]] = {
            topic: self._decoding(topic, msgtype, fields, want)
            for topic, (msgtype, fields) in requests.items()
        }
        passes.update({topic: self._shape_pass(topic, want) for topic in found})
        done = self._in_step(passes)
        return {topic: got for topic in requests if (got := done[topic]) is not None}

    def _decoding(
        self, topic: str, msgtype: str | None, fields: Sequence[str] | None, want: frozenset[int]
    ) -> Generator[None, None, TopicArrays]:
        """decode's pass, yielding after each block; returns the TopicArrays. Each block's columns go straight
        into arrays sized for the topic's count (no second copy to join them)."""
        chans = self._channels_of(topic, msgtype)
        mtype, total = chans[0].msgtype, sum(ch.count for ch in chans)
        wanted = None if fields is None else list(fields)
        times_out = np.empty(total, dtype=np.int64)
        columns: dict[str, NDArray[Any]] = {}
        filled = 0
        for times, classified in self._pass(topic, msgtype, want):
            wanted, (t, cols) = _decode_block(topic, mtype, times, classified, wanted)
            if t.size:
                times_out[filled : filled + t.size] = t
                for path, col in cols.items():
                    if path not in columns:
                        columns[path] = np.empty(total, dtype=col.dtype)
                    columns[path][filled : filled + t.size] = col
                filled += int(t.size)
            yield
        self._note_skipped(topic)
        if filled:
            out = TopicArrays(topic, mtype, times_out[:filled], {p: c[:filled] for p, c in columns.items()})
        else:
            out = _joined(topic, mtype, [], fields)
        t = out.log_time_ns
        if t.size > 1 and np.any(np.diff(t) < 0):
            order = np.argsort(t, kind="stable")
            return TopicArrays(topic, mtype, t[order], {p: c[order] for p, c in out.fields.items()})
        return out

    def decode_batches(
        self,
        topic: str,
        msgtype: str | None = None,
        fields: Sequence[str] | None = None,
        rows: int = 1 << 17,
    ) -> Iterator[TopicArrays]:
        """decode(topic, msgtype, fields) a batch of about ``rows`` messages at a time, in the same order:
        the concatenated batches equal decode's columns, and only one batch is held.

        A topic whose log times go back in the file (or that spans several channels) needs a sort over
        all its messages: it is decoded whole and given as one batch.
        """
        chans = self._channels_of(topic, msgtype)
        mtype = chans[0].msgtype
        if len(chans) > 1 or not chans[0].ordered:
            yield self.decode(topic, msgtype, fields)
            return
        wanted = None if fields is None else list(fields)
        parts: list[tuple[NDArray[np.int64], dict[str, NDArray[Any]]]] = []
        held = 0
        given = False
        for times, classified in self._pass(topic, msgtype):
            wanted, kept = _decode_block(topic, mtype, times, classified, wanted)
            if kept[0].size:
                parts.append(kept)
                held += int(kept[0].size)
            if held >= rows:
                yield _joined(topic, mtype, parts, wanted)
                parts, held, given = [], 0, True
        self._note_skipped(topic)
        if parts or not given:
            yield _joined(topic, mtype, parts, wanted if given else fields)

    def iter_raw(self, topics: Sequence[str] | None = None) -> Iterator[tuple[str, int, bytes]]:
        """(topic, log_time_ns, cdr) of the chosen topics (default all), merged in log-time order."""
        names = list(self.topics) if topics is None else list(topics)
        streams = []
        for name in names:
            times, payloads = self.raw(name)
            streams.append(zip(times.tolist(), [name] * len(payloads), payloads, strict=True))
        for t, name, data in heapq.merge(*streams, key=lambda item: item[0]):
            yield name, t, data


def _size_groups(payloads: _Payloads) -> list[tuple[NDArray[np.int64], NDArray[np.uint8]]]:
    """(indices within the block, (n, size) rows), one group per payload size."""
    if isinstance(payloads, _Slices):
        payloads = payloads.rows()
    if isinstance(payloads, np.ndarray):
        return [(np.arange(payloads.shape[0]), payloads)]
    lengths = np.fromiter(map(len, payloads), dtype=np.int64, count=len(payloads))
    groups = []
    for size in np.unique(lengths).tolist():
        sel = np.flatnonzero(lengths == size)
        groups.append((sel, rows_from_bytes([payloads[i] for i in sel])))
    return groups


def _classify(mtype: str, book: _ShapeBook, payloads: _Payloads) -> _Classified:
    """(shape, indices, rows) of one block's messages that decode, by the shapes in ``book`` (those found
    in earlier blocks first, new ones added); the others are counted in ``book.skipped``."""
    out: _Classified = []

    def take(shape: _Shape, idx: NDArray[np.int64], rows: NDArray[np.uint8], ok: NDArray[np.bool_]) -> None:
        """Give the rows ``ok`` to ``shape`` (no copy when they are all of them)."""
        whole = bool(ok.all())
        shape.count += idx.size if whole else int(ok.sum())
        out.append((shape, idx, rows) if whole else (shape, idx[ok], rows[ok]))

    for idx, rows in _size_groups(payloads):
        todo = np.ones(idx.size, dtype=bool)
        for shape in book.bulk:
            if not todo.any():
                break
            if shape.layout.size == rows.shape[1]:
                ok = todo & shape.layout.matches(rows)
                if ok.any():
                    take(shape, idx, rows, ok)
                    todo &= ~ok
        while todo.any():
            first = int(np.flatnonzero(todo)[0])
            try:
                msg = deserialize(rows[first].tobytes(), mtype)
                layout = Layout.of(msg, mtype)
            except BagError:
                todo[first] = False  # does not decode: skipped
                book.skipped += 1
                continue
            ok = todo & layout.matches(rows)
            if not ok[first]:
                # Decodes, but not as the typestore writes it: the rest of this size, one by one.
                out += _canonical(mtype, book, idx[todo], rows[todo])
                break
            shape = _Shape(layout, msg)
            book.bulk.append(shape)
            take(shape, idx, rows, ok)
            todo &= ~ok
    return out


def _canonical(mtype: str, book: _ShapeBook, idx: NDArray[np.int64], rows: NDArray[np.uint8]) -> _Classified:
    """Shapes of messages decoded one by one, each row replaced by its typestore re-serialisation."""
    groups: dict[bytes, tuple[_Shape, list[int], list[bytes]]] = {}
    for i, row in zip(idx.tolist(), rows, strict=True):
        try:
            msg, canonical = canonical_cdr(row.tobytes(), mtype)
            layout = Layout.of(msg, mtype)
        except BagError:
            book.skipped += 1
            continue
        key = layout.mask.tobytes() + layout.template[layout.mask].tobytes()
        shape = book.canonical.setdefault(key, _Shape(layout, msg))
        shape.count += 1
        entry = groups.setdefault(key, (shape, [], []))
        entry[1].append(i)
        entry[2].append(canonical)
    return [(shape, np.array(i, dtype=np.int64), rows_from_bytes(r)) for shape, i, r in groups.values()]


def _decode_block(
    topic: str, mtype: str, times: NDArray[np.int64], classified: _Classified, wanted: list[str] | None
) -> tuple[list[str] | None, tuple[NDArray[np.int64], dict[str, NDArray[Any]]]]:
    """(the fields wanted, (log times, columns) of one block's messages that decode, in file order).

    ``wanted`` None: every field of the first shape met. BagError when a shape lacks a wanted field.
    """
    n = times.size
    columns: dict[str, NDArray[Any]] = {}
    assigned = np.zeros(n, dtype=bool)
    for shape, idx, rows in classified:
        if wanted is None:
            wanted = list(shape.layout.fields)
        missing = [p for p in wanted if p not in shape.layout.fields]
        if missing:
            at = int(times[int(idx[0])])
            raise BagError(
                f"topic {topic} ({mtype}): the message logged at {at} ns has no field {missing[0]!r}"
            )
        for path, col in shape.layout.decode(rows, wanted).items():
            if path not in columns:
                columns[path] = np.zeros(n, dtype=col.dtype)
            columns[path][idx] = col
        assigned[idx] = True
    if not assigned.all():
        return wanted, (times[assigned], {p: c[assigned] for p, c in columns.items()})
    return wanted, (times, columns)


def _joined(
    topic: str,
    mtype: str,
    parts: list[tuple[NDArray[np.int64], dict[str, NDArray[Any]]]],
    fields: Sequence[str] | None,
) -> TopicArrays:
    """TopicArrays of blocks' (log times, columns) one after the other; no blocks: empty ``fields``."""
    if not parts:
        return TopicArrays(topic, mtype, np.zeros(0, dtype=np.int64), {p: np.zeros(0) for p in fields or ()})
    if len(parts) == 1:
        return TopicArrays(topic, mtype, parts[0][0], parts[0][1])
    times = np.concatenate([t for t, _ in parts])
    return TopicArrays(
        topic, mtype, times, {p: np.concatenate([c[p] for _, c in parts]) for p in parts[0][1]}
    )


@dataclass(frozen=True)
class _Located:
    """A bag's directory (or bare .mcap file), its MCAP files in recording order, its parsed
    metadata.yaml (None: none), and a sentence naming files the metadata lists that are missing."""

    root: Path
    files: list[Path]
    doc: Any
    gone: tuple[str, ...] = ()
    """Files metadata.yaml lists that are not there."""

    @property
    def missing(self) -> str | None:
        """One sentence naming the files that are not there; None when none is missing."""
        if not self.gone:
            return None
        listed = len(self.files) + len(self.gone)
        verb = "is" if len(self.gone) == 1 else "are"
        return (
            f"bag {self.root}: metadata.yaml lists {listed} files and {', '.join(self.gone)} {verb} missing; "
            f"read the {len(self.files)} there"
        )


def _recording_order(name: str) -> list[str | int]:
    """Sort key of a file name with its digit runs as numbers: rosbag2 names a split recording's files
    ``<bag>_0.mcap``, ``<bag>_1.mcap``, …, ``<bag>_10.mcap``, and 10 comes after 9."""
    return [int(part) if i % 2 else part for i, part in enumerate(re.split(r"(\d+)", name))]


def _locate(path: Path) -> _Located:
    """The MCAP files of a bag directory or a bare .mcap file; the metadata is parsed here once, for the
    file names and for read_bag.

    A directory's files are those its metadata.yaml lists (``relative_file_paths``; several for a split
    recording), in that order. When none of them is there (a renamed copy) or there is no metadata, its
    ``*.mcap`` files are the bag, in recording order by name.
    """
    odd = not_a_file_or_directory(path)
    if odd is not None:
        # Opening a FIFO for reading would wait for a writer forever; a device is no bag either.
        raise BagError(f"bag {path} is {odd}, not a bag directory or an .mcap file")
    if path.is_file():
        _check_magic(path)
        return _Located(path, [path], None)
    if not path.is_dir():
        raise BagError(f"bag {path} does not exist")
    meta = path / "metadata.yaml"
    doc = None
    if meta.is_file():
        doc = _load_yaml(meta)
        info = doc.get("rosbag2_bagfile_information") if isinstance(doc, dict) else None
        info = info if isinstance(info, dict) else {}
        files = info.get("relative_file_paths")
        if str(info.get("compression_mode") or "").upper() == "MESSAGE":
            # Each payload is a zstd frame, not CDR: read as CDR, every message would look damaged.
            raise BagError(
                f"bag {path}: its messages are compressed one by one (rosbag2's --compression-mode "
                f"message, {info.get('compression_format') or 'unnamed'}); {convert_hint(path)}"
            )
        # A metadata.yaml of another shape names nothing usable: look for the MCAP files instead.
        names = [str(f) for f in files] if isinstance(files, list) else []
        listed = [inside_bag(path, name) for name in names]
        present = [p for p in listed if p.is_file()]
        for name, target in zip(names, listed, strict=True):
            if target.is_file() and name.endswith(".mcap.zstd"):
                # rosbag2's --compression-mode file: the whole MCAP file is one zstd frame.
                raise BagError(
                    f"bag {path}: {name} is an MCAP file compressed whole (rosbag2's --compression-mode "
                    f"file); {convert_hint(path)}"
                )
            if target.is_file() and not name.endswith(".mcap"):
                raise BagError(f"bag {path} uses storage {name!r}, not MCAP; {convert_hint(path)}")
        if present:
            return _Located(path, present, doc, tuple(p.name for p in listed if not p.is_file()))
    named = sorted(
        (f for f in path.glob("*.mcap") if not f.is_symlink() or _within(path, f)),
        key=lambda f: _recording_order(f.name),
    )
    found = [f for f in named if f.is_file()]
    if not found and named:
        what = not_a_file_or_directory(named[0]) or "a directory"
        raise BagError(f"bag {path}: {named[0].name} is {what}, not an MCAP file")
    if not found:
        raise BagError(f"bag {path} holds no .mcap file: not a bag directory")
    return _Located(path, found, doc)


def convert_hint(source: Path) -> str:
    """'convert it: rosbags-convert --src SRC --dst SRC-mcap --dst-storage mcap': rosbags (a dependency,
    so the command is installed beside ours) rewrites a ROS 1 bag, a rosbag2 SQLite bag or a compressed
    one as an uncompressed MCAP bag, which every command reads."""
    name = source.name.removesuffix(".bag") if source.is_file() else source.name
    dst = source.parent / f"{name}-mcap"
    return f"convert it: rosbags-convert --src {source} --dst {dst} --dst-storage mcap"


_ROS1_MAGIC = b"#ROSBAG V2.0"
_ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"


def _check_magic(path: Path) -> None:
    """BagError unless the regular file ``path`` starts with the MCAP magic bytes (or cannot be read)."""
    try:
        with path.open("rb") as handle:
            head = handle.read(len(_ROS1_MAGIC))
    except OSError as err:
        raise BagError(f"cannot read {path}: {err.strerror or err}") from None
    if head.startswith(_ROS1_MAGIC):
        raise BagError(f"{path} is a ROS 1 bag, not MCAP; {convert_hint(path)}")
    if head.startswith(_ZSTD_MAGIC):
        # rosbags converts a bag directory; a file compressed on its own is decompressed on its own.
        parent = path.parent
        hint = (
            convert_hint(parent) if (parent / "metadata.yaml").is_file() else f"decompress it: zstd -d {path}"
        )
        raise BagError(f"{path} is compressed whole (zstd), not MCAP; {hint}")
    if not head.startswith(_MAGIC):
        raise BagError(f"{path} is not an MCAP file (bad magic bytes)")


def inside_bag(root: Path, name: str) -> Path:
    """root / name for a file name from a bag's metadata; BagError when it would lead out of ``root``.

    Refused: an absolute path, a ``..`` component, and a name (or symlink) resolving outside ``root``.
    """
    parts = Path(name).parts
    if not name or Path(name).is_absolute() or ".." in parts or "\0" in name:
        raise BagError(f"bag {root}: metadata.yaml names {name!r}, outside the bag directory; refused")
    target = root / name
    if not _within(root, target):
        raise BagError(f"bag {root}: metadata.yaml names {name!r}, which leads outside the bag; refused")
    return target


def _within(root: Path, target: Path) -> bool:
    """True when ``target`` (symlinks resolved) lies inside ``root`` (symlinks resolved)."""
    base = os.path.realpath(root)
    return os.path.commonpath([base, os.path.realpath(target)]) == base


def _load_yaml(path: Path) -> Any:
    """Parsed YAML of a file; None when it does not parse."""
    try:
        return load_yaml(path.read_text(encoding="utf8"))
    except (yaml.YAMLError, OSError, UnicodeDecodeError):
        return None


def _decompress(head: ChunkHead, packed: memoryview | bytes) -> bytes | memoryview:
    """Uncompressed chunk records (none or zstd; lz4 when installed); ValueError when they do not inflate.

    An uncompressed chunk's records are ``packed`` itself (a view of the file's bytes, not a copy).
    """
    if head.compression == "":
        return packed
    try:
        if head.compression == "zstd":
            return bytes(
                zstandard.ZstdDecompressor().decompress(packed, max_output_size=head.uncompressed_size)
            )
        if head.compression == "lz4":
            import lz4.frame

            return bytes(lz4.frame.decompress(packed))
    except Exception as err:  # zstd/lz4 raise their own error types on damaged data
        raise ValueError(f"{head.compression} chunk does not decompress ({err})") from None
    raise ValueError(f"unsupported chunk compression {head.compression!r}")


class _RefBuilder:
    """A chunk's _ChunkRef under construction: its MessageIndex records are added as the scan meets them."""

    def __init__(self, part: int, at: int, length: int, crc: int) -> None:
        """The Chunk record at ``at`` of file ``part`` (body ``length`` bytes, CRC-32 ``crc``)."""
        self.part, self.at, self.length, self.crc = part, at, length, crc
        self.indexes: list[tuple[int, int]] = []

    def add(self, at: int, body: bytes | memoryview) -> None:
        """A MessageIndex record at ``at`` read with the chunk."""
        self.indexes.append((at, len(body)))
        self.crc = zlib.crc32(body, self.crc)

    def ref(self) -> _ChunkRef:
        """The finished reference."""
        return _ChunkRef(self.part, self.at, self.length, tuple(self.indexes), self.crc)


class _Scanner:
    """Front-to-back MCAP scan that records schemas, channels and messages into a Bag."""

    def __init__(self, bag: Bag, part: _Part, *, stream: bool = False) -> None:
        """Scan state for ``bag``'s file ``part``; ``stream``: leave intact chunks' messages in it."""
        self.bag = bag
        self.part = part
        self.schemas = part.schemas
        self.cids = part.cids
        self.file = part.file
        self.path = part.path
        self.stream = stream
        # Where a chunk's messages go while it is read to be left in the file (None: into the bag).
        self.sink: dict[int, _ChannelData] | None = None
        self.only: frozenset[int] | None = None  # reading a chunk again: the channels wanted from it
        self.pending: tuple[bytes | memoryview, list[tuple[int, NDArray[np.uint64]]]] | None = None
        self.pending_at = 0  # file offset of the pending chunk
        self.pending_ref: _RefBuilder | None = None  # where the pending chunk lies, when it is intact
        # The pending chunk's number and head, and its damage (None: its CRC matched).
        self.pending_head: tuple[int, ChunkHead | None] = (0, None)
        self.pending_damage: str | None = None
        self.body_crc: int | None = None  # CRC-32 of the last Chunk record body opened, when known
        self.read_chunks: set[int] = set()  # file offsets of chunks read (or skipped as damaged)
        self.chunks_seen = 0  # chunk records met in the scan: the 1-based number of the current one
        self.data_crc = 0  # crc32 of the file's bytes before the record being read
        self.damage_from = len(bag.damage)  # where this file's damage starts in bag.damage

    def _damaged(self, damage: ChunkDamage) -> None:
        """Note ``damage`` in the bag, naming this file when the bag has several."""
        if len(self.bag.mcap_paths) > 1:
            damage = dataclasses.replace(damage, file=self.path.name)
        self.bag.damage.append(damage)

    def schema(self, body: memoryview) -> None:
        """Register a Schema record."""
        rec = Schema.read(ReadDataStream(BytesIO(body)))
        self.schemas[rec.id] = rec

    def channel(self, body: memoryview) -> None:
        """Register a Channel record (its schema names the message type)."""
        rec = Channel.read(ReadDataStream(BytesIO(body)))
        schema = self.schemas.get(rec.schema_id)
        if rec.schema_id != 0 and schema is None:
            raise ValueError(f"channel {rec.id} ({rec.topic}) refers to unknown schema {rec.schema_id}")
        msgtype = schema.name if schema is not None else ""
        qos = rec.metadata.get("offered_qos_profiles", "")
        if rec.id in self.cids:
            return
        channels = self.bag._channels
        taken = set(self.cids.values())
        joined = [
            cid
            for cid, ch in channels.items()
            if self.part.index
            and cid not in taken
            and (ch.topic, ch.msgtype, ch.encoding) == (rec.topic, msgtype, rec.message_encoding)
        ]
        cid = joined[0] if joined else (self.part.index << 16) | rec.id
        self.cids[rec.id] = cid
        if cid not in channels:
            channels[cid] = _ChannelData(rec.topic, msgtype, rec.message_encoding, qos)

    def _target(self, local: int) -> _ChannelData | None:
        """Where this file's channel ``local``'s messages go: the bag's channel, or the sink's; None for
        an unknown one."""
        cid = self.cids.get(local)
        ch = None if cid is None else self.bag._channels.get(cid)
        if ch is None or cid is None or self.sink is None:
            return ch
        got = self.sink.get(cid)
        if got is None:
            got = self.sink[cid] = _ChannelData(ch.topic, ch.msgtype, ch.encoding, ch.qos, track=False)
        return got

    def walk(self, data: bytes | memoryview, start: int, stop: int) -> None:
        """Walk the records of data[start:stop] (inside one chunk); ValueError at the first malformed one."""
        view = memoryview(data)
        pos = start
        unpack_message = _MESSAGE_HEAD.unpack_from
        while pos < stop:
            if pos + 9 > stop:
                raise ValueError(f"record header cut off at chunk byte {pos}")
            op, length = _RECORD_HEAD.unpack_from(data, pos)
            end = pos + 9 + length
            if end > stop:
                raise ValueError(f"record at chunk byte {pos} overruns its chunk")
            if op == Opcode.MESSAGE:
                if length < 22:
                    raise ValueError(f"message record at chunk byte {pos} is too short")
                _, _, cid, _, log_time = unpack_message(data, pos)
                ch = self._target(cid)
                if ch is None:
                    raise ValueError(f"message at chunk byte {pos} on unknown channel {cid}")
                ch.times.append(log_time)
                ch.payloads.append(bytes(data[pos + _MESSAGE_DATA_OFFSET : end]))
            elif op == Opcode.SCHEMA:
                self.schema(view[pos + 9 : end])
            elif op == Opcode.CHANNEL:
                self.channel(view[pos + 9 : end])
            else:
                raise ValueError(f"opcode 0x{op:02x} at chunk byte {pos} does not belong in a chunk")
            pos = end

    def chunk(self, data: bytes | memoryview, indexes: list[tuple[int, NDArray[np.uint64]]]) -> None:
        """Read one uncompressed chunk, in bulk where its message index tiles it, by walking elsewhere.

        The index offsets are checked against the records themselves (opcode, channel, lengths,
        no overlap); the gaps between indexed messages (schemas, channels, unindexed messages)
        are walked. Anything inconsistent falls back to walking the whole chunk.
        """
        end = len(data)
        if not indexes:
            self.walk(data, 0, end)
            return
        offs = np.concatenate([e[:, 1] for _, e in indexes]).astype(np.int64)
        cids = np.concatenate([np.full(e.shape[0], cid, dtype=np.int64) for cid, e in indexes])
        order = np.argsort(offs, kind="stable")
        offs, cids = offs[order], cids[order]
        arr = np.frombuffer(data, dtype=np.uint8)
        if offs.size == 0 or offs[0] < 0 or offs[-1] + _MESSAGE_DATA_OFFSET > end:
            self.walk(data, 0, end)
            return
        lengths = _unaligned(data, "<u8")[offs + 1].astype(np.int64)
        rec_cids = _unaligned(data, "<u2")[offs + 9].astype(np.int64)
        ends = offs + 9 + lengths
        if (
            np.any(arr[offs] != Opcode.MESSAGE)
            or np.any(rec_cids != cids)
            or np.any(lengths < 22)
            or np.any(ends[:-1] > offs[1:])
            or ends[-1] > end
        ):
            self.walk(data, 0, end)
            return
        gap_starts = np.concatenate(([0], ends))
        gap_stops = np.concatenate((offs, [end]))
        for g in np.flatnonzero(gap_stops > gap_starts).tolist():
            self.walk(data, int(gap_starts[g]), int(gap_stops[g]))
        log_times = _unaligned(data, "<u8")[offs + 15].astype(np.int64)
        for cid in sorted({cid for cid, _ in indexes}):
            ch = self._target(cid)
            if ch is None:
                raise ValueError(f"message index refers to unknown channel {cid}")
            if self.only is not None and self.cids.get(cid) not in self.only:
                continue
            sel = np.flatnonzero(cids == cid)
            if sel.size == 0:
                continue
            sizes = lengths[sel] - 22
            starts = offs[sel] + _MESSAGE_DATA_OFFSET
            if np.all(sizes == sizes[0]):
                ch.add_block(log_times[sel], _Slices(arr, starts, int(sizes[0])))
            else:
                ch.add_block(
                    log_times[sel],
                    [bytes(data[a : a + z]) for a, z in zip(starts.tolist(), sizes.tolist(), strict=True)],
                )

    def scan(self) -> None:
        """Read every top-level record, skipping damaged chunks; then indexed chunks past broken framing."""
        bag = self.bag
        # An earlier file's problem stays; this file's sentences follow it.
        earlier, bag.problem = bag.problem, None
        self._summary_channels()
        try:
            stop = self._scan()
        finally:
            self._flush_chunk()
            for ch in bag._channels.values():
                ch.seal()
        if stop is not None:
            recovered = self._indexed_chunks(stop)
            if recovered:
                bag.problem = f"{bag.problem}; read {recovered} chunk(s) after it through the chunk index"
        mine = bag.damage[self.damage_from :]
        if mine:
            origin = damage_origin(bag.start_ns, bag.damage)
            note = "; ".join(f"damaged {d.sentence(origin)}" for d in mine)
            bag.problem = note if bag.problem is None else f"{bag.problem}; {note}"
        if bag.problem is not None:  # this file's own sentences, before the earlier ones join them
            bag.damaged_files.append(self.path)
        if earlier is not None:
            bag.problem = earlier if bag.problem is None else f"{earlier}; {bag.problem}"
        for ch in bag._channels.values():
            ch.seal()

    def _flush_chunk(self) -> None:
        """Read the pending chunk with the message indexes that followed it; a damaged one is noted, and
        only its intact message records are kept. An intact chunk read to stream leaves its messages in
        the file: each channel gets the chunk's count and log time span (``_Lazy``)."""
        if self.pending is None:
            return
        data, indexes = self.pending
        self.pending = None
        damage, self.pending_damage = self.pending_damage, None
        builder, self.pending_ref = self.pending_ref, None
        number, head = self.pending_head
        if damage is not None and head is not None:
            self._recover(bytes(data), indexes, number, head, damage)
            return
        ref = builder.ref() if builder is not None and self.stream else None
        if ref is not None:
            self.sink = {}
        try:
            self.chunk(data, indexes)
        except _RECORD_ERRORS as err:
            start, end = (head.start_ns, head.end_ns) if head is not None else (0, 0)
            self._damaged(ChunkDamage(number, start, end, f"malformed records ({err})"))
        finally:
            if ref is not None and self.sink is not None:
                sink, self.sink = self.sink, None
                for cid, got in sink.items():
                    got.seal()
                    times = [b[0] for b in got.blocks if not isinstance(b, _Lazy)]
                    if got.count:
                        t = np.concatenate(times)
                        lazy = _Lazy(ref, cid, got.count, int(t.min()), int(t.max()))
                        channel = self.bag._channels[cid]
                        if channel.sealed == 0 and not channel.payloads and channel.head is None:
                            first = next(b for b in got.blocks if not isinstance(b, _Lazy))
                            channel.head = _first_payload(first[1])
                        channel.add_lazy(lazy, t)

    def _recover(
        self,
        data: bytes,
        indexes: list[tuple[int, NDArray[np.uint64]]],
        number: int,
        head: ChunkHead,
        reason: str,
    ) -> None:
        """Keep the intact message records of a damaged chunk's ``data`` and note the damage."""
        channels, cids = self.bag._channels, self.cids

        def on_record(op: int, body: memoryview) -> None:
            """Register a schema or channel met inside the damaged chunk, if it still parses."""
            with contextlib.suppress(*_RECORD_ERRORS):
                self.schema(body) if op == Opcode.SCHEMA else self.channel(body)

        offsets = [int(o) for _, entries in indexes for o in entries[:, 1].tolist()]
        kept, dropped = recover_messages(
            data,
            head,
            offsets,
            on_record,
            lambda: {local: channels[cid].msgtype for local, cid in cids.items()},
        )
        for local, log_time, payload in kept:
            ch = channels[cids[local]]
            ch.times.append(log_time)
            ch.payloads.append(payload)
        self._damaged(ChunkDamage(number, head.start_ns, head.end_ns, reason, len(kept), dropped))

    def _open_chunk(self, body: memoryview, at: int, number: int) -> bytes | memoryview | None:
        """Uncompressed data of the Chunk record ``body`` (chunk ``number``) at file offset ``at``.

        Its CRC is checked; a damaged chunk becomes the pending one with its damage, to be recovered
        record by record. None when not even its head parses. Sets ``body_crc`` when the CRC of the
        uncompressed records gives the body's (no second pass over its bytes).
        """
        self.read_chunks.add(at)
        self.body_crc = None
        head = chunk_head(body)
        self.pending_head = (number, head)
        if head is None:
            self._damaged(ChunkDamage(number, 0, 0, "its header fields do not parse"))
            return None
        packed = body[head.records_at :]
        try:
            # The fields were parsed by chunk_head; the records are the rest of the body.
            (records_length,) = struct.unpack_from("<Q", body, head.records_at - 8)
            if records_length != len(packed):
                raise ValueError(f"records length {records_length} does not match the record's {len(packed)}")
            if head.compression == "" and len(packed) != head.uncompressed_size:
                raise ValueError("chunk data is shorter than its declared size")
            data = _decompress(head, packed)
            if len(data) != head.uncompressed_size:
                raise ValueError(f"inflates to {len(data)} bytes, declared {head.uncompressed_size}")
            crc = zlib.crc32(data)
            if head.crc and crc != head.crc:
                raise ValueError("CRC mismatch")
        except _RECORD_ERRORS as err:
            self.pending_damage = str(err)
            return inflate_prefix(head, packed)
        if head.compression == "":
            # The records are the body's tail: crc32(body) from the head's bytes and the records' CRC.
            self.body_crc = crc32_combine(zlib.crc32(body[: head.records_at]), crc, len(data))
        return data

    def _fold(self, head: bytes, body: memoryview, body_crc: int | None = None) -> None:
        """Extend the data section CRC over one record (``body_crc``: crc32 of its body, when known)."""
        self.data_crc = zlib.crc32(head, self.data_crc)
        if body_crc is None:
            self.data_crc = zlib.crc32(body, self.data_crc)
        else:
            self.data_crc = crc32_combine(self.data_crc, body_crc, len(body))

    def _data_end(self, body: memoryview) -> None:
        """Check DataEnd's data section CRC (when written) against the file's bytes before it."""
        (expected,) = struct.unpack_from("<I", body, 0)
        if expected and self.data_crc != expected and len(self.bag.damage) == self.damage_from:
            reason = (
                "data section CRC mismatch with every chunk intact: "
                "a message index, schema, channel or metadata record is damaged"
            )
            self._damaged(ChunkDamage(None, 0, 0, reason))

    def _scan(self) -> int | None:
        """The record loop of scan(); the offset where the framing broke, None when it held to the end."""
        bag = self.bag
        assert self.file is not None, "a scan reads a file"
        read, size = self.file.read, self.file.size
        magic = read(0, len(_MAGIC))
        if magic != _MAGIC:
            what = "empty" if size == 0 else "not an MCAP file (bad magic bytes)"
            if len(bag.mcap_paths) == 1:
                raise BagError(f"{self.path} is {what}")
            # One file of a split recording (a recorder killed as it opened the next file): the others
            # are still the recording.
            bag.problem = f"{self.path} is {what}"
            self.part.ending = what
            return 0
        self.data_crc = zlib.crc32(magic)
        pos = len(_MAGIC)
        while True:
            if pos >= size:
                bag.problem = f"{self.path} ends at byte {size} without its MCAP footer (interrupted?)"
                self.part.ending = CUT_OFF
                return pos
            if pos + 9 > size:
                bag.problem = f"{self.path} is truncated: record header cut off at byte {pos} of {size}"
                self.part.ending = CUT_OFF
                return pos
            head = read(pos, pos + 9)
            op, length = _RECORD_HEAD.unpack_from(head, 0)
            stop = pos + 9 + length
            if op not in _OPCODES or op == 0:
                bag.problem = f"{self.path} is corrupt: unknown record opcode 0x{op:02x} at byte {pos}"
                return pos
            if stop > size:
                bag.problem = (
                    f"{self.path} is truncated: {Opcode(op).name} record at byte {pos} needs "
                    f"{length} bytes, only {size - pos - 9} remain"
                )
                self.part.ending = CUT_OFF
                if op == Opcode.CHUNK:
                    self._cut_chunk(memoryview(read(pos + 9, size)), pos)
                return pos
            body = memoryview(read(pos + 9, stop))
            try:
                if op == Opcode.MESSAGE_INDEX and self.pending is not None:
                    index = _message_index(body)
                    if index is not None:
                        self.pending[1].append(index)
                        if self.pending_ref is not None:
                            self.pending_ref.add(pos, body)
                    self._fold(head, body)
                else:
                    self._flush_chunk()
                    if op == Opcode.FOOTER:
                        self.part.complete = True
                        return None
                    if op == Opcode.CHUNK:
                        self.chunks_seen += 1
                        chunk_data = self._open_chunk(body, pos, self.chunks_seen)
                        body_crc = self.body_crc if self.body_crc is not None else zlib.crc32(body)
                        self._fold(head, body, body_crc)
                        if chunk_data is not None:
                            self.pending, self.pending_at = (chunk_data, []), pos
                            if self.pending_damage is None:
                                self.pending_ref = _RefBuilder(self.part.index, pos, len(body), body_crc)
                    elif op == Opcode.DATA_END:
                        self._data_end(body)
                    else:
                        self._top_level(op, body)
                        self._fold(head, body)
            except _RECORD_ERRORS as err:
                bag.problem = f"{self.path} is corrupt at byte {pos} ({Opcode(op).name} record): {err}"
                return pos
            pos = stop

    def _cut_chunk(self, body: memoryview, at: int) -> None:
        """Keep the intact message records of a chunk record that the end of the file cuts off."""
        self._flush_chunk()  # the chunk before it, still waiting for message indexes
        self.chunks_seen += 1
        head = chunk_head(body)
        self.read_chunks.add(at)
        if head is None:
            self._damaged(ChunkDamage(self.chunks_seen, 0, 0, "cut off by the end of the file"))
            return
        self.pending, self.pending_at = (inflate_prefix(head, body[head.records_at :]), []), at
        self.pending_head = (self.chunks_seen, head)
        self.pending_damage = f"cut off by the end of the file at byte {at + 9 + len(body)}"
        self._flush_chunk()

    def _summary_channels(self) -> None:
        """Register the schemas and channels of the file's summary section, when its footer is intact and
        the summary's CRC (when written) matches.

        A writer may put a channel's only record in the data section inside a chunk (the mcap library
        and rosbag2's MCAP storage write each where the channel's first message goes). Were that chunk
        damaged, every later message of the channel would name an unknown channel and its chunks would
        be lost with it; the summary repeats every schema and channel, so they are known before any
        chunk is read. A file without a usable summary (a killed recorder) is scanned as before."""
        span = self._summary_span(len(_MAGIC))
        if span is None:
            return
        start, tail, crc = span
        try:
            # The CRC covers the summary and the footer through its summary_offset_start field.
            if crc and zlib.crc32(self.file.read(start, tail + 25)) != crc:
                return
            self._summary(self.file.read(start, tail), chunks=False)
        except _RECORD_ERRORS:
            return

    def _summary_span(self, after: int) -> tuple[int, int, int] | None:
        """(summary start, footer offset, summary CRC) from the file's footer, when the file ends in its
        footer and magic and the summary starts past byte ``after``; None otherwise."""
        size = self.file.size
        tail = size - len(_MAGIC) - 9 - 20
        if tail <= after:
            return None
        end = self.file.read(tail, size)
        if end[-len(_MAGIC) :] != _MAGIC or end[0] != Opcode.FOOTER:
            return None
        try:
            footer = Footer.read(ReadDataStream(BytesIO(end[9:29])))
        except _RECORD_ERRORS:
            return None
        start = int(footer.summary_start)
        return (start, tail, int(footer.summary_crc)) if after < start <= tail else None

    def _indexed_chunks(self, broken_at: int) -> int:
        """Read the chunks the summary's chunk index places past ``broken_at``; how many were read.

        Needs the footer (last 37 bytes) and a summary section; the schemas and channels it repeats are
        registered first. Each chunk and its message indexes are read as in the scan; a damaged one is
        skipped and noted. Nothing happens without a usable summary (a killed recorder writes none).
        """
        read = self.file.read
        span = self._summary_span(broken_at)
        if span is None:
            return 0
        start, tail, _ = span
        try:
            indexes = self._summary(read(start, tail))
        except _RECORD_ERRORS:
            return 0
        count = 0
        for number, entry in enumerate(sorted(indexes, key=lambda e: e.chunk_start_offset), start=1):
            at = int(entry.chunk_start_offset)
            if at < broken_at or at in self.read_chunks or at + entry.chunk_length > start:
                continue
            try:
                op, length = _RECORD_HEAD.unpack_from(read(at, at + 9), 0)
                if op != Opcode.CHUNK or at + 9 + length > start:
                    raise ValueError("the chunk index points at no chunk record")
                body = memoryview(read(at + 9, at + 9 + length))
                chunk_data = self._open_chunk(body, at, number)
                if chunk_data is None:
                    continue
                builder = None
                if self.pending_damage is None:
                    builder = _RefBuilder(
                        self.part.index,
                        at,
                        length,
                        self.body_crc if self.body_crc is not None else zlib.crc32(body),
                    )
                message_indexes = []
                for off in entry.message_index_offsets.values():
                    mop, mlen = _RECORD_HEAD.unpack_from(read(off, off + 9), 0)
                    index_body = memoryview(read(off + 9, off + 9 + mlen))
                    found = _message_index(index_body)
                    if mop == Opcode.MESSAGE_INDEX and found is not None:
                        message_indexes.append(found)
                        if builder is not None:
                            builder.add(off, index_body)
            except _RECORD_ERRORS as err:
                t0, t1 = int(entry.message_start_time), int(entry.message_end_time)
                self._damaged(ChunkDamage(number, t0, t1, str(err)))
                self.pending_damage = None
                continue
            self.pending, self.pending_at, self.pending_ref = (chunk_data, message_indexes), at, builder
            self._flush_chunk()
            count += 1
        return count

    def _summary(self, data: bytes, *, chunks: bool = True) -> list[ChunkIndex]:
        """Chunk indexes of the summary section ``data`` (none read with ``chunks`` False); registers its
        schemas and channels."""
        view = memoryview(data)
        found: list[ChunkIndex] = []
        pos, stop = 0, len(data)
        while pos + 9 <= stop:
            op, length = _RECORD_HEAD.unpack_from(data, pos)
            end = pos + 9 + length
            if end > stop:
                raise ValueError(f"summary record at byte {pos} overruns the summary")
            body = view[pos + 9 : end]
            if op == Opcode.SCHEMA:
                self.schema(body)
            elif op == Opcode.CHANNEL:
                self.channel(body)
            elif op == Opcode.CHUNK_INDEX and chunks:
                found.append(ChunkIndex.read(ReadDataStream(BytesIO(body))))
            pos = end
        return found

    def _top_level(self, op: int, body: memoryview) -> None:
        """Handle one top-level record other than a chunk."""
        if op == Opcode.SCHEMA:
            self.schema(body)
        elif op == Opcode.CHANNEL:
            self.channel(body)
        elif op == Opcode.MESSAGE:
            record = bytes([0x05]) + struct.pack("<Q", len(body)) + bytes(body)
            self.walk(record, 0, len(record))
        elif op == Opcode.METADATA:
            meta = Metadata.read(ReadDataStream(BytesIO(body)))
            if meta.name == "rosbag2" and "serialized_metadata" in meta.metadata:
                try:
                    doc = load_yaml(meta.metadata["serialized_metadata"])
                except yaml.YAMLError:
                    doc = None
                if isinstance(doc, dict) and isinstance(doc.get("custom_data"), dict):
                    self.bag.custom_data.update({str(k): str(v) for k, v in doc["custom_data"].items()})


def load_yaml(text: str) -> Any:
    """yaml.safe_load with libyaml's C loader when available (metadata can be long)."""
    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    return yaml.load(text, Loader=loader)


def _gather(arr: NDArray[np.uint8], starts: NDArray[np.int64], width: int) -> NDArray[np.uint8]:
    """(n, width) bytes arr[s : s + width] for each start s."""
    # Copying whole rows of a window view beats an element-wise index (2x at 12 bytes, 25x at 364).
    rows: NDArray[np.uint8] = sliding_window_view(arr, width)[starts]
    return rows


def _unaligned(data: bytes | memoryview, dtype: str) -> NDArray[Any]:
    """View v of ``data`` with v[i] = the ``dtype`` value in data[i : i + itemsize] (any byte offset i)."""
    width = np.dtype(dtype).itemsize
    view: NDArray[Any] = np.ndarray((max(len(data) - width + 1, 0),), dtype=dtype, buffer=data, strides=(1,))
    return view


def _message_index(body: memoryview) -> tuple[int, NDArray[np.uint64]] | None:
    """(channel id, (n, 2) log time/offset entries) of a MessageIndex record; None when malformed."""
    if len(body) < 6:
        return None
    cid, nbytes = struct.unpack_from("<HI", body, 0)
    if nbytes != len(body) - 6 or nbytes % 16:
        return None
    entries = np.frombuffer(body, dtype="<u8", offset=6).reshape(-1, 2)
    return cid, entries


def _custom_data(doc: Any) -> dict[str, str]:
    """custom_data of a metadata.yaml document ({} when it has none)."""
    info = doc.get("rosbag2_bagfile_information") if isinstance(doc, dict) else None
    custom = info.get("custom_data") if isinstance(info, dict) else None
    return {str(k): str(v) for k, v in custom.items()} if isinstance(custom, dict) else {}


def stored_choice(path: Path | str) -> TopicChoice:
    """The TopicChoice of the recording's stored topic map (metadata.yaml), without reading the MCAP."""
    return TopicChoice(stored_roles(_custom_data(_locate(Path(path)).doc)))


def read_bag(path: Path | str, *, salvage: bool = True, stream: bool = True) -> Bag:
    """Scan a bag directory (or .mcap file): every CRC checked, every message counted.

    ``stream`` (default): each intact chunk's messages stay in the file until their topic is asked for,
    then are read chunk by chunk (memory follows what is decoded, not the bag); False holds every message
    in memory from the scan. A truncated or corrupt file keeps what precedes the damage and sets
    ``bag.problem``; with ``salvage=False`` that is a BagError instead. Missing, empty or non-MCAP
    input: BagError.
    """
    found = _locate(Path(path))
    bag = Bag(found.root, found.files)
    for index, mcap_path in enumerate(found.files):
        try:
            bag._parts.append(_Part(index, mcap_path))
        except OSError as err:
            raise BagError(f"cannot read {mcap_path}: {err.strerror}") from None
    if isinstance(found.doc, dict):
        bag.metadata = found.doc
        bag.custom_data.update(_custom_data(found.doc))
    bag.problem = found.missing
    bag.missing_files = found.gone
    for part in bag._parts:
        _Scanner(bag, part, stream=stream).scan()
    bag.choice.roles.update(stored_roles(bag.custom_data))
    if bag.problem is not None and not salvage:
        raise BagError(
            f"bag {bag.path} is damaged ({bag.problem}); refusing to compute from it: pass --salvage "
            f"to use only its intact records, or run `pendulum-accel repair {bag.path}`"
        )
    return bag


def header_library(path: Path) -> str | None:
    """The ``library`` an MCAP file's Header record names (who wrote it: ``pendulum_accel-0.1.0``,
    ``rosbags-0.11.9``, rosbag2's), read by the mcap library; None when it names none or cannot be read."""
    from mcap.stream_reader import StreamReader

    try:
        with path.open("rb") as stream:
            first = next(iter(StreamReader(stream).records), None)
    except Exception:  # the mcap library raises its own errors, struct's and OSError on a bad file
        return None
    return first.library if isinstance(first, Header) and first.library else None


def salvage_note(bag: Bag) -> str | None:
    """One line for a damaged bag: the damage and what was kept; None for an intact one."""
    if bag.problem is None:
        return None
    recovered = sum(d.recovered for d in bag.damage)
    unverified = (
        f", {recovered} of them recovered by parsing damaged chunks: they frame and decode, but no "
        "checksum vouches for their values"
        if recovered
        else ""
    )
    return (
        f"{bag.problem}; read the {bag.message_count} messages that are intact{unverified} "
        f"(`pendulum-accel repair {bag.path}` rewrites the bag from them)"
    )
