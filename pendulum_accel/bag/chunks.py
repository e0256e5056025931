"""One chunk's records into a bag's channels: in bulk through its message indexes, by walking elsewhere.

A chunk's MessageIndex records (one per channel) list each message's log time and offset. Where they
agree with the records themselves (``records.indexed_records``: opcode, channel, lengths, no overlap),
each channel's messages are taken at once, as slices of the chunk (``blocks.Slices``); the gaps between
indexed messages (schemas, channels, unindexed messages) are walked record by record, and a chunk whose
index disagrees is walked whole. ``ChunkReader.chunk`` says whether the indexes alone found every message:
a chunk read again later, its bytes the same (its CRC says so), is then taken for the channels wanted
through their own index entries only. ``Scanner`` (``bag.scan``) reads each chunk with this in the scan,
``Bag`` when it reads a chunk again.
"""

from __future__ import annotations

import itertools
from io import BytesIO
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Schema
from numpy.typing import NDArray

from pendulum_accel.bag.blocks import ChannelData
from pendulum_accel.bag.errors import MalformedRecordError
from pendulum_accel.bag.records import (
    MESSAGE_DATA_OFFSET,
    MESSAGE_HEAD,
    RECORD_HEAD,
    OpenFile,
    indexed_records,
    messages_at,
    unaligned,
)

if TYPE_CHECKING:
    from pendulum_accel.bag.reader import Bag


CUT_OFF = "cut off before its footer"
FRAMING_BROKEN = "record framing broken"


class Part:
    """One MCAP file of a bag (a split recording has several, in recording order): its path, the open
    file, its schemas by id, and its channel ids mapped to the bag's (``cids``). A later file's channel
    of the same topic, type and encoding joins the earlier file's, so a topic stays one channel, in
    log-time order, across the files; an id of its own is ``part << 16 | id`` (MCAP ids are 16-bit)."""

    def __init__(self, index: int, path: Path) -> None:
        """File number ``index`` of the bag, at ``path``; OSError when it cannot be opened."""
        self.index, self.path = index, path
        self.file = OpenFile(path)
        self.schemas: dict[int, Schema] = {}
        self.cids: dict[int, int] = {}
        self.complete = False
        """The scan read this file to its footer."""
        self.ending = FRAMING_BROKEN
        """Why the scan stopped before the footer (when not ``complete``)."""


