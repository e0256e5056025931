"""Read a rosbag2 MCAP bag into numpy arrays, chunk by chunk, salvaging what precedes any damage.

``read_bag`` finds the bag's files (``bag.locate``) and scans each (``bag.scan``): every CRC checked,
every message counted, damage named in ``bag.problem`` with what was kept. The ``Bag`` it returns
answers what the scan found (topics, counts, time span, damage) and reads topics when asked for:
fixed-layout topics are decoded column-wise by shape (``bag.shapes``, numpy over a chunk's messages at
once), payloads are given raw for replay.

Memory follows what is asked for, not the bag's size. The scan keeps, for each intact chunk, where it
lies in the file, the CRC-32 of its bytes as read, and per channel the chunk's message count and log time
span; the messages stay in the file (``bag.blocks``). A topic is read when asked for (``decode``,
``decode_batches``, ``raw``, ``shapes``), one chunk at a time: the chunk is read again, must hash to the
CRC it was verified with (a file changed since is a BagError, never other data), and its records are
taken as in the scan. ``decode`` holds the topic's decoded columns, ``decode_batches`` one batch of
them. Messages outside chunks and the records recovered from damaged chunks are held from the scan.
``read_bag(stream=False)`` holds every message from the scan instead (the reference the streamed reads
are tested against).

A recording split into several files (rosbag2's ``--max-bag-size``/``--max-bag-duration``) is one bag:
its files are scanned in the order metadata.yaml lists them (by name without metadata), and a topic's
channels in each file are one channel of the bag, its messages in log-time order across the files.
"""

from __future__ import annotations

import contextlib
import heapq
import zlib
from collections.abc import Generator, Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

import numpy as np
from mcap.records import Header
from numpy.typing import NDArray

from pendulum_accel.bag.blocks import Block, ChannelData, ChunkRef, Lazy, block_payloads, first_payload
from pendulum_accel.bag.chunks import ChunkReader, Part
from pendulum_accel.bag.errors import BagError, ReaderError
from pendulum_accel.bag.integrity import ChunkDamage, chunk_head
from pendulum_accel.bag.locate import locate
from pendulum_accel.bag.lock import LOCK_NAME, Holder, holder, writer_of
from pendulum_accel.bag.messages import TopicChoice, chain_topic, find_topic, stored_roles
from pendulum_accel.bag.metadata import listed_custom_data
from pendulum_accel.bag.records import RECORD_ERRORS, decompress, message_index
from pendulum_accel.bag.scan import Scanner
from pendulum_accel.bag.shapes import (
    Classified,
    Columns,
    DecodedBlock,
    ShapeBook,
    TopicArrays,
    classify,
    decode_block,
    joined,
)


@dataclass(frozen=True)
class TopicInfo:
    """One topic of a bag: name, message type, serialization, offered QoS (YAML text), message count."""

    name: str
    msgtype: str
    serialization_format: str
    offered_qos_profiles: str
    count: int


