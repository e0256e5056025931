"""MCAP file writer (format v0, ``ros2`` profile) written from the specification, https://mcap.dev/spec.

Layout, the one rosbag2's writers use: magic, Header; then chunks, each followed by one MessageIndex
per channel it holds (schemas and channels are written into the chunk that is open when they are
added); the ``rosbag2`` Metadata record (``serialized_metadata``); DataEnd; the summary (schemas,
channels, chunk indexes, metadata index, statistics) with its summary offsets; Footer; magic.

Checksums as the ``mcap`` library's writer and rosbag2's MCAP storage write them, and one more: every
chunk's ``uncompressed_crc`` (zlib CRC-32 of its uncompressed records), the summary CRC in the Footer
(the summary section through the Footer's ``summary_offset_start`` field), and the data section CRC in
DataEnd (everything from the leading magic through the last record before DataEnd), which both leave
0 by default. A zero CRC means "not computed" to readers, so a file written here is checked end to end.

Messages go in one at a time (``write_message``) or many at once (``append``, records laid out by the
caller); a chunk is closed once its data passes ``CHUNK_BYTES`` or on ``flush``, so a killed process
loses at most the open chunk. Only public numpy, struct and zstandard calls: nothing here depends on
another MCAP writer's internals.
"""

from __future__ import annotations

import struct
import zlib
from collections import defaultdict
from collections.abc import Mapping
from io import BytesIO
from pathlib import Path
from typing import BinaryIO

import numpy as np
import zstandard
from numpy.typing import NDArray

from pendulum_accel.bag.integrity import crc32_combine

MAGIC = b"\x89MCAP0\r\n"
PROFILE = "ros2"
CHUNK_BYTES = 2**20
"""A chunk is closed after the message that takes its uncompressed data past this many bytes."""
COMPRESSIONS = ("", "zstd")

OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE = 0x01, 0x02, 0x03, 0x04, 0x05
OP_CHUNK, OP_MESSAGE_INDEX, OP_CHUNK_INDEX, OP_STATISTICS = 0x06, 0x07, 0x08, 0x0B
OP_METADATA, OP_METADATA_INDEX, OP_SUMMARY_OFFSET, OP_DATA_END = 0x0C, 0x0D, 0x0E, 0x0F

MESSAGE_HEADER = struct.Struct("<BQHIQQ")
"""Message record up to its data: opcode, record length, channel id, sequence, log time, publish time."""
_NO_TIME = 2**63 - 1
IndexEntries = NDArray[np.uint64]
"""(n, 2) uint64 rows (log time, offset of the message record in the chunk's data)."""


def string(value: str) -> bytes:
    """MCAP string: uint32 byte length, UTF-8 bytes."""
    data = value.encode()
    return struct.pack("<I", len(data)) + data


def string_map(entries: Mapping[str, str]) -> bytes:
    """MCAP map<string, string>: uint32 byte length, then key and value strings."""
    body = b"".join(string(k) + string(v) for k, v in entries.items())
    return struct.pack("<I", len(body)) + body


def record(opcode: int, body: bytes) -> bytes:
    """One MCAP record: opcode, uint64 body length, body."""
    return struct.pack("<BQ", opcode, len(body)) + body


class _Chunk:
    """The open chunk: its records, log time range, and message-index entries per channel."""

    def __init__(self) -> None:
        """Empty: no records, an empty time range."""
        self.data = BytesIO()
        self.start_ns = _NO_TIME
        self.end_ns = 0
        self.index: defaultdict[int, list[IndexEntries | tuple[int, int]]] = defaultdict(list)
        self.messages = 0


def _index_entries(parts: list[IndexEntries | tuple[int, int]]) -> IndexEntries:
    """(n, 2) little-endian uint64 (log time, offset) from single entries and (k, 2) blocks, in order."""
    blocks: list[IndexEntries] = []
    run: list[tuple[int, int]] = []
    for item in parts:
        if isinstance(item, np.ndarray):
            if run:
                blocks.append(np.asarray(run, dtype=np.uint64))
                run = []
            blocks.append(item)
        else:
            run.append(item)
    if run:
        blocks.append(np.asarray(run, dtype=np.uint64))
    return np.concatenate(blocks).astype("<u8") if blocks else np.zeros((0, 2), dtype="<u8")


