"""SIGKILL a process writing a bag at 1 kHz: at most ~1 s is lost; repair makes a valid bag of the rest."""

from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import Reader

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.bag.repair import repair_bag
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
