"""accel_estimator over real DDS: each diagnostic state provoked, estimates finite and stamped, parameters."""

from __future__ import annotations

import math
import signal
import time
from pathlib import Path
from typing import Any

import pytest
import yaml

from pendulum_accel.bag import messages as bm
from test.chain_helpers import run_probe, start_node
from test.conftest import Spawn

pytestmark = [
    pytest.mark.ros,
]

G = 9.80665
THETA_2 = math.atan(2.0 / G)  # at rest under a = 2 m/s²


def test_every_diagnostic_state_and_no_nonfinite_output(spawn: Spawn) -> None:
    estimator = start_node(
        spawn,
        "estimator_node",
        {"scene": "lecture_constant", "diagnostics_period": 0.2, "stale_after": 0.5},
    )
    estimator.wait_for(r"estimating with", timeout=60)
    # Stamps advance 50 ms per sample (wall pace 10 ms): after 2 s of sim time a jump back to 0
    # is longer than the guard's 1 s reset threshold.
    normal = [[0.05 * i, THETA_2] for i in range(1, 41)]
    nan_sample = [[2.05, None]]
    after_nan = [[2.05 + 0.05 * i, THETA_2] for i in range(1, 11)]
    steep = [[2.6 + 0.05 * i, math.radians(85.0)] for i in range(10)]
    jumped = [[0.001 + 0.05 * i, THETA_2] for i in range(30)]
    # Each stage waits for its diagnostic before the next is provoked: a busy machine may hold the
    # estimator back long enough for two stages to share one diagnostics period.
    # The first wait is for the probe's own /diagnostics subscription: the estimator may match the probe's
    # publisher (wait_subscribers) before the probe's listener matches the estimator's diagnostics, and
    # then the STALE it published before the first sample never reached the probe (CI, stop 48).
    feed = [
        ["until", "STALE", 10.0],
        *normal,
        ["until", "OK", 10.0],
        *nan_sample,
        *after_nan,
        ["until", "ERROR", 10.0],
        *steep,
        ["until", "WARN", 10.0],
        *jumped,
        ["until", "RESET", 10.0],
    ]
    result = run_probe(
        spawn,
        {
            "listen": ["/car/accel/estimate", "/diagnostics"],
            "wait_subscribers": 1,
            "feed": feed,
            "linger": 1.5,
        },
    )
    states = [values["state"] for _, _, values in result["diagnostics"]]
    messages = [message for _, message, _ in result["diagnostics"]]
    # Before the first sample: STALE, waiting for input (never OK with 0 samples).
    assert messages[0] == "STALE: waiting for input", messages[:3]
    # Each state shows up, in the order it was provoked.
    order = []
    position = 0
    for wanted in ("OK", "ERROR", "WARN near 90°", "RESET", "STALE"):
        for i in range(position, len(states)):
            if (states[i] == wanted) or (
                wanted.startswith("WARN") and states[i] == "WARN" and "near 90°" in messages[i]
            ):
                order.append(i)
                position = i + 1
                break
        else:
            raise AssertionError(
                f"no {wanted} after diagnostic #{position}: {list(zip(states, messages, strict=True))}"
            )
    first = dict(zip(("OK", "ERROR", "WARN", "RESET", "STALE"), order, strict=True))
    levels = {values["state"]: level for level, _, values in result["diagnostics"]}
    assert levels == {"OK": 0, "WARN": 1, "ERROR": 2, "RESET": 1, "STALE": 3}
    assert "non-finite" in messages[first["ERROR"]]
    assert "time jumped back" in messages[first["RESET"]]
    # The input's rate by its stamps (1 / median Δt of the last 64): 50 ms steps, 20 Hz to the stamps' ulps.
    assert float(result["diagnostics"][-1][2]["input_rate_hz"]) == pytest.approx(20.0, rel=1e-9)
    # Estimates: finite, variance ≥ 0, each stamped with an input's stamp, none for the NaN input.
    fed_stamps = {round(t, 9) for t, _ in [*normal, *after_nan, *steep, *jumped]}
    estimates = result["estimates"]
    assert len(estimates) >= 60
    for t, a, var in estimates:
        assert math.isfinite(a) and math.isfinite(var) and var >= 0.0
        assert round(t, 9) in fed_stamps
    # After the reset the estimator starts over from the θ of a = 2 m/s²: the last estimates are near 2.
    assert abs(estimates[-1][1] - 2.0) < 0.05
    estimator.proc.send_signal(signal.SIGINT)
    assert estimator.finish(timeout=20) == 0
    assert "dropped 1 non-finite" in estimator.text and "1 resets" in estimator.text