class McapFile:
    """An MCAP file being written: ``add_schema``, ``add_channel``, messages, ``flush``, ``close``."""

    def __init__(self, path: Path, *, library: str, compression: str = "") -> None:
        """Create ``path`` (it must not exist) and write the magic and the Header record."""
        if compression not in COMPRESSIONS:
            raise ValueError(f"unknown chunk compression {compression!r}; use one of {COMPRESSIONS}")
        self.path = path
        self.compression = compression
        self._file: BinaryIO = path.open("xb")
        self.data_crc = 0
        """zlib CRC-32 of every byte written so far, up to DataEnd (the data section CRC)."""
        self._write(MAGIC + record(OP_HEADER, string(PROFILE) + string(library)))
        self._schemas: list[bytes] = []
        self._channels: list[bytes] = []
        self._chunk_indexes: list[bytes] = []
        self._chunk = _Chunk()
        self.counts: dict[int, int] = {}
        """Messages written so far per channel id."""
        self.start_ns = _NO_TIME
        self.end_ns = 0

    def _write(self, data: bytes) -> None:
        """Write data-section bytes: data_crc = crc32(data, data_crc), then to the file."""
        self.data_crc = zlib.crc32(data, self.data_crc)
        self._file.write(data)

    @property
    def chunk_size(self) -> int:
        """Bytes of records in the open chunk."""
        return self._chunk.data.tell()

    def add_schema(self, name: str, encoding: str, data: str) -> int:
        """Add a Schema record (ids count from 1); returns its id."""
        schema_id = len(self._schemas) + 1
        rec = record(OP_SCHEMA, struct.pack("<H", schema_id) + string(name) + string(encoding) + string(data))
        self._schemas.append(rec)
        self._chunk.data.write(rec)
        return schema_id

    def add_channel(
        self, schema_id: int, topic: str, message_encoding: str, metadata: Mapping[str, str]
    ) -> int:
        """Add a Channel record (ids count from 1); returns its id."""
        channel_id = len(self._channels) + 1
        body = struct.pack("<HH", channel_id, schema_id) + string(topic) + string(message_encoding)
        rec = record(OP_CHANNEL, body + string_map(metadata))
        self._channels.append(rec)
        self.counts[channel_id] = 0
        self._chunk.data.write(rec)
        return channel_id

    def write_message(self, channel_id: int, log_time_ns: int, data: bytes | memoryview) -> None:
        """Append one Message record (sequence 0, publish time = log time) to the open chunk."""
        chunk = self._chunk
        offset = chunk.data.tell()
        chunk.data.write(
            MESSAGE_HEADER.pack(OP_MESSAGE, 22 + len(data), channel_id, 0, log_time_ns, log_time_ns)
        )
        chunk.data.write(data)
        chunk.index[channel_id].append((log_time_ns, offset))
        self._count(channel_id, 1, log_time_ns, log_time_ns)
        if chunk.data.tell() > CHUNK_BYTES:
            self.close_chunk()

    def append(self, records: memoryview | bytes, index: Mapping[int, IndexEntries]) -> None:
        """Append Message records laid out by the caller: ``index`` maps channel id to (log time, offset
        of the record within ``records``) rows, channels in order of first appearance. The chunk is not
        closed here: the caller splits where it wants (``chunk_size``, ``close_chunk``)."""
        chunk = self._chunk
        base = chunk.data.tell()
        for channel_id, entries in index.items():
            if entries.shape[0] == 0:
                continue
            rows = np.array(entries, dtype=np.uint64)
            rows[:, 1] += np.uint64(base)
            chunk.index[channel_id].append(rows)
            times = rows[:, 0]
            self._count(channel_id, int(rows.shape[0]), int(times.min()), int(times.max()))
        chunk.data.write(records)

    def _count(self, channel_id: int, n: int, t_min: int, t_max: int) -> None:
        """Count n messages of a channel with log times in [t_min, t_max] in the chunk and the file."""
        chunk = self._chunk
        chunk.messages += n
        chunk.start_ns = min(chunk.start_ns, t_min)
        chunk.end_ns = max(chunk.end_ns, t_max)
        self.start_ns = min(self.start_ns, t_min)
        self.end_ns = max(self.end_ns, t_max)
        self.counts[channel_id] += n

    def close_chunk(self) -> None:
        """Write the open chunk (compressed as configured) and its message indexes; start a new one."""
        chunk, self._chunk = self._chunk, _Chunk()
        raw = chunk.data.getvalue()
        packed = zstandard.compress(raw) if self.compression == "zstd" else raw
        tail = string(self.compression) + struct.pack("<Q", len(packed))
        # uncompressed_crc = crc32 of the uncompressed records, as mcap's and rosbag2's writers compute it.
        crc = zlib.crc32(raw)
        head = struct.pack("<QQQI", chunk.start_ns, chunk.end_ns, len(raw), crc)
        chunk_start = self._file.tell()
        prefix = struct.pack("<BQ", OP_CHUNK, len(head) + len(tail) + len(packed)) + head + tail
        if packed is raw:
            # Uncompressed: the record ends with the records, whose CRC is known; one pass over them.
            self.data_crc = crc32_combine(zlib.crc32(prefix, self.data_crc), crc, len(raw))
            self._file.write(prefix)
            self._file.write(raw)
        else:
            self._write(prefix + packed)
        chunk_end = self._file.tell()
        offsets = []
        for channel_id, parts in chunk.index.items():
            offsets.append(struct.pack("<HQ", channel_id, self._file.tell()))
            entries = _index_entries(parts)
            body = struct.pack("<HI", channel_id, entries.nbytes) + entries.tobytes()
            self._write(record(OP_MESSAGE_INDEX, body))
        index_length = self._file.tell() - chunk_end
        body = struct.pack(
            "<QQQQI", chunk.start_ns, chunk.end_ns, chunk_start, chunk_end - chunk_start, 10 * len(offsets)
        )
        body += b"".join(offsets) + struct.pack("<Q", index_length) + tail + struct.pack("<Q", len(raw))
        self._chunk_indexes.append(record(OP_CHUNK_INDEX, body))

    def flush(self) -> None:
        """Close the open chunk if it holds messages, and push the file to the OS."""
        if self._chunk.messages:
            self.close_chunk()
        self._file.flush()

    def close(self, rosbag2_metadata: str) -> None:
        """Close the open chunk; write the rosbag2 Metadata record, DataEnd, summary, Footer, magic."""
        if self._chunk.data.tell():
            self.close_chunk()
        out = self._file
        metadata_start = out.tell()
        self._write(
            record(OP_METADATA, string("rosbag2") + string_map({"serialized_metadata": rosbag2_metadata}))
        )
        metadata_end = out.tell()
        out.write(record(OP_DATA_END, struct.pack("<I", self.data_crc)))
        # The summary section and the Footer up to its summary_crc field, collected for that CRC.
        summary = BytesIO()
        groups: list[tuple[int, int, int]] = []
        summary_start = out.tell()

        def group(opcode: int, records: list[bytes]) -> None:
            """Add a summary group and note its (opcode, file offset, length) if it is not empty."""
            start = summary_start + summary.tell()
            summary.write(b"".join(records))
            if summary_start + summary.tell() != start:
                groups.append((opcode, start, summary_start + summary.tell() - start))

        group(OP_SCHEMA, self._schemas)
        group(OP_CHANNEL, self._channels)
        group(OP_CHUNK_INDEX, self._chunk_indexes)
        index = struct.pack("<QQ", metadata_start, metadata_end - metadata_start) + string("rosbag2")
        group(OP_METADATA_INDEX, [record(OP_METADATA_INDEX, index)])
        counts = b"".join(struct.pack("<HQ", cid, n) for cid, n in sorted(self.counts.items()))
        stats = struct.pack(
            "<QHIIIIQQI",
            sum(self.counts.values()),
            len(self._schemas),
            len(self._channels),
            0,  # attachments
            1,  # metadata records
            len(self._chunk_indexes),
            self.start_ns,
            self.end_ns,
            len(counts),
        )
        group(OP_STATISTICS, [record(OP_STATISTICS, stats + counts)])
        offsets_start = summary_start + summary.tell()
        for opcode, start, length in groups:
            summary.write(record(OP_SUMMARY_OFFSET, struct.pack("<BQQ", opcode, start, length)))
        summary.write(struct.pack("<BQQQ", OP_FOOTER, 20, summary_start, offsets_start))
        tail = summary.getvalue()
        out.write(tail + struct.pack("<I", zlib.crc32(tail)) + MAGIC)
        out.close()

    def abort(self) -> None:
        """Close the file as it is (no summary): what a killed process leaves, for tests and errors."""
        self._file.close()
