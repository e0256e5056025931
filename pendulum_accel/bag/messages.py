"""ROS 2 messages of the chain as CDR bytes: one-off via the rosbags typestore, in bulk via numpy.

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
import json
import re
import struct
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray
from rosbags.interfaces import (
    Nodetype,
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore
from rosbags.typesys.stores.ros2_kilted import builtin_interfaces__msg__Time as TimeMsg
from rosbags.typesys.stores.ros2_kilted import diagnostic_msgs__msg__DiagnosticArray as DiagnosticArrayMsg
from rosbags.typesys.stores.ros2_kilted import diagnostic_msgs__msg__DiagnosticStatus as DiagnosticStatusMsg
from rosbags.typesys.stores.ros2_kilted import diagnostic_msgs__msg__KeyValue as KeyValueMsg
from rosbags.typesys.stores.ros2_kilted import geometry_msgs__msg__Accel as AccelMsg
from rosbags.typesys.stores.ros2_kilted import geometry_msgs__msg__AccelStamped as AccelStampedMsg
from rosbags.typesys.stores.ros2_kilted import (
    geometry_msgs__msg__AccelWithCovariance as AccelWithCovarianceMsg,
)
from rosbags.typesys.stores.ros2_kilted import (
    geometry_msgs__msg__AccelWithCovarianceStamped as AccelWithCovarianceStampedMsg,
)
from rosbags.typesys.stores.ros2_kilted import geometry_msgs__msg__Quaternion as QuaternionMsg
from rosbags.typesys.stores.ros2_kilted import geometry_msgs__msg__Vector3 as Vector3Msg
from rosbags.typesys.stores.ros2_kilted import rosgraph_msgs__msg__Clock as ClockMsg
from rosbags.typesys.stores.ros2_kilted import sensor_msgs__msg__Imu as ImuMsg
from rosbags.typesys.stores.ros2_kilted import sensor_msgs__msg__JointState as JointStateMsg
from rosbags.typesys.stores.ros2_kilted import std_msgs__msg__Header as HeaderMsg

from pendulum_accel.errors import BagError, SeveralChainsError

TYPESTORE: Typestore = get_typestore(Stores.ROS2_KILTED)

JOINT_STATE = "sensor_msgs/msg/JointState"
ACCEL_STAMPED = "geometry_msgs/msg/AccelStamped"
ACCEL_WITH_COVARIANCE_STAMPED = "geometry_msgs/msg/AccelWithCovarianceStamped"
CLOCK = "rosgraph_msgs/msg/Clock"
DIAGNOSTIC_ARRAY = "diagnostic_msgs/msg/DiagnosticArray"
IMU = "sensor_msgs/msg/Imu"

STRING_MSG = "std_msgs/msg/String"
MARKER_ARRAY = "visualization_msgs/msg/MarkerArray"

# The chain's topics by role. Relative names, so that a namespace (__ns, launch's namespace:=,
# PushRosNamespace) or a remap applies and two chains on one domain cannot cross-talk; /clock and
# /diagnostics stay global, as ROS conventions want (one clock per graph, one aggregator).
JOINT_STATES = "pendulum/joint_states"
ACCEL_TRUTH = "car/accel/truth"
STRING = "pendulum/string"
ACCEL_ESTIMATE = "car/accel/estimate"
IMU_DATA_RAW = "imu/data_raw"
MARKERS = "pendulum/markers"
ROBOT_DESCRIPTION = "robot_description"

# The same topics as resolved in the root namespace: what ``generate`` and the golden bags hold.
TOPIC_JOINT_STATES = "/" + JOINT_STATES
TOPIC_ACCEL_TRUTH = "/" + ACCEL_TRUTH
TOPIC_STRING = "/" + STRING
TOPIC_ACCEL_ESTIMATE = "/" + ACCEL_ESTIMATE
TOPIC_CLOCK = "/clock"
TOPIC_DIAGNOSTICS = "/diagnostics"

# The fixed topic contract of a generated bag: topic -> message type.
TOPIC_TYPES: dict[str, str] = {
    TOPIC_JOINT_STATES: JOINT_STATE,
    TOPIC_ACCEL_TRUTH: ACCEL_STAMPED,
    TOPIC_STRING: JOINT_STATE,
    TOPIC_ACCEL_ESTIMATE: ACCEL_WITH_COVARIANCE_STAMPED,
    TOPIC_CLOCK: CLOCK,
    TOPIC_DIAGNOSTICS: DIAGNOSTIC_ARRAY,
}

TOPIC_IMU = "/" + IMU_DATA_RAW
"""The estimator's Imu (REP-145 ``imu/data_raw``) as recorded from the root namespace."""
TOPIC_MARKERS = "/" + MARKERS
TOPIC_ROBOT_DESCRIPTION = "/" + ROBOT_DESCRIPTION

