"""bag_player over real DDS: a golden bag replayed into the live estimator gives the offline estimates;
looping makes the estimator reset; start offset, topic filter and /clock publishing work. A path that is
no bag is one line, the reader's own, and never a hang."""

from __future__ import annotations

import json
import os
import pty
import re
import signal
import subprocess
import termios
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pendulum_accel.bag.messages import ACCEL_STAMPED, ACCEL_WITH_COVARIANCE_STAMPED, CLOCK, JOINT_STATE
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.estimators import estimate_batch
from pendulum_accel.nodes.launcher import ParamValue, node_command
from pendulum_accel.recording.settings import estimator_options
from pendulum_accel.scene import load_scene
from test.chain_helpers import PROBE, Output, start_node
from test.conftest import PYTHON, REPO, Spawn, cli
from test.refusal import one_line_error

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
        {
            "path": str(out),
            "topics": ["/car/accel/estimate", "/diagnostics", "/clock", "/pendulum/joint_states"],
        },
    )
    recorder.wait_for("recording 4 topics", timeout=60)
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
            # By name: the estimator's own /clock subscription (use_sim_time) must not stand in for the
            # recorder's, or the first seconds of /clock go unrecorded.
            "reader_nodes": ["accel_estimator"],
            "recorder_node": "bag_recorder",
        },
    )
    assert player.finish(timeout=120) == 0, player.text
    _stop(estimator)
    _stop(recorder)
    golden = read_bag(GOLDEN)
    angles = golden.decode("/pendulum/joint_states")
    offline, offline_var = estimate_batch(
        "kalman", angles.stamp, angles["position[0]"], **estimator_options(load_scene("step_start"), "kalman")
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
    clock = live.decode("/clock").stamp  # the player's own /clock, from the bag time, 40 per bag second
    assert np.all(np.diff(clock) > 0) and 0.0 <= clock[0] < 0.02 and clock[-1] >= 9.9
    assert len(clock) == 401  # rosbag2's default 40 Hz: one tick per 25 ms of bag time, 0 to 10 s


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
    # Pacing never runs ahead of the requested rate; the upper bound only says it is not real time (×1). A
    # receive time is the publish time plus that message's latency, and under load the first ones wait for the
    # reliable handshake (a 10 s bag once spanned 1.92 s of receive time at rate 5, its first angle late): the
    # pace is read between the medians of the second and the ninth tenth, which a few late messages leave.
    n = angles.stamp.size
    early, late = slice(n // 10, n // 5), slice(4 * n // 5, 9 * n // 10)
    bag_span = float(np.median(golden.stamp[late]) - np.median(golden.stamp[early]))
    wall_span = float(np.median(angles.log_time_ns[late]) - np.median(angles.log_time_ns[early])) * 1e-9
    assert 0.98 * bag_span / 5.0 <= wall_span < bag_span, wall_span


CONTROL = [PYTHON, "-m", "test.player_control"]
JOINT = "/pendulum/joint_states"
ESTIMATE = "/car/accel/estimate"
LISTEN = {JOINT: JOINT_STATE, ESTIMATE: ACCEL_WITH_COVARIANCE_STAMPED}


def _control(spawn: Spawn, spec: dict[str, Any], timeout: float = 180.0) -> dict[str, Any]:
    """Run test/player_control.py with ``spec``; its JSON result."""
    proc = spawn([*CONTROL, json.dumps(spec)])
    out, err = proc.communicate(timeout=timeout)
    assert proc.returncode == 0, err
    result: dict[str, Any] = json.loads(out.strip().splitlines()[-1])
    return result


def _offline(angles_from: int) -> np.ndarray:
    """The offline kalman estimates of the golden angles from sample ``angles_from`` on (a fresh start)."""
    angles = read_bag(GOLDEN).decode(JOINT)
    estimates, _ = estimate_batch(
        "kalman",
        angles.stamp[angles_from:],
        angles["position[0]"][angles_from:],
        **estimator_options(load_scene("step_start"), "kalman"),
    )
    return np.asarray(estimates)


def test_pause_resume_play_next_burst_and_rate_services(spawn: Spawn, tmp_path: Path) -> None:
    """Started paused, nothing plays; play_next and burst publish exactly 1 and burst_size messages; the rate
    parameter is set and read back; pause holds the stream; at the end every angle arrived once, in order, and
    the live estimator's recorded estimates equal the offline ones."""
    out = tmp_path / "controlled"
    recorder = start_node(spawn, "recorder_node", {"path": str(out), "topics": [ESTIMATE, "/diagnostics"]})
    recorder.wait_for("recording 2 topics", timeout=60)
    estimator = start_node(spawn, "estimator_node", {"scene": "step_start", "reader_nodes": ["bag_recorder"]})
    estimator.wait_for("estimating with", timeout=60)
    player = start_node(
        spawn,
        "player_node",
        # By name: the probe below also subscribes to the angles, and a count it could satisfy would let the
        # first angles go out before the estimator's subscription has matched (seen once under CI load).
        {"path": str(GOLDEN), "topics": [JOINT], "start_paused": True, "reader_nodes": ["accel_estimator"]},
    )
    player.wait_for("paused", timeout=60)
    steps: list[list[Any]] = [
        ["call", "is_paused"],
        ["sleep", 1.0],
        ["count", JOINT],
        ["call", "play_next"],
        ["wait_count", JOINT, 1],
        ["set", {"burst_size": 9}],
        ["call", "burst"],
        ["wait_count", JOINT, 10],
        ["set", {"rate": 4.0}],
        ["get", ["rate"]],
        ["set", {"rate": 0.0}],  # outside 1e-3..1e3: refused, the rate stays
        ["call", "resume"],
        ["call", "is_paused"],
        ["call", "play_next"],  # only while paused, as in rosbag2
        ["wait_count", JOINT, 11],  # resumed: the next message arrives (however slowly on a loaded machine)
        ["call", "pause"],
        ["sleep", 3.0],  # what was published before the pause is delivered (slowly on a loaded machine)
        ["count", JOINT],
        ["sleep", 1.0],
        ["count", JOINT],
        ["call", "toggle_paused"],
        ["wait_count", JOINT, 1001],
    ]
    result = _control(spawn, {"listen": LISTEN, "matched": [ESTIMATE], "steps": steps, "linger": 0.5})
    r = result["results"]
    assert r[0] == [True, "true"]
    assert r[2] == 0  # paused from the start: nothing in 1 s
    assert r[3] == [True, "played 1 message"] and r[4] == 1
    assert r[6] == [True, "burst 9 messages"] and r[7] == 10
    assert r[8] == [[True, ""]] and r[9] == {"rate": 4.0}
    assert r[10][0][0] is False
    assert r[11] == [True, "playing"] and r[12] == [True, "false"]
    assert r[13][0] is False
    held = r[17]
    assert 10 < held < 1001 and r[19] == held  # nothing more while paused
    assert r[20] == [True, "playing"] and r[21] == 1001
    assert player.finish(timeout=60) == 0, player.text
    _stop(estimator)
    _stop(recorder)
    golden = read_bag(GOLDEN).decode(JOINT)
    stamps = np.array([m[1] for m in result["messages"][JOINT]])
    np.testing.assert_array_equal(stamps, golden.stamp)  # each angle once, in order, whatever the controls
    live = read_bag(out).decode(ESTIMATE)
    # If estimates go missing, the nodes' own logs say on which side.
    logs = f"estimator:\n{estimator.text[-1500:]}\nrecorder:\n{recorder.text[-1500:]}"
    np.testing.assert_array_equal(live.stamp, golden.stamp, err_msg=logs)
    np.testing.assert_allclose(live["accel.accel.linear.x"], _offline(0), rtol=0, atol=1e-9)
    assert re.search(r"bag_player \[paused\] bag time 0\.000 s of 10\.000 s \(0/1001 messages\)", player.text)


def test_play_next_waits_for_the_named_reader(spawn: Spawn) -> None:
    """A paused player's play_next publishes nothing before the reader_nodes are there (a stranger on the
    angles does not count) and says what it waits for; once the estimator is up, play_next waits until it
    is matched, so the estimator gets that first angle (before, a message sent before a volatile reader
    matched never reached it: the estimator once missed the first 10 angles of a play_next and a burst)."""
    player = start_node(
        spawn,
        "player_node",
        {"path": str(GOLDEN), "topics": [JOINT], "start_paused": True, "reader_nodes": ["accel_estimator"]},
    )
    player.wait_for("paused", timeout=60)
    steps: list[list[Any]] = [["call", "play_next"], ["count", JOINT]]
    alone = _control(spawn, {"listen": {JOINT: JOINT_STATE}, "steps": steps})
    assert alone["results"] == [[False, f"waiting for its readers ({JOINT}: /accel_estimator)"], 0]
    estimator = start_node(spawn, "estimator_node", {"scene": "step_start"})
    estimator.wait_for("estimating with", timeout=60)  # started (imports take seconds under load)
    steps = [["sleep", 1.0], ["call", "play_next"], ["wait_count", ESTIMATE, 1]]
    result = _control(spawn, {"listen": LISTEN, "matched": [ESTIMATE], "steps": steps})
    assert result["results"][1:] == [[True, "played 1 message"], 1]
    golden = read_bag(GOLDEN).decode(JOINT)
    assert [m[1] for m in result["messages"][ESTIMATE]] == [golden.stamp[0]]  # the bag's first angle
    _stop(estimator)
    assert re.search(r"\b1 inputs, 1 estimates published", estimator.text), estimator.text
    _stop(player)


def test_seek_forwards_and_backwards_with_clock_and_estimator_reset(spawn: Spawn) -> None:
    """A seek past the end fails; seeks forwards (6 s) and backwards (to 2 s) move the stream, /clock jumps
    with it, and the estimator resets on the jump back, then matches a fresh offline run from 2 s."""
    estimator = start_node(spawn, "estimator_node", {"scene": "step_start"})
    estimator.wait_for("estimating with", timeout=60)
    player = start_node(
        spawn,
        "player_node",
        {
            "path": str(GOLDEN),
            "topics": [JOINT],
            "start_paused": True,
            "rate": 2.0,
            "clock": True,
            "reader_nodes": ["accel_estimator"],  # by name: the probe's subscription must not stand in
        },
    )
    player.wait_for("paused", timeout=60)
    steps: list[list[Any]] = [
        ["set", {"seek_time": 100.0}],
        ["call", "seek"],
        ["set", {"seek_time": 6.0}],
        ["call", "seek"],
        ["call", "resume"],
        ["wait_stamp", JOINT, 8.0],
        ["set", {"seek_time": 2.0}],
        ["call", "seek"],
        ["wait_stamp", JOINT, 10.0],
    ]
    listen = {**LISTEN, "/clock": CLOCK}
    result = _control(spawn, {"listen": listen, "matched": [ESTIMATE], "steps": steps, "linger": 1.0})
    r = result["results"]
    assert r[1][0] is False and r[1][1].startswith("refused: t=")  # outside the bag
    assert r[3] == [True, "seek to t=6.000 s"] and r[7] == [True, "seek to t=2.000 s"]
    assert player.finish(timeout=60) == 0, player.text
    _stop(estimator)
    golden = read_bag(GOLDEN).decode(JOINT).stamp
    stamps = np.array([m[1] for m in result["messages"][JOINT]])
    back = int(np.flatnonzero(np.diff(stamps) < 0)[0]) + 1  # the one jump back
    assert np.all(np.diff(stamps[:back]) > 0) and np.all(np.diff(stamps[back:]) > 0)
    assert stamps[0] == golden[600] and stamps[back - 1] >= 8.0  # forwards: 0..6 s skipped
    np.testing.assert_array_equal(stamps[back:], golden[200:])  # backwards: from 2 s to the end
    clock = np.array([m[1] for m in result["messages"]["/clock"]])
    assert clock[0] == golden[600]  # /clock follows both jumps
    jumps = np.flatnonzero(np.diff(clock) < 0)
    assert jumps.size == 1 and clock[jumps[0] + 1] == golden[200] and clock[-1] >= 9.9
    assert set(clock) <= set(golden.tolist())  # each tick is stamped with a message's time
    resets = re.search(r"(\d+) resets", estimator.text)
    assert resets is not None and int(resets.group(1)) == 1, estimator.text
    estimates = np.array([m[1:] for m in result["messages"][ESTIMATE]])
    after = estimates[-(golden.size - 200) :]
    np.testing.assert_array_equal(after[:, 0], golden[200:])
    np.testing.assert_allclose(after[:, 1], _offline(200), rtol=0, atol=1e-9)


def test_topic_filters_remap_window_delay_and_default_clock(spawn: Spawn) -> None:
    """Include/exclude regexes and lists pick /car/accel/truth only, `-r` remaps it, start_offset 1 s with
    playback_duration 2 s plays [1, 3] s, /clock ticks 40 times per bag second, and the delay holds the
    first message back by 1 s."""
    params: dict[str, ParamValue] = {
        "path": str(GOLDEN),
        "topics_regex": "^/(pendulum|car)/",  # not /clock nor /diagnostics
        "exclude_regex": "estimate$",
        "exclude_topics": [JOINT, "/pendulum/markers"],  # the golden bag draws the swing too
        "start_offset": 1.0,
        "playback_duration": 2.0,
        "delay": 1.0,
        "clock": True,
        "wait_for_recorder": True,
    }
    player = Output(spawn([*node_command("player_node", params), "-r", "/car/accel/truth:=/replay/truth"]))
    started = player.wait_for(r"\[INFO\] \[(\d+\.\d+)\] \[bag_player\]: playing 201 messages", timeout=60)
    listen = {
        "/replay/truth": ACCEL_STAMPED,
        "/car/accel/truth": ACCEL_STAMPED,
        ESTIMATE: ACCEL_WITH_COVARIANCE_STAMPED,
        JOINT: JOINT_STATE,
        "/clock": CLOCK,
    }
    steps = [["wait_count", "/replay/truth", 201]]
    result = _control(spawn, {"listen": listen, "steps": steps, "linger": 1.0})
    assert player.finish(timeout=60) == 0, player.text
    got = result["messages"]
    assert not got["/car/accel/truth"] and not got[ESTIMATE] and not got[JOINT]
    truth = read_bag(GOLDEN).decode("/car/accel/truth").stamp
    stamps = np.array([m[1] for m in got["/replay/truth"]])
    np.testing.assert_array_equal(stamps, truth[(truth >= 1.0 - 1e-9) & (truth <= 3.0 + 1e-9)])
    clock = np.array([m[1] for m in got["/clock"]])
    assert clock.size == 81 and clock[0] == stamps[0] and np.all(np.diff(clock) > 0)  # 1 + 2 s x 40 Hz
    assert got["/replay/truth"][0][0] - float(started.group(1)) >= 1.0  # the delay


def test_keyboard_controls_on_a_terminal(spawn: Spawn) -> None:
    """With stdin a terminal: space pauses, ↑/↓ step the rate by 0.1, → plays one message while paused,
    space resumes; the services see the same state, and the terminal gets its mode back at exit."""
    master, slave = pty.openpty()
    try:
        params: dict[str, ParamValue] = {
            "path": str(GOLDEN),
            "topics": [JOINT],
            "loop": True,
            "progress_period": 0.0,
        }
        player = Output(spawn(node_command("player_node", params), stdin=slave))
        player.wait_for("keys: space pause/resume", timeout=60)
        for key, answer in (
            (b" ", r"key: paused$"),
            (b"\x1b[A", r"key: rate 1\.1$"),
            (b"\x1b[B", r"key: rate 1$"),
            (b"\x1b[B", r"key: rate 0\.9$"),
            (b"\x1b[C", r"key: played next$"),
        ):
            os.write(master, key)
            player.wait_for(f"(?m){answer}", timeout=30)
        result = _control(spawn, {"steps": [["call", "is_paused"], ["get", ["rate"]]]})
        assert result["results"] == [[True, "true"], {"rate": 0.9}]
        os.write(master, b" ")
        player.wait_for("key: playing", timeout=30)
        _stop(player)
        assert termios.tcgetattr(slave)[3] & termios.ICANON  # canonical mode is back
    finally:
        os.close(master)
        os.close(slave)


def test_seek_at_the_end_plays_on_and_a_seek_outside_the_bag_is_refused(spawn: Spawn) -> None:
    """exit_on_end false: after the last message the player stays; a seek back plays on from there.
    Seeks before the first or after the last message are refused (success false), nothing moves."""
    player = start_node(
        spawn,
        "player_node",
        {
            "path": str(GOLDEN),
            "topics": [JOINT],
            "rate": 20.0,
            "exit_on_end": False,
            "wait_for_subscribers": 1,
        },
    )
    steps: list[list[Any]] = [
        ["wait_stamp", JOINT, 10.0],  # the whole bag played (its last angle is stamped 10 s)
        ["sleep", 1.0],
        ["count", JOINT],
        ["set", {"seek_time": 10.5}],
        ["call", "seek"],
        ["set", {"seek_time": -1.0}],
        ["call", "seek"],
        ["set", {"seek_time": 9.0}],
        ["call", "seek"],
        ["wait_count", JOINT, 1001 + 101],
        ["sleep", 1.0],
        ["count", JOINT],
    ]
    result = _control(spawn, {"listen": {JOINT: JOINT_STATE}, "matched": [JOINT], "steps": steps})
    r = result["results"]
    assert r[4][0] is False and "outside the bag" in r[4][1]
    assert r[6][0] is False and "outside the bag" in r[6][1]
    assert r[8] == [True, "seek to t=9.000 s"]
    assert r[11] - r[2] == 101  # 9.00 .. 10.00 s of 100 Hz angles, played again after the end, once
    _stop(player)


def test_the_progress_line_shows_the_position_when_behind() -> None:
    """A player that fell behind prints where it is (the next message still to go out) and by how much it
    is behind, not the schedule (the issue's 'bag time 140001 s of 1700 s'); at the end, the last
    message and no lag."""
    import threading
    from types import SimpleNamespace

    from pendulum_accel.bag.playback import Playback
    from pendulum_accel.nodes.player_node import PlayerNode
    from test.test_bag_playback import NS, FakeWall

    wall = FakeWall()
    playback = Playback(np.arange(10, dtype=np.int64) * NS, wall=wall)  # messages at 0, 1, ..., 9 s
    stop = threading.Event()
    playback.take_due(stop)  # message 0 out; the next is at 1 s
    wall.now += 1000.5  # nothing taken meanwhile: the schedule is at 1000.5 s

    def figures() -> tuple[float, float, int, float | None]:
        """(position s, end s, messages out, behind s or None) parsed from the progress line."""
        line = PlayerNode.progress_line(SimpleNamespace(playback=playback))  # type: ignore[arg-type]
        found = re.search(r"bag time (\S+) s of (\S+) s \((\d+)/10 messages\)", line)
        assert found is not None, line
        behind = re.search(r"behind by (\S+) s", line)
        lag = float(behind.group(1)) if behind else None
        return float(found.group(1)), float(found.group(2)), int(found.group(3)), lag

    # Printed with 3 decimals: 1e-3 s covers the rounding of whole seconds and halves.
    position, end, out, behind = figures()
    assert abs(position - 1.0) < 1e-3 and abs(end - 9.0) < 1e-3 and out == 1
    assert behind is not None and abs(behind - 999.5) < 1e-3
    while playback.take_due(stop) is not None:
        pass
    position, end, out, behind = figures()
    assert abs(position - 9.0) < 1e-3 and out == 10 and behind is None


@pytest.mark.parametrize(
    ("make", "words"),
    [
        ("empty_dir", ("holds no .mcap file",)),
        ("dir_named_mcap", ("x.mcap is a directory",)),
        ("/etc/hostname", ("not an MCAP file",)),
        ("fifo", ("FIFO",)),
        ("/dev/null", ("character device",)),
    ],
)
def test_the_player_refuses_a_path_that_is_no_bag(tmp_path: Path, make: str, words: tuple[str, ...]) -> None:
    path = tmp_path / make
    if make == "empty_dir":
        path.mkdir()
    elif make == "dir_named_mcap":
        (path / "x.mcap").mkdir(parents=True)
    elif make == "fifo":
        os.mkfifo(path)  # opened for reading, it would wait for a writer forever
    else:
        path = Path(make)
    result = subprocess.run(
        [PYTHON, "-m", "pendulum_accel.nodes.player_node", "--ros-args", "-p", f"path:={path}"],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=REPO,
    )
    one_line_error(result, *words)
    one_line_error(cli("info", str(path)), *words)  # the same reader: every command says the same