CHUNKS_KEPT = 4
"""Chunks read again that a Bag keeps, so that passes over several topics in step read each chunk once."""
_T = TypeVar("_T")


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
        self.metadata: dict[str, object] | None = None
        """metadata.yaml as parsed, when it is a mapping (unchecked: metadata.listed_counts reads it)."""
        self.custom_data: dict[str, str] = {}
        self.damage: list[ChunkDamage] = []
        """Damaged chunks (and damage between chunks) in file order; empty when every CRC matched."""
        self.missing_files: tuple[str, ...] = ()
        """Files of the recording that metadata.yaml lists and that are not there."""
        self.damaged_files: list[Path] = []
        """The MCAP files whose own scan found a problem (cut off, corrupt, a CRC mismatch), in order."""
        self.recording: Holder | None = None
        """The process writing the bag now (its lock, bag/lock.py), if another: its end is not written yet."""
        self.abandoned: Holder | None = None
        """The writer whose lock file is left without its lock: it ended without closing the bag."""
        self._channels: dict[int, ChannelData] = {}
        self._parts: list[Part] = []
        # Chunks read again lately: (file, offset) -> (channels read, their messages), for passes in step.
        self._kept: dict[tuple[int, int], tuple[frozenset[int], dict[int, ChannelData]]] = {}
        # topic -> the shapes of its last complete pass: the contract check and later decodes share them.
        self._shape_cache: dict[str, ShapeBook] = {}
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

    def _channels_of(self, topic: str, msgtype: str | None) -> list[ChannelData]:
        """Channels of ``topic``; BagError when it is absent or has another type than ``msgtype``."""
        chans = [ch for ch in self._channels.values() if ch.topic == topic]
        if not chans:
            known = ", ".join(sorted(self.topics)) or "none"
            raise ReaderError(f"bag {self.path} has no topic {topic} (topics: {known})")
        types = {ch.msgtype for ch in chans}
        if msgtype is not None and types != {msgtype}:
            raise ReaderError(
                f"topic {topic} in {self.path} has type {', '.join(sorted(types))}, expected {msgtype}"
            )
        if len(types) > 1:
            raise ReaderError(f"topic {topic} in {self.path} mixes types {', '.join(sorted(types))}")
        for ch in chans:
            if ch.encoding != "cdr":
                raise ReaderError(f"topic {topic} in {self.path} is {ch.encoding!r}-encoded, expected cdr")
        return chans

    def _load(self, lazy: Lazy, want: frozenset[int]) -> list[Block]:
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
            raise ReaderError(
                f"{self._parts[lazy.ref.part].path}: chunk at byte {lazy.ref.at} no longer holds the "
                "messages it held"
            )
        got.seal()
        return [b for b in got.blocks if not isinstance(b, Lazy)]

    def _read_chunk(self, ref: ChunkRef, want: frozenset[int]) -> dict[int, ChannelData]:
        """The messages of channels ``want`` in one intact chunk, read again from the file; BagError when
        the bytes read are not those the scan verified (the file changed since it was read)."""
        part = self._parts[ref.part]
        spans = [(ref.at + 9, ref.at + 9 + ref.length), *((at + 9, at + 9 + n) for at, n in ref.indexes)]
        low, high = min(a for a, _ in spans), max(b for _, b in spans)
        if high - low <= sum(b - a + 9 for a, b in spans):
            # The chunk and its message indexes follow each other (as MCAP writers lay them): one read.
            whole = memoryview(part.file.read(low, high))
            body, *bodies = [whole[a - low : b - low] for a, b in spans]
        else:
            body, *bodies = [memoryview(part.file.read(a, b)) for a, b in spans]
        crc = zlib.crc32(body)
        for index_body in bodies:
            crc = zlib.crc32(index_body, crc)
        head = chunk_head(body) if len(body) == ref.length and crc == ref.crc else None
        if head is None:
            raise ReaderError(
                f"{part.path} changed since it was read (chunk at byte {ref.at} differs): read it again"
            )
        indexes = [i for i in (message_index(b) for b in bodies) if i is not None]
        reader = ChunkReader(self, part)
        reader.sink, reader.only = {}, want
        # The same bytes as the scan's: the records that preceded an error there precede it here.
        with contextlib.suppress(*RECORD_ERRORS):
            reader.chunk(decompress(head, body[head.records_at :]), indexes, indexed=ref.indexed)
        return reader.sink

    def _cids(self, topics: Sequence[str]) -> frozenset[int]:
        """Ids of the channels of ``topics``."""
        return frozenset(cid for cid, ch in self._channels.items() if ch.topic in topics)

    def _iter_blocks(self, chans: list[ChannelData], want: frozenset[int]) -> Iterator[Block]:
        """Blocks of ``chans`` in channel then file order; a chunk left in the file is read when reached
        (with the channels ``want``)."""
        for ch in chans:
            ch.seal()
            for block in list(ch.blocks):
                if isinstance(block, Lazy):
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
            payloads += block_payloads(data)
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
                if not isinstance(block, Lazy):
                    first = first_payload(block[1])
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
            yield from block_payloads(data)

    def _classify_blocks(
        self, topic: str, msgtype: str | None, want: frozenset[int] | None = None
    ) -> Iterator[tuple[NDArray[np.int64], Classified]]:
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
        book = ShapeBook()
        for times, payloads in self._iter_blocks(chans, self._cids([topic]) if want is None else want):
            yield times, classify(mtype, book, payloads)
        self._shape_cache[topic] = book

    def _shape_pass(self, topic: str, want: frozenset[int]) -> Generator[None, None, None]:
        """A pass over ``topic`` for its shapes (cached at its end), yielding after each block."""
        for _ in self._classify_blocks(topic, None, want):
            yield

    def find_shapes(self, topics: Sequence[str]) -> None:
        """Find the shapes of ``topics`` (those present, not yet known) in one pass over the file."""
        todo = [t for t in dict.fromkeys(topics) if t in self.topics and t not in self._shape_cache]
        want = self._cids(todo)
        self._in_step({t: self._shape_pass(t, want) for t in todo})

    def _shape_book(self, topic: str, msgtype: str | None) -> ShapeBook:
        """The shapes of ``topic`` (type-checked), from the cache or from a pass over it."""
        self._channels_of(topic, msgtype)
        if topic not in self._shape_cache:
            for _ in self._classify_blocks(topic, msgtype):
                pass
        return self._shape_cache[topic]

    def shapes(self, topic: str, msgtype: str | None = None) -> list[tuple[object, int]]:
        """(first decoded message, message count) of each shape of ``topic`` (strings, frame, names, sizes).

        A cheap look at what a topic holds (e.g. which joints a JointState names) without decoding every
        message: a shape is every message equal to the first outside the numeric fields.
        """
        return [(s.msg, s.count) for s in self._shape_book(topic, msgtype).shapes]

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
        columns: Columns = {}
        filled = 0
        for times, classified in self._classify_blocks(topic, msgtype, want):
            wanted, (t, cols) = decode_block(topic, mtype, times, classified, wanted)
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
            out = joined(topic, mtype, [], fields)
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
        parts: list[DecodedBlock] = []
        held = 0
        given = False
        for times, classified in self._classify_blocks(topic, msgtype):
            wanted, kept = decode_block(topic, mtype, times, classified, wanted)
            if kept[0].size:
                parts.append(kept)
                held += int(kept[0].size)
            if held >= rows:
                yield joined(topic, mtype, parts, wanted)
                parts, held, given = [], 0, True
        self._note_skipped(topic)
        if parts or not given:
            yield joined(topic, mtype, parts, wanted if given else fields)

    def iter_raw(self, topics: Sequence[str] | None = None) -> Iterator[tuple[str, int, bytes]]:
        """(topic, log_time_ns, cdr) of the chosen topics (default all), merged in log-time order."""
        names = list(self.topics) if topics is None else list(topics)
        streams = []
        for name in names:
            times, payloads = self.raw(name)
            streams.append(zip(times.tolist(), [name] * len(payloads), payloads, strict=True))
        for t, name, data in heapq.merge(*streams, key=lambda item: item[0]):
            yield name, t, data


