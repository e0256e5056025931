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
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.reader import SeekingReader
from mcap.records import Chunk, ChunkIndex

from pendulum_accel.bag.errors import MalformedRecordError, NotIndexedError, ReaderError
from pendulum_accel.bag.integrity import ChunkHead
from pendulum_accel.bag.locate import locate
from pendulum_accel.bag.records import RECORD_HEAD, decompress

_INDEX_HEAD = 1 + 8 + 2 + 4  # MessageIndex record: opcode, length, channel id, entries byte length
_ENTRY = struct.Struct("<QQ")  # (log time, offset in the chunk)
# A message record's body: channel id, sequence, log time (publish time next).
_MESSAGE_HEAD = struct.Struct("<HIQ")
_OP_MESSAGE = int(Opcode.MESSAGE)


@dataclass(frozen=True)
class FileChunk:
    """One chunk of a bag's file number ``part`` (a split recording has several files): its index entry."""

    part: int
    index: ChunkIndex

    @property
    def message_start_time(self) -> int:
        """Log time of the chunk's first message (ns)."""
        return int(self.index.message_start_time)

    @property
    def message_end_time(self) -> int:
        """Log time of the chunk's last message (ns)."""
        return int(self.index.message_end_time)


class StreamedBag:
    """Topics, time span and time-ordered messages of one bag, read through its chunk index; a split
    recording's files are read as one bag."""

    def __init__(self, path: Path | str) -> None:
        """Open the bag's MCAP files and read their summaries; NotIndexedError when one has no chunk index."""
        found = locate(Path(path))
        self.path, mcap_paths = found.root, found.files
        if found.missing is not None:
            # What is there is read whole by bag.reader, which names what is missing.
            raise NotIndexedError(found.missing)
        self._files: list[BinaryIO] = []
        self.chunks: list[FileChunk] = []
        self.topics: dict[str, str] = {}
        self._channels: dict[str, list[tuple[int, int]]] = {}
        try:
            for part, mcap_path in enumerate(mcap_paths):
                self._open(part, mcap_path, len(mcap_paths) > 1)
        except BaseException:
            self.close()
            raise
        self.chunks.sort(key=lambda c: c.message_start_time)
        self.start_ns = min(c.message_start_time for c in self.chunks)
        self.end_ns = max(c.message_end_time for c in self.chunks)

    def _open(self, part: int, mcap_path: Path, split: bool) -> None:
        """Open file number ``part``, add its chunks and channels; NotIndexedError without a chunk index."""
        handle: BinaryIO = open(mcap_path, "rb")  # noqa: SIM115 (closed by close())
        self._files.append(handle)
        what = f"bag {self.path}" + (f" ({mcap_path.name})" if split else "")
        try:
            summary = SeekingReader(handle).get_summary()
        except (McapError, ValueError, OSError, EOFError, struct.error) as err:
            raise NotIndexedError(f"{what}: no readable summary ({err})") from None
        if summary is None or not summary.chunk_indexes:
            raise NotIndexedError(f"{what} has no chunk index (its recording did not close)")
        self.chunks += [FileChunk(part, c) for c in summary.chunk_indexes]
        for channel_id, channel in summary.channels.items():
            schema = summary.schemas.get(channel.schema_id)
            self.topics.setdefault(channel.topic, schema.name if schema is not None else "")
            self._channels.setdefault(channel.topic, []).append((part, channel_id))

    def close(self) -> None:
        """Close the files."""
        for handle in self._files:
            handle.close()

    def messages(
        self, topics: Sequence[str], first_ns: int, last_ns: int
    ) -> Iterator[tuple[str, int, bytes]]:
        """(topic, log time ns, CDR) of ``topics`` with first_ns ≤ log time ≤ last_ns, in log-time order
        (ties: file order).

        Chunks are taken in order of their first message; one is decoded when the messages held so far
        all come after its start (chunks that overlap in time are merged), so a bag whose chunks
        follow each other holds one decoded chunk at a time.
        """
        wanted = {key: topic for topic in topics for key in self._channels.get(topic, [])}
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
        self, where: FileChunk, wanted: dict[tuple[int, int], str], first_ns: int, last_ns: int
    ) -> list[tuple[int, str, bytes]]:
        """The (log time, topic, CDR) of one chunk's messages on ``wanted`` (file, channel id)s inside the
        window, sorted by log time (stable); BagError when its CRC (if written) does not match."""
        index, handle = where.index, self._files[where.part]
        handle.seek(index.chunk_start_offset + 1 + 8)
        chunk = Chunk.read(ReadDataStream(handle))
        try:
            head = ChunkHead(
                chunk.message_start_time,
                chunk.message_end_time,
                chunk.uncompressed_size,
                chunk.uncompressed_crc,
                chunk.compression,
                0,
            )
            data = decompress(head, chunk.data)
        except MalformedRecordError as err:
            raise ReaderError(f"bag {self.path}: chunk at byte {index.chunk_start_offset}: {err}") from None
        if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
            raise ReaderError(f"bag {self.path}: chunk at byte {index.chunk_start_offset} fails its CRC")
        out: list[tuple[int, str, bytes]] = []
        at, end = 0, len(data)
        record, message = RECORD_HEAD.unpack_from, _MESSAGE_HEAD.unpack_from
        while at + 9 <= end:
            opcode, length = record(data, at)
            body = at + 9
            if opcode == _OP_MESSAGE and length >= 22:
                channel, _sequence, log_time = message(data, body)
                topic = wanted.get((where.part, channel))
                if topic is not None and first_ns <= log_time <= last_ns:
                    out.append((log_time, topic, bytes(data[body + 22 : body + length])))
            at = body + length
        if any(out[i][0] > out[i + 1][0] for i in range(len(out) - 1)):
            out.sort(key=lambda m: m[0])
        return out

    def count(self, topics: Sequence[str], first_ns: int, last_ns: int) -> int:
        """Messages of ``topics`` with first_ns ≤ log time ≤ last_ns: a chunk wholly inside by its index
        records' lengths, a chunk across an edge by reading its index entries (never the chunk itself)."""
        wanted = {key for topic in topics for key in self._channels.get(topic, [])}
        total = 0
        for where in self.chunks:
            chunk, handle = where.index, self._files[where.part]
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
                if (where.part, channel_id) not in wanted:
                    continue
                n = (end - offset - _INDEX_HEAD) // _ENTRY.size
                if inside:
                    total += n
                    continue
                handle.seek(offset + _INDEX_HEAD)
                entries = handle.read(n * _ENTRY.size)
                total += sum(
                    1
                    for t, _ in _ENTRY.iter_unpack(entries[: len(entries) // _ENTRY.size * _ENTRY.size])
                    if first_ns <= t <= last_ns
                )
        return total
