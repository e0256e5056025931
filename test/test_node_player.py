"""bag_player over real DDS: a golden bag replayed into the live estimator gives the offline estimates;
looping makes the estimator reset; start offset, topic filter and /clock publishing work."""

from __future__ import annotations

import json
import re
import signal
from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.bag.reader import read_bag
from pendulum_accel.estimators import estimate_batch
from pendulum_accel.recording.settings import estimator_settings
from pendulum_accel.scene import load_scene
from test.chain_helpers import PROBE, Output, start_node
from test.conftest import PYTHON, REPO, Spawn

pytestmark = [
    pytest.mark.ros,
]

GOLDEN = REPO / "bags" / "step_start"


def _stop(node: Output) -> None:
    """SIGINT (the node drains its queue) and expect a clean exit."""
    node.proc.send_signal(signal.SIGINT)
    assert node.finish(timeout=30) == 0, node.text


def test_golden_bag_through_live_estimator_matches_offline_estimates(spawn: Spawn, tmp_path: Path) -> None:
    out = tmp_path / "replayed"
    recorder = start_node(
        spawn,
        "recorder_node",
        {"path": str(out), "topics": ["/car/accel/estimate", "/diagnostics", "/clock"]},
    )
    recorder.wait_for("recording 3 topics", timeout=60)
    # The recorder reads the estimate (not the Imu): wait for it by name on the estimate.
    estimator = start_node(spawn, "estimator_node", {"scene": "step_start", "reader_nodes": ["bag_recorder"]})
    estimator.wait_for("estimating with", timeout=60)
    player = start_node(
        spawn,
        "player_node",
        {
            "path": str(GOLDEN),
            "topics": ["/pendulum/joint_states"],
            "rate": 5.0,
            "clock": True,
            "wait_for_subscribers": 1,
            "wait_for_recorder": True,  # its /clock too has its reader before the first message
        },
    )
    assert player.finish(timeout=120) == 0, player.text
    _stop(estimator)
    _stop(recorder)
    golden = read_bag(GOLDEN)
    angles = golden.decode("/pendulum/joint_states")
    offline, offline_var = estimate_batch(
        "kalman", angles.stamp, angles["position[0]"], **estimator_settings(load_scene("step_start"))
    )
    live = read_bag(out)
    replayed = live.decode("/car/accel/estimate")
    assert len(replayed) == len(angles) == 1001
    assert np.array_equal(replayed.stamp, angles.stamp)
    # The live node and the offline batch path (what `pendulum-accel analyze` runs) agree to ~1e-12.
    np.testing.assert_allclose(replayed["accel.accel.linear.x"], offline, rtol=0, atol=1e-9)
    np.testing.assert_allclose(replayed["accel.covariance[0]"], offline_var, rtol=1e-9, atol=0)
    truth = golden.decode("/car/accel/truth")["accel.linear.x"]
    assert (
        np.abs(replayed["accel.accel.linear.x"] - truth)[angles.stamp >= 4.0].max() < 0.1
    )  # settled on 3 m/s²
    clock = live.decode("/clock").stamp  # the player's own /clock, from the bag time, 100 per bag second
    assert np.all(np.diff(clock) > 0) and 0.0 <= clock[0] < 0.02 and clock[-1] >= 9.9
    assert abs(len(clock) - 1001) <= 2


def test_looping_player_resets_the_estimator(spawn: Spawn) -> None:
    estimator = start_node(spawn, "estimator_node", {"scene": "step_start", "diagnostics_period": 0.2})
    estimator.wait_for("estimating with", timeout=60)
    probe = spawn(
        [PYTHON, PROBE, json.dumps({"listen": ["/car/accel/estimate", "/diagnostics"], "linger": 5.0})]
    )
    player = start_node(
        spawn,
        "player_node",
        {
            "path": str(GOLDEN),
            "topics": ["/pendulum/joint_states"],
            "rate": 10.0,
            "loop": True,
            "start_offset": 5.0,
            "wait_for_subscribers": 1,
        },
    )
    out, err = probe.communicate(timeout=60)
    assert probe.returncode == 0, err
    result = json.loads(out.strip().splitlines()[-1])
    _stop(player)
    stamps = np.array([t for t, _, _ in result["estimates"]])
    assert stamps.size > 300 and stamps.min() >= 5.0 - 1e-9  # nothing before the offset
    assert np.any(np.diff(stamps) < -4.0)  # the loop went back to the offset
    states = {values["state"] for _, _, values in result["diagnostics"]}
    assert "RESET" in states
    _stop(estimator)
    resets = re.search(r"(\d+) resets", estimator.text)
    assert resets is not None and int(resets.group(1)) >= 1, estimator.text


def test_rate_factor_and_topic_filter(spawn: Spawn, tmp_path: Path) -> None:
    """rate 5 plays the 10 s bag in about 2 s of wall time; a filtered-out topic is never published."""
    out = tmp_path / "filtered"
    recorder = start_node(
        spawn,
        "recorder_node",
        {
            "path": str(out),
            "topics": ["/pendulum/joint_states", "/car/accel/truth"],
            "log_time": "receive",  # the recorder's wall clock: shows the player's pacing
            "time_source": "wall",  # its clock is the system clock (sim time would stand at 0: no /clock)
        },
    )
    recorder.wait_for("recording 2 topics", timeout=60)
    player = start_node(
        spawn,
        "player_node",
        {"path": str(GOLDEN), "topics": ["/pendulum/joint_states"], "rate": 5.0, "wait_for_subscribers": 1},
    )
    assert player.finish(timeout=120) == 0, player.text
    _stop(recorder)
    bag = read_bag(out)
    # The recorder subscribed to both; the filtered-out topic had no publisher, so nothing came.
    assert {name: info.count for name, info in bag.topics.items()} == {"/pendulum/joint_states": 1001}
    angles = bag.decode("/pendulum/joint_states")
    golden = read_bag(GOLDEN).decode("/pendulum/joint_states")
    np.testing.assert_array_equal(angles.stamp, golden.stamp)  # every message, in order
    np.testing.assert_array_equal(angles["position[0]"], golden["position[0]"])
    bag_span = float(golden.stamp[-1] - golden.stamp[0])
    wall_span = float(angles.log_time_ns[-1] - angles.log_time_ns[0]) * 1e-9
    # Pacing never runs ahead of the requested rate; the upper bound only says it is not real time (×1).
    assert 0.98 * bag_span / 5.0 <= wall_span < bag_span, wall_span