VIEWER_TOPIC_TYPES: dict[str, str] = {
    TOPIC_IMU: IMU,
    TOPIC_MARKERS: MARKER_ARRAY,
    TOPIC_ROBOT_DESCRIPTION: STRING_MSG,
}
"""What a recording holds beside the contract above, for viewers (RViz, Foxglove): the Imu, the markers
and the URDF. ``generate`` and the golden bags hold both, as a live recording of the chain does."""

ROLE_TYPES: dict[str, str] = {
    JOINT_STATES: JOINT_STATE,
    ACCEL_TRUTH: ACCEL_STAMPED,
    STRING: JOINT_STATE,
    ACCEL_ESTIMATE: ACCEL_WITH_COVARIANCE_STAMPED,
    IMU_DATA_RAW: IMU,
    MARKERS: MARKER_ARRAY,
    ROBOT_DESCRIPTION: STRING_MSG,
    TOPIC_CLOCK: CLOCK,
    TOPIC_DIAGNOSTICS: DIAGNOSTIC_ARRAY,
}
"""Every topic of a live chain by role (a relative name, or /clock and the global /diagnostics). A namespaced
chain's clock is remapped to ``<ns>/clock``, which plays the /clock role (role_of)."""

CHAIN_ROLES: tuple[str, ...] = tuple(ROLE_TYPES)
"""What the recorder records by default: every role, resolved in the recorder's namespace."""


def role_of(name: str) -> str | None:
    """The chain role of a topic name: a global role as is, a chain's own clock (``/car1/clock``) as
    /clock, else the relative role ``name`` ends with ('pendulum/joint_states', '/pendulum/joint_states',
    '/car1/pendulum/joint_states' → the same role); None for any other name."""
    if name in (TOPIC_CLOCK, TOPIC_DIAGNOSTICS):
        return name
    if name.startswith("/") and name.endswith(TOPIC_CLOCK):
        return TOPIC_CLOCK
    bare = name.lstrip("/")
    for role in ROLE_TYPES:
        if not role.startswith("/") and (bare == role or bare.endswith("/" + role)):
            return role
    return None


def topic_type(name: str) -> str | None:
    """Message type of a chain topic under any namespace (see role_of); None for any other name."""
    role = role_of(name)
    return None if role is None else ROLE_TYPES[role]


CUSTOM_TOPICS = "pendulum_accel.topics"
"""custom_data key of a recording's topic map: JSON {role: recorded name} (a remap or a namespace applied)."""


PENDULUM_JOINT = "pendulum_joint"
"""The pendulum's joint in the chain's JointState (the URDF's, the simulator's; the estimator's default)."""
FRAME_ID = "base_link"
"""The car's frame (REP-103), in which the chain stamps its messages."""


@dataclass
class TopicChoice:
    """Which of a bag's topics plays each chain role: ``roles`` (role -> name: the recording's stored map,
    then the user's ``--topic ROLE=NAME`` on top), and ``namespace`` ('' or '/car1': of a bag holding
    several chains, the one to read)."""

    roles: dict[str, str] = field(default_factory=dict)
    namespace: str = ""
    joint: str = PENDULUM_JOINT
    """The pendulum's joint in the angles' JointState (``--joint``; the estimator node's ``joint``)."""
    joint_frame: str = FRAME_ID
    """The frame_id the angles may carry besides none (``--joint-frame``; the node's ``joint_frame_id``)."""


def stored_roles(custom_data: Mapping[str, str]) -> dict[str, str]:
    """{role: topic} of a recording's stored topic map (CUSTOM_TOPICS); {} when it has none or it is not
    a JSON object of strings."""
    try:
        doc = json.loads(custom_data.get(CUSTOM_TOPICS, "{}"))
    except ValueError:
        return {}
    if not isinstance(doc, dict):
        return {}
    return {str(k): str(v) for k, v in doc.items() if isinstance(v, str) and role_of(str(k)) == str(k)}


