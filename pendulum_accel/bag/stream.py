"""A bag read chunk by chunk through the MCAP summary's chunk index: bounded memory for any bag size.

The player streams with this: ``messages`` decompresses a chunk (its CRC checked when written) only
when its first message is due in log-time order, as the ``mcap`` library's SeekingReader does, so at
most the chunks overlapping in time are held decoded (one, for a bag whose chunks follow each other);
the summary comes from the library, the message records are cut with one struct call each. ``count``
counts messages from the chunks' MessageIndex records (16 bytes a message) without decompressing
anything: the progress index and a seek's position are exact. A bag without a summary (its recorder
was killed) has no chunk index: ``StreamedBag`` refuses it with NotIndexedError, and the caller reads
it whole through ``bag.reader`` (which salvages).
"""

from __future__ import annotations

import heapq
import struct
import zlib
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import BinaryIO

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.reader import SeekingReader
from mcap.records import Chunk, ChunkIndex

from pendulum_accel.bag.integrity import ChunkHead
from pendulum_accel.bag.reader import _decompress, _find_mcap
from pendulum_accel.errors import BagError

_INDEX_HEAD = 1 + 8 + 2 + 4  # MessageIndex record: opcode, length, channel id, entries byte length
_ENTRY = struct.Struct("<QQ")  # (log time, offset in the chunk)
# A record's head (opcode, length), then a message's: channel id, sequence, log time (publish time next).
_RECORD_HEAD = struct.Struct("<BQ")
_MESSAGE_HEAD = struct.Struct("<HIQ")
_OP_MESSAGE = int(Opcode.MESSAGE)


class NotIndexedError(BagError):
    """The bag has no summary with a chunk index (a killed recording): it cannot be streamed."""


class StreamedBag:
    """Topics, time span and time-ordered messages of one bag, read through its chunk index."""

    def __init__(self, path: Path | str) -> None:
        """Open the bag's MCAP and read its summary; NotIndexedError without a chunk index."""
        self.path, mcap_path = _find_mcap(Path(path))
        self._file: BinaryIO = open(mcap_path, "rb")  # noqa: SIM115 (closed by close())
        try:
            self._reader = SeekingReader(self._file)
            summary = self._reader.get_summary()
        except (McapError, ValueError, OSError, EOFError, struct.error) as err:
            self._file.close()
            raise NotIndexedError(f"bag {self.path}: no readable summary ({err})") from None
        if summary is None or not summary.chunk_indexes:
            self._file.close()
            raise NotIndexedError(f"bag {self.path} has no chunk index (its recording did not close)")
        self._summary = summary
        self.chunks: list[ChunkIndex] = sorted(summary.chunk_indexes, key=lambda c: c.message_start_time)
        self.topics: dict[str, str] = {}
        self._channels: dict[str, list[int]] = {}
        for channel_id, channel in summary.channels.items():
            schema = summary.schemas.get(channel.schema_id)
            self.topics.setdefault(channel.topic, schema.name if schema is not None else "")
            self._channels.setdefault(channel.topic, []).append(channel_id)
        self.start_ns = min(c.message_start_time for c in self.chunks)
        self.end_ns = max(c.message_end_time for c in self.chunks)

    def close(self) -> None:
        """Close the file."""
        self._file.close()

    def messages(
        self, topics: Sequence[str], first_ns: int, last_ns: int
    ) -> Iterator[tuple[str, int, bytes]]:
        """(topic, log time ns, CDR) of ``topics`` with first_ns ≤ log time ≤ last_ns, in log-time order
        (ties: file order).

        Chunks are taken in order of their first message; one is decoded when the messages held so far
        all come after its start (chunks that overlap in time are merged), so a bag whose chunks
        follow each other holds one decoded chunk at a time.
        """
        wanted = {cid: topic for topic in topics for cid in self._channels.get(topic, [])}
        chunks = [
            c for c in self.chunks if c.message_end_time >= first_ns and c.message_start_time <= last_ns
        ]
        held: list[tuple[int, str, bytes]] = []
        pos = 0
        for chunk in chunks:
            while pos < len(held) and held[pos][0] < chunk.message_start_time:
                yield held[pos][1], held[pos][0], held[pos][2]
                pos += 1
            new = self.decode_chunk(chunk, wanted, first_ns, last_ns)
            rest = held[pos:]
            held = list(heapq.merge(rest, new, key=lambda m: m[0])) if rest else new
            pos = 0
        for t, topic, data in held[pos:]:
            yield topic, t, data

    def decode_chunk(
        self, index: ChunkIndex, wanted: dict[int, str], first_ns: int, last_ns: int
    ) -> list[tuple[int, str, bytes]]:
        """The (log time, topic, CDR) of one chunk's messages on ``wanted`` channels inside the window,
        sorted by log time (stable); BagError when its CRC (if written) does not match."""
        self._file.seek(index.chunk_start_offset + 1 + 8)
        chunk = Chunk.read(ReadDataStream(self._file))
        try:
            head = ChunkHead(
                chunk.message_start_time,
                chunk.message_end_time,
                chunk.uncompressed_size,
                chunk.uncompressed_crc,
                chunk.compression,
                0,
            )
            data = _decompress(head, chunk.data)
        except ValueError as err:
            raise BagError(f"bag {self.path}: chunk at byte {index.chunk_start_offset}: {err}") from None
        if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
            raise BagError(f"bag {self.path}: chunk at byte {index.chunk_start_offset} fails its CRC")
        out: list[tuple[int, str, bytes]] = []
        at, end = 0, len(data)
        record, message = _RECORD_HEAD.unpack_from, _MESSAGE_HEAD.unpack_from
        while at + 9 <= end:
            opcode, length = record(data, at)
            body = at + 9
            if opcode == _OP_MESSAGE and length >= 22:
                channel, _sequence, log_time = message(data, body)
                if channel in wanted and first_ns <= log_time <= last_ns:
                    out.append((log_time, wanted[channel], bytes(data[body + 22 : body + length])))
            at = body + length
        if any(out[i][0] > out[i + 1][0] for i in range(len(out) - 1)):
            out.sort(key=lambda m: m[0])
        return out

    def count(self, topics: Sequence[str], first_ns: int, last_ns: int) -> int:
        """Messages of ``topics`` with first_ns ≤ log time ≤ last_ns: a chunk wholly inside by its index
        records' lengths, a chunk across an edge by reading its index entries (never the chunk itself)."""
        wanted = {cid for topic in topics for cid in self._channels.get(topic, [])}
        total = 0
        for chunk in self.chunks:
            if chunk.message_end_time < first_ns or chunk.message_start_time > last_ns:
                continue
            inside = first_ns <= chunk.message_start_time and chunk.message_end_time <= last_ns
            ordered = sorted(chunk.message_index_offsets.items(), key=lambda item: item[1])
            if not ordered:
                continue
            # The MessageIndex records follow each other: each ends where the next starts, the last at
            # the start of the first plus their total length.
            ends = [offset for _, offset in ordered[1:]] + [ordered[0][1] + chunk.message_index_length]
            for (channel_id, offset), end in zip(ordered, ends, strict=True):
                if channel_id not in wanted:
                    continue
                n = (end - offset - _INDEX_HEAD) // _ENTRY.size
                if inside:
                    total += n
                    continue
                self._file.seek(offset + _INDEX_HEAD)
                entries = self._file.read(n * _ENTRY.size)
                total += sum(
                    1
                    for t, _ in _ENTRY.iter_unpack(entries[: len(entries) // _ENTRY.size * _ENTRY.size])
                    if first_ns <= t <= last_ns
                )
        return total