def test_invalid_parameters_are_rejected_with_a_reason(spawn: Spawn) -> None:
    estimator = start_node(spawn, "estimator_node", {"scene": "lecture_constant"})
    estimator.wait_for(r"estimating with", timeout=60)
    result = run_probe(
        spawn,
        {
            "set": {
                "node": "accel_estimator",
                "params": {"method": "bogus", "length": -1.0, "noise_std": 0.002},
            }
        },
    )
    (method_ok, method_reason), (length_ok, length_reason), (noise_ok, noise_reason) = result["set"]
    assert not method_ok and "unknown estimator 'bogus'" in method_reason
    assert not length_ok and "length" in length_reason
    assert noise_ok, noise_reason
    assert result["get"] == {"method": "kalman", "length": 1.0, "noise_std": 0.002}
    # One rebuild, for the one accepted change: none at start up, where each publisher declares its
    # qos_overrides parameters (those had rebuilt the estimator 20 times, the scene read each time).
    estimator.proc.send_signal(signal.SIGINT)
    assert estimator.finish(timeout=20) == 0
    assert estimator.text.count("estimator rebuilt") == 1, estimator.text


def test_other_joint_state_shapes_take_the_general_path(spawn: Spawn) -> None:
    """Our joint without velocity: not our fixed layout, so rclpy deserializes it and â = g tan θ. Joints
    without ours are another robot's JointState (guard.joint_state_problem, the rule the offline commands
    apply too): dropped, counted, no estimate."""
    estimator = start_node(
        spawn, "estimator_node", {"scene": "lecture_constant", "method": "instant", "diagnostics_period": 0.2}
    )
    estimator.wait_for(r"estimating with", timeout=60)
    theta = math.atan2(2.0, G)
    feed = [[0.01 * i, theta] for i in range(50)]
    result = run_probe(
        spawn,
        {
            "listen": ["/car/accel/estimate"],
            "wait_subscribers": 1,
            "joints": ["pendulum_joint"],
            "feed": feed,
            "until_estimates": [len(feed), 30.0],
            "linger": 1.0,
        },
    )
    stamps = [t for t, _, _ in result["estimates"]]
    assert stamps == pytest.approx([t for t, _ in feed], abs=1e-9)  # one estimate per input, in order
    for _, accel, _ in result["estimates"]:
        # g tan(atan(2/g)): atan then tan, each ≤ 1 ulp, amplified by tan's condition 2θ/sin 2θ ≈ 1.0: ~4 ε
        assert accel == pytest.approx(2.0, rel=1e-12)  # g tan(atan(2/g))
    later = [[1.0 + 0.01 * i, theta] for i in range(50)]
    result = run_probe(
        spawn,
        {
            "listen": ["/car/accel/estimate", "/diagnostics"],
            "wait_subscribers": 1,
            "joints": ["wheel", "elbow_joint"],
            "feed": later,
            "until_values": [{"dropped_wrong_joint": len(later)}, 30.0],
            "linger": 1.0,
        },
    )
    assert result["estimates"] == []
    errors = [values for level, _, values in result["diagnostics"] if level == 2]
    assert errors and int(errors[-1]["dropped_wrong_joint"]) == 50, result["diagnostics"]


