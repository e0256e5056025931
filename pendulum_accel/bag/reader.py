"""Read a rosbag2 MCAP bag into numpy arrays, salvaging what precedes any damage.

The file is scanned front to back, without the summary or index: every top-level record is
framed (opcode, length) and checked against the file size; Header, Schema, Channel, Chunk and
Metadata records are parsed by the ``mcap`` library; inside a chunk, each message record's
channel, log time and payload slice are taken with one ``struct.unpack_from``. The scan stops at
the first record that is cut off or malformed and keeps everything before it, so a bag whose
recorder was killed reads up to its last flushed chunk. Fixed-layout topics are then decoded
column-wise with :class:`pendulum_accel.bag.messages.Layout` (numpy over all messages at once).
"""

from __future__ import annotations

import heapq
import struct
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from io import BytesIO
from pathlib import Path
from typing import Any

import numpy as np
import zstandard
from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Metadata, Schema
from numpy.typing import NDArray
from ruamel.yaml import YAML
from ruamel.yaml.error import YAMLError

from pendulum_accel.bag.messages import Layout, deserialize, rows_from_bytes, stamp_seconds
from pendulum_accel.errors import BagError

_MAGIC = b"\x89MCAP0\r\n"
_RECORD_HEAD = struct.Struct("<BQ")
_MESSAGE_HEAD = struct.Struct("<BQHIQ")
_MESSAGE_DATA_OFFSET = 31  # opcode 1 + length 8 + channel 2 + sequence 4 + log time 8 + publish time 8
_OPCODES = {int(op) for op in Opcode}
_IN_CHUNK = {int(Opcode.SCHEMA), int(Opcode.CHANNEL), int(Opcode.MESSAGE)}


@dataclass(frozen=True)
class TopicInfo:
    """One topic of a bag: name, message type, serialization, offered QoS (YAML text), message count."""

    name: str
    msgtype: str
    serialization_format: str
    offered_qos_profiles: str
    count: int


@dataclass(frozen=True)
class TopicArrays:
    """Decoded columns of one topic: ``log_time_ns`` and ``fields[path]`` (e.g. ``position[0]``)."""

    topic: str
    msgtype: str
    log_time_ns: NDArray[np.int64]
    fields: dict[str, NDArray[Any]]

    def __len__(self) -> int:
        """Number of messages."""
        return int(self.log_time_ns.size)

    def __getitem__(self, path: str) -> NDArray[Any]:
        """Column of field ``path``; BagError naming the topic when the messages have no such field."""
        try:
            return self.fields[path]
        except KeyError:
            raise BagError(f"topic {self.topic} ({self.msgtype}) messages have no field {path!r}") from None

    @property
    def stamp(self) -> NDArray[np.float64]:
        """t = header.stamp (or clock for Clock) in seconds; log time when the type has no stamp."""
        for prefix in ("header.stamp", "clock"):
            if f"{prefix}.sec" in self.fields:
                return stamp_seconds(self.fields[f"{prefix}.sec"], self.fields[f"{prefix}.nanosec"])
        return self.log_time_ns.astype(np.float64) * 1e-9


@dataclass
class _ChannelData:
    """Messages of one MCAP channel in file order."""

    topic: str
    msgtype: str
    encoding: str
    qos: str
    times: list[int] = field(default_factory=list)
    payloads: list[bytes] = field(default_factory=list)


