"""The ``bag_topic`` profile: a(t) from one topic of a recorded bag (ROS 1, rosbag2 sqlite3 or MCAP, or
the MCAP files of a directory that has no metadata.yaml).

The bag is read with ``rosbags.highlevel.AnyReader`` (pure Python, no ROS). What a(t) is depends on the
topic's type:

============================================  =====================  ==================================
type                                          field read             a(t)
============================================  =====================  ==================================
nav_msgs/msg/Odometry                         twist.twist.linear.x   speed, differentiated (trace)
geometry_msgs/msg/TwistStamped                twist.linear.x         speed, differentiated (trace)
geometry_msgs/msg/TwistWithCovarianceStamped  twist.twist.linear.x   speed, differentiated (trace)
sensor_msgs/msg/Imu                           linear_acceleration.x  used as recorded (low-passed by
geometry_msgs/msg/AccelStamped                accel.linear.x         the smoothing spline only when
geometry_msgs/msg/AccelWithCovarianceStamped  accel.accel.linear.x   the profile states cutoff_hz)
geometry_msgs/msg/Vector3Stamped              vector.x
============================================  =====================  ==================================

``field`` reads another numeric field of the same message instead (dotted, e.g. ``linear_acceleration.z``
for an IMU mounted with z forward), and ``scale`` multiplies what is read (-1 for an axis pointing
backward): a real robot's IMU is seldom mounted x forward. The type still decides whether the value is a
speed or an acceleration.

Times are the messages' header stamps, shifted so the first is t = 0 (the bag's log times when every
stamp is zero, i.e. never set). Stamps that go back, gaps, NaN: one-line errors naming the message.
"""

from __future__ import annotations

import operator
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.motion_input.fields import (
    field_path,
    field_scale,
    field_text,
    window_fields,
)
from pendulum_accel.motion_input.speed_trace import speed_recipe
from pendulum_accel.motion_input.trace import (
    check_trace,
    describe_differentiation,
    differentiate,
    fitted_stretch,
    median_step,
    recorded_acceleration,
)
from pendulum_accel.physics.profiles import Table
from pendulum_accel.textfile import not_a_file_or_directory

SPEED_FIELDS: dict[str, str] = {
    "nav_msgs/msg/Odometry": "twist.twist.linear.x",
    "geometry_msgs/msg/TwistStamped": "twist.linear.x",
    "geometry_msgs/msg/TwistWithCovarianceStamped": "twist.twist.linear.x",
}
"""Types whose forward speed (m/s) is differentiated into a(t), and the field each is read from."""

ACCEL_FIELDS: dict[str, str] = {
    "sensor_msgs/msg/Imu": "linear_acceleration.x",
    "geometry_msgs/msg/AccelStamped": "accel.linear.x",
    "geometry_msgs/msg/AccelWithCovarianceStamped": "accel.accel.linear.x",
    "geometry_msgs/msg/Vector3Stamped": "vector.x",
}
"""Types whose forward acceleration (m/s²) is a(t) itself, and the field each is read from (a
Vector3Stamped: an IMU driver's free or filtered acceleration, e.g. an Xsens's)."""

DEFAULT_FIELDS = SPEED_FIELDS | ACCEL_FIELDS
"""Every type bag_topic reads, and the field read when the profile names none."""


# Any (message): a rosbags message dataclass of a type read from the bag; its fields are found by name.
def numeric_fields(message: Any, prefix: str = "") -> list[str]:
    """Dotted paths of a message's scalar number fields (header and arrays left out): the choices a
    ``field`` error lists."""
    names: list[str] = []
    for name in getattr(message, "__dataclass_fields__", {}):
        if name in ("header", "__msgtype__"):
            continue
        value = getattr(message, name)
        path = f"{prefix}{name}"
        if isinstance(value, int | float) and not isinstance(value, bool):
            names.append(path)
        elif hasattr(value, "__dataclass_fields__"):
            names.extend(numeric_fields(value, path + "."))
    return names


# Any: rosbags message dataclasses of a type read from the bag (see numeric_fields).
def field_reader(msgtype: str, field: str, message: Any) -> Callable[[Any], float]:
    """A reader of the dotted ``field`` of messages shaped as ``message`` (the first one), checked on it:
    ParameterError listing the type's numeric fields when the path leads to no scalar number."""
    parts = field.split(".")
    value: Any = message
    for part in parts:
        if (
            part.startswith("_")
            or not hasattr(value, "__dataclass_fields__")
            or part not in (value.__dataclass_fields__)
        ):
            value = None
            break
        value = getattr(value, part)
    if not isinstance(value, int | float) or isinstance(value, bool):
        raise ParameterError(
            f"{msgtype} has no number field {field!r} (its number fields: "
            f"{', '.join(numeric_fields(message))})",
            path="field",
        )

    getter = operator.attrgetter(field)  # the dotted walk just checked, in C: it runs once per message
    return lambda m: float(getter(m))


def _bag_sources(path: Path) -> list[Path]:
    """What AnyReader opens: a ROS 1 .bag file, or the rosbag2 directory (also when given its .mcap/.db3);
    for a directory without its metadata.yaml (a recorder that was killed, or MCAP files copied into one)
    the .mcap files in it, which carry their own schemas and which AnyReader merges in log-time order."""
    if path.is_file() and path.suffix in (".mcap", ".db3") and (path.parent / "metadata.yaml").is_file():
        return [path.parent]
    if path.is_dir() and not (path / "metadata.yaml").exists():
        files = sorted(f for f in path.glob("*.mcap") if f.is_file())
        if not files:
            raise ParameterError(
                f"cannot read bag {path}: no metadata.yaml and no .mcap file in it (a ROS 1 bag is one "
                ".bag file: name it)",
                path="path",
            )
        return files
    return [path]