def stored_choice(path: Path | str) -> TopicChoice:
    """The TopicChoice of the recording's stored topic map (metadata.yaml), without reading the MCAP."""
    return TopicChoice(stored_roles(listed_custom_data(locate(Path(path)).doc)))


def read_bag(path: Path | str, *, salvage: bool = True, stream: bool = True) -> Bag:
    """Scan a bag directory (or .mcap file): every CRC checked, every message counted.

    ``stream`` (default): each intact chunk's messages stay in the file until their topic is asked for,
    then are read chunk by chunk (memory follows what is decoded, not the bag); False holds every message
    in memory from the scan. A truncated or corrupt file keeps what precedes the damage and sets
    ``bag.problem``; with ``salvage=False`` that is a BagError instead. Missing, empty or non-MCAP
    input: BagError.
    """
    found = locate(Path(path))
    bag = Bag(found.root, found.files)
    for index, mcap_path in enumerate(found.files):
        try:
            bag._parts.append(Part(index, mcap_path))
        except OSError as err:
            raise ReaderError(f"cannot read {mcap_path}: {err.strerror}") from None
    if isinstance(found.doc, dict):
        bag.metadata = found.doc
        bag.custom_data.update(listed_custom_data(found.doc))
    bag.problem = found.missing
    bag.missing_files = found.gone
    writer = _lock_holder(found.root)
    for part in bag._parts:
        try:
            Scanner(bag, part, stream=stream).scan()
        except BagError as err:
            writer = writer if writer is not None else writer_of(bag.mcap_paths)
            if writer is None or writer.ours:
                raise
            if writer.live:
                # Before the recorder's first flush its file is empty: nothing to summarise yet.
                raise ReaderError(
                    f"bag {bag.path} is being recorded by {writer.describe()}; nothing is written yet ({err})"
                ) from None
            raise ReaderError(f"{err}: its writer {writer.describe()} ended without closing it") from None
    bag.choice.roles.update(stored_roles(bag.custom_data))
    if writer is None and bag.problem is not None:
        # Cut off, and no lock of ours: a recorder of another make may be writing it (rosbag2 marks
        # nothing, ros2/rosbag2#1597); only a scan that found a problem pays for the look through /proc.
        writer = writer_of(bag.mcap_paths)
    if writer is not None and writer.live and not writer.ours:
        bag.recording = writer
        # A live file has no footer yet; what the scan took for damage is the end still being written.
        bag.problem = f"bag {bag.path} is being recorded by {writer.describe()}"
        if not salvage:
            raise ReaderError(
                f"{bag.problem}: its end is not written yet; run this again once the recording ends, or "
                f"pass --salvage to use the {bag.message_count} messages written so far"
            )
    elif writer is not None and not writer.live:
        bag.abandoned = writer
    if bag.problem is not None and not salvage:
        raise ReaderError(
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


def _lock_holder(root: Path) -> Holder | None:
    """The holder of the lock of the bag at ``root`` (its directory's, or a bare .mcap file's directory's
    when that holds the lock file); None without one."""
    directory = root if root.is_dir() else root.parent
    if not (directory / LOCK_NAME).exists():
        return None
    return holder(directory)


def salvage_note(bag: Bag) -> str | None:
    """One line for a damaged bag or one being recorded: the damage and what was kept; None for an intact
    one."""
    if bag.problem is None:
        return None
    if bag.recording is not None:
        return (
            f"{bag.problem}: read the {bag.message_count} messages written so far (its end is not written "
            "yet: read it again once the recording ends)"
        )
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