class Bag:
    """Everything readable in one bag. ``problem`` is None for an intact bag, else one sentence.

    ``topics`` (name -> TopicInfo), ``custom_data``, ``start_ns``/``end_ns``, ``decode(topic)``,
    ``raw(topic)`` and ``iter_raw()`` (time-ordered (topic, log_time_ns, cdr) for replay).
    """

    def __init__(self, path: Path, mcap_path: Path) -> None:
        """Empty bag for ``path``; filled by read_bag."""
        self.path = path
        self.mcap_path = mcap_path
        self.problem: str | None = None
        self.metadata: dict[str, Any] | None = None
        self.custom_data: dict[str, str] = {}
        self.complete = False
        self._channels: dict[int, _ChannelData] = {}

    @property
    def topics(self) -> dict[str, TopicInfo]:
        """name -> TopicInfo for every channel (topics with 0 messages included), in channel order."""
        out: dict[str, TopicInfo] = {}
        for ch in self._channels.values():
            if ch.topic in out:
                prev = out[ch.topic]
                out[ch.topic] = TopicInfo(
                    prev.name,
                    prev.msgtype,
                    prev.serialization_format,
                    prev.offered_qos_profiles,
                    prev.count + len(ch.times),
                )
            else:
                out[ch.topic] = TopicInfo(ch.topic, ch.msgtype, ch.encoding, ch.qos, len(ch.times))
        return out

    @property
    def message_count(self) -> int:
        """Total messages read."""
        return sum(len(ch.times) for ch in self._channels.values())

    @property
    def start_ns(self) -> int:
        """Earliest log time (ns), 0 for an empty bag."""
        firsts = [min(ch.times) for ch in self._channels.values() if ch.times]
        return min(firsts) if firsts else 0

    @property
    def end_ns(self) -> int:
        """Latest log time (ns), 0 for an empty bag."""
        lasts = [max(ch.times) for ch in self._channels.values() if ch.times]
        return max(lasts) if lasts else 0

    @property
    def duration_s(self) -> float:
        """(end − start) in seconds."""
        return (self.end_ns - self.start_ns) * 1e-9

    def _channels_of(self, topic: str, msgtype: str | None) -> list[_ChannelData]:
        """Channels of ``topic``; BagError when it is absent or has another type than ``msgtype``."""
        chans = [ch for ch in self._channels.values() if ch.topic == topic]
        if not chans:
            known = ", ".join(sorted(self.topics)) or "none"
            raise BagError(f"bag {self.path} has no topic {topic} (topics: {known})")
        types = {ch.msgtype for ch in chans}
        if msgtype is not None and types != {msgtype}:
            raise BagError(
                f"topic {topic} in {self.path} has type {', '.join(sorted(types))}, expected {msgtype}"
            )
        if len(types) > 1:
            raise BagError(f"topic {topic} in {self.path} mixes types {', '.join(sorted(types))}")
        for ch in chans:
            if ch.encoding != "cdr":
                raise BagError(f"topic {topic} in {self.path} is {ch.encoding!r}-encoded, expected cdr")
        return chans

    def raw(self, topic: str, msgtype: str | None = None) -> tuple[NDArray[np.int64], list[bytes]]:
        """(log times ns, CDR payloads) of ``topic``, sorted by log time (stable)."""
        chans = self._channels_of(topic, msgtype)
        times = np.array([t for ch in chans for t in ch.times], dtype=np.int64)
        payloads = [p for ch in chans for p in ch.payloads]
        if times.size > 1 and np.any(np.diff(times) < 0):
            order = np.argsort(times, kind="stable")
            return times[order], [payloads[i] for i in order]
        return times, payloads

    def decode(
        self, topic: str, msgtype: str | None = None, fields: Sequence[str] | None = None
    ) -> TopicArrays:
        """Numeric columns of ``topic`` (all, or ``fields``) decoded in bulk, one array per field.

        Messages are grouped by shape (strings and sequence lengths); each shape is decoded with numpy
        over all its messages. BagError when a requested field is missing from some shape.
        """
        chans = self._channels_of(topic, msgtype)
        mtype = chans[0].msgtype
        times, payloads = self.raw(topic)
        n = len(payloads)
        columns: dict[str, NDArray[Any]] = {}
        if n == 0:
            return TopicArrays(topic, mtype, times, {p: np.zeros(0) for p in fields or ()})
        lengths = np.fromiter(map(len, payloads), dtype=np.int64, count=n)
        assigned = np.zeros(n, dtype=bool)
        wanted: Sequence[str] | None = fields
        for size in np.unique(lengths):
            idx = np.flatnonzero(lengths == size)
            rows = rows_from_bytes([payloads[i] for i in idx]) if idx.size < n else rows_from_bytes(payloads)
            todo = np.ones(idx.size, dtype=bool)
            while todo.any():
                first = int(np.flatnonzero(todo)[0])
                try:
                    layout = Layout.of(deserialize(payloads[idx[first]], mtype), mtype)
                except BagError as err:
                    raise BagError(f"topic {topic}, message {int(idx[first])}: {err}") from None
                ok = todo & layout.matches(rows)
                if not ok[first]:
                    raise BagError(f"topic {topic}, message {int(idx[first])}: bytes do not re-serialize")
                if wanted is None:
                    wanted = list(layout.fields)
                missing = [p for p in wanted if p not in layout.fields]
                if missing:
                    raise BagError(
                        f"topic {topic} ({mtype}): message {int(idx[first])} has no field {missing[0]!r}"
                    )
                decoded = layout.decode(rows[ok], wanted)
                for path, col in decoded.items():
                    if path not in columns:
                        columns[path] = np.zeros(n, dtype=col.dtype)
                    columns[path][idx[ok]] = col
                assigned[idx[ok]] = True
                todo &= ~ok
        assert assigned.all()
        return TopicArrays(topic, mtype, times, columns)

    def iter_raw(self, topics: Sequence[str] | None = None) -> Iterator[tuple[str, int, bytes]]:
        """(topic, log_time_ns, cdr) of the chosen topics (default all), merged in log-time order."""
        names = list(self.topics) if topics is None else list(topics)
        streams = []
        for name in names:
            times, payloads = self.raw(name)
            streams.append(zip(times.tolist(), [name] * len(payloads), payloads, strict=True))
        for t, name, data in heapq.merge(*streams, key=lambda item: item[0]):
            yield name, t, data