def role_name(text: str) -> str:
    """The chain role ``text`` names ('/pendulum/joint_states' or 'pendulum/joint_states' → the latter);
    ValueError listing the roles when it names none."""
    role = role_of(text)
    if role is None or text.lstrip("/") != role.lstrip("/"):
        raise ValueError(f"{text!r} is not a chain role: one of {', '.join(CHAIN_ROLES)}")
    return role


def namespace_of(name: str, role: str) -> str:
    """The namespace a topic ``name`` playing ``role`` is in ('/car1/car/accel/truth' → '/car1'; '/')."""
    cut = len(role) if role.startswith("/") else len(role) + 1
    return name[:-cut] or "/"


def in_namespace(name: str, namespace: str) -> bool:
    """True when topic ``name`` belongs to ``namespace`` ('/car1'), or is the global /diagnostics."""
    return name == TOPIC_DIAGNOSTICS or name.startswith(namespace.rstrip("/") + "/")


def find_topic(names: Iterable[str], role: str, choice: TopicChoice | None = None) -> str | None:
    """The one name in ``names`` (a bag's topics) that plays ``role``, None when none does: the one the
    ``choice`` maps it to, else the one whose name ends with the role, under any namespace (under the
    choice's namespace, when it names one); BagError when several do (a bag holding two chains)."""
    names = list(names)
    if choice is not None and choice.roles.get(role) in names:
        return choice.roles[role]
    found = [name for name in names if role_of(name) == role]
    if choice is not None and choice.namespace:
        found = [name for name in found if in_namespace(name, choice.namespace)]
    if len(found) > 1:
        spaces = sorted({namespace_of(name, role) for name in found})
        raise SeveralChainsError(
            f"{len(found)} topics play the role {role} ({', '.join(sorted(found))}): the bag holds "
            f"several chains; pick one with --namespace ({' or '.join(spaces)}) or name the topic with "
            f"--topic {role}=NAME",
            spaces,
        )
    return found[0] if found else None


def chain_topic(names: Iterable[str], topic: str, choice: TopicChoice | None = None) -> str:
    """The name among ``names`` (a bag's topics) of a chain topic given by its root name
    (``/pendulum/joint_states``): the topic that plays its role (find_topic: the ``choice``'s, else
    under any namespace, ``/car1/pendulum/joint_states``), else ``topic`` itself, so a missing one is
    reported by its usual name; BagError when several namespaces hold it (see find_topic)."""
    found = find_topic(names, role_of(topic) or topic, choice)
    return topic if found is None else found


STRING_JOINT = "string_joint"

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
_NS_PER_S = 1_000_000_000


def qos_profile(*, reliable: bool = True, depth: int = 1000, transient_local: bool = False) -> Qos:
    """Offered QoS of one publisher, as rosbag2 stores it (KEEP_LAST depth, reliability, durability)."""
    zero = QosTime(sec=0, nsec=0)
    return Qos(
        history=QosHistory.KEEP_LAST,
        depth=depth,
        reliability=QosReliability.RELIABLE if reliable else QosReliability.BEST_EFFORT,
        durability=QosDurability.TRANSIENT_LOCAL if transient_local else QosDurability.VOLATILE,
        deadline=zero,
        lifespan=zero,
        liveliness=QosLiveliness.AUTOMATIC,
        liveliness_lease_duration=zero,
        avoid_ros_namespace_conventions=False,
    )


def seconds_to_ns(t: ArrayLike) -> NDArray[np.int64]:
    """ns = round(t · 1e9), rejecting NaN, inf and negative times (ROS stamps are unsigned)."""
    arr = np.asarray(t, dtype=np.float64)
    if not np.all(np.isfinite(arr)):
        raise BagError("time stamps must be finite, got NaN or inf")
    if np.any(arr < 0.0):
        raise BagError(f"time stamps must be >= 0, got {float(arr.min())!r}")
    return np.rint(arr * _NS_PER_S).astype(np.int64)


