"""The scan of one MCAP file of a bag, front to back: records, chunks, CRCs, and what damage leaves.

The schemas and channels the file's summary repeats are registered first (when the footer and the
summary's CRC hold: a writer may put a channel's only other record inside a chunk, which damage can
take). Then every top-level record is framed (opcode, length) and checked against the file size;
Header, Schema, Channel, Chunk and Metadata records are parsed by the ``mcap`` library; a chunk's
records go to the bag's channels through ``bag.chunks`` (in bulk where its message indexes agree with
them), the small records between chunks come from one read (``records.ReadAhead``). Every chunk's
CRC and the data section CRC are verified (``bag.integrity``). A chunk whose data is damaged (CRC
mismatch, does not inflate, cut off by the end of the file) is listed in ``bag.damage`` and only its
intact message records are kept (``integrity.recover_messages``); the scan goes on with the next
record, since its framing still holds. When the framing itself breaks (a record cut off or with a
damaged opcode or length), the scan stops there, and the chunks after the damage are read through the
chunk index of the MCAP summary when the file still has its footer. A file whose recorder was killed
(no summary) reads up to its last flushed chunk.

Streaming (``Scanner(stream=True)``, what ``read_bag`` does by default), an intact chunk's messages stay
in the file: each channel gets a ``blocks.Lazy`` entry (the chunk's place and CRC, the channel's count
and log time span there, and whether its message indexes found every message), and ``Bag`` reads the
chunk again when a topic in it is asked for, through a ``chunks.ChunkReader`` that takes only the
channels wanted.
"""

from __future__ import annotations

import contextlib
import dataclasses
import struct
import zlib
from io import BytesIO
from typing import TYPE_CHECKING

import numpy as np
import yaml
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import ChunkIndex, Metadata
from numpy.typing import NDArray

from pendulum_accel.bag.blocks import ChunkRef, Lazy, first_payload
from pendulum_accel.bag.chunks import CUT_OFF, ChunkReader, Part
from pendulum_accel.bag.errors import MalformedRecordError, ReaderError
from pendulum_accel.bag.integrity import (
    ChunkDamage,
    ChunkHead,
    chunk_head,
    crc32_combine,
    damage_origin,
    inflate_prefix,
    recover_messages,
)
from pendulum_accel.bag.mcap_file import MAGIC
from pendulum_accel.bag.metadata import load_yaml
from pendulum_accel.bag.records import (
    OPCODES,
    RECORD_ERRORS,
    RECORD_HEAD,
    ReadAhead,
    decompress,
    message_index,
    summary_span,
)

if TYPE_CHECKING:
    from pendulum_accel.bag.reader import Bag


class _RefBuilder:
    """A chunk's ChunkRef under construction: its MessageIndex records are added as the scan meets them."""

    def __init__(self, part: int, at: int, length: int, crc: int) -> None:
        """The Chunk record at ``at`` of file ``part`` (body ``length`` bytes, CRC-32 ``crc``)."""
        self.part, self.at, self.length, self.crc = part, at, length, crc
        self.indexes: list[tuple[int, int]] = []

    def add(self, at: int, body: bytes | memoryview) -> None:
        """A MessageIndex record at ``at`` read with the chunk."""
        self.indexes.append((at, len(body)))
        self.crc = zlib.crc32(body, self.crc)

    def ref(self, indexed: bool) -> ChunkRef:
        """The finished reference; ``indexed``: the scan read the chunk by its message indexes alone."""
        return ChunkRef(self.part, self.at, self.length, tuple(self.indexes), self.crc, indexed)


