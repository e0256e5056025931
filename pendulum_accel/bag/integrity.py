"""MCAP checksums and record recovery: what the reader verifies and what a damaged chunk still yields.

The checksums are the MCAP specification's zlib CRC-32s: a chunk's ``uncompressed_crc`` covers its
uncompressed records; DataEnd's ``data_section_crc`` covers the file from its leading magic through
the last record before DataEnd (0 in either means "not computed"). The data section CRC is built from
the chunk CRCs already verified with ``crc32_combine`` (zlib's algorithm), so each byte of chunk data
is hashed once.

A chunk whose CRC does not match, that does not inflate, or that the end of the file cuts off is not
thrown away whole: ``recover_messages`` keeps each of its message records that is intact, meaning
that it frames (opcode 0x05, a length that fits), names a known channel, carries a log time inside
the chunk's [message_start, message_end], and whose payload decodes as CDR of the channel's type.
A CRC cannot say which record holds the damage, so a record whose damage leaves it decodable (a
flipped bit inside a float) passes these checks: recovered records are counted apart and reported.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

import numpy as np
import zstandard

from pendulum_accel.bag.errors import BagError
from pendulum_accel.bag.messages import TYPESTORE, deserialize

OP_MESSAGE, OP_SCHEMA, OP_CHANNEL = 0x05, 0x03, 0x04
_RECORD_HEAD = struct.Struct("<BQ")
_MESSAGE_HEAD = struct.Struct("<BQHIQ")
_MESSAGE_DATA_OFFSET = 31  # opcode 1 + length 8 + channel 2 + sequence 4 + log time 8 + publish time 8
_CHUNK_HEAD = struct.Struct("<QQQII")  # start, end, uncompressed size, crc, compression string length

_POLY = 0xEDB88320  # CRC-32 (IEEE 802.3), reflected, as zlib


def _multmodp(a: int, b: int) -> int:
    """a·b modulo the CRC-32 polynomial (reflected bit order, zlib's multmodp)."""
    m = 1 << 31
    p = 0
    while True:
        if a & m:
            p ^= b
            if (a & (m - 1)) == 0:
                return p
        m >>= 1
        b = (b >> 1) ^ _POLY if b & 1 else b >> 1


def _x2n_table() -> list[int]:
    """x^(2^k) modulo the polynomial for k = 0..31."""
    table = [1 << 30]  # x^1
    for _ in range(31):
        table.append(_multmodp(table[-1], table[-1]))
    return table


_X2N = _x2n_table()


def crc32_combine(crc1: int, crc2: int, len2: int) -> int:
    """crc32(A + B) from crc1 = crc32(A), crc2 = crc32(B) and len(B): crc1·x^(8·len2) mod P xor crc2."""
    p = 1 << 31  # x^0
    n, k = len2, 3  # x^(8·len2) = product of x^(2^k) over the set bits of len2, shifted by 3
    while n:
        if n & 1:
            p = _multmodp(_X2N[k & 31], p)
        n >>= 1
        k += 1
    return _multmodp(p, crc1) ^ crc2


@dataclass(frozen=True)
class ChunkDamage:
    """One damaged stretch: a chunk (1-based position in the file) or, with chunk None, the records
    between chunks. ``recovered`` message records were kept by parsing, ``dropped`` were not intact."""

    chunk: int | None
    start_ns: int
    end_ns: int
    reason: str
    recovered: int = 0
    dropped: int = 0
    file: str = ""
    """The MCAP file's name when the bag is split into several ("": the bag's one file)."""

    def span(self, origin_ns: int) -> str:
        """'chunk 4, 3.012–3.998 s' (times from the chunk's message start/end, relative to origin_ns);
        'bag_1.mcap chunk 4, …' in a bag of several files."""
        where = f"{self.file} " if self.file else ""
        if self.chunk is None:
            return f"{where}outside the chunks"
        t0 = (self.start_ns - origin_ns) * 1e-9
        t1 = (self.end_ns - origin_ns) * 1e-9
        return f"{where}chunk {self.chunk}, {t0:.3f}–{t1:.3f} s"

    def sentence(self, origin_ns: int) -> str:
        """'chunk 4, 3.012–3.998 s: CRC mismatch; 812 message records recovered by parsing, 1 dropped'."""
        text = f"{self.span(origin_ns)}: {self.reason}"
        if self.chunk is not None:
            text += f"; {self.recovered} message records recovered by parsing"
            text += f", {self.dropped} dropped as not intact"
        return text


def damage_origin(start_ns: int, damage: Iterable[ChunkDamage]) -> int:
    """The bag's start for damage times: its first log time read, or a damaged chunk's earlier start."""
    starts = [d.start_ns for d in damage if d.chunk is not None and d.start_ns]
    return min([start_ns, *starts]) if starts else start_ns


@dataclass(frozen=True)
class ChunkHead:
    """The fields before a Chunk record's records, read without the records (which may be cut off)."""

    start_ns: int
    end_ns: int
    uncompressed_size: int
    crc: int
    compression: str
    records_at: int
    """Offset of the (compressed) records within the chunk record's body."""


def chunk_head(body: bytes | memoryview) -> ChunkHead | None:
    """ChunkHead of a Chunk record body (complete or cut off); None when even its fields are cut off."""
    if len(body) < _CHUNK_HEAD.size:
        return None
    start, end, size, crc, clen = _CHUNK_HEAD.unpack_from(body, 0)
    at = _CHUNK_HEAD.size + clen + 8
    if at > len(body):
        return None
    try:
        compression = bytes(body[_CHUNK_HEAD.size : _CHUNK_HEAD.size + clen]).decode()
    except UnicodeDecodeError:
        return None
    return ChunkHead(start, end, size, crc, compression, at)


def inflate_prefix(head: ChunkHead, packed: bytes | memoryview) -> bytes:
    """As much of the uncompressed records as ``packed`` (cut off or damaged) still yields, in order."""
    if head.compression == "":
        return bytes(packed)
    if head.compression != "zstd":
        return b""
    out: list[bytes] = []
    decoder = zstandard.ZstdDecompressor().decompressobj()
    step = 1 << 16  # feed in pieces: a damaged frame then costs only the piece it is found in
    try:
        for at in range(0, len(packed), step):
            out.append(decoder.decompress(bytes(packed[at : at + step])))
    except zstandard.ZstdError:
        pass
    return b"".join(out)[: head.uncompressed_size]


def _framed_offsets(data: bytes, on_record: Callable[[int, memoryview], None]) -> tuple[list[int], int]:
    """(offsets of message records, offset where framing broke or len(data)) walking data from 0;
    schema and channel records go to ``on_record(opcode, body)`` as they are met."""
    view = memoryview(data)
    pos, size = 0, len(data)
    found: list[int] = []
    while pos + 9 <= size:
        op, length = _RECORD_HEAD.unpack_from(data, pos)
        end = pos + 9 + length
        if op not in (OP_MESSAGE, OP_SCHEMA, OP_CHANNEL) or end > size:
            return found, pos
        if op == OP_MESSAGE:
            found.append(pos)
        else:
            on_record(op, view[pos + 9 : end])
        pos = end
    return found, pos


def _plausible_offsets(data: bytes, start: int, channels: Iterable[int], t_min: int, t_max: int) -> list[int]:
    """Offsets ≥ start that look like message record heads (opcode, a length that fits, a known
    channel, a log time in [t_min, t_max]): where to pick the walk up again after broken framing."""
    arr = np.frombuffer(data, dtype=np.uint8)
    last = arr.size - _MESSAGE_DATA_OFFSET
    if last < start:
        return []
    cand = np.flatnonzero(arr[start : last + 1] == OP_MESSAGE) + start
    if cand.size == 0:
        return []
    idx = cand[:, None] + np.arange(_MESSAGE_DATA_OFFSET)
    heads = arr[idx]
    length = heads[:, 1:9].copy().view("<u8")[:, 0]
    cid = heads[:, 9:11].copy().view("<u2")[:, 0]
    log = heads[:, 15:23].copy().view("<u8")[:, 0]
    ok = (length >= 22) & (length <= arr.size - cand - 9)
    ok &= np.isin(cid, np.fromiter(channels, dtype=np.uint16))
    ok &= (log >= np.uint64(t_min)) & (log <= np.uint64(t_max))
    return [int(c) for c in cand[ok]]


def recover_messages(
    data: bytes,
    head: ChunkHead,
    index_offsets: Iterable[int],
    on_record: Callable[[int, memoryview], None],
    msgtypes: Callable[[], Mapping[int, str]],
) -> tuple[list[tuple[int, int, bytes]], int]:
    """([(channel id, log time, payload)] of the intact message records of damaged chunk records
    ``data``, count of message records found but not intact, the one cut off at a break included).

    Candidates: the records met walking from the start until the framing breaks, the offsets of the
    chunk's message indexes, and past a break every offset that looks like a message head. Taken in
    offset order, a candidate is kept when it does not overlap the last kept record and is intact
    (see the module docstring). ``on_record`` registers the schemas and channels the walk meets;
    ``msgtypes()`` then gives channel id -> message type.
    """
    walked, broke_at = _framed_offsets(data, on_record)
    types = dict(msgtypes())
    known = set(walked) | {int(o) for o in index_offsets}
    cands = set(known)
    if broke_at < len(data):
        cands |= set(_plausible_offsets(data, broke_at, types, head.start_ns, head.end_ns))
    kept: list[tuple[int, int, bytes]] = []
    # The record the framing broke at (cut off, or its head damaged) is lost unless a candidate starts there.
    dropped = 1 if broke_at < len(data) and broke_at not in cands else 0
    after = 0  # end of the last kept record
    for pos in sorted(cands):
        if pos < after or pos + _MESSAGE_DATA_OFFSET > len(data):
            continue
        op, length, cid, _, log_time = _MESSAGE_HEAD.unpack_from(data, pos)
        end = pos + 9 + length
        msgtype = types.get(cid)
        intact = (
            op == OP_MESSAGE
            and length >= 22
            and end <= len(data)
            and msgtype is not None
            and msgtype in TYPESTORE.types
            and head.start_ns <= log_time <= head.end_ns
        )
        payload = data[pos + _MESSAGE_DATA_OFFSET : end] if intact else b""
        if intact and msgtype is not None:
            try:
                deserialize(payload, msgtype)
            except BagError:
                intact = False
        if intact:
            kept.append((cid, log_time, payload))
            after = end
        elif pos in known:
            dropped += 1
    return kept, dropped