def _find_mcap(path: Path) -> tuple[Path, Path]:
    """(bag directory or file, .mcap path) for a bag directory or a bare .mcap file."""
    if path.is_file():
        return path, path
    if not path.is_dir():
        raise BagError(f"bag {path} does not exist")
    meta = path / "metadata.yaml"
    if meta.is_file():
        doc = _load_yaml(meta)
        info = doc.get("rosbag2_bagfile_information", {}) if isinstance(doc, dict) else {}
        files = info.get("relative_file_paths") or []
        if len(files) > 1:
            raise BagError(
                f"bag {path} is split into {len(files)} files; only single-file bags are supported"
            )
        if files and (path / files[0]).is_file():
            if not str(files[0]).endswith(".mcap"):
                raise BagError(f"bag {path} uses storage {files[0]!r}; only MCAP bags are supported")
            return path, path / files[0]
    found = sorted(path.glob("*.mcap"))
    if len(found) != 1:
        raise BagError(f"bag {path} has {len(found)} .mcap files, expected 1")
    return path, found[0]


def _load_yaml(path: Path) -> Any:
    """Parsed YAML of a file; None when it does not parse."""
    try:
        return YAML(typ="safe").load(path.read_text(encoding="utf8"))
    except (YAMLError, OSError, UnicodeDecodeError):
        return None


def _decompress(chunk: Chunk) -> bytes:
    """Uncompressed chunk data (none or zstd; lz4 when installed); BagError when it does not inflate."""
    if chunk.compression == "":
        return chunk.data
    try:
        if chunk.compression == "zstd":
            return bytes(
                zstandard.ZstdDecompressor().decompress(chunk.data, max_output_size=chunk.uncompressed_size)
            )
        if chunk.compression == "lz4":
            import lz4.frame

            return bytes(lz4.frame.decompress(chunk.data))
    except Exception as err:  # zstd/lz4 raise their own error types on damaged data
        raise ValueError(f"{chunk.compression} chunk does not decompress ({err})") from None
    raise ValueError(f"unsupported chunk compression {chunk.compression!r}")


