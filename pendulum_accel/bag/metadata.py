"""rosbag2 metadata: offered QoS profiles as rosbag2 stores them, and the metadata.yaml document (v9).

The QoS form is rosbag2's version 9 one (enum names in lower case, times as sec/nsec), the same text
in metadata.yaml and in each MCAP channel's ``offered_qos_profiles`` entry; parsing also takes the
version 8 form (enum values as integers). A document is written with ``write_metadata`` and read back with
``load_metadata``, ``listed_counts`` and ``listed_custom_data``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from enum import Enum
from pathlib import Path
from typing import TypedDict, TypeVar

import yaml
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

from pendulum_accel.bag.errors import ReaderError

# metadata.yaml's layout, as rosbag2 writes it (rosbag2_storage's metadata_io.cpp, version 9) and
# rosbags types it (rosbags.rosbag2.metadata). These type what this library writes; a document read
# back is parsed YAML, unchecked (``object``), and is read through listed_counts and listed_custom_data.


class QosTimeDict(TypedDict):
    """A QoS duration: seconds and nanoseconds."""

    sec: int
    nsec: int


class QosDict(TypedDict):
    """One offered QoS profile as rosbag2 v9 writes it in YAML (enum names in lower case)."""

    history: str
    depth: int
    reliability: str
    durability: str
    deadline: QosTimeDict
    lifespan: QosTimeDict
    liveliness: str
    liveliness_lease_duration: QosTimeDict
    avoid_ros_namespace_conventions: bool


class Duration(TypedDict):
    """A bag's or file's duration."""

    nanoseconds: int


class StartingTime(TypedDict):
    """A bag's or file's first log time."""

    nanoseconds_since_epoch: int


class TopicMetadata(TypedDict):
    """One topic: name, message type, serialization, offered QoS, type hash (RIHS01)."""

    name: str
    type: str
    serialization_format: str
    offered_qos_profiles: list[QosDict]
    type_description_hash: str


class TopicWithMessageCount(TypedDict):
    """One topic and its message count."""

    topic_metadata: TopicMetadata
    message_count: int


class FileInformation(TypedDict):
    """One storage file: its path (relative to the bag), first log time, duration, message count."""

    path: str
    starting_time: StartingTime
    duration: Duration
    message_count: int


class BagfileInformation(TypedDict):
    """rosbag2_bagfile_information, the document's one entry."""

    version: int
    storage_identifier: str
    relative_file_paths: list[str]
    duration: Duration
    starting_time: StartingTime
    message_count: int
    topics_with_message_count: list[TopicWithMessageCount]
    compression_format: str
    compression_mode: str
    files: list[FileInformation]
    custom_data: dict[str, str] | None
    ros_distro: str


class MetadataDocument(TypedDict):
    """metadata.yaml: {"rosbag2_bagfile_information": {...}}."""

    rosbag2_bagfile_information: BagfileInformation


@dataclass(frozen=True)
class TopicRecord:
    """One topic as metadata.yaml lists it: name, type, type hash (RIHS01), offered QoS, count."""

    name: str
    msgtype: str
    type_hash: str
    qos: list[Qos]
    count: int


def _time(value: QosTime) -> QosTimeDict:
    """{sec, nsec} of a QoS duration."""
    return {"sec": int(value.sec), "nsec": int(value.nsec)}


def qos_dicts(qos: Sequence[Qos]) -> list[QosDict]:
    """Offered QoS profiles in rosbag2's v9 form (keys as rosbag2 writes them)."""
    return [
        {
            "history": q.history.name.lower(),
            "depth": int(q.depth),
            "reliability": q.reliability.name.lower(),
            "durability": q.durability.name.lower(),
            "deadline": _time(q.deadline),
            "lifespan": _time(q.lifespan),
            "liveliness": q.liveliness.name.lower(),
            "liveliness_lease_duration": _time(q.liveliness_lease_duration),
            "avoid_ros_namespace_conventions": bool(q.avoid_ros_namespace_conventions),
        }
        for q in qos
    ]


def complete_qos(offered: Qos, published: Qos) -> Qos:
    """``offered`` with history and depth from ``published`` when discovery left them UNKNOWN/0 and the
    reliability and durability agree (DDS discovery carries neither history nor depth, so rosbag2's
    recorder stores "unknown, 0"; a chain publisher's own profile is known)."""
    if offered.history != QosHistory.UNKNOWN or (offered.reliability, offered.durability) != (
        published.reliability,
        published.durability,
    ):
        return offered
    return offered._replace(history=published.history, depth=published.depth)


def qos_text(qos: Sequence[Qos]) -> str:
    """The profiles as the YAML text of an MCAP channel's ``offered_qos_profiles`` entry (keys sorted)."""
    dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
    text: str = yaml.dump(qos_dicts(qos), Dumper=dumper, default_flow_style=False)
    return text.strip()


_E = TypeVar("_E", bound=Enum)


def _enum(kind: type[_E], value: object) -> _E:
    """Enum member from its v9 name or v8 integer value; the UNKNOWN member for anything else."""
    try:
        if isinstance(value, int):
            return kind(value)
        return kind[str(value).upper()]
    except (KeyError, ValueError):
        return kind["UNKNOWN"]


def _qos_time(item: Mapping[str, object], key: str) -> QosTime:
    """QosTime from the {sec, nsec} entry ``key``; zero when absent."""
    value = item.get(key)
    if not isinstance(value, Mapping):
        return QosTime(0, 0)
    return QosTime(int(value.get("sec", 0)), int(value.get("nsec", 0)))


