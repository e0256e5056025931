"""Bulk CDR of fixed-layout messages: the byte offset of each numeric field, learnt from the typestore.

A *fixed-layout* message (JointState with one joint, AccelStamped, AccelWithCovarianceStamped,
Clock, ...) serialises to the same bytes except at the offsets of its numeric fields once its
strings and sequence lengths are fixed. :class:`Layout` learns those offsets from the typestore
serializer itself (it serialises the message twice with two different values in one field and
looks where the bytes differ), so no CDR alignment rule is written here; bulk encoding fills a
serialized template row-wise, bulk decoding reads the field columns back with numpy.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import re
import struct
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray
from rosbags.interfaces import Nodetype

from pendulum_accel.bag.errors import BagError
from pendulum_accel.bag.messages import TYPESTORE, serialize

_NUMERIC: dict[str, str] = {
    "int8": "i1",
    "uint8": "u1",
    "byte": "u1",
    "char": "u1",
    "octet": "u1",
    "int16": "<i2",
    "uint16": "<u2",
    "int32": "<i4",
    "uint32": "<u4",
    "int64": "<i8",
    "uint64": "<u8",
    "float32": "<f4",
    "float64": "<f8",
}


_PATH_TOKEN = re.compile(r"([A-Za-z_][A-Za-z0-9_]*)(?:\[(\d+)\])?")


def _resolve(msg: object, path: str) -> tuple[object, str, int | None]:
    """(parent object, attribute, index or None) that ``path`` (e.g. ``accel.covariance[0]``) names."""
    obj = msg
    parts = path.split(".")
    for part in parts[:-1]:
        m = _PATH_TOKEN.fullmatch(part)
        assert m is not None
        obj = getattr(obj, m.group(1))
        if m.group(2) is not None:
            obj = obj[int(m.group(2))]
    m = _PATH_TOKEN.fullmatch(parts[-1])
    assert m is not None
    return obj, m.group(1), None if m.group(2) is None else int(m.group(2))


def _set_leaf(msg: object, path: str, value: float) -> None:
    """msg.<path> = value, in place (numeric scalar or one element of a numeric array)."""
    parent, attr, index = _resolve(msg, path)
    if index is None:
        setattr(parent, attr, value)
    else:
        # Deserialized arrays are read-only views into the CDR buffer: replace, don't mutate.
        array = np.array(getattr(parent, attr))
        array[index] = value
        setattr(parent, attr, array)


def _fill(msgtype: str, msg: object, byte: int) -> None:
    """Every numeric field of ``msg``, array elements too, set in place to the value whose bytes all equal
    ``byte`` (0: zero); the walk of _numeric_leaves, an array replaced whole (not copied per element)."""
    # Any: rosbags types field definitions as a union by node kind; the kind tag below narrows it.
    fielddefs: list[tuple[str, tuple[Any, Any]]] = TYPESTORE.fielddefs[msgtype][1]
    for name, (kind, detail) in fielddefs:
        value = getattr(msg, name)
        if kind == Nodetype.NAME:
            _fill(detail, value, byte)
        elif kind == Nodetype.BASE and detail[0] in _NUMERIC:
            setattr(msg, name, _filled(_NUMERIC[detail[0]], byte).item())
        elif kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            (sub_kind, sub_detail), _ = detail
            if sub_kind == Nodetype.BASE and sub_detail[0] in _NUMERIC:
                dtype = _NUMERIC[sub_detail[0]]
                setattr(msg, name, np.full(len(value), _filled(dtype, byte), dtype=np.dtype(dtype)))
            elif sub_kind == Nodetype.NAME:
                for item in value:
                    _fill(sub_detail, item, byte)


def _filled(dtype: str, byte: int) -> np.generic:
    """The ``dtype`` scalar whose every byte is ``byte``."""
    value: np.generic = np.frombuffer(bytes([byte] * np.dtype(dtype).itemsize), dtype=dtype)[0]
    return value


def _numeric_leaves(msgtype: str, msg: object, prefix: str = "") -> list[tuple[str, str]]:
    """(path, numpy dtype) of every numeric field of ``msg``, array elements one by one, in field order."""
    leaves: list[tuple[str, str]] = []
    # Any: rosbags types field definitions as a union by node kind; the kind tag below narrows it.
    fielddefs: list[tuple[str, tuple[Any, Any]]] = TYPESTORE.fielddefs[msgtype][1]
    for name, (kind, detail) in fielddefs:
        path = prefix + name
        value = getattr(msg, name)
        if kind == Nodetype.NAME:
            leaves += _numeric_leaves(detail, value, path + ".")
        elif kind == Nodetype.BASE:
            if detail[0] in _NUMERIC:
                leaves.append((path, _NUMERIC[detail[0]]))
        elif kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            (sub_kind, sub_detail), _ = detail
            if sub_kind == Nodetype.BASE and sub_detail[0] in _NUMERIC:
                leaves += [(f"{path}[{i}]", _NUMERIC[sub_detail[0]]) for i in range(len(value))]
            elif sub_kind == Nodetype.NAME:
                for i, item in enumerate(value):
                    leaves += _numeric_leaves(sub_detail, item, f"{path}[{i}].")
    return leaves


def _struct_of(dtype: str) -> struct.Struct:
    """Little-endian struct codec of one numpy scalar dtype (CDR payloads here are little-endian)."""
    return struct.Struct("<" + np.dtype(dtype).char)


@dataclass(frozen=True)
class Layout:
    """Byte layout of one message shape: a serialized template plus the offset of each numeric field.

    ``fields[path] = (offset, dtype)``; ``mask`` is True on the bytes no numeric field covers, which
    every message of this shape has equal to ``template``.
    """

    msgtype: str
    template: NDArray[np.uint8]
    fields: dict[str, tuple[int, str]]
    mask: NDArray[np.bool_] = field(repr=False)

    @property
    def size(self) -> int:
        """Serialized size in bytes (the same for every message of this shape)."""
        return int(self.template.size)

    @classmethod
    def of(cls, msg: object, msgtype: str) -> Layout:
        """Layout of ``msg``'s shape, learnt from the typestore serializer (two values per field, diff).

        Cached per shape (the message with every numeric field zeroed); the template is ``msg``'s bytes.
        """
        zeroed = copy.deepcopy(msg)
        _fill(msgtype, zeroed, 0)
        key = (msgtype, serialize(zeroed, msgtype))
        cached = _LAYOUTS.get(key)
        if cached is None:
            cached = _LAYOUTS[key] = cls._learn(zeroed, msgtype)
        template = np.frombuffer(serialize(msg, msgtype), dtype=np.uint8).copy()
        if template.size != cached.size:
            raise BagError(f"{msgtype}: serialized size depends on the values, not a fixed layout")
        return dataclasses.replace(cached, template=template)

    @classmethod
    def _learn(cls, msg: object, msgtype: str) -> Layout:
        """Uncached Layout.of from two serializations: every numeric field filled with bytes 0x01, then
        0x02. The bytes that differ are the fields' bytes; CDR writes the fields in declaration order, as
        _numeric_leaves lists them, so field k is the next run of its width. Linear in the message (a
        MarkerArray of 2000 markers, 64 000 fields, took hours at two serializations a field); where the
        runs do not fall so, _learn_by_field's one pair a field says which field is at fault."""
        leaves = _numeric_leaves(msgtype, msg)
        template = np.frombuffer(serialize(msg, msgtype), dtype=np.uint8).copy()
        probes = []
        for fill in (0x01, 0x02):
            probe = copy.deepcopy(msg)
            _fill(msgtype, probe, fill)
            probes.append(np.frombuffer(serialize(probe, msgtype), dtype=np.uint8))
        widths = np.array([np.dtype(dtype).itemsize for _, dtype in leaves], dtype=np.int64)
        if probes[0].size != template.size or probes[1].size != template.size:
            return cls._learn_by_field(msg, msgtype)
        diff = np.flatnonzero(probes[0] != probes[1])
        if diff.size != int(widths.sum()):
            return cls._learn_by_field(msg, msgtype)
        first = np.cumsum(widths) - widths
        offsets, lasts = diff[first], diff[first + widths - 1]
        if np.any(lasts - offsets != widths - 1):
            return cls._learn_by_field(msg, msgtype)
        mask = np.ones(template.size, dtype=bool)
        mask[diff] = False
        fields = {path: (int(o), dtype) for (path, dtype), o in zip(leaves, offsets.tolist(), strict=True)}
        return cls(msgtype=msgtype, template=template, fields=fields, mask=mask)

    @classmethod
    def _learn_by_field(cls, msg: object, msgtype: str) -> Layout:
        """_learn one field at a time: one pair of serializations per numeric field."""
        template = np.frombuffer(serialize(msg, msgtype), dtype=np.uint8).copy()
        mask = np.ones(template.size, dtype=bool)
        fields: dict[str, tuple[int, str]] = {}
        for path, dtype in _numeric_leaves(msgtype, msg):
            width = np.dtype(dtype).itemsize
            probes = []
            for fill in (0x01, 0x02):
                probe = copy.deepcopy(msg)
                value = np.frombuffer(bytes([fill] * width), dtype=dtype)[0]
                _set_leaf(probe, path, value.item())
                probes.append(np.frombuffer(serialize(probe, msgtype), dtype=np.uint8))
            if probes[0].size != template.size or probes[1].size != template.size:
                raise BagError(f"{msgtype}.{path}: serialized size depends on the value, not a fixed layout")
            diff = np.flatnonzero(probes[0] != probes[1])
            if diff.size != width or diff[-1] - diff[0] != width - 1:
                raise BagError(f"{msgtype}.{path}: cannot locate the field in the serialized bytes")
            offset = int(diff[0])
            fields[path] = (offset, dtype)
            mask[offset : offset + width] = False
        return cls(msgtype=msgtype, template=template, fields=fields, mask=mask)

    def encode(self, n: int, columns: Mapping[str, ArrayLike]) -> NDArray[np.uint8]:
        """(n, size) uint8 rows: the template with each named field set from its column (or scalar)."""
        out = np.empty((n, self.size), dtype=np.uint8)
        out[:] = self.template
        for path, values in columns.items():
            if path not in self.fields:
                raise BagError(f"{self.msgtype} has no numeric field {path!r} in this layout")
            offset, dtype = self.fields[path]
            col = np.asarray(values)
            if col.dtype.kind == "f" and not np.all(np.isfinite(col)):
                raise BagError(f"{self.msgtype}.{path}: refusing to write NaN or inf")
            col = np.ascontiguousarray(np.broadcast_to(col.astype(dtype), (n,)))
            width = np.dtype(dtype).itemsize
            out[:, offset : offset + width] = col.view(np.uint8).reshape(n, width)
        return out

    def matches(self, rows: NDArray[np.uint8]) -> NDArray[np.bool_]:
        """Per row: True when every non-field byte equals the template (the row has this shape).

        Row r matches when (word(r) AND m) = (word(template) AND m) for every 8-byte word holding a
        non-field byte (m: 0xFF on those bytes), and byte for byte outside the words.
        """
        if rows.ndim != 2 or rows.shape[1] != self.size:
            return np.zeros(rows.shape[0] if rows.ndim else 0, dtype=bool)
        start, stop, words, mask_words, template_words, loose = self._word_plan
        rows = np.ascontiguousarray(rows)
        # Words from byte 4, where the CDR body starts: its 8-byte fields fill whole words, skipped.
        picked = rows[:, start:stop].view("<u8")[:, words]
        result: NDArray[np.bool_] = ~np.any((picked & mask_words) != template_words, axis=1)
        if loose.size:
            result &= np.all(rows[:, loose] == self.template[loose], axis=1)
        return result

    @functools.cached_property
    def _word_plan(
        self,
    ) -> tuple[int, int, NDArray[np.intp], NDArray[np.uint64], NDArray[np.uint64], NDArray[np.intp]]:
        """(start, stop, words with a non-field byte, their masks, template AND mask, non-field bytes
        outside data[start:stop]) for ``matches``: 8-byte words over data[start:stop]."""
        start = min(4, self.size)
        stop = start + (self.size - start) // 8 * 8
        byte_mask = np.where(self.mask, 0xFF, 0).astype(np.uint8)
        mask_words = byte_mask[start:stop].view("<u8")
        words = np.flatnonzero(mask_words)
        template_words = self.template[start:stop].view("<u8")[words] & mask_words[words]
        outside = np.ones(self.size, dtype=bool)
        outside[start:stop] = False
        loose = np.flatnonzero(self.mask & outside)
        return start, stop, words, mask_words[words], template_words, loose

    def reader(self, paths: Sequence[str]) -> Callable[[bytes], tuple[float, ...] | None]:
        """For one message at a time: bytes ↦ the values at ``paths`` if the bytes have this shape, else None.

        The same shape test as ``matches`` (size and every non-field byte), with struct instead of numpy:
        a node calls it per message, where numpy's per-call cost would dominate.
        """
        template = self.template.tobytes()
        edges = np.flatnonzero(np.diff(np.concatenate(([0], self.mask.astype(np.int8), [0]))))
        fixed = [(int(a), int(b), template[a:b]) for a, b in zip(edges[::2], edges[1::2], strict=True)]
        unpack = [(offset, _struct_of(dtype)) for offset, dtype in self._fields_at(paths)]
        size = self.size

        def read(data: bytes) -> tuple[float, ...] | None:
            """Field values, or None when ``data`` is another shape."""
            if len(data) != size or any(data[a:b] != expected for a, b, expected in fixed):
                return None
            return tuple(codec.unpack_from(data, offset)[0] for offset, codec in unpack)

        return read

    def writer(self, paths: Sequence[str]) -> Callable[..., bytes]:
        """For one message at a time: values for ``paths`` ↦ the template's bytes with those fields set."""
        template = self.template.tobytes()
        pack = [(offset, _struct_of(dtype)) for offset, dtype in self._fields_at(paths)]

        def write(*values: float) -> bytes:
            """Serialized message of this shape holding ``values``."""
            buffer = bytearray(template)
            for (offset, codec), value in zip(pack, values, strict=True):
                codec.pack_into(buffer, offset, value)
            return bytes(buffer)

        return write

    def _fields_at(self, paths: Sequence[str]) -> list[tuple[int, str]]:
        """(offset, dtype) of each path; BagError naming the first unknown one."""
        missing = [p for p in paths if p not in self.fields]
        if missing:
            raise BagError(f"{self.msgtype} has no numeric field {missing[0]!r} in this layout")
        return [self.fields[p] for p in paths]

    def decode(self, rows: NDArray[np.uint8], paths: Sequence[str] | None = None) -> dict[str, NDArray[Any]]:
        """{path: column} read from (n, size) rows of this shape (all fields, or just ``paths``)."""
        wanted = self.fields if paths is None else paths
        out: dict[str, NDArray[Any]] = {}  # Any: each column keeps its field's dtype (int32, float64, …)
        for path in wanted:
            if path not in self.fields:
                raise BagError(f"{self.msgtype} messages have no field {path!r}")
            offset, dtype = self.fields[path]
            width = np.dtype(dtype).itemsize
            block = rows[:, offset : offset + width]
            if block.strides[1] != 1:  # a dtype view needs contiguous bytes within a row
                block = np.ascontiguousarray(block)
            # One copy: the (n, 1) dtype view of the field's bytes, converted to native order.
            out[path] = block.view(dtype)[:, 0].astype(np.dtype(dtype).newbyteorder("="))
        return out


_LAYOUTS: dict[tuple[str, bytes], Layout] = {}


def rows_from_bytes(payloads: Sequence[bytes]) -> NDArray[np.uint8]:
    """(n, size) uint8 matrix from n equally long CDR payloads (one join, no per-row copies)."""
    if not payloads:
        return np.zeros((0, 0), dtype=np.uint8)
    size = len(payloads[0])
    return np.frombuffer(b"".join(payloads), dtype=np.uint8).reshape(len(payloads), size)