class _Scanner:
    """Front-to-back MCAP scan that records schemas, channels and messages into a Bag."""

    def __init__(self, bag: Bag) -> None:
        """Scan state for ``bag``."""
        self.bag = bag
        self.schemas: dict[int, Schema] = {}

    def schema(self, body: memoryview) -> None:
        """Register a Schema record."""
        rec = Schema.read(ReadDataStream(BytesIO(body)))
        self.schemas[rec.id] = rec

    def channel(self, body: memoryview) -> None:
        """Register a Channel record (its schema names the message type)."""
        rec = Channel.read(ReadDataStream(BytesIO(body)))
        schema = self.schemas.get(rec.schema_id)
        if rec.schema_id != 0 and schema is None:
            raise ValueError(f"channel {rec.id} ({rec.topic}) refers to unknown schema {rec.schema_id}")
        msgtype = schema.name if schema is not None else ""
        qos = rec.metadata.get("offered_qos_profiles", "")
        if rec.id not in self.bag._channels:
            self.bag._channels[rec.id] = _ChannelData(rec.topic, msgtype, rec.message_encoding, qos)

    def chunk_records(self, data: bytes) -> None:
        """Walk the records of one uncompressed chunk; ValueError at the first malformed one."""
        channels = self.bag._channels
        view = memoryview(data)
        end = len(data)
        pos = 0
        unpack_message = _MESSAGE_HEAD.unpack_from
        while pos < end:
            if pos + 9 > end:
                raise ValueError(f"record header cut off at chunk byte {pos}")
            op, length = _RECORD_HEAD.unpack_from(data, pos)
            stop = pos + 9 + length
            if stop > end:
                raise ValueError(f"record at chunk byte {pos} overruns its chunk")
            if op == 0x05:
                if length < 22:
                    raise ValueError(f"message record at chunk byte {pos} is too short")
                _, _, cid, _, log_time = unpack_message(data, pos)
                ch = channels.get(cid)
                if ch is None:
                    raise ValueError(f"message at chunk byte {pos} on unknown channel {cid}")
                ch.times.append(log_time)
                ch.payloads.append(data[pos + _MESSAGE_DATA_OFFSET : stop])
            elif op == Opcode.SCHEMA:
                self.schema(view[pos + 9 : stop])
            elif op == Opcode.CHANNEL:
                self.channel(view[pos + 9 : stop])
            elif op not in _IN_CHUNK:
                raise ValueError(
                    f"record with opcode 0x{op:02x} at chunk byte {pos} does not belong in a chunk"
                )
            pos = stop

    def scan(self, data: bytes) -> None:
        """Read all top-level records; sets bag.problem and stops at the first bad one."""
        bag = self.bag
        size = len(data)
        if size < len(_MAGIC) or data[: len(_MAGIC)] != _MAGIC:
            raise BagError(f"{bag.mcap_path} is not an MCAP file (bad magic bytes)")
        view = memoryview(data)
        pos = len(_MAGIC)
        while True:
            if pos >= size:
                bag.problem = (
                    f"{bag.mcap_path} ends at byte {size} without an MCAP footer (recording interrupted?)"
                )
                return
            if pos + 9 > size:
                bag.problem = f"{bag.mcap_path} is truncated: record header cut off at byte {pos} of {size}"
                return
            op, length = _RECORD_HEAD.unpack_from(data, pos)
            stop = pos + 9 + length
            if op not in _OPCODES or op == 0:
                bag.problem = f"{bag.mcap_path} is corrupt: unknown record opcode 0x{op:02x} at byte {pos}"
                return
            if stop > size:
                bag.problem = (
                    f"{bag.mcap_path} is truncated: {Opcode(op).name} record at byte {pos} needs "
                    f"{length} bytes, only {size - pos - 9} remain"
                )
                return
            body = view[pos + 9 : stop]
            try:
                if op == Opcode.FOOTER:
                    bag.complete = True
                    return
                self._top_level(op, body)
            except (ValueError, struct.error, UnicodeDecodeError, KeyError) as err:
                bag.problem = f"{bag.mcap_path} is corrupt at byte {pos} ({Opcode(op).name} record): {err}"
                return
            pos = stop

    def _top_level(self, op: int, body: memoryview) -> None:
        """Handle one top-level record."""
        if op == Opcode.CHUNK:
            chunk = Chunk.read(ReadDataStream(BytesIO(body)))
            if chunk.compression == "" and len(chunk.data) != chunk.uncompressed_size:
                raise ValueError("chunk data is shorter than its declared size")
            self.chunk_records(_decompress(chunk))
        elif op == Opcode.SCHEMA:
            self.schema(body)
        elif op == Opcode.CHANNEL:
            self.channel(body)
        elif op == Opcode.MESSAGE:
            self.chunk_records(bytes([0x05]) + struct.pack("<Q", len(body)) + bytes(body))
        elif op == Opcode.METADATA:
            meta = Metadata.read(ReadDataStream(BytesIO(body)))
            if meta.name == "rosbag2" and "serialized_metadata" in meta.metadata:
                try:
                    doc = YAML(typ="safe").load(meta.metadata["serialized_metadata"])
                except YAMLError:
                    doc = None
                if isinstance(doc, dict) and isinstance(doc.get("custom_data"), dict):
                    self.bag.custom_data.update({str(k): str(v) for k, v in doc["custom_data"].items()})


def read_bag(path: Path | str, *, salvage: bool = True) -> Bag:
    """Read every message of a bag directory (or .mcap file) into memory.

    A truncated or corrupt file keeps what precedes the damage and sets ``bag.problem``; with
    ``salvage=False`` that is a BagError instead. Missing, empty or non-MCAP input: BagError.
    """
    root, mcap_path = _find_mcap(Path(path))
    bag = Bag(root, mcap_path)
    try:
        data = mcap_path.read_bytes()
    except OSError as err:
        raise BagError(f"cannot read {mcap_path}: {err.strerror}") from None
    meta_path = root / "metadata.yaml" if root.is_dir() else None
    if meta_path is not None and meta_path.is_file():
        doc = _load_yaml(meta_path)
        if isinstance(doc, dict):
            bag.metadata = doc
            info = doc.get("rosbag2_bagfile_information") or {}
            custom = info.get("custom_data") if isinstance(info, dict) else None
            if isinstance(custom, dict):
                bag.custom_data.update({str(k): str(v) for k, v in custom.items()})
    _Scanner(bag).scan(data)
    if bag.problem is not None and not salvage:
        raise BagError(bag.problem)
    return bag


def salvage_note(bag: Bag) -> str | None:
    """One line for a damaged bag: the damage and what was kept; None for an intact one."""
    if bag.problem is None:
        return None
    return (
        f"{bag.problem}; read the {bag.message_count} messages before it "
        f"(`pendulum-accel repair {bag.path}` rewrites the bag from them)"
    )


def scene_name(bag: Bag) -> str | None:
    """Scene name from the bag's stored scene YAML (custom_data), None when absent or unreadable."""
    text = bag.custom_data.get("pendulum_accel.scene")
    if not text:
        return None
    try:
        doc = YAML(typ="safe").load(text)
    except YAMLError:
        return None
    name = doc.get("name") if isinstance(doc, dict) else None
    return str(name) if name is not None else None
