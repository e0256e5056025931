"""Two chains in two namespaces on one domain stay apart; a remapped topic is recorded under its name.

step_start runs in /car1 (a steps to 3 m/s² at t = 1 s) and at_rest in /car2 (a = 0) at once, with a
stranger subscribed to the root-namespace angles before either starts. Each estimate must follow its
own truth, every angle must have its estimate, and each bag must hold only its own chain's messages:
its clock (``/car1/clock``, not the other chain's) and its own estimator's /diagnostics statuses; and
every message each chain publishes in a frame is in its own (``car1/base_link``: ``run --namespace`` sets
the frame prefix).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pendulum_accel.allan import bag_series
from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import Bag, read_bag
from pendulum_accel.bag.writer import CUSTOM_SCENE, BagWriter
from pendulum_accel.cli.info import info_lines
from pendulum_accel.nodes.recorder_node import status_namespace
from pendulum_accel.recording import visual
from pendulum_accel.recording.analyze import analyze_bag
from test.chain_helpers import Output
from test.conftest import PYTHON, REPO, Spawn, cli

pytestmark = [pytest.mark.ros]

STRANGER = str(REPO / "test" / "stranger.py")
DURATION = 3.0  # s of each scene: step_start's step is at t = 1 s


def _chain(spawn: Spawn, scene: str, namespace: str, bag: Path, *extra: str) -> Output:
    """``pendulum-accel run SCENE --fast --namespace NS --record BAG`` (short via --set)."""
    cmd = [PYTHON, "-m", "pendulum_accel.cli.main", "run", scene, "--fast", "--set", f"duration={DURATION}"]
    return Output(spawn([*cmd, "--namespace", namespace, "--record", str(bag), *extra]))


def _own_topics_only(bag: Bag, namespace: str) -> None:
    """Every topic of ``bag`` is under /namespace (its clock included), except the global /diagnostics,
    whose statuses all come from this namespace's estimator (named by its full name), and the global
    /tf_static, recorded whole where tf2_msgs is installed (the TF tree is shared)."""
    for topic in bag.topics:
        assert topic in (bm.TOPIC_DIAGNOSTICS, "/tf_static") or topic.startswith(f"/{namespace}/"), topic
    assert bm.TOPIC_CLOCK not in bag.topics and f"/{namespace}/clock" in bag.topics
    names = {
        status.name
        for raw in bag.raw(bm.TOPIC_DIAGNOSTICS)[1]
        for status in bm.deserialize_as(raw, bm.DIAGNOSTIC_ARRAY, bm.DiagnosticArrayMsg).status
    }
    assert names == {f"{namespace}/accel_estimator"}, names  # its full name without the leading '/'


def test_a_status_name_gives_its_nodes_namespace_with_or_without_the_leading_slash() -> None:
    """The recorder keeps the statuses of its namespace's nodes: named 'car1/accel_estimator' (the
    estimator's), '/car1/accel_estimator' (a full name) or 'node: task' (diagnostic_updater's, root)."""
    assert status_namespace("car1/accel_estimator") == status_namespace("/car1/accel_estimator") == "/car1"
    assert status_namespace("fleet/car1/accel_estimator: input") == "/fleet/car1"
    assert status_namespace("accel_estimator") == status_namespace("/accel_estimator") == "/"
    assert status_namespace("camera_driver: frequency") == "/"


def _drawn_frames(bag: Bag, namespace: str) -> set[str]:
    """The frame_id of every estimate, truth, marker and Imu message the chain in ``namespace`` recorded
    (everything it publishes in a frame but its joint states, which name none under a prefix)."""
    frames: set[str] = set()
    for topic, msgtype in (
        (bm.ACCEL_ESTIMATE, bm.ACCEL_WITH_COVARIANCE_STAMPED),
        (bm.ACCEL_TRUTH, bm.ACCEL_STAMPED),
        (bm.MARKERS, bm.MARKER_ARRAY),
        (bm.IMU_DATA_RAW, bm.IMU),
    ):
        _, payloads = bag.raw(f"/{namespace}/{topic}")
        assert payloads, topic
        for data in payloads:
            message: Any = bm.deserialize(data, msgtype)
            inner = message.markers if msgtype == bm.MARKER_ARRAY else [message]
            frames |= {m.header.frame_id for m in inner}
    return frames


def _joint_frames(bag: Bag, namespace: str) -> set[str]:
    """The frame_id of every joint state the chain in ``namespace`` recorded."""
    _, payloads = bag.raw(f"/{namespace}/{bm.JOINT_STATES}")
    return {bm.deserialize(data, bm.JOINT_STATE).header.frame_id for data in payloads}  # type: ignore[attr-defined]


def _truth_arrows(bag: Bag, namespace: str) -> tuple[list[float], list[float]]:
    """(a the truth arrow draws, a the truth says) at each marker stamp of the chain in ``namespace``."""
    _, truths = bag.raw(f"/{namespace}/{bm.ACCEL_TRUTH}")
    truth: dict[tuple[int, int], float] = {}
    for data in truths:
        message: Any = bm.deserialize(data, bm.ACCEL_STAMPED)
        truth[(message.header.stamp.sec, message.header.stamp.nanosec)] = message.accel.linear.x
    drawn, said = [], []
    _, payloads = bag.raw(f"/{namespace}/{bm.MARKERS}")
    for data in payloads:
        markers: Any = bm.deserialize(data, bm.MARKER_ARRAY)
        for marker in markers.markers:
            stamp = (marker.header.stamp.sec, marker.header.stamp.nanosec)
            if marker.ns == "accel_truth" and stamp in truth:
                drawn.append(marker.points[1].x / visual.ARROW_M_PER_MS2)
                said.append(truth[stamp])
    return drawn, said


def _namespace(namespace: str) -> argparse.Namespace:
    """The --topic and --namespace arguments of a command, as parsed, for ``namespace``."""
    return argparse.Namespace(topic_roles=[], namespace=namespace)


def _info_figures(path: Path, topic: str) -> tuple[float, float]:
    """(duration s, rate Hz of ``topic``) parsed from ``info``'s lines."""
    lines, _ = info_lines(str(path))
    duration = float(next(line for line in lines if line.startswith("duration:")).split()[1])
    row = next(line for line in lines if line.split()[:1] == [topic])
    return duration, float(row.split()[-2])


