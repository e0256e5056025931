"""``pendulum-accel export``: a golden bag round-trips through CSV and Parquet to the values the reader
decodes, under PlotJuggler's column names; the merged table sits on the angle's stamps."""

from __future__ import annotations

import re
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from pendulum_accel.bag import cdr_layout
from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.errors import ExportError
from pendulum_accel.bag.export import (
    BULK_TYPES,
    VISUAL_ROLES,
    column_name,
    export_bag,
    file_stem,
)
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.cli.main import main
from test.conftest import REPO
from test.refusal import error_line

GOLDEN = REPO / "bags" / "step_start"
JOINT_NAMES = {"position[0]": "pendulum_joint/position", "velocity[0]": "pendulum_joint/velocity"}
"""PlotJuggler's JointState series: <joint name>/<field>, not <field>[i]."""


def _read(path: Path) -> pd.DataFrame:
    """A table written by export, read back with pandas."""
    return pd.read_csv(path) if path.suffix == ".csv" else pd.read_parquet(path)


@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_every_topic_round_trips_to_the_reader_values(tmp_path: Path, fmt: str) -> None:
    bag = read_bag(GOLDEN)
    paths = export_bag(bag, tmp_path, fmt=fmt)
    # Every topic but what RViz and Foxglove draw (markers, the URDF), which export leaves out by default.
    tables = {t: info for t, info in bag.topics.items() if bm.role_of(t) not in VISUAL_ROLES}
    assert sorted(p.name for p in paths) == sorted(f"{file_stem(t)}.{fmt}" for t in tables)
    assert bm.TOPIC_IMU in tables
    for topic, info in tables.items():
        table = _read(tmp_path / f"{file_stem(topic)}.{fmt}")
        assert len(table) == info.count
        if info.msgtype in BULK_TYPES:
            arrays = bag.decode(topic)
            np.testing.assert_array_equal(table["t"], arrays.stamp)
            np.testing.assert_array_equal(table["log_time"], arrays.log_time_ns * 1e-9)
            for path, column in arrays.fields.items():
                name = column_name(
                    topic, JOINT_NAMES.get(path, path) if topic == bm.TOPIC_JOINT_STATES else path
                )
                np.testing.assert_array_equal(table[name], column)
        else:  # /diagnostics, named as PlotJuggler names it: <hardware_id>/<name>/<key>
            _, payloads = bag.raw(topic)
            messages: list[Any] = [bm.deserialize(p, info.msgtype) for p in payloads]
            prefix = f"{topic}/pendulum_accel/accel_estimator"
            assert table[f"{prefix}/message"].tolist() == [m.status[0].message for m in messages]
            assert table[f"{prefix}/level"].tolist() == [int(m.status[0].level) for m in messages]
            pairs = [{kv.key: kv.value for kv in m.status[0].values} for m in messages]
            for key in ("method", "state", "accepted", "resets"):
                expected = [p[key] if key in ("method", "state") else float(p[key]) for p in pairs]
                assert table[f"{prefix}/{key}"].tolist() == expected
    estimate = _read(tmp_path / f"car__accel__estimate.{fmt}")
    assert "/car/accel/estimate/accel/accel/linear/x" in estimate.columns  # PlotJuggler's name


def test_merged_table_sits_on_the_angle_stamps(tmp_path: Path) -> None:
    bag = read_bag(GOLDEN)
    (path,) = export_bag(bag, tmp_path, fmt="parquet", merged=True)
    table = _read(path)
    angles = bag.decode(bm.TOPIC_JOINT_STATES)
    np.testing.assert_array_equal(table["t"], angles.stamp)
    estimate = bag.decode(bm.TOPIC_ACCEL_ESTIMATE)
    at = np.searchsorted(angles.stamp, estimate.stamp)
    x = table["/car/accel/estimate/accel/accel/linear/x"].to_numpy()
    np.testing.assert_array_equal(x[at], estimate["accel.accel.linear.x"])
    np.testing.assert_array_equal(
        table["/car/accel/truth/accel/linear/x"], bag.decode("/car/accel/truth")["accel.linear.x"]
    )
    # /diagnostics (1 Hz): the latest report at or before each angle.
    message = table["/diagnostics/pendulum_accel/accel_estimator/message"]
    assert message.notna().all() and message.iloc[150] == message.iloc[100] != message.iloc[99]


