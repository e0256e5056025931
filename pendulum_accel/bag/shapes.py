"""A topic's messages by shape, decoded column-wise: what ``Bag.decode`` and ``Bag.shapes`` are made of.

A *shape* is every message equal to a first one outside the numeric fields of its
:class:`~pendulum_accel.bag.cdr_layout.Layout` (strings, frame, joint names, sequence lengths). A pass
over a topic classifies each block's payloads by shape (``classify``), the shapes found so far kept in
a ``ShapeBook``: rows matching a known shape are taken in bulk; the first row of a new shape is decoded
by the typestore and its layout learnt; rows that decode but not as the typestore writes them are
re-serialised one by one; rows that do not decode are counted as skipped. ``decode_block`` then reads
the wanted fields of each shape's rows with numpy, and ``joined`` puts blocks' columns one after the
other into ``TopicArrays``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.bag.blocks import Payloads, Slices
from pendulum_accel.bag.cdr_layout import Layout, rows_from_bytes
from pendulum_accel.bag.errors import BagError, ReaderError
from pendulum_accel.bag.messages import canonical_cdr, deserialize, stamp_seconds

Column = NDArray[Any]
"""One decoded field, a value per message. Any: its dtype is the field's (float64, int32, uint8, bool,
str), known only once the message type is read; a caller takes the column of a field it named as that
field's type."""
Columns = dict[str, Column]
"""Decoded fields by path (``position[0]``)."""
DecodedBlock = tuple[NDArray[np.int64], Columns]
"""(log times, columns) of one block of a topic's messages."""


@dataclass(frozen=True)
class TopicArrays:
    """Decoded columns of one topic: ``log_time_ns`` and ``fields[path]`` (e.g. ``position[0]``)."""

    topic: str
    msgtype: str
    log_time_ns: NDArray[np.int64]
    fields: Columns

    def __len__(self) -> int:
        """Number of messages."""
        return int(self.log_time_ns.size)

    def __getitem__(self, path: str) -> Column:
        """Column of field ``path``; BagError naming the topic when the messages have no such field."""
        try:
            return self.fields[path]
        except KeyError:
            raise ReaderError(
                f"topic {self.topic} ({self.msgtype}) messages have no field {path!r}"
            ) from None

    @property
    def stamp(self) -> NDArray[np.float64]:
        """t = header.stamp (or clock for Clock) in seconds; log time when the type has no stamp."""
        for prefix in ("header.stamp", "clock"):
            if f"{prefix}.sec" in self.fields:
                return stamp_seconds(self.fields[f"{prefix}.sec"], self.fields[f"{prefix}.nanosec"])
        return self.log_time_ns.astype(np.float64) * 1e-9


@dataclass
class Shape:
    """Messages of one shape: equal outside the numeric fields of ``layout``; ``msg`` the first decoded."""

    layout: Layout
    msg: object
    count: int = 0


@dataclass
class ShapeBook:
    """What one pass over a topic found: shapes taken in bulk (in the order found), shapes of messages
    decoded one by one (by layout), and the count of messages that do not decode."""

    bulk: list[Shape] = field(default_factory=list)
    canonical: dict[bytes, Shape] = field(default_factory=dict)
    skipped: int = 0

    @property
    def shapes(self) -> list[Shape]:
        """Every shape with messages: the bulk ones, then those decoded one by one."""
        return [s for s in (*self.bulk, *self.canonical.values()) if s.count]


Classified = list[tuple[Shape, NDArray[np.int64], NDArray[np.uint8]]]
"""(shape, indices within the block, rows) of one block's messages that decode."""


def _size_groups(payloads: Payloads) -> list[tuple[NDArray[np.int64], NDArray[np.uint8]]]:
    """(indices within the block, (n, size) rows), one group per payload size, sizes ascending."""
    if isinstance(payloads, Slices):
        return payloads.groups()
    lengths = np.fromiter(map(len, payloads), dtype=np.int64, count=len(payloads))
    groups = []
    for size in np.unique(lengths).tolist():
        sel = np.flatnonzero(lengths == size)
        groups.append((sel, rows_from_bytes([payloads[i] for i in sel])))
    return groups