def parse_qos(text: str | Sequence[Mapping[str, object]]) -> list[Qos]:
    """Offered QoS profiles from rosbag2's YAML text (or its parsed list); BagError when unreadable."""
    if not text:
        return []
    try:
        items = yaml.safe_load(text) if isinstance(text, str) else list(text)
        if not isinstance(items, list):
            raise TypeError(f"expected a list of profiles, got {type(items).__name__}")
        return [
            Qos(
                _enum(QosHistory, item.get("history")),
                int(item.get("depth", 0)),
                _enum(QosReliability, item.get("reliability")),
                _enum(QosDurability, item.get("durability")),
                _qos_time(item, "deadline"),
                _qos_time(item, "lifespan"),
                _enum(QosLiveliness, item.get("liveliness")),
                _qos_time(item, "liveliness_lease_duration"),
                bool(item.get("avoid_ros_namespace_conventions", False)),
            )
            for item in items
        ]
    except (yaml.YAMLError, TypeError, ValueError, AttributeError) as err:
        raise ReaderError(f"unreadable offered_qos_profiles: {err}") from None


def metadata_document(
    *,
    mcap_name: str,
    topics: Sequence[TopicRecord],
    start_ns: int,
    end_ns: int,
    custom_data: Mapping[str, str],
) -> MetadataDocument:
    """rosbag2 metadata.yaml (version 9, mcap storage) for one file, laid out as rosbags writes it."""
    duration = max(0, end_ns - start_ns)
    count = sum(t.count for t in topics)
    return {
        "rosbag2_bagfile_information": {
            "version": 9,
            "storage_identifier": "mcap",
            "relative_file_paths": [mcap_name],
            "duration": {"nanoseconds": duration},
            "starting_time": {"nanoseconds_since_epoch": start_ns},
            "message_count": count,
            "topics_with_message_count": [
                {
                    "topic_metadata": {
                        "name": t.name,
                        "type": t.msgtype,
                        "serialization_format": "cdr",
                        "offered_qos_profiles": qos_dicts(t.qos),
                        "type_description_hash": t.type_hash,
                    },
                    "message_count": t.count,
                }
                for t in topics
            ],
            # rosbags/rosbag2 leave both empty for chunk-level (storage) compression.
            "compression_format": "",
            "compression_mode": "",
            "files": [
                {
                    "path": mcap_name,
                    "starting_time": {"nanoseconds_since_epoch": start_ns},
                    "duration": {"nanoseconds": duration},
                    "message_count": count,
                }
            ],
            "custom_data": dict(custom_data) or None,
            "ros_distro": ros_distro(),
        }
    }


ROS_DISTRO = "kilted"
"""The distribution of the message definitions bags are written with (rosbags' ROS2_KILTED typestore,
the ros-kilted-* wheels of requirements-ros.txt)."""


def listed_counts(document: object) -> tuple[dict[str, int], int] | None:
    """({topic: message_count}, message_count) that a parsed metadata.yaml lists; None when it lists no
    counts in rosbag2's shape (no metadata, another shape, a count that is not a number)."""
    info = document.get("rosbag2_bagfile_information") if isinstance(document, dict) else None
    if not isinstance(info, dict):
        return None
    try:
        topics = {
            str(t["topic_metadata"]["name"]): int(t["message_count"])
            for t in info.get("topics_with_message_count") or []
        }
        return topics, int(info.get("message_count", -1))
    except (KeyError, TypeError, ValueError):
        return None


def listed_custom_data(document: object) -> dict[str, str]:
    """custom_data of a parsed metadata.yaml ({} when it has none)."""
    info = document.get("rosbag2_bagfile_information") if isinstance(document, dict) else None
    custom = info.get("custom_data") if isinstance(info, dict) else None
    return {str(k): str(v) for k, v in custom.items()} if isinstance(custom, dict) else {}


def load_yaml(text: str) -> object:
    """yaml.safe_load with libyaml's C loader when available (metadata can be long)."""
    loader = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
    document: object = yaml.load(text, Loader=loader)
    return document


def load_metadata(path: Path) -> object:
    """The parsed YAML of file ``path`` (a metadata.yaml); None when it cannot be read or does not parse."""
    try:
        return load_yaml(path.read_text(encoding="utf8"))
    except (yaml.YAMLError, OSError, UnicodeDecodeError):
        return None


def ros_distro() -> str:
    """metadata.yaml's ``ros_distro``, as rosbag2 writes it: $ROS_DISTRO when a ROS 2 install is sourced,
    else the distribution of the message definitions in use ("kilted")."""
    return os.environ.get("ROS_DISTRO", "").strip() or ROS_DISTRO


def write_metadata(bag_dir: Path, document: MetadataDocument) -> None:
    """Atomically replace bag_dir/metadata.yaml with ``document`` (write to .tmp, rename)."""
    tmp = bag_dir / "metadata.yaml.tmp"
    tmp.write_text(dump_yaml(document), encoding="utf8")
    tmp.replace(bag_dir / "metadata.yaml")


def dump_yaml(document: Mapping[str, object]) -> str:
    """Block-style YAML in insertion order (libyaml's safe dumper when available)."""
    dumper = getattr(yaml, "CSafeDumper", yaml.SafeDumper)
    text: str = yaml.dump(dict(document), Dumper=dumper, default_flow_style=False, sort_keys=False)
    return text