@pytest.mark.slow
def test_two_namespaced_chains_on_one_domain_do_not_cross_talk(spawn: Spawn, tmp_path: Path) -> None:
    stranger = Output(spawn([PYTHON, STRANGER, "stranger_first"]))
    stranger.wait_for("stranger stranger_first: subscribed", timeout=60)
    car1 = _chain(spawn, "step_start", "car1", tmp_path / "car1")
    car2 = _chain(spawn, "at_rest", "car2", tmp_path / "car2")
    assert car1.finish(timeout=240) == 0, car1.text
    assert car2.finish(timeout=240) == 0, car2.text
    for namespace, scene_truth in (("car1", 3.0), ("car2", 0.0)):
        bag = read_bag(tmp_path / namespace)
        _own_topics_only(bag, namespace)
        assert _drawn_frames(bag, namespace) == {f"{namespace}/{bm.FRAME_ID}"}, namespace
        # The joint states name no frame (as robots' do): an unprefixed base_link was another robot's.
        assert _joint_frames(bag, namespace) == {""}, namespace
        # The simulator's truth arrow draws its own truth: it was read back with the unprefixed layout,
        # every field shifted by the prefix, and drew ~1e-319. A product by ARROW_M_PER_MS2 and the
        # quotient back, each rounded once: within 2 ulp of |a| ≤ 3 m/s² (~1e-15); 1e-12 allows that.
        drawn, said = _truth_arrows(bag, namespace)
        assert drawn and np.allclose(drawn, said, rtol=0.0, atol=1e-12), namespace
        joint = f"/{namespace}/{bm.JOINT_STATES}"
        estimate = f"/{namespace}/{bm.ACCEL_ESTIMATE}"
        angles = bag.decode(joint).stamp
        estimates = bag.decode(estimate).stamp
        # Every angle got its estimate: the kalman filter has no warm-up, and no foreign angle was
        # dropped as out of order (the cross-talk of absolute names dropped about 20).
        assert angles.size == round(DURATION * 100) + 1
        assert np.array_equal(estimates, angles), namespace
        result = analyze_bag(bag)
        assert result.recorded is not None and result.recorded.n == angles.size
        lines, note = info_lines(str(bag.path))  # info finds the namespaced chain: every angle estimated
        assert note is None and "[complete]" in lines[0], lines
        # The scene's duration and rate: the other chain's clock, recorded too, made them 12 s and 83 Hz.
        # 1e-6 s: stamps are whole nanoseconds of 10 ms steps, and info prints 3 decimals.
        duration, rate = _info_figures(bag.path, joint)
        assert abs(duration - DURATION) < 1e-3 and abs(rate - 100.0) < 0.1, lines
        # The chain's own clock only: one tick per 100 Hz sample (the default clock rate is 100 Hz).
        assert bag.topics[f"/{namespace}/clock"].count == angles.size, namespace
        assert bag_series(str(bag.path)).accel is not None  # allan finds the namespaced estimate too
        # The recorded estimate follows its own truth: after settling, the other car's truth (3 m/s²
        # apart) would put the mean error near ±1.5 m/s²; 0.3 m/s² is 10 times the settled kalman bias
        # these scenes show (< 0.03 m/s²) and 5 times below the cross-talk's error.
        tail = result.t > 2.0
        assert abs(float(np.mean(result.accel_true[tail])) - scene_truth) < 1e-9
        recorded = bag.decode(
            estimate, fields=["header.stamp.sec", "header.stamp.nanosec", "accel.accel.linear.x"]
        )
        late = recorded.stamp > 2.0
        assert abs(float(np.mean(recorded["accel.accel.linear.x"][late])) - scene_truth) < 0.3, namespace
    assert "received 0" in stranger.text or stranger.proc.poll() is None  # the stranger heard no chain
    _one_bag_of_two_chains(tmp_path)