def read_topic(path: Path, topic: str, field: str | None = None) -> tuple[str, np.ndarray, np.ndarray, bool]:
    """(msgtype, t in s, values, stamped) of every message on ``topic``, in the bag's log order: the type's
    DEFAULT_FIELDS entry, or the dotted ``field``.

    ``stamped`` is False when every header stamp is zero and the log times were used instead.
    """
    from rosbags.highlevel import AnyReader  # a heavy import, needed only for this profile type
    from rosbags.typesys import Stores, get_typestore

    if not path.exists():
        raise ParameterError(f"cannot read bag {path}: no such file or directory", path="path")
    # AnyReader opens the file (or every file of a rosbag2 directory) and would wait forever on a FIFO.
    try:
        sources = _bag_sources(path)
        members = [*sources, *(m for s in sources if s.is_dir() for m in sorted(s.iterdir()))]
    except OSError as exc:
        raise ParameterError(f"cannot read bag {path}: {exc.strerror or exc}", path="path") from None
    for member in members:
        kind = not_a_file_or_directory(member)
        if kind is not None:
            raise ParameterError(
                f"cannot read bag {path}: {member.name} is {kind}, not a bag file", path="path"
            )
    stamps: list[int] = []
    logs: list[int] = []
    values: list[float] = []
    try:
        # The default typestore decodes rosbag2 sqlite3 bags that carry no message definitions.
        with AnyReader(sources, default_typestore=get_typestore(Stores.LATEST)) as reader:
            connections = [c for c in reader.connections if c.topic == topic]
            if not connections:
                listed = ", ".join(sorted({c.topic for c in reader.connections})) or "none"
                raise ParameterError(f"bag {path} has no topic {topic!r} (topics: {listed})", path="topic")
            msgtypes = {c.msgtype for c in connections}
            msgtype = connections[0].msgtype
            if len(msgtypes) > 1:
                raise ParameterError(
                    f"bag {path} topic {topic} has several types: {', '.join(sorted(msgtypes))}"
                )
            default = DEFAULT_FIELDS.get(msgtype)
            if default is None:
                raise ParameterError(
                    f"bag {path} topic {topic} is {msgtype}; bag_topic reads {', '.join(DEFAULT_FIELDS)}",
                    path="topic",
                )
            for connection, log_ns, raw in reader.messages(connections=connections):
                # Any: a message of a type read from the bag, its fields read by name.
                message: Any = reader.deserialize(raw, connection.msgtype)
                if not values:  # the field is checked on the first message, then read from each as from it
                    read = field_reader(msgtype, default if field is None else field, message)
                stamps.append(
                    int(message.header.stamp.sec) * 1_000_000_000 + int(message.header.stamp.nanosec)
                )
                logs.append(int(log_ns))
                values.append(float(read(message)))
    except ParameterError:
        raise
    except Exception as exc:  # rosbags raises many types (its own, struct.error, KeyError) on a bad bag
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ParameterError(f"cannot read bag {path}: {first}", path="path") from None
    if not values:
        raise ParameterError(f"bag {path} topic {topic} has no messages", path="topic")
    stamped = any(stamps)
    ns = np.array(stamps if stamped else logs, dtype=np.int64)
    # Integer nanoseconds relative to the first, then seconds: no float rounding of 1.4e9 s epochs.
    return msgtype, (ns - ns[0]).astype(float) * 1e-9, np.array(values), stamped


def bag_topic_profile(d: Mapping[str, object], base_dir: Path | None) -> Table:
    """Table of a(t) from a bag_topic mapping (field names checked by registry.profile_from_dict)."""
    kind = "bag_topic"
    path = field_path(kind, d["path"], base_dir)
    topic = field_text(kind, "topic", d["topic"])
    field = field_text(kind, "field", d["field"]) if "field" in d else None
    scale = field_scale(kind, d)
    msgtype, times, values, stamped = read_topic(path, topic, field)
    values = values * scale
    where: Callable[[int], str] = lambda i: f"bag {path.name} {topic} message {i}"  # noqa: E731
    start, end = window_fields(kind, d)
    name = "speed" if msgtype in SPEED_FIELDS else "acceleration"
    stretch = check_trace(times, values, where, name=name, start=start, end=end)
    clock = "header stamps" if stamped else "log times (header stamps unset)"
    read = field if field is not None else DEFAULT_FIELDS[msgtype]
    scaled = f" x {scale:g}" if scale != 1.0 else ""
    count = f"{stretch.times.size} messages, {clock}{stretch.note()}"
    label = f"bag_topic {path.name} {topic} ({msgtype} {read}{scaled}, {count})"
    if msgtype in SPEED_FIELDS:
        stretch, cutoff, default = fitted_stretch(kind, d, stretch)
        origin = f"{label}: " + describe_differentiation(cutoff, median_step(stretch.times), default)
        # A standalone copy (the scene stored in a bag): the speeds themselves, as a speed_table.
        recipe = speed_recipe("m/s", stretch, cutoff, d, signed=True)
        return differentiate(
            stretch.times,
            stretch.values,
            cutoff,
            start=stretch.lo,
            end=stretch.hi,
            origin=origin,
            recipe=recipe,
        )
    return recorded_acceleration(kind, d, stretch, label)
