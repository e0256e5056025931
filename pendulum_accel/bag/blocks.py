"""Where a bag's messages are held between the scan and a read: blocks, per channel, in file order.

A block holds messages in memory: (log times, payloads), the payloads as (n, size) rows, as equal-size
slices left in their verified chunk (``Slices``: copied out only when their topic is read), or as a
list of bytes. A chunk's messages left in the file are a ``Lazy`` entry instead: the chunk's place and
CRC (``ChunkRef``), the channel's message count and log time span there; a read takes them again from
the file. ``ChannelData`` keeps one MCAP channel's blocks in file order and whether its log times ever
go back.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.bag.records import gather


@dataclass(frozen=True)
class Slices:
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
        return gather(self.data, self.starts, self.size)


Payloads = NDArray[np.uint8] | Slices | list[bytes]
Block = tuple[NDArray[np.int64], Payloads]
"""Messages in file order: (log times, payloads as (n, size) rows, slices of a chunk, or a list of bytes)."""


def first_payload(data: Payloads) -> bytes | None:
    """A block's first payload (None when it holds none), without copying the others out."""
    if isinstance(data, Slices):
        start = int(data.starts[0]) if data.starts.size else None
        return None if start is None else data.data[start : start + data.size].tobytes()
    if isinstance(data, np.ndarray):
        return data[0].tobytes() if data.shape[0] else None
    return data[0] if data else None


def block_payloads(data: Payloads) -> list[bytes]:
    """A block's payloads as bytes, one per message, in order."""
    if isinstance(data, Slices):
        data = data.rows()
    return [row.tobytes() for row in data] if isinstance(data, np.ndarray) else data


@dataclass(frozen=True)
class ChunkRef:
    """Where an intact chunk lies: in the bag's file number ``part``, its Chunk record at file offset ``at``
    (body ``length`` bytes), the (offset, body length) of the MessageIndex records read with it, and the
    CRC-32 of those bodies, in that order, as the scan read and verified them."""

    part: int
    at: int
    length: int
    indexes: tuple[tuple[int, int], ...]
    crc: int


@dataclass(frozen=True)
class Lazy:
    """The ``count`` messages of channel ``cid`` in one intact chunk, left in the file; log times in
    [t_min, t_max]."""

    ref: ChunkRef
    cid: int
    count: int
    t_min: int
    t_max: int


@dataclass
class ChannelData:
    """Messages of one MCAP channel in file order."""

    topic: str
    msgtype: str
    encoding: str
    qos: str
    blocks: list[Block | Lazy] = field(default_factory=list)
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

    def add_block(self, times: NDArray[np.int64], payloads: Slices | list[bytes]) -> None:
        """Append a bulk-read block after the walked messages so far."""
        self.seal()
        self._note(times)
        self.blocks.append((times, payloads))
        self.sealed += int(times.size)

    def add_lazy(self, lazy: Lazy, times: NDArray[np.int64]) -> None:
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
        lows = [b.t_min if isinstance(b, Lazy) else int(b[0].min()) for b in self.blocks if block_size(b)]
        highs = [b.t_max if isinstance(b, Lazy) else int(b[0].max()) for b in self.blocks if block_size(b)]
        return (min(lows), max(highs)) if lows else None


def block_size(block: Block | Lazy) -> int:
    """Messages in a block."""
    return block.count if isinstance(block, Lazy) else int(block[0].size)