class Scanner(ChunkReader):
    """Front-to-back MCAP scan that records schemas, channels and messages into a Bag."""

    def __init__(self, bag: Bag, part: Part, *, stream: bool = False) -> None:
        """Scan state for ``bag``'s file ``part``; ``stream``: leave intact chunks' messages in it."""
        super().__init__(bag, part)
        self.file = part.file
        self.stream = stream
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
        the file: each channel gets the chunk's count and log time span (``Lazy``)."""
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
        tally = builder is not None and self.stream
        if tally:
            self.sink = {}
        indexed = False
        try:
            indexed = self.chunk(data, indexes)
        except RECORD_ERRORS as err:
            start, end = (head.start_ns, head.end_ns) if head is not None else (0, 0)
            self._damaged(ChunkDamage(number, start, end, f"malformed records ({err})"))
        finally:
            if builder is not None and tally and self.sink is not None:
                ref = builder.ref(indexed)
                sink, self.sink = self.sink, None
                for cid, got in sink.items():
                    got.seal()
                    times = [b[0] for b in got.blocks if not isinstance(b, Lazy)]
                    if got.count:
                        t = np.concatenate(times)
                        lazy = Lazy(ref, cid, got.count, int(t.min()), int(t.max()))
                        channel = self.bag._channels[cid]
                        if channel.sealed == 0 and not channel.payloads and channel.head is None:
                            first = next(b for b in got.blocks if not isinstance(b, Lazy))
                            channel.head = first_payload(first[1])
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
            with contextlib.suppress(*RECORD_ERRORS):
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
                raise MalformedRecordError(
                    f"records length {records_length} does not match the record's {len(packed)}"
                )
            if head.compression == "" and len(packed) != head.uncompressed_size:
                raise MalformedRecordError("chunk data is shorter than its declared size")
            data = decompress(head, packed)
            if len(data) != head.uncompressed_size:
                raise MalformedRecordError(
                    f"inflates to {len(data)} bytes, declared {head.uncompressed_size}"
                )
            crc = zlib.crc32(data)
            if head.crc and crc != head.crc:
                raise MalformedRecordError("CRC mismatch")
        except RECORD_ERRORS as err:
            self.pending_damage = str(err)
            return inflate_prefix(head, packed)
        if head.compression == "":
            # The records are the body's tail: crc32(body) from the head's bytes and the records' CRC.
            self.body_crc = crc32_combine(zlib.crc32(body[: head.records_at]), crc, len(data))
        return data

    def _extend_data_crc(self, head: bytes, body: memoryview, body_crc: int | None = None) -> None:
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
        read, size = ReadAhead(self.file).read, self.file.size
        magic = read(0, len(MAGIC))
        if magic != MAGIC:
            what = "empty" if size == 0 else "not an MCAP file (bad magic bytes)"
            if len(bag.mcap_paths) == 1:
                raise ReaderError(f"{self.path} is {what}")
            # One file of a split recording (a recorder killed as it opened the next file): the others
            # are still the recording.
            bag.problem = f"{self.path} is {what}"
            self.part.ending = what
            return 0
        self.data_crc = zlib.crc32(magic)
        pos = len(MAGIC)
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
            op, length = RECORD_HEAD.unpack_from(head, 0)
            stop = pos + 9 + length
            if op not in OPCODES or op == 0:
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
                    index = message_index(body)
                    if index is not None:
                        self.pending[1].append(index)
                        if self.pending_ref is not None:
                            self.pending_ref.add(pos, body)
                    self._extend_data_crc(head, body)
                else:
                    self._flush_chunk()
                    if op == Opcode.FOOTER:
                        self.part.complete = True
                        return None
                    if op == Opcode.CHUNK:
                        self.chunks_seen += 1
                        chunk_data = self._open_chunk(body, pos, self.chunks_seen)
                        body_crc = self.body_crc if self.body_crc is not None else zlib.crc32(body)
                        self._extend_data_crc(head, body, body_crc)
                        if chunk_data is not None:
                            self.pending, self.pending_at = (chunk_data, []), pos
                            if self.pending_damage is None:
                                self.pending_ref = _RefBuilder(self.part.index, pos, len(body), body_crc)
                    elif op == Opcode.DATA_END:
                        self._data_end(body)
                    else:
                        self._top_level(op, body)
                        self._extend_data_crc(head, body)
            except RECORD_ERRORS as err:
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
        span = summary_span(self.file, len(MAGIC))
        if span is None:
            return
        start, tail, crc = span
        try:
            # The CRC covers the summary and the footer through its summary_offset_start field.
            if crc and zlib.crc32(self.file.read(start, tail + 25)) != crc:
                return
            self._summary(self.file.read(start, tail), chunks=False)
        except RECORD_ERRORS:
            return

    def _indexed_chunks(self, broken_at: int) -> int:
        """Read the chunks the summary's chunk index places past ``broken_at``; how many were read.

        Needs the footer (last 37 bytes) and a summary section; the schemas and channels it repeats are
        registered first. Each chunk and its message indexes are read as in the scan; a damaged one is
        skipped and noted. Nothing happens without a usable summary (a killed recorder writes none).
        """
        read = self.file.read
        span = summary_span(self.file, broken_at)
        if span is None:
            return 0
        start, tail, _ = span
        try:
            indexes = self._summary(read(start, tail))
        except RECORD_ERRORS:
            return 0
        count = 0
        for number, entry in enumerate(sorted(indexes, key=lambda e: e.chunk_start_offset), start=1):
            at = int(entry.chunk_start_offset)
            if at < broken_at or at in self.read_chunks or at + entry.chunk_length > start:
                continue
            try:
                op, length = RECORD_HEAD.unpack_from(read(at, at + 9), 0)
                if op != Opcode.CHUNK or at + 9 + length > start:
                    raise MalformedRecordError("the chunk index points at no chunk record")
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
                    mop, mlen = RECORD_HEAD.unpack_from(read(off, off + 9), 0)
                    index_body = memoryview(read(off + 9, off + 9 + mlen))
                    found = message_index(index_body)
                    if mop == Opcode.MESSAGE_INDEX and found is not None:
                        message_indexes.append(found)
                        if builder is not None:
                            builder.add(off, index_body)
            except RECORD_ERRORS as err:
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
            op, length = RECORD_HEAD.unpack_from(data, pos)
            end = pos + 9 + length
            if end > stop:
                raise MalformedRecordError(f"summary record at byte {pos} overruns the summary")
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
