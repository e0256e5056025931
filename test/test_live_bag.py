"""Every bag command on a bag recorded live by ``pendulum-accel run`` (rclpy serialised its messages).

One bag is recorded per test module: step_start for 3 s over the real ROS chain, with a stranger
subscribed to the angles first. Then info, analyze, export (every topic, the Imu included, CSV and
Parquet), allan, animate and repair run on it as a user runs them, and bag_player plays it (through its
chunk index) to a plain subscriber, seeking inside and outside it. rclpy pads each CDR payload to a
multiple of 4 bytes and leaves padding bytes uninitialised, so its /diagnostics messages do not
re-serialise byte for byte: the reader must keep them because they decode correctly. The ROS-free
tests at the end build such payloads by hand and check the same rule, and that bytes that do not
decode are still skipped.
"""

from __future__ import annotations

import contextlib
import json
import re
import shutil
import signal
import subprocess
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from PIL import Image

from pendulum_accel.allan import MISFIT_LIMIT
from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.export import VISUAL_ROLES, column_name, export_bag, file_stem
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.bag.writer import BagWriter
from pendulum_accel.cli.export import SMOOTHED
from pendulum_accel.errors import BagError
from pendulum_accel.recording.generate import DIAGNOSTIC_NAME, generate_bag
from pendulum_accel.scene import load_scene
from test.chain_helpers import Output, start_node
from test.conftest import PYTHON, REPO, Spawn, cli, rclpy_available, stop_processes, strict_json
from test.figures import assert_same_figures
from test.split_recording import split_recording

DURATION = 3.0  # s of step_start recorded live
SAMPLES = 301  # 100 Hz over [0, 3] s
STRANGER = str(REPO / "test" / "stranger.py")
SAMPLED_TOPICS = (
    bm.TOPIC_JOINT_STATES,
    bm.TOPIC_ACCEL_TRUTH,
    bm.TOPIC_ACCEL_ESTIMATE,
    bm.TOPIC_CLOCK,
    bm.TOPIC_IMU,
)


@contextlib.contextmanager
def _processes() -> Iterator[list[subprocess.Popen[str]]]:
    """Processes started into the list, each in its own group, stopped at exit by conftest's
    ``stop_processes`` as ``spawn`` stops them: a module-scoped fixture cannot use ``spawn``."""
    procs: list[subprocess.Popen[str]] = []
    try:
        yield procs
    finally:
        stop_processes(procs)


def _start(procs: list[subprocess.Popen[str]], args: list[str]) -> Output:
    """Start ``args`` in a new session (collected output) and remember it for the stop."""
    proc = subprocess.Popen(
        args,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=str(REPO),
        start_new_session=True,
    )
    procs.append(proc)
    return Output(proc)


@pytest.fixture(scope="module")
def live_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A bag recorded by ``pendulum-accel run step_start --set duration=3 --record BAG``, a stranger on the
    graph before the chain starts."""
    if not rclpy_available():
        pytest.fail("rclpy does not import: run the tests through `make test`", pytrace=False)
    bag = tmp_path_factory.mktemp("live") / "bag"
    with _processes() as procs:
        stranger = _start(procs, [PYTHON, STRANGER, "stranger_live_bag"])
        stranger.wait_for("stranger stranger_live_bag: subscribed", timeout=60)
        run = _start(
            procs,
            [
                PYTHON,
                "-m",
                "pendulum_accel.cli.main",
                "run",
                "step_start",
                "--set",
                f"duration={DURATION:g}",
                "--record",
                str(bag),
            ],
        )
        assert run.finish(timeout=180) == 0, run.text
    return bag


@pytest.fixture(scope="module")
def live_split(live_bag: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The live bag as ``ros2 bag record --max-bag-size`` leaves a recording: three MCAP files, rosbag2's
    names and metadata (test.split_recording)."""
    out = tmp_path_factory.mktemp("live_split") / "bag"
    split_recording(live_bag, out, 3, chunk_size=8192)
    return out