def classify(mtype: str, book: ShapeBook, payloads: Payloads) -> Classified:
    """(shape, indices, rows) of one block's messages that decode, by the shapes in ``book`` (those found
    in earlier blocks first, new ones added); the others are counted in ``book.skipped``."""
    out: Classified = []

    def take(shape: Shape, idx: NDArray[np.int64], rows: NDArray[np.uint8], ok: NDArray[np.bool_]) -> None:
        """Give the rows ``ok`` to ``shape`` (no copy when they are all of them)."""
        whole = bool(ok.all())
        shape.count += idx.size if whole else int(ok.sum())
        out.append((shape, idx, rows) if whole else (shape, idx[ok], rows[ok]))

    for idx, rows in _size_groups(payloads):
        todo = np.ones(idx.size, dtype=bool)
        for shape in book.bulk:
            if not todo.any():
                break
            if shape.layout.size == rows.shape[1]:
                ok = todo & shape.layout.matches(rows)
                if ok.any():
                    take(shape, idx, rows, ok)
                    todo &= ~ok
        while todo.any():
            first = int(np.flatnonzero(todo)[0])
            try:
                msg = deserialize(rows[first].tobytes(), mtype)
                layout = Layout.of(msg, mtype)
            except BagError:
                todo[first] = False  # does not decode: skipped
                book.skipped += 1
                continue
            ok = todo & layout.matches(rows)
            if not ok[first]:
                # Decodes, but not as the typestore writes it: the rest of this size, one by one.
                out += _canonical(mtype, book, idx[todo], rows[todo])
                break
            shape = Shape(layout, msg)
            book.bulk.append(shape)
            take(shape, idx, rows, ok)
            todo &= ~ok
    return out


def _canonical(mtype: str, book: ShapeBook, idx: NDArray[np.int64], rows: NDArray[np.uint8]) -> Classified:
    """Shapes of messages decoded one by one, each row replaced by its typestore re-serialisation."""
    groups: dict[bytes, tuple[Shape, list[int], list[bytes]]] = {}
    for i, row in zip(idx.tolist(), rows, strict=True):
        try:
            msg, canonical = canonical_cdr(row.tobytes(), mtype)
            layout = Layout.of(msg, mtype)
        except BagError:
            book.skipped += 1
            continue
        key = layout.mask.tobytes() + layout.template[layout.mask].tobytes()
        shape = book.canonical.setdefault(key, Shape(layout, msg))
        shape.count += 1
        entry = groups.setdefault(key, (shape, [], []))
        entry[1].append(i)
        entry[2].append(canonical)
    return [(shape, np.array(i, dtype=np.int64), rows_from_bytes(r)) for shape, i, r in groups.values()]


def decode_block(
    topic: str, mtype: str, times: NDArray[np.int64], classified: Classified, wanted: list[str] | None
) -> tuple[list[str] | None, DecodedBlock]:
    """(the fields wanted, (log times, columns) of one block's messages that decode, in file order).

    ``wanted`` None: every field of the first shape met. BagError when a shape lacks a wanted field.
    """
    n = times.size
    columns: Columns = {}
    assigned = np.zeros(n, dtype=bool)
    for shape, idx, rows in classified:
        if wanted is None:
            wanted = list(shape.layout.fields)
        missing = [p for p in wanted if p not in shape.layout.fields]
        if missing:
            at = int(times[int(idx[0])])
            raise ReaderError(
                f"topic {topic} ({mtype}): the message logged at {at} ns has no field {missing[0]!r}"
            )
        for path, col in shape.layout.decode(rows, wanted).items():
            if path not in columns:
                columns[path] = np.zeros(n, dtype=col.dtype)
            columns[path][idx] = col
        assigned[idx] = True
    if not assigned.all():
        return wanted, (times[assigned], {p: c[assigned] for p, c in columns.items()})
    return wanted, (times, columns)


def joined(
    topic: str,
    mtype: str,
    parts: list[DecodedBlock],
    fields: Sequence[str] | None,
) -> TopicArrays:
    """TopicArrays of blocks' (log times, columns) one after the other; no blocks: empty ``fields``."""
    if not parts:
        return TopicArrays(topic, mtype, np.zeros(0, dtype=np.int64), {p: np.zeros(0) for p in fields or ()})
    if len(parts) == 1:
        return TopicArrays(topic, mtype, parts[0][0], parts[0][1])
    times = np.concatenate([t for t, _ in parts])
    return TopicArrays(
        topic, mtype, times, {p: np.concatenate([c[p] for _, c in parts]) for p in parts[0][1]}
    )
