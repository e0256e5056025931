"""The live chain as a robot meets it: one time base per run, strangers on the graph, the Imu output.

Each run records step_start through ``pendulum-accel run`` while plain subscribers (what
``ros2 topic echo`` is) come and go: one before the chain starts, one during its start-up, one after
publishing began. Every angle must have its estimate and its Imu, every message must be recorded,
the bag's duration must be the scene's and every stamp on the run's one time base.
"""

from __future__ import annotations

import re
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import Bag, read_bag
from pendulum_accel.cli.info import info_lines
from pendulum_accel.nodes.accounting import CUSTOM_ACCOUNTING, Accounting
from pendulum_accel.nodes.launcher import BAG_OUTLIVED
from pendulum_accel.nodes.parameters import UNMEASURED_ACCEL_VARIANCE
from pendulum_accel.scene import load_scene
from test.chain_helpers import Output
from test.conftest import PYTHON, REPO, Spawn
from test.figures import assert_figure

pytestmark = [pytest.mark.ros]

DURATION = 3.0  # s of step_start (its step 0 -> 3 m/s² is at t = 1 s)
RATE = 100.0  # Hz, the scene's
SAMPLES = int(DURATION * RATE) + 1
STRANGER = str(REPO / "test" / "stranger.py")
TEARDOWN_CRASH = re.compile(
    re.escape(BAG_OUTLIVED)
    .replace(re.escape("{how}"), r"killed by SIG\w+")
    .replace(re.escape("{path}"), r".+")
)
"""The one WARNING a run here may print: the recorder killed by a signal after it closed a bag that then read
complete (launcher.Chain._bag_outlived). That is a crash inside rclpy's node teardown (rcl_node_fini under the
EventsExecutor, ros2/rclpy#1644, open), seen about once in 30 chains under the full suite's load and not in 15
runs of this test alone; it costs the recording nothing, the line says so, and test_recorder_teardown_crash
holds the launcher to that. Every other WARNING fails the run."""


def _stranger(spawn: Spawn, name: str) -> Output:
    """A plain subscriber to /pendulum/joint_states, once it is up."""
    out = Output(spawn([PYTHON, STRANGER, name]))
    out.wait_for(f"stranger {name}: subscribed", timeout=60)
    return out


def _run(spawn: Spawn, bag: Path, *flags: str) -> Output:
    """``pendulum-accel run step_start --set duration=3 --record BAG FLAGS`` with strangers around it."""
    _stranger(spawn, "stranger_before")
    cmd = [PYTHON, "-m", "pendulum_accel.cli.main", "run", "step_start", "--set", f"duration={DURATION}"]
    run = Output(spawn([*cmd, "--record", str(bag), *flags]))
    Output(spawn([PYTHON, STRANGER, "stranger_during"]))  # joins while the chain starts up
    run.wait_for(r"subscribers matched: publishing", timeout=90)
    Output(spawn([PYTHON, STRANGER, "stranger_after"]))
    assert run.finish(timeout=120) == 0, run.text
    warnings = [
        line for line in run.text.splitlines() if "WARNING" in line and not TEARDOWN_CRASH.search(line)
    ]
    assert not warnings, run.text
    return run


def _stamped(bag: Bag) -> list[str]:
    """The bag's topics whose messages carry a stamp: all but robot_description (std_msgs/String, logged
    at the recorder's clock on arrival), which must hold the URDF once."""
    description = bm.find_topic(bag.topics, bm.ROBOT_DESCRIPTION)
    assert description is not None and bag.topics[description].count == 1
    assert bm.find_topic(bag.topics, bm.MARKERS) is not None
    return [topic for topic in bag.topics if topic != description]