def test_the_joint_parameter_names_the_pendulum_among_a_robots_joints(spawn: Spawn) -> None:
    """joint = encoder: a real sensor's JointState naming its joints its own way (the pendulum's after a
    wheel) gives one estimate per angle, from the encoder's position; the chain's own pendulum_joint is
    then another robot's joint: dropped, counted, no estimate."""
    estimator = start_node(
        spawn,
        "estimator_node",
        {"scene": "lecture_constant", "method": "instant", "joint": "encoder", "diagnostics_period": 0.2},
    )
    estimator.wait_for(r"estimating with", timeout=60)
    theta = math.atan2(2.0, G)
    feed = [[0.01 * i, theta] for i in range(50)]
    result = run_probe(
        spawn,
        {
            "listen": ["/car/accel/estimate"],
            "wait_subscribers": 1,
            "joints": ["wheel", "encoder"],
            "others": 0.3,
            "feed": feed,
            "until_estimates": [len(feed), 30.0],
            "linger": 1.0,
        },
    )
    assert [t for t, _, _ in result["estimates"]] == pytest.approx([t for t, _ in feed], abs=1e-9)
    for _, accel, _ in result["estimates"]:
        assert accel == pytest.approx(2.0, rel=1e-12)  # g tan(atan(2/g)), as above: the encoder's θ
    result = run_probe(
        spawn,
        {
            "listen": ["/car/accel/estimate", "/diagnostics"],
            "wait_subscribers": 1,
            "joints": ["pendulum_joint"],
            "feed": [[1.0 + 0.01 * i, theta] for i in range(50)],
            "until_values": [{"dropped_wrong_joint": 50}, 30.0],
            "linger": 1.0,
        },
    )
    assert result["estimates"] == []
    errors = [values for level, _, values in result["diagnostics"] if level == 2]
    assert errors and int(errors[-1]["dropped_wrong_joint"]) == 50, result["diagnostics"]
    estimator.proc.send_signal(signal.SIGINT)
    assert estimator.finish(timeout=20) == 0


def test_joint_frame_id_accepts_a_sensors_own_frame(spawn: Spawn) -> None:
    """joint_frame_id = pan_link: a real sensor's driver stamping its JointState in its own frame gives one
    estimate per angle; angles in the chain's base_link are then another frame's: dropped, counted, and
    the ERROR names both frames."""
    estimator = start_node(
        spawn,
        "estimator_node",
        {
            "scene": "lecture_constant",
            "method": "instant",
            "joint_frame_id": "pan_link",
            "diagnostics_period": 0.2,
        },
    )
    estimator.wait_for(r"estimating with", timeout=60)
    theta = math.atan2(2.0, G)
    feed = [[0.01 * i, theta] for i in range(50)]
    spec = {"listen": ["/car/accel/estimate"], "wait_subscribers": 1, "feed": feed, "linger": 1.0}
    result = run_probe(spawn, {**spec, "frame_id": "pan_link", "until_estimates": [len(feed), 30.0]})
    assert [t for t, _, _ in result["estimates"]] == pytest.approx([t for t, _ in feed], abs=1e-9)
    later = [[1.0 + 0.01 * i, theta] for i in range(50)]
    chain = {
        **spec,
        "listen": ["/car/accel/estimate", "/diagnostics"],
        "feed": later,
        "frame_id": "base_link",
        "until_values": [{"dropped_wrong_joint": len(later)}, 30.0],
    }
    result = run_probe(spawn, chain)
    assert result["estimates"] == []
    errors = [(message, values) for level, message, values in result["diagnostics"] if level == 2]
    assert errors and int(errors[-1][1]["dropped_wrong_joint"]) == 50, result["diagnostics"]
    assert "frame_id 'base_link', not 'pan_link'" in errors[-1][0]
    estimator.proc.send_signal(signal.SIGINT)
    assert estimator.finish(timeout=20) == 0


