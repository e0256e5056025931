"""bag_topic profiles: a(t) from a topic of a ROS 1, sqlite3 or MCAP bag (odometry differentiated, an
acceleration copied), the stated field and scale, bags without metadata, and one-line errors. "The units
test's bound" is test_speed_trace's straight-ramp test's.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pendulum_accel.errors import ParameterError
from pendulum_accel.motion_input import profile_from_dict
from test.motion_tables import table_of

# ---------------------------------------------------------------- bag_topic


def odometry(typestore: object, stamp_ns: int, vx: float) -> object:
    """nav_msgs/Odometry with twist.twist.linear.x = vx, of ``typestore``'s classes."""
    types = typestore.types  # type: ignore[attr-defined]
    time = types["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
    ros1 = "seq" in types["std_msgs/msg/Header"].__dataclass_fields__  # ROS 1 headers count messages
    header = types["std_msgs/msg/Header"](stamp=time, frame_id="odom", **({"seq": 0} if ros1 else {}))
    vec = types["geometry_msgs/msg/Vector3"]
    twist = types["geometry_msgs/msg/Twist"](linear=vec(x=vx, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=0.0))
    pose = types["geometry_msgs/msg/Pose"](
        position=types["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
        orientation=types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
    )
    return types["nav_msgs/msg/Odometry"](
        header=header,
        child_frame_id="base_link",
        pose=types["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
        twist=types["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=np.zeros(36)),
    )


EPOCH_NS = 1_700_000_000 * 10**9  # a recorded bag's stamps are wall-clock times
TIMES = np.arange(0.0, 30.0, 0.05)  # 20 Hz odometry
SPEEDS = 1.0 + 0.4 * TIMES  # a straight ramp: a = 0.4 m/s² exactly (see the units test's bound)


def write_odometry(path: Path, storage: str, stamps_s: np.ndarray = TIMES) -> Path:
    """A bag of /odom (nav_msgs/Odometry, v = SPEEDS) written with rosbags' own writers."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    ros1 = storage == "ros1"
    typestore = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    msgtype = "nav_msgs/msg/Odometry"
    if ros1:
        writer: object = Writer1(path)
    else:
        plugin = StoragePlugin.SQLITE3 if storage == "sqlite3" else StoragePlugin.MCAP
        writer = Writer2(path, version=9, storage_plugin=plugin)
    with writer as w:  # type: ignore[attr-defined]
        conn = w.add_connection("/odom", msgtype, typestore=typestore)
        # Logged in order at TIMES; the header stamps are ``stamps_s``, which may go back.
        for log_s, t, v in zip(TIMES, stamps_s, SPEEDS, strict=True):
            ns = EPOCH_NS + round(t * 1e9)
            msg = odometry(typestore, ns, float(v))
            raw = typestore.serialize_ros1(msg, msgtype) if ros1 else typestore.serialize_cdr(msg, msgtype)
            w.write(conn, EPOCH_NS + round(log_s * 1e9), raw)
    return path


@pytest.mark.parametrize("storage", ["ros1", "sqlite3", "mcap"])
def test_bag_topic_differentiates_odometry_from_any_bag(storage: str, tmp_path: Path) -> None:
    """ROS 1 bag, rosbag2 sqlite3 and MCAP (rosbags' writers): v = 1 + 0.4 t gives a = 0.4 from t = 0."""
    path = write_odometry(tmp_path / ("odom.bag" if storage == "ros1" else "odom"), storage)
    profile = table_of({"type": "bag_topic", "path": str(path), "topic": "/odom"})
    assert profile.times[0] == 0.0 and profile.times[-1] == pytest.approx(TIMES[-1], abs=1e-9)
    assert np.max(np.abs(np.array(profile.accels) - 0.4)) <= 1e-9  # a straight line (units test's bound)
    assert "nav_msgs/msg/Odometry twist.twist.linear.x, 600 messages, header stamps" in profile.origin
    assert profile_from_dict(profile.to_dict()) == profile  # a standalone speed_table


def test_bag_topic_reads_the_projects_own_mcap_truth(tmp_path: Path) -> None:
    """AccelStamped written by pendulum_accel's BagWriter: a(t) is the samples as recorded, t from 0."""
    from pendulum_accel.bag import messages as bm
    from pendulum_accel.bag.writer import BagWriter

    accels = np.sin(TIMES)
    with BagWriter(tmp_path / "truth") as writer:
        writer.add_topic("/car/accel/true", bm.ACCEL_STAMPED)
        for t, a in zip(TIMES, accels, strict=True):
            ns = EPOCH_NS + round(t * 1e9)
            writer.write(
                "/car/accel/true", ns, bm.serialize(bm.accel_stamped(ns, float(a)), bm.ACCEL_STAMPED)
            )
    for path in (tmp_path / "truth", next((tmp_path / "truth").glob("*.mcap"))):
        profile = table_of({"type": "bag_topic", "path": str(path), "topic": "/car/accel/true"})
        assert np.array_equal(np.array(profile.accels), accels)  # copied, not computed
        assert np.max(np.abs(np.array(profile.times) - TIMES)) <= 1e-9  # ns stamps, exact to 1 ns
    window = table_of(
        {
            "type": "bag_topic",
            "path": str(tmp_path / "truth"),
            "topic": "/car/accel/true",
            "start": 10.0,
            "end": 20.0,
        }
    )
    # Window ends interpolated linearly between 50 ms samples of sin: error ≤ (0.05)²/8 × max|sin''|.
    assert window.times[0] == 0.0 and window.times[-1] == pytest.approx(10.0, abs=1e-9)
    assert window.accels[0] == pytest.approx(math.sin(10.0), abs=0.05**2 / 8)


def split_mcap(source: Path, out_dir: Path, parts: int) -> None:
    """``source``'s messages in ``parts`` MCAP files of out_dir (a split recording, ros2 profile), each
    with the schemas and channels it uses, and no metadata.yaml (written with the mcap library)."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with source.open("rb") as stream:
        messages = list(make_reader(stream).iter_messages())
    out_dir.mkdir()
    for part, chunk in enumerate(np.array_split(np.arange(len(messages)), parts)):
        with (out_dir / f"part_{part}.mcap").open("wb") as out:
            writer = Writer(out)
            writer.start(profile="ros2")
            schemas: dict[int, int] = {}
            channels: dict[int, int] = {}
            for i in chunk:
                schema, channel, message = messages[i]
                if schema.id not in schemas:
                    schemas[schema.id] = writer.register_schema(schema.name, schema.encoding, schema.data)
                if channel.id not in channels:
                    channels[channel.id] = writer.register_channel(
                        channel.topic, channel.message_encoding, schemas[schema.id], channel.metadata
                    )
                writer.add_message(channels[channel.id], message.log_time, message.data, message.publish_time)
            writer.finish()


def test_bag_topic_reads_mcap_files_in_a_directory_without_metadata(tmp_path: Path) -> None:
    """A rosbag2 directory that lost its metadata.yaml (a recorder killed before writing it), or MCAP
    files copied into one: its .mcap files are read, one or a split recording's several, merged in log
    order, and give the table of the whole bag, float for float. With none: one line saying so."""
    bag = write_odometry(tmp_path / "odom", "mcap")
    whole = table_of({"type": "bag_topic", "path": str(bag), "topic": "/odom"})
    lone = tmp_path / "lone"
    lone.mkdir()
    mcap_file = next(bag.glob("*.mcap"))
    (lone / mcap_file.name).write_bytes(mcap_file.read_bytes())
    split_mcap(mcap_file, tmp_path / "split", parts=3)
    for directory in (lone, tmp_path / "split"):
        profile = table_of({"type": "bag_topic", "path": str(directory), "topic": "/odom"})
        assert np.array_equal(profile.times, whole.times) and np.array_equal(profile.accels, whole.accels)
    (tmp_path / "empty").mkdir()
    with pytest.raises(ParameterError, match=r"^cannot read bag .*empty: no metadata\.yaml and no \.mcap"):
        profile_from_dict({"type": "bag_topic", "path": str(tmp_path / "empty"), "topic": "/odom"})


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ({"topic": "/nope"}, "has no topic '/nope' (topics: /odom)"),
        ({"topic": "/odom", "path": "missing.bag"}, "no such file or directory"),
        ({"topic": "/odom", "cutoff_hz": 50.0}, "Nyquist frequency 10 Hz"),
    ],
)
def test_bag_topic_errors_are_one_line(spec: dict[str, object], message: str, tmp_path: Path) -> None:
    """Unknown topic, missing bag, cut-off beyond Nyquist: one line each."""
    write_odometry(tmp_path / "odom.bag", "ros1")
    full = {"type": "bag_topic", "path": "odom.bag", **spec}
    with pytest.raises(ParameterError) as info:
        profile_from_dict(full, base_dir=tmp_path)
    assert message in str(info.value) and "\n" not in str(info.value)


def write_imu(path: Path, forward: np.ndarray) -> Path:
    """An MCAP bag of /imu (sensor_msgs/Imu at TIMES) from an IMU mounted z backward, x up: the car's forward
    acceleration is −z and x holds g, as a robot's IMU often is (the Husky's in robot_localization)."""
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_HUMBLE)
    types = typestore.types
    msgtype = "sensor_msgs/msg/Imu"
    vec, quat = types["geometry_msgs/msg/Vector3"], types["geometry_msgs/msg/Quaternion"]
    with Writer2(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection("/imu", msgtype, typestore=typestore)
        for t, a in zip(TIMES, forward, strict=True):
            ns = EPOCH_NS + round(t * 1e9)
            time = types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            msg = types[msgtype](
                header=types["std_msgs/msg/Header"](stamp=time, frame_id="imu"),
                orientation=quat(x=0.0, y=0.0, z=0.0, w=1.0),
                orientation_covariance=np.zeros(9),
                angular_velocity=vec(x=0.0, y=0.0, z=0.0),
                angular_velocity_covariance=np.zeros(9),
                linear_acceleration=vec(x=9.81, y=0.0, z=-float(a)),
                linear_acceleration_covariance=np.zeros(9),
            )
            w.write(conn, ns, typestore.serialize_cdr(msg, msgtype))
    return path


def test_bag_topic_reads_the_stated_field_and_scale(tmp_path: Path) -> None:
    """An IMU mounted z backward: ``field: linear_acceleration.z`` with ``scale: -1`` gives the forward a(t)
    exactly (a copy times −1: no rounding), where the default field reads the IMU's x (g here); and
    odometry with ``scale: -1`` (an odometry whose x points backward) gives a = −0.4 to the units test's
    bound. The origin names the field and the scale, and the standalone copy keeps the scaled speeds."""
    accels = 0.8 * np.sin(0.5 * TIMES)
    path = write_imu(tmp_path / "imu", accels)
    spec: dict[str, object] = {"type": "bag_topic", "path": str(path), "topic": "/imu"}
    stated = table_of({**spec, "field": "linear_acceleration.z", "scale": -1})
    assert np.array_equal(np.array(stated.accels), accels)
    assert "sensor_msgs/msg/Imu linear_acceleration.z x -1," in stated.origin
    default = table_of(spec)
    assert np.all(np.array(default.accels) == 9.81)
    assert "sensor_msgs/msg/Imu linear_acceleration.x," in default.origin
    odom = write_odometry(tmp_path / "odom.bag", "ros1")
    backward = table_of({"type": "bag_topic", "path": str(odom), "topic": "/odom", "scale": -1})
    assert np.max(np.abs(np.array(backward.accels) + 0.4)) <= 1e-9
    assert profile_from_dict(backward.to_dict()) == backward


def test_bag_topic_reads_twist_with_covariance_and_vector3_stamped(tmp_path: Path) -> None:
    """robot_localization's twist input (TwistWithCovarianceStamped: a speed, differentiated: a = 0.4 to the
    units test's bound) and an IMU driver's free acceleration (Vector3Stamped: copied exactly), each from an
    MCAP bag written by rosbags."""
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_HUMBLE)
    types = typestore.types
    vec = types["geometry_msgs/msg/Vector3"]
    accels = 0.3 * np.cos(TIMES)

    def header(ns: int) -> Any:  # a rosbags message class instance
        time = types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
        return types["std_msgs/msg/Header"](stamp=time, frame_id="base_link")

    def twist(ns: int, k: int) -> object:
        moving = types["geometry_msgs/msg/Twist"](
            linear=vec(x=float(SPEEDS[k]), y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=0.0)
        )
        with_cov = types["geometry_msgs/msg/TwistWithCovariance"](twist=moving, covariance=np.zeros(36))
        return types["geometry_msgs/msg/TwistWithCovarianceStamped"](header=header(ns), twist=with_cov)

    def vector(ns: int, k: int) -> object:
        return types["geometry_msgs/msg/Vector3Stamped"](
            header=header(ns), vector=vec(x=float(accels[k]), y=0.0, z=0.0)
        )

    cases = (
        ("geometry_msgs/msg/TwistWithCovarianceStamped", twist),
        ("geometry_msgs/msg/Vector3Stamped", vector),
    )
    for msgtype, build in cases:
        path = tmp_path / msgtype.rsplit("/", 1)[1]
        with Writer2(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
            conn = w.add_connection("/motion", msgtype, typestore=typestore)
            for k, t in enumerate(TIMES):
                ns = EPOCH_NS + round(t * 1e9)
                w.write(conn, ns, typestore.serialize_cdr(build(ns, k), msgtype))
        profile = table_of({"type": "bag_topic", "path": str(path), "topic": "/motion"})
        assert msgtype in profile.origin
        if build is twist:
            assert np.max(np.abs(np.array(profile.accels) - 0.4)) <= 1e-9
        else:
            assert np.array_equal(np.array(profile.accels), accels)


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        (
            {"field": "linear_acceleration.w"},
            "sensor_msgs/msg/Imu has no number field 'linear_acceleration.w' (its number fields: "
            "orientation.x, orientation.y",
        ),
        ({"field": "header"}, "has no number field 'header'"),
        ({"field": ""}, "sensor_msgs/msg/Imu has no number field ''"),
        ({"field": "orientation_covariance"}, "has no number field 'orientation_covariance'"),
        ({"field": 3}, "bag_topic profile field 'field' must be text, got 3"),
        ({"scale": 0}, "bag_topic profile field 'scale' must not be 0"),
    ],
)
def test_bag_topic_field_and_scale_errors_are_one_line(
    spec: dict[str, object], message: str, tmp_path: Path
) -> None:
    """A field the type lacks (or that is no single number), a field that is not text, a zero scale: one
    line each, the first listing the type's number fields."""
    write_imu(tmp_path / "imu", np.zeros(TIMES.size))
    with pytest.raises(ParameterError) as info:
        profile_from_dict({"type": "bag_topic", "path": "imu", "topic": "/imu", **spec}, base_dir=tmp_path)
    assert message in str(info.value) and "\n" not in str(info.value)


def test_bag_topic_refuses_stamps_that_go_back_and_gaps(tmp_path: Path) -> None:
    """A header stamp before the previous one, or a hole of 5+ median steps: the message is named."""
    back = TIMES.copy()
    back[100] = back[98]
    write_odometry(tmp_path / "back.bag", "ros1", back)
    with pytest.raises(ParameterError, match=r"/odom message 100: time steps back"):
        profile_from_dict({"type": "bag_topic", "path": str(tmp_path / "back.bag"), "topic": "/odom"})
    holed = TIMES.copy()
    holed[300:] += 2.0
    write_odometry(tmp_path / "holed.bag", "ros1", holed)
    with pytest.raises(ParameterError, match=r"/odom message 300: gap of 2.05 s"):
        profile_from_dict({"type": "bag_topic", "path": str(tmp_path / "holed.bag"), "topic": "/odom"})