def _stamps(bag: Bag, topic: str) -> tuple[np.ndarray, np.ndarray]:
    """(header stamps, log times) of every message on ``topic``, in integer ns (one message at a time)."""
    stamps, logs = [], []
    for _, ns, data in bag.iter_raw([topic]):
        msg: Any = bm.deserialize(data, bag.topics[topic].msgtype)
        if topic == bm.TOPIC_CLOCK:
            stamp = msg.clock
        elif bag.topics[topic].msgtype == bm.MARKER_ARRAY:
            stamp = msg.markers[0].header.stamp
        else:
            stamp = msg.header.stamp
        stamps.append(stamp.sec * 1_000_000_000 + stamp.nanosec)
        logs.append(ns)
    return np.array(stamps), np.array(logs)


def _check_every_sample(bag: Bag) -> None:
    """Each angle has its estimate and its Imu (same stamps); every published message was recorded."""
    assert bag.problem is None
    angles = bag.decode(bm.TOPIC_JOINT_STATES).stamp
    estimates = bag.decode(bm.TOPIC_ACCEL_ESTIMATE).stamp
    imu = bag.decode(bm.TOPIC_IMU).stamp
    assert angles.size == SAMPLES
    assert np.array_equal(estimates, angles) and np.array_equal(imu, angles)
    accounting = Accounting.from_json(bag.custom_data[CUSTOM_ACCOUNTING])
    for topic in (bm.TOPIC_JOINT_STATES, bm.TOPIC_ACCEL_TRUTH, bm.TOPIC_ACCEL_ESTIMATE, bm.TOPIC_IMU):
        assert accounting.published(topic) == accounting.recorded(topic) == bag.topics[topic].count, topic
    assert accounting.estimator["inputs"] == SAMPLES
    lines, note = info_lines(str(bag.path))
    assert note is None and "[complete]" in lines[0], lines


def _check_sim_time_base(bag: Bag) -> None:
    """Sim time: the bag spans the scene (duration, rates), every stamp and log time inside [0, 3] s."""
    assert abs(bag.duration_s - DURATION) < 1e-6, bag.duration_s
    assert bag.start_ns == 0 and bag.end_ns == round(DURATION * 1e9)
    for topic in (bm.TOPIC_JOINT_STATES, bm.TOPIC_ACCEL_TRUTH, bm.TOPIC_ACCEL_ESTIMATE, bm.TOPIC_IMU):
        rate = (bag.topics[topic].count - 1) / bag.duration_s
        assert abs(rate - RATE) < 1e-6, (topic, rate)
    assert bag.topics[bm.TOPIC_CLOCK].count == SAMPLES  # /clock at 100 Hz: one per sample here
    for topic in _stamped(bag):  # /diagnostics and the markers included
        stamps, logs = _stamps(bag, topic)
        assert stamps.size == bag.topics[topic].count > 0, topic
        assert stamps.min() >= 0 and stamps.max() <= round(DURATION * 1e9), topic
        assert np.array_equal(stamps, logs), topic  # log time = stamp: one time base in the bag
    lines, _ = info_lines(str(bag.path))
    assert_figure("\n".join(lines), "duration:", DURATION, rel=0.0)  # integer stamps: exact to its digits