def test_lag_stamps_each_estimate_with_the_sample_it_describes(spawn: Spawn) -> None:
    """lag = 0.2 s at the scene's 100 Hz is N = 20 samples: the node states its latency (log, /diagnostics),
    gives nothing for the first 20 inputs, then one estimate per input stamped with the input 20 back."""
    estimator = start_node(
        spawn, "estimator_node", {"scene": "lecture_constant", "lag": 0.2, "diagnostics_period": 0.2}
    )
    estimator.wait_for(r"latency 0\.200 s", timeout=60)
    fed = [[0.01 * i, THETA_2] for i in range(1, 61)]
    result = run_probe(
        spawn,
        {
            "listen": ["/car/accel/estimate", "/diagnostics"],
            "wait_subscribers": 1,
            "feed": fed,
            "until_estimates": [len(fed) - 20, 30.0],
            "linger": 1.5,
        },
    )
    stamps = [round(t, 9) for t, _, _ in result["estimates"]]
    assert stamps == [round(t, 9) for t, _ in fed[: len(fed) - 20]]
    assert all(math.isfinite(a) and var > 0.0 for _, a, var in result["estimates"])
    assert {values.get("latency_s") for _, _, values in result["diagnostics"]} == {"0.2"}
    estimator.proc.send_signal(signal.SIGINT)
    assert estimator.finish(timeout=20) == 0


def test_preset_comes_from_the_scene_and_can_be_set(spawn: Spawn) -> None:
    """preset 'scene' (the default): husky_odom states no motion, so the node runs auto, learned from the
    angles (no guess from the robot's speeds); preset = car rebuilds with it as a prior; an unknown preset is
    refused, saying why."""
    estimator = start_node(spawn, "estimator_node", {"scene": "husky_odom"})
    estimator.wait_for(r"preset auto: learned from the angles", timeout=60)
    result = run_probe(
        spawn,
        {"set": {"node": "accel_estimator", "params": {"preset": "car"}}},
    )
    ((ok, reason),) = result["set"]
    assert ok, reason
    estimator.wait_for(r"estimator rebuilt: .*preset car", timeout=20)
    result = run_probe(
        spawn,
        {"set": {"node": "accel_estimator", "params": {"preset": "bogus"}}},
    )
    ((ok, reason),) = result["set"]
    assert not ok and "motion must be one of auto, car, robot, lab_steps" in reason
    assert result["get"] == {"preset": "car"}
    estimator.proc.send_signal(signal.SIGINT)
    assert estimator.finish(timeout=20) == 0


def test_imu_frame_goes_on_tf_static_or_is_stated_with_the_frame_prefix(spawn: Spawn) -> None:
    """imu_frame_id with an offset and frame_prefix car1/: the transform car1/base_link → car1/imu_link is
    published on /tf_static where tf2_msgs is installed, and stated as a command where it is not."""
    from pendulum_accel.nodes.static_tf import tf_message_type

    params: dict[str, float | str] = {"scene": "lecture_constant", "imu_frame_id": "imu_link"}
    estimator = start_node(spawn, "estimator_node", {**params, "imu_offset_x": 0.3, "frame_prefix": "car1/"})
    where = ": published on /tf_static" if tf_message_type() is not None else r" \(tf2_msgs is not installed"
    estimator.wait_for(r"car1/imu_link at \(0\.3, 0, 0\) m in car1/base_link" + where, timeout=60)


def test_the_recorder_records_tf_static_where_tf2_msgs_is_installed_and_says_so_where_not(
    spawn: Spawn, tmp_path: Path
) -> None:
    """A recorder started after the estimator: with tf2_msgs it subscribes to /tf_static transient local
    and records the transform sent before it started (car1/base_link → car1/imu_link); without, it says
    in one line that /tf_static is not recorded, and the bag has no such topic."""
    from pendulum_accel.bag.reader import read_bag
    from pendulum_accel.nodes.static_tf import TF_MESSAGE, tf_message_type

    params: dict[str, float | str] = {"scene": "lecture_constant", "imu_frame_id": "imu_link"}
    estimator = start_node(spawn, "estimator_node", {**params, "imu_offset_x": 0.3, "frame_prefix": "car1/"})
    estimator.wait_for(r"car1/imu_link at \(0\.3, 0, 0\) m in car1/base_link", timeout=60)
    bag = tmp_path / "bag"
    recorder = start_node(spawn, "recorder_node", {"path": str(bag), "scene": "lecture_constant"})
    recorder.wait_for(r"recording \d+ topics to", timeout=60)
    if tf_message_type() is None:
        recorder.wait_for(r"/tf_static is not recorded: tf2_msgs is not installed", timeout=5)
    else:
        time.sleep(2.0)  # discovery, then the transient-local history is delivered
    recorder.proc.send_signal(signal.SIGINT)
    assert recorder.finish(timeout=30) == 0, recorder.text
    estimator.proc.send_signal(signal.SIGINT)
    assert estimator.finish(timeout=20) == 0, estimator.text
    topics = read_bag(bag).topics
    if tf_message_type() is None:
        assert "/tf_static" not in topics
        return
    _, payloads = read_bag(bag).raw("/tf_static")
    messages: list[Any] = [bm.deserialize(data, TF_MESSAGE) for data in payloads]
    frames = [(t.header.frame_id, t.child_frame_id) for message in messages for t in message.transforms]
    assert frames == [("car1/base_link", "car1/imu_link")]
    offered = yaml.safe_load(topics["/tf_static"].offered_qos_profiles)
    assert [profile["durability"] for profile in offered] == ["transient_local"]  # as the estimator offers