def split_stamp(ns: ArrayLike) -> tuple[NDArray[np.int32], NDArray[np.uint32]]:
    """(sec, nanosec) = (ns div 1e9, ns mod 1e9): builtin_interfaces/Time from integer nanoseconds."""
    arr = np.asarray(ns, dtype=np.int64)
    return (arr // _NS_PER_S).astype(np.int32), (arr % _NS_PER_S).astype(np.uint32)


def stamp_seconds(sec: ArrayLike, nanosec: ArrayLike) -> NDArray[np.float64]:
    """t = sec + nanosec · 1e-9 (float seconds from a builtin_interfaces/Time column pair)."""
    return np.asarray(sec, dtype=np.float64) + np.asarray(nanosec, dtype=np.float64) * 1e-9


def _time(ns: int) -> TimeMsg:
    """builtin_interfaces/Time for integer nanoseconds."""
    sec, nanosec = divmod(int(ns), _NS_PER_S)
    return TimeMsg(sec=sec, nanosec=nanosec)


def _header(ns: int, frame_id: str = FRAME_ID) -> HeaderMsg:
    """std_msgs/Header with stamp = ns and the given frame."""
    return HeaderMsg(stamp=_time(ns), frame_id=frame_id)


def _vector3(x: float = 0.0, y: float = 0.0, z: float = 0.0) -> Vector3Msg:
    """geometry_msgs/Vector3 (x, y, z)."""
    return Vector3Msg(x=float(x), y=float(y), z=float(z))


def _floats(values: Sequence[float]) -> NDArray[np.float64]:
    """float64 sequence field as the typestore expects it (a numpy array)."""
    return np.asarray(values, dtype=np.float64).reshape(-1)


def joint_state(
    stamp_ns: int,
    names: Sequence[str],
    position: Sequence[float],
    velocity: Sequence[float] = (),
    effort: Sequence[float] = (),
    frame_id: str = FRAME_ID,
) -> JointStateMsg:
    """sensor_msgs/JointState(header(stamp, frame_id), name, position, velocity, effort)."""
    return JointStateMsg(
        header=_header(stamp_ns, frame_id),
        name=list(names),
        position=_floats(position),
        velocity=_floats(velocity),
        effort=_floats(effort),
    )


def accel_stamped(stamp_ns: int, ax: float, frame_id: str = FRAME_ID) -> AccelStampedMsg:
    """geometry_msgs/AccelStamped with accel.linear.x = ax, all else 0."""
    accel = AccelMsg(linear=_vector3(ax), angular=_vector3())
    return AccelStampedMsg(header=_header(stamp_ns, frame_id), accel=accel)


# geometry_msgs/AccelWithCovariance has no "unknown" flag (sensor_msgs/Imu's −1 is for Imu only);
# robot_localization copies the matrix as given and ignores axes whose update vector is false, so
# a variance far beyond any real one says "no information" (its diagnostics flag > 1e3 on axes it fuses).
UNMEASURED_VARIANCE = 1.0e6


def accel_with_covariance_stamped(
    stamp_ns: int, ax: float, variance: float, frame_id: str = FRAME_ID
) -> AccelWithCovarianceStampedMsg:
    """geometry_msgs/AccelWithCovarianceStamped: linear.x = ax, covariance[0] = variance, rest unmeasured.

    Row-major 6×6 over (linear x, y, z, angular x, y, z): [0] = var(a_x) in (m/s²)²; the other
    diagonal entries [7], [14] (linear y, z, (m/s²)²) and [21], [28], [35] (angular, (rad/s²)²) are
    UNMEASURED_VARIANCE, "not measured" (a zero would read "known exactly"); off-diagonals 0.
    """
    accel = AccelMsg(linear=_vector3(ax), angular=_vector3())
    cov = np.zeros(36, dtype=np.float64)
    cov[7::7] = UNMEASURED_VARIANCE
    cov[0] = variance
    wrapped = AccelWithCovarianceMsg(accel=accel, covariance=cov)
    return AccelWithCovarianceStampedMsg(header=_header(stamp_ns, frame_id), accel=wrapped)


def imu(
    stamp_ns: int, ax: float, az: float, var_x: float, var_unmeasured: float, frame_id: str = FRAME_ID
) -> ImuMsg:
    """sensor_msgs/Imu of a pendulum (REP-145 data_raw): specific force (ax, 0, az), its covariance
    diag(var_x, var_unmeasured, var_unmeasured). Orientation and angular velocity are not measured:
    covariance[0] = -1, as the message definition asks, with the identity quaternion (a valid unit
    quaternion: rviz_imu_plugin rejects (0, 0, 0, 0)) and a zero angular velocity."""
    not_measured = np.zeros(9, dtype=np.float64)
    not_measured[0] = -1.0
    accel_cov = np.diag([var_x, var_unmeasured, var_unmeasured]).astype(np.float64).reshape(9)
    return ImuMsg(
        header=_header(stamp_ns, frame_id),
        orientation=QuaternionMsg(x=0.0, y=0.0, z=0.0, w=1.0),
        orientation_covariance=not_measured,
        angular_velocity=_vector3(),
        angular_velocity_covariance=not_measured.copy(),
        linear_acceleration=_vector3(ax, 0.0, az),
        linear_acceleration_covariance=accel_cov,
    )


def clock(stamp_ns: int) -> ClockMsg:
    """rosgraph_msgs/Clock(clock = stamp)."""
    return ClockMsg(clock=_time(stamp_ns))


def diagnostic_array(
    stamp_ns: int, level: int, name: str, message: str, values: Mapping[str, str] | None = None
) -> DiagnosticArrayMsg:
    """diagnostic_msgs/DiagnosticArray holding one DiagnosticStatus(level, name, message, values)."""
    status = DiagnosticStatusMsg(
        level=int(level),
        name=name,
        message=message,
        hardware_id="pendulum_accel",
        values=[KeyValueMsg(key=k, value=v) for k, v in (values or {}).items()],
    )
    return DiagnosticArrayMsg(header=_header(stamp_ns, ""), status=[status])


def serialize(msg: object, msgtype: str) -> bytes:
    """CDR bytes of one message via the rosbags typestore."""
    return bytes(TYPESTORE.serialize_cdr(msg, msgtype))


def deserialize(raw: bytes | memoryview, msgtype: str) -> object:
    """One message from its CDR bytes via the rosbags typestore; BagError when they do not parse."""
    try:
        return TYPESTORE.deserialize_cdr(raw, msgtype)
    except Exception as err:  # rosbags raises assorted low-level errors on bad bytes
        raise BagError(f"cannot decode a {msgtype} message ({len(raw)} bytes): {err}") from None


CDR_END_ALIGNMENT = 4
"""A CDR stream may end with up to 3 padding bytes that round its length up to a multiple of 4 (rclpy
writes them; the typestore does not)."""


def canonical_cdr(raw: bytes | memoryview, msgtype: str) -> tuple[object, bytes]:
    """(message, its typestore bytes) when ``raw`` decodes correctly, else BagError.

    Correct: the typestore decodes it and consumes the whole payload, except the end padding that
    rounds the length up to a multiple of CDR_END_ALIGNMENT. The decode consumes exactly as many
    bytes as the typestore writes for the message, so consumed = len(canonical bytes). Padding
    bytes inside the payload are not compared (rclpy leaves them uninitialised).
    """
    msg = deserialize(raw, msgtype)
    canonical = serialize(msg, msgtype)
    used, size = len(canonical), len(raw)
    padded = -(-used // CDR_END_ALIGNMENT) * CDR_END_ALIGNMENT
    if size != used and size != padded:
        raise BagError(f"a {msgtype} message has {size - used} bytes past its end (uses {used} of {size})")
    return msg, canonical


M = TypeVar("M")


def deserialize_as(raw: bytes | memoryview, msgtype: str, cls: type[M]) -> M:
    """deserialize(raw, msgtype) typed as ``cls`` (the rosbags class of msgtype); BagError otherwise."""
    msg = deserialize(raw, msgtype)
    if not isinstance(msg, cls):
        raise BagError(f"a {msgtype} message decoded as {type(msg).__name__}, not {cls.__name__}")
    return msg


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
    return np.frombuffer(bytes([byte] * np.dtype(dtype).itemsize), dtype=dtype)[0]


def _numeric_leaves(msgtype: str, msg: object, prefix: str = "") -> list[tuple[str, str]]:
    """(path, numpy dtype) of every numeric field of ``msg``, array elements one by one, in field order."""
    leaves: list[tuple[str, str]] = []
    # rosbags types field definitions as a union by node kind; the kind tag below narrows it.
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
        out: dict[str, NDArray[Any]] = {}
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
