"""ROS 2 messages of the chain: their types, topics and roles, each message built and its CDR bytes read and
written one at a time via the rosbags typestore (in bulk via numpy: ``cdr_layout``)."""

from __future__ import annotations

import json
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TypeVar

import numpy as np
from numpy.typing import ArrayLike, NDArray
from rosbags.interfaces import (
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
from rosbags.typesys.stores.ros2_kilted import diagnostic_msgs__msg__DiagnosticArray
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

from pendulum_accel.bag.errors import BagError, SeveralChainsError

TYPESTORE: Typestore = get_typestore(Stores.ROS2_KILTED)

DiagnosticArrayMsg = diagnostic_msgs__msg__DiagnosticArray
"""The rosbags class of a /diagnostics message (deserialize_as checks one against it): a name of this module,
so its readers need not import the typestore's."""

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