def test_tf_static_is_asked_for_as_tf2s_static_listener_does() -> None:
    """The recorder's /tf_static subscription: reliable, transient local, keep last 100 (tf2_ros's
    StaticListenerQoS), so it receives what static broadcasters sent before it started."""
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, ReliabilityPolicy

    from pendulum_accel.nodes.qos import qos_for

    profile = qos_for("/tf_static")
    assert profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
    assert profile.reliability == ReliabilityPolicy.RELIABLE
    assert (profile.history, profile.depth) == (HistoryPolicy.KEEP_LAST, 100)


def test_a_tf_message_is_logged_at_its_first_transforms_stamp() -> None:
    """stamp_offset of a TFMessage points at its first transform's header stamp (CDR made by rosbags, not
    by the code under test); a type outside the chain has none (logged at its receive time)."""
    from pendulum_accel.nodes.conversions import stamp_offset
    from pendulum_accel.nodes.recorder_node import stamp_ns
    from pendulum_accel.nodes.static_tf import TF_MESSAGE

    types = bm.TYPESTORE.types
    header = types["std_msgs/msg/Header"](
        stamp=types["builtin_interfaces/msg/Time"](sec=12, nanosec=345), frame_id="car1/base_link"
    )
    transform = types["geometry_msgs/msg/Transform"](
        translation=types["geometry_msgs/msg/Vector3"](x=0.3, y=0.0, z=0.0),
        rotation=types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
    )
    stamped = types["geometry_msgs/msg/TransformStamped"](
        header=header, child_frame_id="car1/imu_link", transform=transform
    )
    data = bm.serialize(types[TF_MESSAGE](transforms=[stamped]), TF_MESSAGE)
    offset = stamp_offset(TF_MESSAGE)
    assert offset is not None and stamp_ns(data, offset) == 12 * 1_000_000_000 + 345
    assert stamp_offset("std_msgs/msg/Float64") is None


def test_the_recorders_bulk_stamps_are_its_per_message_ones() -> None:
    """log_times (the recorder's fast path, all of a write's messages at once) reads each payload's stamp as
    stamp_ns reads it one by one: int32 seconds (negative too) and uint32 nanoseconds at the type's offset."""
    from pendulum_accel.nodes.conversions import stamp_offset
    from pendulum_accel.nodes.recorder_node import log_times, stamp_ns

    stamps = [0, 1, 999_999_999, 12 * 1_000_000_000 + 345, (2**31 - 1) * 1_000_000_000 + 999_999_999, -5]
    for msgtype, make in (
        (bm.JOINT_STATE, lambda ns: bm.joint_state(ns, [bm.PENDULUM_JOINT], [0.1], [0.2])),
        (bm.ACCEL_STAMPED, lambda ns: bm.accel_stamped(ns, 0.3)),
    ):
        offset = stamp_offset(msgtype)
        assert offset is not None
        payloads = [bm.serialize(make(max(ns, 0)), msgtype) for ns in stamps]
        # A negative stamp cannot be made through the message builders: write its int32 seconds directly.
        last = payloads[-1]
        payloads[-1] = last[:offset] + (-1).to_bytes(4, "little", signed=True) + last[offset + 4 :]
        assert log_times(payloads, offset).tolist() == [stamp_ns(p, offset) for p in payloads]