class ChunkReader:
    """Reads chunks of ``bag``'s file ``part`` into the bag's channels, or into ``sink`` (by bag channel id)
    when set; ``only``: the bag channel ids taken from a chunk (None: all)."""

    def __init__(self, bag: Bag, part: Part) -> None:
        """Chunk reading for ``bag``'s file ``part``, into the bag."""
        self.bag = bag
        self.part = part
        self.schemas = part.schemas
        self.cids = part.cids
        self.path = part.path
        # Where a chunk's messages go while it is read to be left in the file (None: into the bag).
        self.sink: dict[int, ChannelData] | None = None
        self.only: frozenset[int] | None = None  # reading a chunk again: the channels wanted from it
        self.walked = 0  # message records met by walking (not through a message index)

    def schema(self, body: memoryview) -> None:
        """Register a Schema record."""
        rec = Schema.read(ReadDataStream(BytesIO(body)))
        self.schemas[rec.id] = rec

    def channel(self, body: memoryview) -> None:
        """Register a Channel record (its schema names the message type)."""
        rec = Channel.read(ReadDataStream(BytesIO(body)))
        schema = self.schemas.get(rec.schema_id)
        if rec.schema_id != 0 and schema is None:
            raise MalformedRecordError(
                f"channel {rec.id} ({rec.topic}) refers to unknown schema {rec.schema_id}"
            )
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
            channels[cid] = ChannelData(rec.topic, msgtype, rec.message_encoding, qos)

    def _target(self, local: int) -> ChannelData | None:
        """Where this file's channel ``local``'s messages go: the bag's channel, or the sink's; None for
        an unknown one."""
        cid = self.cids.get(local)
        ch = None if cid is None else self.bag._channels.get(cid)
        if ch is None or cid is None or self.sink is None:
            return ch
        got = self.sink.get(cid)
        if got is None:
            got = self.sink[cid] = ChannelData(ch.topic, ch.msgtype, ch.encoding, ch.qos, track=False)
        return got

    def walk(self, data: bytes | memoryview, start: int, stop: int) -> None:
        """Walk the records of data[start:stop] (inside one chunk); MalformedRecordError at the first
        malformed one."""
        view = memoryview(data)
        pos = start
        unpack_message = MESSAGE_HEAD.unpack_from
        while pos < stop:
            if pos + 9 > stop:
                raise MalformedRecordError(f"record header cut off at chunk byte {pos}")
            op, length = RECORD_HEAD.unpack_from(data, pos)
            end = pos + 9 + length
            if end > stop:
                raise MalformedRecordError(f"record at chunk byte {pos} overruns its chunk")
            if op == Opcode.MESSAGE:
                if length < 22:
                    raise MalformedRecordError(f"message record at chunk byte {pos} is too short")
                _, _, cid, _, log_time = unpack_message(data, pos)
                ch = self._target(cid)
                if ch is None:
                    raise MalformedRecordError(f"message at chunk byte {pos} on unknown channel {cid}")
                ch.times.append(log_time)
                ch.payloads.append(bytes(data[pos + MESSAGE_DATA_OFFSET : end]))
                self.walked += 1
            elif op == Opcode.SCHEMA:
                self.schema(view[pos + 9 : end])
            elif op == Opcode.CHANNEL:
                self.channel(view[pos + 9 : end])
            else:
                raise MalformedRecordError(
                    f"opcode 0x{op:02x} at chunk byte {pos} does not belong in a chunk"
                )
            pos = end

    def chunk(
        self,
        data: bytes | memoryview,
        indexes: list[tuple[int, NDArray[np.uint64]]],
        *,
        indexed: bool = False,
    ) -> bool:
        """Read one uncompressed chunk, in bulk where its message index tiles it, by walking elsewhere;
        True when its message indexes alone located every message record (nothing walked but schemas and
        channels).

        The index offsets are checked against the records themselves (opcode, channel, lengths,
        no overlap); the gaps between indexed messages (schemas, channels, unindexed messages)
        are walked. Anything inconsistent falls back to walking the whole chunk. ``indexed``: these
        very bytes (a chunk read again, its CRC the scan's) returned True in the scan; the wanted
        channels' messages are then taken from their own index entries, without checking the index
        again or looking at the other channels' records.
        """
        end = len(data)
        if indexed:
            self._indexed(data, indexes)
            return True
        found = indexed_records(data, indexes)
        if found is None:
            self.walk(data, 0, end)
            return False
        offs, cids, lengths = found
        walked = self.walked
        ends = offs + 9 + lengths
        gap_starts = np.concatenate(([0], ends))
        gap_stops = np.concatenate((offs, [end]))
        for g in np.flatnonzero(gap_stops > gap_starts).tolist():
            self.walk(data, int(gap_starts[g]), int(gap_stops[g]))
        # Grouped by channel (ids are 16-bit: a stable radix sort), each group in file order.
        by = np.argsort(cids.astype(np.uint16), kind="stable")
        cids, offs, lengths = cids[by], offs[by], lengths[by]
        edges = [0, *(np.flatnonzero(cids[1:] != cids[:-1]) + 1).tolist(), int(cids.size)]
        groups = {int(cids[a]): (a, b) for a, b in itertools.pairwise(edges) if b > a}
        for cid in sorted({cid for cid, _ in indexes}):
            ch = self._target(cid)
            if ch is None:
                raise MalformedRecordError(f"message index refers to unknown channel {cid}")
            if cid in groups and (self.only is None or self.cids.get(cid) in self.only):
                a, b = groups[cid]
                ch.add_block(*messages_at(data, offs[a:b], lengths[a:b]))
        return self.walked == walked

    def _indexed(self, data: bytes | memoryview, indexes: list[tuple[int, NDArray[np.uint64]]]) -> None:
        """chunk(indexed=True): each wanted channel's messages at its index entries' offsets, file order."""
        entries: dict[int, list[NDArray[np.uint64]]] = {}
        for cid, found in indexes:
            if self.only is None or self.cids.get(cid) in self.only:
                entries.setdefault(cid, []).append(found[:, 1])
        for cid in sorted(entries):
            ch = self._target(cid)
            if ch is None:
                raise MalformedRecordError(f"message index refers to unknown channel {cid}")
            offs = np.sort(np.concatenate(entries[cid]).astype(np.int64))
            if offs.size:
                ch.add_block(*messages_at(data, offs, unaligned(data, "<u8")[offs + 1].astype(np.int64)))
