"""Where a bag's messages are held between the scan and a read: blocks, per channel, in file order.

A block holds messages in memory: (log times, payloads), the payloads as slices left in their verified
chunk (``Slices``: copied out only when their topic is read) or as a list of bytes. A chunk's messages
left in the file are a ``Lazy`` entry instead: the chunk's place and CRC (``ChunkRef``), the channel's
message count and log time span there; a read takes them again from the file. ``ChannelData`` keeps
one MCAP channel's blocks in file order and whether its log times ever go back.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray


def gather(arr: NDArray[np.uint8], starts: NDArray[np.int64], width: int) -> NDArray[np.uint8]:
    """(n, width) bytes arr[s : s + width] for each start s."""
    # Copying whole rows of a window view beats an element-wise index, the more so the wider the rows.
    rows: NDArray[np.uint8] = sliding_window_view(arr, width)[starts]
    return rows


@dataclass(frozen=True)
class Slices:
    """Payloads left in their verified chunk: ``data[s : s + z]`` for each start s and size z, in order.

    Copied out only when their topic is asked for: a topic nobody reads costs no copy.
    """

    data: NDArray[np.uint8]
    starts: NDArray[np.int64]
    sizes: NDArray[np.int64]

    def groups(self) -> list[tuple[NDArray[np.int64], NDArray[np.uint8]]]:
        """(indices, (n, size) rows) of the payloads of each size, sizes ascending."""
        if not self.starts.size:
            return []
        first = int(self.sizes[0])
        if bool(np.all(self.sizes == first)):
            return [(np.arange(self.starts.size), gather(self.data, self.starts, first))]
        out = []
        for size in np.unique(self.sizes).tolist():
            sel = np.flatnonzero(self.sizes == size)
            out.append((sel, gather(self.data, self.starts[sel], size)))
        return out

    def payloads(self) -> list[bytes]:
        """Each payload as bytes, in order."""
        data = self.data
        return [
            data[s : s + z].tobytes() for s, z in zip(self.starts.tolist(), self.sizes.tolist(), strict=True)
        ]


Payloads = Slices | list[bytes]
Block = tuple[NDArray[np.int64], Payloads]
"""Messages in file order: (log times, payloads as slices of a chunk or a list of bytes)."""


def first_payload(data: Payloads) -> bytes | None:
    """A block's first payload (None when it holds none), without copying the others out."""
    if isinstance(data, Slices):
        if not data.starts.size:
            return None
        start = int(data.starts[0])
        return data.data[start : start + int(data.sizes[0])].tobytes()
    return data[0] if data else None


def block_payloads(data: Payloads) -> list[bytes]:
    """A block's payloads as bytes, one per message, in order."""
    return data.payloads() if isinstance(data, Slices) else data


@dataclass(frozen=True)
class ChunkRef:
    """Where an intact chunk lies: in the bag's file number ``part``, its Chunk record at file offset ``at``
    (body ``length`` bytes), the (offset, body length) of the MessageIndex records read with it, and the
    CRC-32 of those bodies, in that order, as the scan read and verified them; ``indexed``: the scan found
    every message record of the chunk through those indexes (Scanner.chunk)."""

    part: int
    at: int
    length: int
    indexes: tuple[tuple[int, int], ...]
    crc: int
    indexed: bool = False


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
