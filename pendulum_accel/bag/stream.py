"""A bag read chunk by chunk through the MCAP summary's chunk index: bounded memory for any bag size.

The player streams with this: ``messages`` goes through the ``mcap`` library's SeekingReader, which
decompresses a chunk only when its first message is due in log-time order, so at most the chunks
overlapping in time are held decoded (one, for a bag whose chunks follow each other). ``count``
counts messages from the chunks' MessageIndex records (16 bytes a message) without decompressing
anything: the progress index and a seek's position are exact. A bag without a summary (its recorder
was killed) has no chunk index: ``StreamedBag`` refuses it with NotIndexedError, and the caller reads
it whole through ``bag.reader`` (which salvages).
"""

from __future__ import annotations

import struct
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import BinaryIO

from mcap.exceptions import McapError
from mcap.reader import SeekingReader
from mcap.records import ChunkIndex

from pendulum_accel.bag.reader import _find_mcap
from pendulum_accel.errors import BagError

_INDEX_HEAD = 1 + 8 + 2 + 4  # MessageIndex record: opcode, length, channel id, entries byte length
_ENTRY = struct.Struct("<QQ")  # (log time, offset in the chunk)


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
        except (McapError, ValueError, OSError, EOFError) as err:
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
        """(topic, log time ns, CDR) of ``topics`` with first_ns ≤ log time ≤ last_ns, in log-time order,
        decompressing one chunk at a time (the library's SeekingReader over the chunk index)."""
        for _, channel, message in self._reader.iter_messages(
            topics=list(topics), starting_at=first_ns, ending_at=last_ns, log_time_order=True
        ):
            yield channel.topic, message.log_time, message.data

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