def _check_imu(bag: Bag) -> None:
    """REP-145 data_raw conventions: frame, stamps, specific force (â, 0, +g), covariances, -1 markers."""
    imu = bag.decode(bm.TOPIC_IMU)
    est = bag.decode(bm.TOPIC_ACCEL_ESTIMATE)
    g = load_scene("step_start").pendulum.gravity
    msg = bm.deserialize(next(data for topic, _, data in bag.iter_raw([bm.TOPIC_IMU])), bm.IMU)
    assert msg.header.frame_id == bm.FRAME_ID  # type: ignore[attr-defined]
    assert np.array_equal(imu.stamp, bag.decode(bm.TOPIC_JOINT_STATES).stamp)
    assert np.array_equal(imu["linear_acceleration.x"], est["accel.accel.linear.x"])
    assert np.all(imu["linear_acceleration.y"] == 0.0)
    assert np.all(imu["linear_acceleration.z"] == g)
    cov = np.stack([imu[f"linear_acceleration_covariance[{i}]"] for i in range(9)], axis=1)
    assert np.array_equal(cov[:, 0], est["accel.covariance[0]"]) and np.all(cov[:, 0] > 0)
    assert np.all(cov[:, 4] == UNMEASURED_ACCEL_VARIANCE) and np.all(cov[:, 8] == UNMEASURED_ACCEL_VARIANCE)
    assert np.all(cov[:, [1, 2, 3, 5, 6, 7]] == 0.0)
    assert np.all(imu["orientation_covariance[0]"] == -1.0)
    assert np.all(imu["angular_velocity_covariance[0]"] == -1.0)
    for name in ("orientation.x", "orientation.y", "orientation.z", "angular_velocity.x"):
        assert np.all(imu[name] == 0.0), name
    assert np.all(imu["orientation.w"] == 1.0)  # the identity quaternion: valid, and flagged -1 above


def test_real_time_recording_with_strangers_is_whole_and_on_sim_time(spawn: Spawn, tmp_path: Path) -> None:
    run = _run(spawn, tmp_path / "live")
    assert "time source: sim" in run.text
    bag = read_bag(tmp_path / "live")
    _check_every_sample(bag)
    _check_sim_time_base(bag)
    _check_imu(bag)


def test_fast_recording_with_strangers_is_whole_and_on_sim_time(spawn: Spawn, tmp_path: Path) -> None:
    _run(spawn, tmp_path / "fast", "--fast")
    bag = read_bag(tmp_path / "fast")
    _check_every_sample(bag)
    _check_sim_time_base(bag)


def test_wall_time_run_stamps_with_the_system_clock_and_publishes_no_clock(
    spawn: Spawn, tmp_path: Path
) -> None:
    before = time.time()
    _run(spawn, tmp_path / "wall", "--time-source", "wall")
    after = time.time()
    bag = read_bag(tmp_path / "wall")
    _check_every_sample(bag)
    assert bm.TOPIC_CLOCK not in bag.topics
    angles = bag.decode(bm.TOPIC_JOINT_STATES).stamp
    first = int(_stamps(bag, bm.TOPIC_JOINT_STATES)[0][0])  # ns
    assert before < angles[0] and angles[-1] < after
    # The due times: 10 ms apart from the first sample on (those due while the first was being
    # acknowledged go out late, with their due stamps). 1e-6 s: the stamps are float seconds near
    # 1.8e9 s, whose resolution is 2.4e-7 s, twice per difference.
    np.testing.assert_allclose(np.diff(angles), 1.0 / RATE, atol=1e-6)
    for topic in _stamped(bag):  # diagnostics included: every stamp on the wall clock, inside the run
        stamps, logs = _stamps(bag, topic)
        assert before < stamps.min() * 1e-9 and stamps.max() * 1e-9 < after, topic
        # The bag starts at the first angle: what was stamped before it (the first STALE reports of
        # start-up) is logged at that angle's stamp, everything else at its own stamp.
        assert np.array_equal(logs, np.maximum(stamps, first)), topic
    description = bm.find_topic(bag.topics, bm.ROBOT_DESCRIPTION)
    assert description is not None  # latched before the data, still kept, logged at the first angle
    assert [ns for _, ns, _ in bag.iter_raw([description])] == [first]
    assert bag.start_ns == first
    # info's duration is the data's: the last angle is due exactly DURATION after the first (10 ms steps,
    # asserted above), and nothing is logged after it but the estimates and diagnostics stamped with the
    # angles they describe; 0.05 s is the bound, the rest is the 1 ms of info's rounding.
    lines, _ = info_lines(str(bag.path))
    shown = float(next(line for line in lines if line.startswith("duration:")).split()[1])
    assert abs(shown - DURATION) < 0.05, lines
