"""MCAP records as the reader cuts them: framing, the errors a malformed record raises, chunk data.

The layout is the MCAP specification's (https://mcap.dev/spec): a record is an opcode byte and a
uint64 length, then its body; a Message record's body starts with channel id (uint16), sequence
(uint32), log time and publish time (uint64 each), then the payload. The ``mcap`` library parses the
records read once (Header, Schema, Channel, Chunk, Metadata); the many message records are cut here
with ``struct`` and numpy: in bulk where a chunk's message indexes agree with its records
(``indexed_records``, ``messages_at``). ``decompress`` gives an intact chunk's records, ``OpenFile``
reads the file by offset, ``summary_span`` finds the summary from the footer. Shared by the whole-bag
reader (``bag.scan``, ``bag.reader``) and the streaming one (``bag.stream``).
"""

from __future__ import annotations

import os
import struct
import weakref
from io import BytesIO
from pathlib import Path

import numpy as np
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Footer
from numpy.typing import NDArray

from pendulum_accel.bag.blocks import Slices
from pendulum_accel.bag.errors import MalformedRecordError
from pendulum_accel.bag.integrity import ChunkHead
from pendulum_accel.bag.mcap_file import MAGIC

RECORD_HEAD = struct.Struct("<BQ")
"""A record's head: opcode, body length."""
MESSAGE_HEAD = struct.Struct("<BQHIQ")
"""A Message record up to its log time: opcode, length, channel id, sequence, log time."""
MESSAGE_DATA_OFFSET = 31  # opcode 1 + length 8 + channel 2 + sequence 4 + log time 8 + publish time 8
OPCODES = {int(op) for op in Opcode}
RECORD_ERRORS = (MalformedRecordError, ValueError, struct.error, UnicodeDecodeError, KeyError, IndexError)
"""What a malformed record makes the parsers raise: this reader's own checks MalformedRecordError; the
``mcap`` library's record parsers and ``struct`` struct.error, UnicodeDecodeError (a name that is not
UTF-8), KeyError and IndexError; numpy ValueError (a buffer of the wrong size)."""


class OpenFile:
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


class ReadAhead:
    """A file read front to back: a read of up to ``AHEAD`` bytes is served from one read of ``AHEAD``
    bytes from its start, so that the small records between chunks (message indexes, schemas,
    channels) cost one system call between them rather than two each; a larger read goes to the file."""

    AHEAD = 1 << 17

    def __init__(self, file: OpenFile) -> None:
        """Reads of ``file``, none held yet."""
        self.file = file
        self.at = 0
        self.held = b""

    def read(self, start: int, stop: int) -> bytes:
        """OpenFile.read(start, stop): the file's bytes [start, stop), fewer when the file ends first."""
        if self.at <= start and stop <= self.at + len(self.held):
            return self.held[start - self.at : stop - self.at]
        if stop - start > self.AHEAD:
            return self.file.read(start, stop)
        self.at, self.held = start, self.file.read(start, start + self.AHEAD)
        return self.held[: stop - start]


def decompress(head: ChunkHead, packed: memoryview | bytes) -> bytes | memoryview:
    """Uncompressed chunk records (none or zstd; lz4 when installed); MalformedRecordError when they do not
    inflate.

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
        raise MalformedRecordError(f"{head.compression} chunk does not decompress ({err})") from None
    raise MalformedRecordError(f"unsupported chunk compression {head.compression!r}")


def unaligned(data: bytes | memoryview, dtype: str) -> NDArray[np.generic]:
    """View v of ``data`` with v[i] = the ``dtype`` value in data[i : i + itemsize] (any byte offset i)."""
    width = np.dtype(dtype).itemsize
    view: NDArray[np.generic] = np.ndarray(
        (max(len(data) - width + 1, 0),), dtype=dtype, buffer=data, strides=(1,)
    )
    return view


def message_index(body: memoryview) -> tuple[int, NDArray[np.uint64]] | None:
    """(channel id, (n, 2) log time/offset entries) of a MessageIndex record; None when malformed."""
    if len(body) < 6:
        return None
    cid, nbytes = struct.unpack_from("<HI", body, 0)
    if nbytes != len(body) - 6 or nbytes % 16:
        return None
    entries = np.frombuffer(body, dtype="<u8", offset=6).reshape(-1, 2)
    return cid, entries


def indexed_records(
    data: bytes | memoryview, indexes: list[tuple[int, NDArray[np.uint64]]]
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]] | None:
    """(record offsets, channel ids, record lengths) of the message records that a chunk's MessageIndex
    entries place in its uncompressed records ``data``, in file order; None when the entries and the
    records disagree (not a Message opcode, another channel, shorter than a message's 22 bytes past its
    head, past the end of ``data``, two records overlapping) or there are none."""
    if not indexes:
        return None
    end = len(data)
    offs = np.concatenate([e[:, 1] for _, e in indexes]).astype(np.int64)
    cids = np.concatenate([np.full(e.shape[0], cid, dtype=np.int64) for cid, e in indexes])
    order = np.argsort(offs, kind="stable")
    offs, cids = offs[order], cids[order]
    if offs.size == 0 or offs[0] < 0 or offs[-1] + MESSAGE_DATA_OFFSET > end:
        return None
    lengths = unaligned(data, "<u8")[offs + 1].astype(np.int64)
    ends = offs + 9 + lengths
    if (
        np.any(np.frombuffer(data, dtype=np.uint8)[offs] != Opcode.MESSAGE)
        or np.any(unaligned(data, "<u2")[offs + 9].astype(np.int64) != cids)
        or np.any(lengths < 22)
        or np.any(ends[:-1] > offs[1:])
        or ends[-1] > end
    ):
        return None
    return offs, cids, lengths


def messages_at(
    data: bytes | memoryview, offs: NDArray[np.int64], lengths: NDArray[np.int64]
) -> tuple[NDArray[np.int64], Slices]:
    """(log times, payloads left in ``data``) of the message records at ``offs`` with body ``lengths``:
    log time at offset + 15, payload data[offset + 31 : offset + 9 + length]."""
    log_times = unaligned(data, "<u8")[offs + 15].astype(np.int64)
    payloads = Slices(np.frombuffer(data, dtype=np.uint8), offs + MESSAGE_DATA_OFFSET, lengths - 22)
    return log_times, payloads


def summary_span(file: OpenFile, after: int) -> tuple[int, int, int] | None:
    """(summary start, footer offset, summary CRC) from the file's footer, when the file ends in its
    footer and magic and the summary starts past byte ``after``; None otherwise."""
    size = file.size
    tail = size - len(MAGIC) - 9 - 20
    if tail <= after:
        return None
    end = file.read(tail, size)
    if end[-len(MAGIC) :] != MAGIC or end[0] != Opcode.FOOTER:
        return None
    try:
        footer = Footer.read(ReadDataStream(BytesIO(end[9:29])))
    except RECORD_ERRORS:
        return None
    start = int(footer.summary_start)
    return (start, tail, int(footer.summary_crc)) if after < start <= tail else None