def _one_bag_of_two_chains(tmp_path: Path) -> None:
    """Both chains' topics in one bag (what `ros2 bag record -a` would hold): the commands refuse to guess
    which chain to read, say how to pick one, and read the one --namespace picks."""
    both = tmp_path / "both"
    # Without a topic map or counters (another recorder's bag), with at_rest's scene, which car2 ran.
    custom = {k: v for k, v in read_bag(tmp_path / "car2").custom_data.items() if k == CUSTOM_SCENE}
    with BagWriter(both, custom_data=custom) as writer:
        for namespace in ("car1", "car2"):
            bag = read_bag(tmp_path / namespace)
            for name, info in bag.topics.items():
                if name not in writer.counts:
                    writer.add_topic(name, info.msgtype)
            for name, ns, data in bag.iter_raw():
                writer.write(name, ns, data)
    listed = cli("info", str(both))  # listed, its state left to a --namespace
    assert listed.returncode == 0 and "several chains (/car1, /car2)" in listed.stdout, listed.stderr
    lines, note = info_lines(str(both), _namespace("car1"))
    assert note is None and "[complete]" in lines[0], lines
    refused = cli("analyze", str(both))
    assert refused.returncode == 2 and "--namespace (/car1 or /car2)" in refused.stderr, refused.stderr
    assert "Traceback" not in refused.stderr and len(refused.stderr.strip().splitlines()) == 1
    car2 = cli("analyze", str(both), "--namespace", "car2", "--json")
    assert car2.returncode == 0, car2.stderr
    export = cli("export", str(both), "--namespace", "/car1", "--out", str(tmp_path / "t1"), "--no-smoothed")
    assert export.returncode == 0, export.stderr
    written = {Path(line).name for line in export.stdout.split()}
    assert written and all("car2" not in name for name in written), written
    topics = ["--topics", "/car1/pendulum/joint_states", "/car1/car/accel/estimate"]
    merged = cli(
        "export", str(both), "--namespace", "car1", "--merged", *topics, "--out", str(tmp_path / "t2")
    )
    assert merged.returncode == 0, merged.stderr
    wrong = cli("analyze", str(both), "--namespace", "car9")
    assert wrong.returncode == 2 and "no topic under /car9/" in wrong.stderr, wrong.stderr