@pytest.fixture(scope="module")
def live_sensor(live_bag: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The live bag as a real sensor's chain records it: no truth topic and no stored scene (rewritten by
    the mcap library without /car/accel/truth, test.split_recording)."""
    out = tmp_path_factory.mktemp("live_sensor") / "bag"
    split_recording(live_bag, out, 1, drop=(bm.TOPIC_ACCEL_TRUTH,), custom_data=False)
    assert read_bag(out).custom_data == {}  # no scene: the length is told on the command line
    return out


def _no_traceback(result: subprocess.CompletedProcess[str]) -> None:
    """Exit 0 and nothing on stderr that looks like a crash."""
    assert result.returncode == 0, result.stderr
    assert "Traceback" not in result.stderr and "error:" not in result.stderr, result.stderr


@pytest.mark.ros
def test_the_live_bag_keeps_every_message_rclpy_wrote(live_bag: Path) -> None:
    bag = read_bag(live_bag)
    assert bag.problem is None
    for topic in SAMPLED_TOPICS:
        assert bag.topics[topic].count == SAMPLES, topic
        assert len(bag.decode(topic)) == SAMPLES, topic
    _, payloads = bag.raw(bm.TOPIC_DIAGNOSTICS)
    assert payloads
    # rclpy's bytes, padded to 4 and with uninitialised padding: not the typestore's, decoded anyway.
    assert any(
        p != bm.serialize(bm.deserialize(p, bm.DIAGNOSTIC_ARRAY), bm.DIAGNOSTIC_ARRAY) for p in payloads
    )
    stamps = bag.decode(bm.TOPIC_DIAGNOSTICS, fields=["header.stamp.sec", "header.stamp.nanosec"])
    assert len(stamps) == len(payloads)
    assert bag.problem is None  # nothing was skipped as damaged


@pytest.mark.ros
@pytest.mark.ros
def test_the_live_status_is_named_as_in_generated_and_golden_bags(live_bag: Path) -> None:
    """The estimator's /diagnostics status in a live bag has the generated and golden bags' name, so a
    PlotJuggler layout (series <hardware_id>/<name>/<key>) drawn on golden bags draws live ones too."""
    bag = read_bag(live_bag)
    names = {
        status.name
        for raw in bag.raw(bm.TOPIC_DIAGNOSTICS)[1]
        for status in bm.deserialize_as(raw, bm.DIAGNOSTIC_ARRAY, bm.DiagnosticArrayMsg).status
    }
    golden = read_bag(REPO / "bags" / "lecture_constant")
    golden_names = {
        status.name
        for raw in golden.raw(bm.TOPIC_DIAGNOSTICS)[1]
        for status in bm.deserialize_as(raw, bm.DIAGNOSTIC_ARRAY, bm.DiagnosticArrayMsg).status
    }
    assert names == golden_names == {DIAGNOSTIC_NAME}, (names, golden_names)


def test_info(live_bag: Path) -> None:
    result = cli("info", str(live_bag))
    _no_traceback(result)
    for topic in (*SAMPLED_TOPICS, bm.TOPIC_DIAGNOSTICS):
        assert topic in result.stdout


@pytest.mark.ros
def test_analyze(live_bag: Path) -> None:
    result = cli("analyze", str(live_bag), "--json")
    _no_traceback(result)
    figures = strict_json(result.stdout)
    assert figures["samples"] == SAMPLES and np.isfinite(figures["rms"])
    recorded = figures["recorded"]
    assert recorded["angles"] == recorded["estimates"] == SAMPLES and recorded["missing"] == 0
    # The live node computed what the offline re-run does: the bound test_node_player holds the live
    # estimator to against the offline batch (1e-9 m/s²; they agree to ~1e-12).
    assert figures["recorded_vs_offline_samples"] == SAMPLES and figures["recorded_vs_offline_max"] <= 1e-9


@pytest.mark.ros
@pytest.mark.slow
def test_analyze_and_animate_a_live_recording_without_truth(
    live_bag: Path, live_sensor: Path, tmp_path: Path
) -> None:
    """Without its truth and scene, the live recording's estimate figures (counts, mean, range, median σ)
    are those the whole recording gives, and its error figures are null; animate draws it."""
    length = str(load_scene("step_start").pendulum.length)
    whole = strict_json(cli("analyze", str(live_bag), "--json").stdout)
    result = cli("analyze", str(live_sensor), "--json", "--length", length)
    _no_traceback(result)
    bare = strict_json(result.stdout)
    assert whole["truth"] is True and bare["truth"] is False and bare["rms"] is None
    keys = ("estimates", "angles", "missing", "estimate_mean", "estimate_min", "estimate_max", "sigma_median")
    # The recorded stream is the same floats with or without the truth beside them: the same figures.
    assert {k: bare["recorded"][k] for k in keys} == {k: whole["recorded"][k] for k in keys}
    assert bare["recorded"]["estimates"] == SAMPLES
    gif = tmp_path / "sensor.gif"
    _no_traceback(cli("animate", str(live_sensor), "--out", str(gif), "--length", length, "--duration", "1"))
    assert gif.stat().st_size > 0
    # export writes the smoother's series for it once --length gives the sensor, as analyze's smoother.
    _no_traceback(cli("export", str(live_sensor), "--out", str(tmp_path / "bare")))
    assert not (tmp_path / "bare" / f"{file_stem(SMOOTHED)}.csv").exists()  # no sensor, no smoother
    _no_traceback(cli("export", str(live_sensor), "--out", str(tmp_path / "told"), "--length", length))
    smoothed = pd.read_csv(tmp_path / "told" / f"{file_stem(SMOOTHED)}.csv")
    assert len(smoothed) == SAMPLES and np.isfinite(smoothed[f"{SMOOTHED}/a"]).all()
    told = cli("analyze", str(live_sensor), "--json", "--length", length, "--estimator", "smoother")
    # The same smoother, settings and samples: the two means differ only by their summation order, at most
    # n ε Σ|a| / |Σ a| relative (the sum's condition number; the CSV keeps every digit, 17 significant).
    a = smoothed[f"{SMOOTHED}/a"].to_numpy()
    rel = SAMPLES * np.finfo(float).eps * float(np.abs(a).sum() / abs(a.sum()))
    assert strict_json(told.stdout)["offline"]["estimate_mean"] == pytest.approx(float(a.mean()), rel=rel)


@pytest.mark.ros
@pytest.mark.parametrize("fmt", ["csv", "parquet"])
def test_export_every_topic(live_bag: Path, tmp_path: Path, fmt: str) -> None:
    out = tmp_path / "tables"
    result = cli("export", str(live_bag), "--out", str(out), "--format", fmt)
    _no_traceback(result)
    bag = read_bag(live_bag)
    # Every topic but the visual ones (markers, URDF: exported only when named), plus the smoother's series.
    tabled = [t for t in bag.topics if bm.role_of(t) not in VISUAL_ROLES]
    assert len(tabled) == len(bag.topics) - len(VISUAL_ROLES)
    expected = sorted(f"{file_stem(t)}.{fmt}" for t in [*tabled, SMOOTHED])
    assert sorted(p.name for p in out.iterdir()) == expected
    tables = {
        t: pd.read_csv(out / f"{file_stem(t)}.{fmt}")
        if fmt == "csv"
        else pd.read_parquet(out / f"{file_stem(t)}.{fmt}")
        for t in tabled
    }
    for topic in tabled:
        assert len(tables[topic]) == bag.topics[topic].count, topic  # /diagnostics included: none dropped
    imu, est = tables[bm.TOPIC_IMU], tables[bm.TOPIC_ACCEL_ESTIMATE]
    # The Imu carries the estimate as specific force x: the same float64, through the same writer.
    np.testing.assert_array_equal(
        imu[column_name(bm.TOPIC_IMU, "linear_acceleration.x")],
        est[column_name(bm.TOPIC_ACCEL_ESTIMATE, "accel.accel.linear.x")],
    )
    np.testing.assert_array_equal(imu["t"], tables[bm.TOPIC_JOINT_STATES]["t"])
    diagnostics = tables[bm.TOPIC_DIAGNOSTICS]
    assert set(diagnostics[f"{bm.TOPIC_DIAGNOSTICS}/pendulum_accel/accel_estimator/method"]) == {"kalman"}
    # A figure the estimator does not have yet is "none" on /diagnostics (the input rate before two angles,
    # the time since the last when not stale): a missing number, so its column is numbers, not strings.
    for key in ("input_rate_hz", "angle_noise_rad", "stale_for_s", "last_t"):
        column = diagnostics[f"{bm.TOPIC_DIAGNOSTICS}/pendulum_accel/accel_estimator/{key}"]
        assert column.dtype.kind == "f", (key, column.dtype)
    rates = diagnostics[f"{bm.TOPIC_DIAGNOSTICS}/pendulum_accel/accel_estimator/input_rate_hz"].dropna()
    # 1 / the median of 10 ms stamp steps, as the report prints it (6 significant digits).
    assert len(rates) > 0 and np.allclose(rates, 100.0, rtol=1e-5)
    noise = diagnostics[f"{bm.TOPIC_DIAGNOSTICS}/pendulum_accel/accel_estimator/angle_noise_rad"].dropna()
    # The scene's 1 mrad, from the last report's window (≥ 200 third differences: ~8 % standard error).
    assert len(noise) > 0 and noise.iloc[-1] == pytest.approx(1e-3, rel=0.25)
    merged_dir = tmp_path / "merged"
    _no_traceback(cli("export", str(live_bag), "--out", str(merged_dir), "--format", fmt, "--merged"))
    merged_path = merged_dir / f"merged.{fmt}"
    merged = pd.read_csv(merged_path) if fmt == "csv" else pd.read_parquet(merged_path)
    assert len(merged) == SAMPLES  # one row per angle, each with its own Imu (same stamp)
    np.testing.assert_array_equal(
        merged[column_name(bm.TOPIC_IMU, "linear_acceleration.x")],
        merged[column_name(bm.TOPIC_ACCEL_ESTIMATE, "accel.accel.linear.x")],
    )


@pytest.mark.ros
def test_allan(live_bag: Path, tmp_path: Path) -> None:
    result = cli("allan", str(live_bag), "--plot", str(tmp_path / "allan.png"))
    _no_traceback(result)
    assert "angle θ" in result.stdout
    # The bob swings after the step: the angle's σ(τ) is not a sensor at rest, and allan says so.
    misfit = re.search(
        r"model misfit: σ\(τ\) of the angle misses N²/τ \+ K²τ/3 by χ²/dof (\S+) ", result.stdout
    )
    assert misfit is not None and float(misfit.group(1)) > MISFIT_LIMIT, result.stdout
    assert "Gauss-Markov bias   σ_b" not in result.stdout  # nor is the swing taken for a wandering bias
    # 3 s is too short for the estimate's fit (from τ = 5 s): said, and the angle's figures still given.
    assert "not fitted" in result.stdout
    assert (tmp_path / "allan.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.ros
def test_animate(live_bag: Path, tmp_path: Path) -> None:
    out = tmp_path / "swing.gif"
    result = cli("animate", str(live_bag), "--out", str(out), "--duration", "0.5", "--fps", "4")
    _no_traceback(result)
    with Image.open(out) as img:
        assert getattr(img, "n_frames", 1) == 3  # t = 0, 0.25, 0.5 s


@pytest.mark.ros
def test_repair(live_bag: Path, tmp_path: Path) -> None:
    copy = tmp_path / "bag"
    shutil.copytree(live_bag, copy)
    total = read_bag(copy).message_count
    result = cli("repair", str(copy))
    _no_traceback(result)
    assert "intact" in result.stdout and str(total) in result.stdout
    mcap = next(copy.glob("*.mcap"))
    data = mcap.read_bytes()
    mcap.write_bytes(data[: len(data) // 2])  # the recorder killed half-way
    result = cli("repair", str(copy))
    _no_traceback(result)
    assert f"damaged file kept as {mcap}.damaged" in result.stdout
    fixed = read_bag(copy, salvage=False)
    assert 0 < fixed.message_count < total


@pytest.mark.ros
@pytest.mark.slow
def test_every_command_reads_a_split_live_recording_as_its_one_file(
    live_bag: Path, live_split: Path, tmp_path: Path
) -> None:
    """info, analyze, export, allan, animate and repair on the live bag split into three files give what
    they give on the one file: the same counts, figures and tables (parsed, not compared as text)."""
    assert len(read_bag(live_split).mcap_paths) == 3
    one, split = cli("info", str(live_bag)), cli("info", str(live_split))
    _no_traceback(split)
    assert "[complete]" in split.stdout.splitlines()[0] and "3 files" in split.stdout.splitlines()[1]
    # The same messages through the same code: rel 0, the printed digits' half-units only. The writer's
    # line differs (the split files were written by the mcap library) and holds a version's digits.

    def figures_text(stdout: str) -> str:
        """info's lines after the file line, but the writer's."""
        return "\n".join(x for x in stdout.splitlines()[2:] if not x.startswith("written by"))

    assert_same_figures(figures_text(split.stdout), figures_text(one.stdout), 0.0)
    one, split = cli("analyze", str(live_bag), "--json"), cli("analyze", str(live_split), "--json")
    _no_traceback(split)
    figures, split_figures = strict_json(one.stdout), strict_json(split.stdout)
    figures.pop("bag", None), split_figures.pop("bag", None)
    assert split_figures == figures  # the same computation on the same messages
    for bag in (live_bag, live_split):
        _no_traceback(cli("export", str(bag), "--out", str(tmp_path / bag.parent.name), "--format", "csv"))
    tables = sorted(p.name for p in (tmp_path / live_bag.parent.name).iterdir())
    assert tables and sorted(p.name for p in (tmp_path / live_split.parent.name).iterdir()) == tables
    for name in tables:
        a = pd.read_csv(tmp_path / live_bag.parent.name / name)
        b = pd.read_csv(tmp_path / live_split.parent.name / name)
        pd.testing.assert_frame_equal(a, b, check_exact=True)
    one = cli("allan", str(live_bag))
    split = cli("allan", str(live_split))
    _no_traceback(split)
    assert_same_figures(
        split.stdout.replace(str(live_split), "BAG"), one.stdout.replace(str(live_bag), "BAG"), 0.0
    )
    out = tmp_path / "swing.gif"
    _no_traceback(cli("animate", str(live_split), "--out", str(out), "--duration", "0.5", "--fps", "4"))
    with Image.open(out) as img:
        assert getattr(img, "n_frames", 1) == 3
    copy = tmp_path / "copy"
    shutil.copytree(live_split, copy)
    result = cli("repair", str(copy))
    _no_traceback(result)
    assert "intact" in result.stdout and str(read_bag(live_bag).message_count) in result.stdout


SEEK_TO = 2.0  # s of bag time: where the first pass starts, after the refused seeks


@pytest.mark.ros
@pytest.mark.parametrize("recording", ["live_bag", "live_split"])
def test_player(recording: str, request: pytest.FixtureRequest, spawn: Spawn) -> None:
    """bag_player plays every topic of the live bag (one file, and split into three) to a plain subscriber
    (player_control): started paused, seeks past the end and before the start are refused, a seek to 2 s
    plays [2, 3] s, a seek back to 0 at the end plays the whole bag; each message arrives exactly once per
    pass, in order, stamps unchanged."""
    live_bag: Path = request.getfixturevalue(recording)
    bag = read_bag(live_bag)
    listen = {topic: info.msgtype for topic, info in bag.topics.items()}
    first_pass = {  # messages logged at or after the seek target (the player seeks on log time)
        topic: int(np.count_nonzero(bag.raw(topic)[0] >= round(SEEK_TO * 1e9))) for topic in listen
    }
    total = {topic: first_pass[topic] + bag.topics[topic].count for topic in listen}
    player = start_node(
        spawn,
        "player_node",
        {
            "path": str(live_bag),
            "start_paused": True,
            "rate": 2.0,  # 0.5 s + 1.5 s of wall time: KEEP_ALL QoS makes a slow listener slow it, not lose
            "exit_on_end": False,  # stays at the end so the seek back can play the bag again
            # By name, on every topic: no message goes out before the listener below has matched it.
            "recorder_node": "player_control",
        },
    )
    player.wait_for("paused", timeout=60)
    end = bag.end_ns * 1e-9
    steps: list[list[Any]] = [
        ["set", {"seek_time": end + 0.5}],
        ["call", "seek"],
        ["set", {"seek_time": -0.5}],
        ["call", "seek"],
        ["set", {"seek_time": SEEK_TO}],
        ["call", "seek"],
        ["call", "resume"],
        *(["wait_count", topic, n] for topic, n in first_pass.items()),  # the first pass is over
        ["set", {"seek_time": 0.0}],
        ["call", "seek"],
        *(["wait_count", topic, n] for topic, n in total.items()),
    ]
    proc = spawn(
        [PYTHON, "-m", "test.player_control", json.dumps({"listen": listen, "steps": steps, "linger": 0.5})]
    )
    out, err = proc.communicate(timeout=180)
    assert proc.returncode == 0, err
    result = json.loads(out.strip().splitlines()[-1])
    player.proc.send_signal(signal.SIGINT)
    assert player.finish(timeout=30) == 0, player.text
    r = result["results"]
    assert r[1][0] is False and "outside the bag" in r[1][1], r[1]
    assert r[3][0] is False and "outside the bag" in r[3][1], r[3]
    assert r[5] == [True, f"seek to t={SEEK_TO:.3f} s"] and r[6] == [True, "playing"]
    assert r[7 + len(listen) + 1] == [True, "seek to t=0.000 s"]  # after the 7 steps and one wait per topic
    got = result["messages"]
    # Every topic, once per pass: nothing lost, nothing doubled (the linger would have caught a late extra).
    assert {topic: len(got[topic]) for topic in listen} == total
    played = re.search(r"played (\d+) messages in 1 pass", player.text)
    assert played is not None and int(played.group(1)) == sum(first_pass.values()), player.text
    for topic in (bm.TOPIC_JOINT_STATES, bm.TOPIC_ACCEL_TRUTH, bm.TOPIC_ACCEL_ESTIMATE, bm.TOPIC_CLOCK):
        recorded = bag.decode(topic)
        # The raw CDR is republished: the stamps come back bit for bit, [2, 3] s then the whole bag.
        expected = np.concatenate(
            [recorded.stamp[recorded.log_time_ns >= round(SEEK_TO * 1e9)], recorded.stamp]
        )
        np.testing.assert_array_equal([m[1] for m in got[topic]], expected, err_msg=topic)
    angles = bag.decode(bm.TOPIC_JOINT_STATES)["position[0]"]
    np.testing.assert_array_equal(
        [m[2] for m in got[bm.TOPIC_JOINT_STATES]][first_pass[bm.TOPIC_JOINT_STATES] :], angles
    )


# --- ROS-free: rclpy's byte layout built by hand ---------------------------------------------------


def _padding_offsets(data: bytes, msgtype: str) -> list[int]:
    """Offsets of the bytes a decode ignores: changing one leaves the decoded message's bytes as they were."""
    out = []
    for i in range(4, len(data)):  # the 4-byte encapsulation header is not padding
        probe = bytearray(data)
        probe[i] ^= 0xA5
        with contextlib.suppress(BagError):
            if bm.serialize(bm.deserialize(bytes(probe), msgtype), msgtype) == data:
                out.append(i)
    return out


