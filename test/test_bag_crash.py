"""SIGKILL a process writing a bag at 1 kHz: at most ~1 s is lost; repair makes a valid bag of the rest."""

from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import Reader

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.bag.repair import repair_bag
from test.chain_helpers import start_node
from test.conftest import Spawn

# Writes JointState + Clock at 1 kHz of wall time, log time = wall clock, until killed.
WRITER_SCRIPT = """
import sys, time
from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.writer import BagWriter
w = BagWriter(sys.argv[1], custom_data={"pendulum_accel.plan": "crash test"})
w.add_topic(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)
w.add_topic(bm.TOPIC_CLOCK, bm.CLOCK)
print("ready", flush=True)
i = 0
next_t = time.monotonic()
while True:
    now = time.time_ns()
    js = bm.joint_state(now, [bm.PENDULUM_JOINT], [i * 1e-3])
    w.write(bm.TOPIC_JOINT_STATES, now, bm.serialize(js, bm.JOINT_STATE))
    w.write(bm.TOPIC_CLOCK, now, bm.serialize(bm.clock(now), bm.CLOCK))
    i += 1
    next_t += 1e-3
    time.sleep(max(0.0, next_t - time.monotonic()))
"""

MAX_LOSS_S = 1.0
# Between SIGKILL of the recorder and SIGINT reaching the simulator's publishing loop.
SIGNAL_GAP_S = 0.25


def test_sigkill_loses_at_most_a_second_and_repair_restores(tmp_path: Path, spawn: Spawn) -> None:
    """Kill after ~2.5 s of writing: data up to ≥ kill − 1 s reads back; repair gives a bag rosbags opens."""
    bag_dir = tmp_path / "killed"
    proc = spawn([sys.executable, "-c", WRITER_SCRIPT, str(bag_dir)])
    assert proc.stdout is not None
    assert proc.stdout.readline().strip() == "ready"
    time.sleep(2.5)
    kill_ns = time.time_ns()
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=10)
    assert proc.returncode == -signal.SIGKILL

    bag = read_bag(bag_dir)
    assert bag.problem is not None  # no footer: the process never closed the bag
    js = bag.decode(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)
    assert len(js) > 1000
    lost_s = (kill_ns - int(js.log_time_ns[-1])) * 1e-9
    assert 0.0 <= lost_s <= MAX_LOSS_S, f"lost {lost_s:.3f} s of data"
    # What is there is exactly the first messages written, in order.
    # stored as the float64 bytes of the writer's k·1e-3, the same product as here: equal to the bit; the
    # 1e-12 (< 1e-3, one message apart) only says which message each is
    np.testing.assert_allclose(js["position[0]"], np.arange(len(js)) * 1e-3, rtol=0, atol=1e-12)
    assert bag.custom_data["pendulum_accel.plan"] == "crash test"  # provisional metadata.yaml

    result = repair_bag(bag_dir)
    assert result.rewritten
    assert result.counts[bm.TOPIC_JOINT_STATES] == len(js)
    fixed = read_bag(bag_dir, salvage=False)
    assert fixed.complete and fixed.custom_data["pendulum_accel.plan"] == "crash test"
    with Reader(bag_dir) as reader:
        topics = {c.topic: c.msgcount for c in reader.connections}
        assert topics[bm.TOPIC_JOINT_STATES] == len(js)
        assert sum(1 for _ in reader.messages()) == fixed.message_count


@pytest.mark.ros
def test_sigkilled_recorder_node_loses_at_most_a_second(tmp_path: Path, spawn: Spawn) -> None:
    """The real bag_recorder, fed at 1 kHz by the real-time simulator, SIGKILLed after ~3 s of data.

    The simulator is stopped right after the kill; its 'published … (X s simulated)' line bounds what
    was on the wire. The salvaged bag reaches X − 1 s (plus the gap between the two signals), and
    ``repair`` leaves a bag that rosbags opens with the same messages.
    """
    bag_dir = tmp_path / "killed_recorder"
    recorder = start_node(
        spawn, "recorder_node", {"path": str(bag_dir), "topics": [bm.TOPIC_JOINT_STATES, bm.TOPIC_CLOCK]}
    )
    recorder.wait_for("recording 2 topics", timeout=60)
    sim = start_node(
        spawn,
        "simulator_node",
        {
            "scene": "lecture_constant",
            "rate_hz": 1000.0,
            "duration": 60.0,
            "reader_nodes": ["bag_recorder"],
            "publish_clock": True,
        },
    )
    sim.wait_for("subscribers matched", timeout=60)
    time.sleep(3.0)
    os.killpg(recorder.proc.pid, signal.SIGKILL)
    sim.proc.send_signal(signal.SIGINT)
    published = sim.wait_for(r"published (\d+)/\d+ samples \(([0-9.]+) s simulated\)", timeout=30)
    assert sim.finish(timeout=30) == 0, sim.text
    assert recorder.finish(timeout=10) == -signal.SIGKILL
    on_wire_s = float(published.group(2))
    assert on_wire_s > 2.0, sim.text

    bag = read_bag(bag_dir)
    assert bag.problem is not None  # killed: no footer, no final metadata
    js = bag.decode(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)
    lost_s = on_wire_s - float(js.stamp[-1])
    assert 0.0 <= lost_s <= MAX_LOSS_S + SIGNAL_GAP_S, f"lost {lost_s:.3f} s of {on_wire_s:.3f} s"
    # Nothing before the loss is missing: consecutive stamps 1 ms apart from the first sample.
    np.testing.assert_allclose(np.diff(js.stamp), 1e-3, atol=1e-9)
    assert js.stamp[0] == 0.0

    result = repair_bag(bag_dir)
    assert result.counts[bm.TOPIC_JOINT_STATES] == len(js)
    with Reader(bag_dir) as reader:
        assert {c.topic: c.msgcount for c in reader.connections}[bm.TOPIC_JOINT_STATES] == len(js)