@pytest.mark.slow
def test_a_remapped_recording_is_read_by_every_tool(spawn: Spawn, tmp_path: Path) -> None:
    """A live chain run with its angles remapped: the bag stores the chain's topic map, and analyze,
    allan, export --merged and animate read the remapped angles by it; --topic names them by hand."""
    path = tmp_path / "remapped"
    run = _chain(spawn, "step_start", "car3", path, "--remap", "pendulum/joint_states:=angles")
    assert run.finish(timeout=240) == 0, run.text
    bag = read_bag(path)
    samples = round(DURATION * 100) + 1
    assert "/car3/angles" in bag.topics and f"/car3/{bm.JOINT_STATES}" not in bag.topics
    assert bag.topics["/car3/angles"].msgtype == bm.JOINT_STATE
    assert bag.topics["/car3/angles"].count == samples
    assert bm.find_topic(bag.topics, bm.JOINT_STATES) is None  # by its name alone, it plays no role
    assert bag.find_topic(bm.JOINT_STATES) == "/car3/angles"  # by the stored map, it does
    assert bag.find_topic("/clock") == "/car3/clock"
    analysis = cli("analyze", str(path), "--json")
    assert analysis.returncode == 0, analysis.stderr
    assert json.loads(analysis.stdout)["recorded"]["estimates"] == samples
    allan = cli("allan", str(path))
    assert allan.returncode == 0 and f"{samples} samples at 100 Hz" in allan.stdout, allan.stderr
    export = cli("export", str(path), "--merged", "--out", str(tmp_path / "tables"))
    assert export.returncode == 0, export.stderr
    (table,) = export.stdout.split()
    assert len(Path(table).read_text().splitlines()) == samples + 1  # a header, then one row per angle
    animation = cli("animate", str(path), "--duration", "1", "--fps", "5", "--out", str(tmp_path / "a.gif"))
    assert animation.returncode == 0 and (tmp_path / "a.gif").stat().st_size > 0, animation.stderr
    # Named by hand: the same figures; a wrong rule is one line, exit 2.
    by_hand = cli("analyze", str(path), "--json", "--topic", "pendulum/joint_states=/car3/angles")
    assert json.loads(by_hand.stdout)["recorded"] == json.loads(analysis.stdout)["recorded"]
    for rule, says in (
        ("joint_states=/car3/angles", "is not a chain role"),
        ("pendulum/joint_states=/nope", "has no topic /nope"),
        ("pendulum/joint_states", "must read ROLE=NAME"),
    ):
        bad = cli("analyze", str(path), "--topic", rule)
        assert bad.returncode == 2 and says in bad.stderr and len(bad.stderr.strip().splitlines()) == 1


def _frame_prefixes(*args: str) -> dict[str, str | None]:
    """{role: the frame_prefix its command sets (None: unset)} for ``run step_start ARGS``."""
    from pendulum_accel.cli.main import build_parser
    from pendulum_accel.cli.run import chain_config
    from pendulum_accel.nodes.launcher import Chain

    config = chain_config(build_parser().parse_args(["run", "step_start", *args]))
    out: dict[str, str | None] = {}
    for role, command in Chain(config, log=False).commands("step_start", Path("summaries")):
        rules = [rule for rule in command if rule.startswith("frame_prefix:=")]
        out[role] = json.loads(rules[-1].partition(":=")[2]) if rules else None
    return out


def test_run_namespace_sets_the_frame_prefix_unless_the_user_sets_it() -> None:
    """--namespace car1 gives the simulator and the estimator frame_prefix car1/ (two chains draw apart);
    --frame-prefix sets another, '' none; without a namespace nothing is set (the nodes' default '')."""
    assert _frame_prefixes("--namespace", "car1") == {"estimator": "car1/", "simulator": "car1/"}
    assert _frame_prefixes("--namespace", "/fleet/car1") == {
        "estimator": "fleet/car1/",
        "simulator": "fleet/car1/",
    }
    assert _frame_prefixes("--namespace", "car1", "--frame-prefix", "left/") == {
        "estimator": "left/",
        "simulator": "left/",
    }
    unset = {"estimator": None, "simulator": None}
    assert _frame_prefixes("--namespace", "car1", "--frame-prefix", "") == unset
    assert _frame_prefixes() == unset