def _rclpy_like(data: bytes, msgtype: str, fill: int) -> bytes:
    """``data`` as rclpy writes it: end padded to 4 bytes, padding bytes left at ``fill`` (uninitialised)."""
    probe = bytearray(data + bytes(-len(data) % bm.CDR_END_ALIGNMENT))
    for i in _padding_offsets(data, msgtype):
        probe[i] = fill
    return bytes(probe)


def test_messages_that_decode_are_kept_though_they_do_not_reserialise(tmp_path: Path) -> None:
    generate_bag("step_start", tmp_path / "src", duration=0.5)
    source = read_bag(tmp_path / "src")
    changed = 0
    last = b""
    with BagWriter(tmp_path / "bag") as writer:
        for topic, info in source.topics.items():
            writer.add_topic(topic, info.msgtype)
        for topic, ns, data in source.iter_raw():
            if topic == bm.TOPIC_DIAGNOSTICS:
                odd = _rclpy_like(data, bm.DIAGNOSTIC_ARRAY, fill=0x5A)
                changed += odd != data
                data = last = odd
            writer.write(topic, ns, data)
        damaged = last[: len(last) // 2]  # a diagnostic cut in half: does not decode
        writer.write(bm.TOPIC_DIAGNOSTICS, ns + 1, damaged)
        padded_too_far = last + bytes(8)  # decodes, but 8 bytes past its end are not CDR's end padding
        writer.write(bm.TOPIC_DIAGNOSTICS, ns + 2, padded_too_far)
    assert changed == source.topics[bm.TOPIC_DIAGNOSTICS].count > 0
    bag = read_bag(tmp_path / "bag")
    stamps = bag.decode(bm.TOPIC_DIAGNOSTICS, fields=["header.stamp.sec", "header.stamp.nanosec"])
    expected = source.decode(bm.TOPIC_DIAGNOSTICS, fields=["header.stamp.sec", "header.stamp.nanosec"])
    np.testing.assert_array_equal(stamps.stamp, expected.stamp)  # every odd one kept, the 2 bad ones not
    assert bag.problem is not None and "skipped 2 damaged" in bag.problem
    paths = export_bag(read_bag(tmp_path / "bag"), tmp_path / "tables")
    table = pd.read_csv(next(p for p in paths if p.stem == file_stem(bm.TOPIC_DIAGNOSTICS)))
    np.testing.assert_array_equal(table["t"], expected.stamp)


def test_canonical_cdr_accepts_only_end_padding() -> None:
    msg = bm.diagnostic_array(10, 0, "accel_estimator", "OK", {"method": "kalman"})
    data = bm.serialize(msg, bm.DIAGNOSTIC_ARRAY)
    assert len(data) % 4 != 0  # the typestore does not pad the end: the case rclpy differs in
    padded = data + bytes(-len(data) % 4)
    for raw in (data, padded, _rclpy_like(data, bm.DIAGNOSTIC_ARRAY, fill=0xFF)):
        _, canonical = bm.canonical_cdr(raw, bm.DIAGNOSTIC_ARRAY)
        assert canonical == data
    short_of_alignment = [k for k in (1, 2, 3) if (len(data) + k) % 4]
    assert short_of_alignment  # len(data) % 4 != 0 leaves at least one
    for k in short_of_alignment:  # within the typestore's own 3-byte slack, but not an end padding
        with pytest.raises(BagError, match="past its end"):
            bm.canonical_cdr(data + bytes(k), bm.DIAGNOSTIC_ARRAY)
    with pytest.raises(BagError):  # the typestore itself refuses 4 or more bytes past the end
        bm.canonical_cdr(padded + bytes(4), bm.DIAGNOSTIC_ARRAY)
    with pytest.raises(BagError):
        bm.canonical_cdr(data[:-12], bm.DIAGNOSTIC_ARRAY)