def test_missing_extra_and_bad_input_are_one_line_errors(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["export", str(GOLDEN), "--out", str(tmp_path), "--topics", "/nope"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("pendulum-accel export: error: bag") and "/nope" in err and "\n" not in err
    monkeypatch.setitem(sys.modules, "pandas", None)
    with pytest.raises(ExportError, match=r"pip install 'pendulum_accel\[export\]'"):
        export_bag(read_bag(GOLDEN), tmp_path)
    assert main(["export", str(GOLDEN), "--out", str(tmp_path)]) == 2
    assert "needs pandas" in capsys.readouterr().err


def _robot_bag(path: Path, messages: list[tuple[str, str, Any]]) -> Path:
    """A rosbag2 MCAP bag of ``(topic, type, message)`` written by rosbags, 10 ms apart (ROS 2 Humble
    types): a robot's recording, not the chain's."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conns: dict[str, Any] = {}
        for i, (topic, msgtype, msg) in enumerate(messages):
            if topic not in conns:
                conns[topic] = writer.add_connection(topic, msgtype, typestore=store)
            writer.write(conns[topic], 10_000_000 * (i + 1), store.serialize_cdr(msg, msgtype))
    return path


def test_a_robot_s_topics_of_other_types_are_exported_when_they_are_tables(tmp_path: Path) -> None:
    """A robot's Odometry (87 numbers a message, frame strings aside) is a table: its columns carry the
    values written, PlotJuggler's names, t from its header. Messages of varying length, and messages of
    more than MAX_COLUMNS numbers (a camera image), are refused in one line before any file is written."""
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_HUMBLE)
    odometry, header = store.types["nav_msgs/msg/Odometry"], store.types["std_msgs/msg/Header"]
    time, pwc = (
        store.types["builtin_interfaces/msg/Time"],
        store.types["geometry_msgs/msg/PoseWithCovariance"],
    )
    twc, twist = store.types["geometry_msgs/msg/TwistWithCovariance"], store.types["geometry_msgs/msg/Twist"]
    pose, point = store.types["geometry_msgs/msg/Pose"], store.types["geometry_msgs/msg/Point"]
    quat, vec = store.types["geometry_msgs/msg/Quaternion"], store.types["geometry_msgs/msg/Vector3"]
    speeds = np.linspace(0.0, 2.0, 50)

    def odom(i: int, v: float) -> Any:
        return odometry(
            header(time(100 + i // 10, (i % 10) * 100_000_000), "odom"),
            "base_link",
            pwc(pose(point(0.1 * i, 0.0, 0.0), quat(0.0, 0.0, 0.0, 1.0)), np.zeros(36)),
            twc(twist(vec(v, 0.0, 0.0), vec(0.0, 0.0, 0.5)), np.eye(6).ravel()),
        )

    bag = _robot_bag(
        tmp_path / "robot", [("/odom", "nav_msgs/msg/Odometry", odom(i, v)) for i, v in enumerate(speeds)]
    )
    assert main(["export", str(bag), "--out", str(tmp_path / "tables")]) == 0
    table = pd.read_csv(tmp_path / "tables" / "odom.csv")
    assert len(table) == speeds.size and len(table.columns) == 2 + 87
    np.testing.assert_array_equal(table["/odom/twist/twist/linear/x"], speeds)  # shortest repr: exact
    np.testing.assert_array_equal(table["/odom/twist/twist/angular/z"], 0.5)
    np.testing.assert_array_equal(table["/odom/pose/pose/position/x"], 0.1 * np.arange(speeds.size))
    np.testing.assert_array_equal(table["t"], 100 + np.arange(speeds.size) * 0.1)  # header stamps, s
    array, layout = (
        store.types["std_msgs/msg/Float64MultiArray"],
        store.types["std_msgs/msg/MultiArrayLayout"],
    )
    image = store.types["sensor_msgs/msg/Image"]
    for name, msgs, problem in (
        (
            "ragged",
            [
                ("/scores", "std_msgs/msg/Float64MultiArray", array(layout([], 0), np.arange(n, dtype=float)))
                for n in (2, 3)
            ],
            "its messages come in 2 shapes with different fields (arrays of varying length)",
        ),
        (
            "camera",
            [
                (
                    "/image",
                    "sensor_msgs/msg/Image",
                    image(header(time(1, 0), "cam"), 40, 40, "mono8", 0, 40, np.zeros(1600, np.uint8)),
                )
            ],
            "1606 numbers a message; a table takes at most 1000 columns",  # stamp 2, sizes 4, data 1600,
        ),
    ):
        bag = _robot_bag(tmp_path / name, [("/odom", "nav_msgs/msg/Odometry", odom(0, 1.0)), *msgs])
        out = tmp_path / f"{name}_tables"
        with pytest.raises(ExportError, match=re.escape(problem)):
            export_bag(read_bag(bag), out)
        assert not out.exists()  # nothing half-exported: the odometry was not written either


def _marker_array(count: int) -> Any:
    """A MarkerArray of ``count`` markers, each a copy of the golden bag's first marker (its own object,
    as a decoded message's markers are)."""
    import copy

    _, payloads = read_bag(GOLDEN).raw(bm.TOPIC_MARKERS)
    first: Any = bm.deserialize(payloads[0], bm.MARKER_ARRAY)
    return type(first)(markers=[copy.deepcopy(first.markers[0]) for _ in range(count)])


def test_export_of_marker_arrays_with_big_messages_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Issue 58's case: 6 MarkerArrays, 3 of them with 2000 markers (64 000 numbers each). Export hung
    learning their layout (killed after 120 s, nothing written); it now refuses the topic in one line,
    exit 2, nothing written."""
    from pendulum_accel.bag.writer import BagWriter

    with BagWriter(tmp_path / "markers") as writer:
        writer.add_topic("/viz", bm.MARKER_ARRAY)
        for k in range(6):
            writer.write(
                "/viz",
                (k + 1) * 10_000_000,
                bm.serialize(_marker_array(2000 if k % 2 else 1), bm.MARKER_ARRAY),
            )
    code = main(["export", str(tmp_path / "markers"), "--out", str(tmp_path / "tables")])
    error_line(code, capsys.readouterr().err, "topic /viz has type visualization_msgs/msg/MarkerArray",
               "which export does not flatten")  # fmt: skip
    assert not (tmp_path / "tables").exists()


def test_a_layout_is_learnt_from_a_fixed_number_of_serializations(monkeypatch: pytest.MonkeyPatch) -> None:
    """Layout.of of a 50-marker MarkerArray (1 600 numeric fields) serializes the message 5 times (the
    zeroed key, the template, two fills, and the template again), not twice per field, which made a
    2000-marker message take hours; and it finds the same offsets as the field-by-field learning, for a
    3-marker MarkerArray and for every message type of the golden bag."""
    bag = read_bag(GOLDEN)
    samples: list[tuple[object, str]] = [(_marker_array(3), bm.MARKER_ARRAY)]
    for topic, info in bag.topics.items():
        _, payloads = bag.raw(topic)
        samples.append((bm.deserialize(payloads[0], info.msgtype), info.msgtype))
    calls = []
    real = bm.serialize

    def counted(msg: object, msgtype: str) -> bytes:
        calls.append(msgtype)
        return real(msg, msgtype)

    one = len(cdr_layout.Layout.of(_marker_array(1), bm.MARKER_ARRAY).fields)
    monkeypatch.setattr(cdr_layout, "serialize", counted)
    cdr_layout._LAYOUTS.clear()
    layout = cdr_layout.Layout.of(_marker_array(50), bm.MARKER_ARRAY)
    assert len(layout.fields) == 50 * one > 1000
    assert len(calls) == 5, calls
    monkeypatch.setattr(cdr_layout, "serialize", real)
    for msg, msgtype in samples:
        fast = cdr_layout.Layout._learn(msg, msgtype)
        by_field = cdr_layout.Layout._learn_by_field(msg, msgtype)
        assert fast.fields == by_field.fields, msgtype
        np.testing.assert_array_equal(fast.mask, by_field.mask)
        np.testing.assert_array_equal(fast.template, by_field.template)
