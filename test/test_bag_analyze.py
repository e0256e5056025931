"""Offline analysis of a bag: a step scene written with the bulk path, re-analysed without ROS."""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pendulum_accel.bag import cdr_layout, mcap_file
from pendulum_accel.bag import messages as bm
from pendulum_accel.bag import writer as bag_writer
from pendulum_accel.bag.blocks import Lazy
from pendulum_accel.bag.reader import Bag, read_bag
from pendulum_accel.bag.writer import BagWriter, Stream
from pendulum_accel.cli.main import main
from pendulum_accel.cli.output import json_text
from pendulum_accel.errors import BagError, ParameterError
from pendulum_accel.estimators import DEFAULT_ESTIMATOR, estimate_batch
from pendulum_accel.estimators.guard import frame_problem
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Step
from pendulum_accel.physics.simulate import simulate
from pendulum_accel.recording.analysis_plot import plot_analysis
from pendulum_accel.recording.analyze import analyze_bag
from pendulum_accel.recording.changes import CHANGE_ONSET, CHANGE_WINDOW, after_change, change_rule
from pendulum_accel.recording.contract import decode_chain, unprefixed
from pendulum_accel.recording.figures import settling
from pendulum_accel.recording.generate import chain_streams, generate_bag, write_chain_bag
from test.conftest import strict_json
from test.figures import assert_figure
from test.refusal import error_line
from test.sensor_bag import A_STEP, CONFIG, DAMPING, LENGTH, NOISE, RATE, T_STEP, write_step_bag


@pytest.fixture(scope="module")
def step_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """0 → 3 m/s² step at t = 2 s, damped pendulum, 200 Hz angles with 1 mrad noise, 12 s."""
    return write_step_bag(tmp_path_factory.mktemp("analyze") / "step")


def test_analyze_recovers_the_step(step_bag: Path) -> None:
    """Re-running the estimator offline: steady state within 0.05 m/s² RMS, settles within 3 s of the step."""
    result = analyze_bag(step_bag, config=CONFIG)
    assert result.t.size == int(12.0 * RATE)
    np.testing.assert_allclose(result.accel_true[result.t >= T_STEP], A_STEP)
    assert result.settling_time is not None and result.settling_time < 3.0
    assert result.settle_from == pytest.approx(T_STEP, abs=1.0 / RATE)
    assert result.settled_stats.rms < 0.05
    assert abs(result.settled_stats.bias) < 0.02
    assert result.stats.max_abs >= result.stats.rms >= abs(result.stats.bias)
    # The estimate recorded in the bag came from the same estimator: same figures.
    assert result.recorded is not None
    assert result.recorded.n == result.stats.n


def test_other_estimator_and_plot(step_bag: Path, tmp_path: Path) -> None:
    """Any estimator can be re-run; the plot is a PNG with three panels' worth of pixels."""
    result = analyze_bag(step_bag, estimator="instant", config=CONFIG, skip=5.0)
    assert result.estimator == "instant"
    # instant: â = g tan θ_meas, error std ≈ g σ sec²θ ≈ 0.01 m/s² at rest after the transient decays.
    assert result.stats.rms < 0.5
    png = plot_analysis(result, tmp_path / "a.png")
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000


def test_analyze_needs_a_length_without_scene(step_bag: Path) -> None:
    """No stored scene and no --length: a one-line BagError saying what to pass."""
    with pytest.raises(BagError, match="--length"):
        analyze_bag(step_bag)


def test_settling_definition() -> None:
    """t_s follows the last out-of-band sample; the reference is the last truth jump before it."""
    t = np.arange(10.0)
    truth = np.array([0, 0, 3, 3, 3, 3, 3, 3, 3, 3], dtype=float)
    est = np.array([np.nan, 0, 0, 1, 2.5, 2.95, 3.01, 2.99, 3.0, 3.0])
    t_ref, t_settle = settling(t, est - truth, truth, 0.1)
    assert t_ref == 2.0 and t_settle == 3.0
    _, never = settling(t, np.append(np.zeros(9), 1.0), np.zeros(10), 0.1)
    assert never is None


def test_cli_info_and_analyze(step_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """`info` lists topics, counts, plan; `analyze --json` prints the figures; exit codes 0."""
    assert main(["info", str(step_bag)]) == 0
    out = capsys.readouterr().out
    assert "/pendulum/joint_states" in out and "2400 msgs" in out and "rigid/DOP853 (test)" in out
    png = tmp_path / "plot.png"
    assert main(["analyze", str(step_bag), "--length", str(LENGTH), "--plot", str(png), "--json"]) == 0
    figures = __import__("json").loads(capsys.readouterr().out)
    assert figures["estimator"] == DEFAULT_ESTIMATOR and figures["samples"] > 0
    assert math.isfinite(figures["rms"]) and png.exists()


def test_cli_damaged_bag_warns_and_salvages(
    step_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A truncated copy: info prints what is readable and one warning line, exit 1; analyze refuses it in
    one line, exit 2, and with --salvage analyses its intact records with one warning line, exit 1;
    repair fixes it."""
    copy = tmp_path / "step"
    copy.mkdir()
    data = (step_bag / "step.mcap").read_bytes()
    (copy / "step.mcap").write_bytes(data[: len(data) * 4 // 5])  # past the first 1 MiB chunk
    assert main(["info", str(copy)]) == 1
    captured = capsys.readouterr()
    assert "truncated" in captured.err and captured.err.count("\n") == 1
    assert main(["analyze", str(copy), "--length", str(LENGTH)]) == 2
    captured = capsys.readouterr()
    assert "damaged" in captured.err and "--salvage" in captured.err and captured.err.count("\n") == 1
    assert "RMS" not in captured.out
    assert main(["analyze", str(copy), "--length", str(LENGTH), "--salvage"]) == 1
    captured = capsys.readouterr()
    assert "RMS" in captured.out and "recovered by parsing" in captured.err and captured.err.count("\n") == 1
    assert main(["repair", str(copy)]) == 0
    assert "rebuilt with" in capsys.readouterr().out
    bag = read_bag(copy, salvage=False)
    assert 0 < bag.topics[bm.TOPIC_JOINT_STATES].count < 2400
    assert main(["info", str(tmp_path / "missing")]) == 2
    assert "does not exist" in capsys.readouterr().err


def test_cli_wrong_type_topic(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """/pendulum/joint_states recorded as AccelStamped: analyze names the topic and both types, exit 2."""
    layout = cdr_layout.Layout.of(bm.accel_stamped(0, 0.0), bm.ACCEL_STAMPED)
    ns = np.arange(10, dtype=np.int64) * 10_000_000
    sec, nsec = bm.split_stamp(ns)
    rows = layout.encode(10, {"header.stamp.sec": sec, "header.stamp.nanosec": nsec})
    with BagWriter(tmp_path / "wrong") as writer:
        writer.add_topic(bm.TOPIC_JOINT_STATES, bm.ACCEL_STAMPED)
        writer.write_sorted([Stream(bm.TOPIC_JOINT_STATES, ns, rows)])
    assert main(["analyze", str(tmp_path / "wrong"), "--length", "1"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "/pendulum/joint_states" in err and "geometry_msgs/msg/AccelStamped" in err
    assert "expected sensor_msgs/msg/JointState" in err


@pytest.mark.parametrize("command", ["info", "analyze", "export", "allan"])
def test_a_topic_rule_of_the_wrong_type_is_refused_by_every_command(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--topic pendulum/joint_states=/car/accel/truth`` (an AccelStamped topic for the JointState role):
    one line naming the rule and both types, exit 2, nothing written; info read the bag as if no rule had
    been given (analyze, export and allan refused it only once they decoded the topic)."""
    golden = Path(__file__).resolve().parents[1] / "bags" / "step_start"
    out = ["--out", str(tmp_path / "tables")] if command == "export" else []
    rule = ["--topic", "pendulum/joint_states=/car/accel/truth"]
    code = main([command, str(golden), *rule, *out])
    error_line(code, capsys.readouterr().err, "--topic 'pendulum/joint_states=/car/accel/truth'",
               "has type geometry_msgs/msg/AccelStamped, expected sensor_msgs/msg/JointState")  # fmt: skip
    assert list(tmp_path.iterdir()) == []


@pytest.fixture(scope="module")
def holed_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The step scene recorded with the lowpass estimator whose stream misses 1.9 s (t in [3, 4.9))."""
    pendulum = Pendulum(LENGTH, damping=DAMPING)
    t = np.arange(0.0, 12.0, 1.0 / RATE)
    traj = simulate(pendulum, Step(T_STEP, 0.0, A_STEP), t, theta0=0.0)
    theta = traj.theta + np.random.default_rng(7).normal(0.0, NOISE, t.size)
    a_est, var = estimate_batch("lowpass", t, theta, rate_hz=RATE, **CONFIG)
    a_est = np.where((t >= 3.0) & (t < 4.9 - 1e-9), np.nan, a_est)  # nothing published in the hole
    streams = chain_streams(
        t, theta, traj.theta_dot, traj.accel, a_est, var, estimator="lowpass", rate_hz=RATE
    )
    path = tmp_path_factory.mktemp("analyze") / "holed"
    write_chain_bag(path, streams, custom_data={})
    return path


def test_recorded_and_rerun_side_by_side_with_the_hole(holed_bag: Path) -> None:
    """The re-run defaults to the recorded estimator (from /diagnostics); the recorded stream's hole is
    found to the sample; another --estimator gives other offline figures while the recorded ones stay."""
    result = analyze_bag(holed_bag, config=CONFIG)
    rec, off = result.recorded_figures, result.offline_figures
    assert rec is not None and rec.estimator == "lowpass" and result.estimator == "lowpass"
    assert off.count == rec.angles == 2400 and rec.count == 2400 - 380
    (hole,) = rec.holes
    assert hole.start == pytest.approx(3.0) and hole.end == pytest.approx(4.9) and hole.missing == 380
    assert off.holes == () and rec.stats.n == off.stats.n - 380
    kalman = analyze_bag(holed_bag, estimator="kalman", config=CONFIG)
    assert kalman.recorded_figures is not None and kalman.recorded_figures.stats == rec.stats
    # recorded − re-run over the recorded estimates: for the same method on the same angles, rounding only
    # (the re-run's rate is 1/median Δt of the stamps, 200 Hz to ~1e-13 relative: ~3e-12 m/s² here; the
    # 1e-9 test_node_player holds the live node to), and the methods' difference for another.
    same, other = result.agreement, kalman.agreement
    assert same is not None and same.n == 2400 - 380 and same.max_abs <= 1e-9
    assert other is not None and other.n == same.n and other.rms > 0.01
    assert kalman.offline_figures.settled_stats.rms < off.settled_stats.rms  # kalman beats lowpass
    report = "\n".join(result.lines())
    assert "recorded (lowpass)" in report and "offline re-run (lowpass)" in report
    # the hole's figures parsed: 3.0 s to 4.9 s from integer stamps, exact to their printed digits
    assert "1 (380 angles), longest " in report
    assert_figure(report, "(380 angles), longest ", 1.9, rel=0.0)
    assert_figure(report, " s at t=", 3.0, rel=0.0)


def test_analyze_json_carries_both_streams(holed_bag: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["analyze", str(holed_bag), "--length", str(LENGTH), "--json"]) == 0
    figures = strict_json(capsys.readouterr().out)
    rec, off = figures["recorded"], figures["offline"]
    assert rec["estimator"] == off["estimator"] == figures["estimator"] == "lowpass"
    assert rec["missing"] == 380 and rec["longest_hole"] == pytest.approx(1.9) and off["missing"] == 0
    for stream in (rec, off):
        for key in ("bias", "rms", "max_error", "settled_bias", "settled_rms", "settled_max_error"):
            assert math.isfinite(stream[key])
    assert off["rms"] == figures["rms"] and off["settling_time"] == figures["settling_time"]


@pytest.fixture(scope="module")
def sensor_bag(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """step_bag as a real sensor's recording: the same angles and live estimate, and no truth topic."""
    return write_step_bag(tmp_path_factory.mktemp("analyze") / "sensor", truth=False)


def test_a_bag_without_truth_gets_the_figures_that_need_none(sensor_bag: Path, step_bag: Path) -> None:
    """No truth topic (a real sensor's bag): counts, holes, the estimates' mean and range and median σ,
    equal to those of the same angles and estimate beside a truth; no error figure, settling or
    calibration, and the report says why. Before, the bag was refused ("has no topic /car/accel/truth")."""
    bare, full = analyze_bag(sensor_bag, config=CONFIG), analyze_bag(step_bag, config=CONFIG)
    assert not bare.has_truth and full.has_truth
    for with_truth, without in ((full.offline_figures, bare.offline_figures),
                                (full.recorded_figures, bare.recorded_figures)):  # fmt: skip
        assert with_truth is not None and without is not None
        # The same floats through the same code: the same figures, whatever the truth beside them.
        assert without.values == with_truth.values and without.count == with_truth.count == 2400
        assert without.stats.n == 0 and math.isnan(without.stats.rms) and without.settling_time is None
    assert bare.calibration is None and bare.recorded_calibration is None
    assert np.isnan(bare.accel_true).all()
    values = bare.offline_figures.values
    # The step's estimate, from its start at rest to 3 m/s²: its mean lies between (10 of 12 s at 3 m/s²)
    # and the range spans both levels.
    assert 2.0 < values.mean < A_STEP and values.low < 0.5 and values.high > A_STEP - 0.1
    assert values.sigma_median == pytest.approx(float(np.sqrt(np.median(bare.variance))))
    report = "\n".join(bare.lines())
    assert "no truth in the bag (/car/accel/truth)" in report
    assert "RMS:" not in report and "settling" not in report
    assert_figure(report, "mean â:", values.mean, rel=1e-4)
    with pytest.raises(ParameterError, match=r"settling band around the truth, and bag .* has none"):
        analyze_bag(sensor_bag, config=CONFIG, tolerance=0.1)


def test_angles_on_another_topic_are_refused_with_the_flag_that_reads_them(
    sensor_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A sensor's angles on its own topic (/sensor/angle): analyze says the bag has no angles, names its
    topics and the --topic rule, in one line; with that rule it reads them."""
    bag = read_bag(sensor_bag)
    moved = tmp_path / "moved"
    with BagWriter(moved, custom_data=bag.custom_data) as writer:
        rename = {bm.TOPIC_JOINT_STATES: "/sensor/angle"}
        for name, info in bag.topics.items():
            writer.add_topic(rename.get(name, name), info.msgtype)
        for topic, ns, data in bag.iter_raw():
            writer.write(rename.get(topic, topic), ns, data)
    assert main(["analyze", str(moved), "--length", str(LENGTH)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "has no angles: no topic /pendulum/joint_states (topics: " in err
    assert "/sensor/angle" in err and "--topic pendulum/joint_states=NAME" in err
    rule = ["--topic", "pendulum/joint_states=/sensor/angle"]
    assert main(["analyze", str(moved), "--length", str(LENGTH), "--json", *rule]) == 0
    assert strict_json(capsys.readouterr().out)["offline"]["estimates"] == 2400


def test_without_a_scene_the_noise_is_measured_from_the_angles(tmp_path: Path) -> None:
    """A sensor bag without a scene whose noise is 4 mrad, not the estimators' default 1 mrad: the re-run
    measures σ from the angles (sensor.noise_from_angles) and says so. With it the published variance
    keeps both windows within 12 % beyond 2σ; with the default σ, a quarter of the errors lie beyond."""
    bag = write_step_bag(tmp_path / "noisy", noise=4e-3)
    sensor = {"length": LENGTH, "damping": DAMPING}
    measured = analyze_bag(bag, config=sensor)
    assert measured.noise_from_angles
    # A robust scale (MAD) of 2400 third differences: a few % standard error; 15 % is several of them.
    assert measured.config["noise_std"] == pytest.approx(4e-3, rel=0.15)
    assert "noise_std from the angles' third differences" in "\n".join(measured.lines())
    default = analyze_bag(bag, config={**sensor, "noise_std": 1e-3})
    assert not default.noise_from_angles
    for result, within in ((measured, True), (default, False)):
        cal = result.calibration
        assert cal is not None
        shares = (cal.steady.share_2sigma, cal.after_change.share_2sigma)
        assert all(share <= 0.12 for share in shares) is within, shares


def test_analyze_cli_on_a_bag_without_truth(
    sensor_bag: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`analyze --json` is strict JSON with "truth": false and null error figures; --plot draws the 2σ."""
    png = tmp_path / "sensor.png"
    assert main(["analyze", str(sensor_bag), "--length", str(LENGTH), "--json", "--plot", str(png)]) == 0
    figures = strict_json(capsys.readouterr().out)
    assert figures["truth"] is False
    for key in ("rms", "bias", "max_error", "settling_time", "tolerance", "nees_steady_mean"):
        assert figures[key] is None, key
    for stream in (figures["offline"], figures["recorded"]):
        assert stream["estimates"] == 2400 and stream["rms"] is None
        assert stream["estimate_min"] < stream["estimate_mean"] < stream["estimate_max"]
        assert stream["sigma_median"] > 0.0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


# ---------------------------------------------------------------- the change rule, strict JSON, the model

GOLDEN = sorted(p for p in (Path(__file__).resolve().parents[1] / "bags").iterdir() if p.is_dir())


def test_a_change_is_a_jump_over_one_second_from_its_onset_to_two_seconds_after() -> None:
    """recording.changes: a 3 m/s² step at t = 1 s on 100 Hz samples differs from a(t − 1 s) by 3 for
    t ∈ [1, 2), so the samples from 1 s to 1.99 s + CHANGE_WINDOW are after a change. A 1.8 m/s³ ramp from
    t = 5 s is detected at 5.12 s (0.2 m/s² reached) but counts from its onset, the first sample where a
    has moved by CHANGE_ONSET (5.01 s: 0.018 m/s²). A 0.1 m/s³ ramp (under CHANGE_JUMP in any second) and
    a ±0.05 m/s² wiggle are steady; a 0.3 m/s³ ramp is not."""
    t = np.round(np.arange(0.0, 10.0, 0.01), 10)
    step = np.where(t >= 1.0, 3.0, 0.0)
    assert np.array_equal(after_change(t, t, step), (t >= 1.0) & (t <= 1.99 + CHANGE_WINDOW))
    ramp = np.clip(1.8 * (t - 5.0), 0.0, 1.8)
    after = after_change(t, t, ramp)
    assert t[np.argmax(after)] == 5.01 and 1.8 * (5.01 - 5.0) > CHANGE_ONSET > 1.8 * (5.005 - 5.0)
    for slope, changes in ((0.1, False), (0.3, True)):
        assert after_change(t, t, slope * t).any() == changes
    wiggle = 0.05 * np.sin(2 * np.pi * 3.0 * t)
    assert not after_change(t, t, wiggle).any()
    assert "|a(t) − a(t − 1 s)| > 0.2 m/s²" in change_rule() and "to 2 s after" in change_rule()


def test_json_text_writes_null_for_what_is_not_a_number() -> None:
    """NaN and ±inf (Python's json would print bare NaN and Infinity) become null; numpy scalars numbers."""
    text = json_text({"a": math.nan, "b": [math.inf, -math.inf, 1.5], "c": np.float32(2.0), "d": np.int64(3)})
    assert strict_json(text) == {"a": None, "b": [None, None, 1.5], "c": 2.0, "d": 3}
    with pytest.raises(ValueError, match="not strict JSON"):
        strict_json('{"a": NaN}')


@pytest.mark.parametrize("bag", GOLDEN, ids=[p.name for p in GOLDEN])
def test_analyze_json_is_strict_and_names_the_motion_model_on_every_golden_bag(
    bag: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Every golden bag: `analyze --json` parses as strict JSON and names the motion model and the change
    rule; the text report names the same model."""
    assert main(["analyze", str(bag), "--json"]) == 0
    figures = strict_json(capsys.readouterr().out)
    assert figures["change_rule"] == change_rule()
    assert main(["analyze", str(bag)]) == 0
    text = capsys.readouterr().out
    if figures["estimator"] in ("kalman", "smoother"):
        assert isinstance(figures["motion_model"], str) and figures["motion_reason"]
        assert f"motion model {figures['motion_model']} (" in text
    else:
        assert figures["motion_model"] is None and "motion model" not in text
    assert f"changes:    {change_rule()}" in text


def test_analyze_splits_a_real_trace_into_steady_and_after_change(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A real robot's odometry (husky_odom, 60 s): both windows hold samples, as the rule says, so both
    shares are numbers; under the old rule (any change of a between samples) every sample was "after a
    change" and the steady share was NaN. The motion model is auto, as for any data."""
    generate_bag("husky_odom", tmp_path / "husky", duration=60.0)
    result = analyze_bag(tmp_path / "husky")
    assert result.calibration is not None
    expected_after = after_change(result.t, result.t, result.accel_true)
    assert 0 < np.count_nonzero(expected_after) < result.t.size
    assert result.calibration.steady.n == np.count_nonzero(~expected_after)
    assert result.calibration.after_change.n == np.count_nonzero(expected_after)
    assert main(["analyze", str(tmp_path / "husky"), "--json"]) == 0
    figures = strict_json(capsys.readouterr().out)
    for window in ("steady", "after_change"):
        share = figures[f"nees_{window}_share_2sigma"]
        assert 0.0 <= share <= 1.0
        # the independent errors behind the share, and its 95 % interval around it (recording.coverage)
        assert 1.0 <= figures[f"nees_{window}_trials"] <= getattr(result.calibration, window).n
        low, high = figures[f"nees_{window}_share_2sigma_low"], figures[f"nees_{window}_share_2sigma_high"]
        assert low <= share <= high
        # The share beyond 3σ beside it: the same computation as the result's (a float's JSON is exact),
        # and never above the 2σ share (NEES > 9 implies NEES > 4).
        beyond3 = figures[f"nees_{window}_share_3sigma"]
        assert beyond3 == getattr(result.calibration, window).share_3sigma and 0.0 <= beyond3 <= share
    assert figures["motion_model"] == result.motion_model == "auto"  # learned from the angles, no scene rule


@pytest.fixture
def small_chunks(monkeypatch: pytest.MonkeyPatch) -> None:
    """Bags written in this test close a chunk past 16 KiB, so a short bag has many chunks to read again."""
    monkeypatch.setattr(mcap_file, "CHUNK_BYTES", 1 << 14)
    monkeypatch.setattr(bag_writer, "CHUNK_BYTES", 1 << 14)


def _chunk_reads(monkeypatch: pytest.MonkeyPatch) -> list[int]:
    """The file offsets of the chunks every Bag reads again from now on, one entry per read."""
    reads: list[int] = []
    read_chunk = Bag._read_chunk

    def counted(self: Bag, ref: Any, want: frozenset[int]) -> Any:
        """Bag._read_chunk, noted."""
        reads.append(ref.at)
        return read_chunk(self, ref, want)

    monkeypatch.setattr(Bag, "_read_chunk", counted)
    return reads


@pytest.mark.usefixtures("small_chunks")
def test_analyze_reads_each_chunk_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The angles, the truth and the recorded estimate are decoded, and the chain contract checked, in one
    pass: after the scan, analyze reads each chunk of the file again once, however many it has, and its
    recorded figures and calibration are those of the recorded estimate decoded on its own."""
    generate_bag("lecture_constant", tmp_path / "bag", duration=2.0)
    bag = read_bag(tmp_path / "bag")
    reads = _chunk_reads(monkeypatch)
    result = analyze_bag(bag)
    chunks = {b.ref.at for ch in bag._channels.values() for b in ch.blocks if isinstance(b, Lazy)}
    assert len(chunks) > 5 and sorted(reads) == sorted(chunks)
    est = read_bag(tmp_path / "bag").decode(
        bm.TOPIC_ACCEL_ESTIMATE,
        fields=["header.stamp.sec", "header.stamp.nanosec", "accel.accel.linear.x", "accel.covariance[0]"],
    )
    order = np.argsort(est.stamp, kind="stable")
    assert result.recorded_figures is not None and result.recorded_calibration is not None
    np.testing.assert_array_equal(result.recorded_figures.t, est.stamp[order])  # the same numbers, moved
    np.testing.assert_array_equal(result.recorded_figures.accel, est["accel.accel.linear.x"][order])
    steady, after = result.recorded_calibration.steady, result.recorded_calibration.after_change
    assert steady.n + after.n == int(np.count_nonzero(est["accel.covariance[0]"] > 0.0))


@pytest.mark.usefixtures("small_chunks")
def test_allan_reads_each_chunk_at_most_once(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """allan's series (the angles and the recorded estimate, and the chain contract) come from one pass:
    after the scan no chunk is read twice, and the series are the topics' own numbers."""
    from pendulum_accel.allan import bag_series

    generate_bag("lecture_constant", tmp_path / "bag", duration=2.0)
    bag = read_bag(tmp_path / "bag")
    reads = _chunk_reads(monkeypatch)
    series = bag_series(bag)
    assert len(reads) > 5 and len(reads) == len(set(reads))
    fresh = read_bag(tmp_path / "bag")
    js = fresh.decode(
        bm.TOPIC_JOINT_STATES, fields=["header.stamp.sec", "header.stamp.nanosec", "position[0]"]
    )
    est = fresh.decode(
        bm.TOPIC_ACCEL_ESTIMATE, fields=["header.stamp.sec", "header.stamp.nanosec", "accel.accel.linear.x"]
    )
    np.testing.assert_array_equal(series.theta, js["position[0]"][np.argsort(js.stamp, kind="stable")])
    assert series.accel is not None
    np.testing.assert_array_equal(
        series.accel, est["accel.accel.linear.x"][np.argsort(est.stamp, kind="stable")]
    )


@pytest.mark.usefixtures("small_chunks")
def test_the_recorded_estimator_is_read_from_the_first_report_only(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A bag that names its estimator only in /diagnostics (as a live recording does): analyze reads each
    chunk again once for its data, and then only the chunk of the first report, which names the method."""
    t = np.arange(0.0, 6.0, 1.0 / RATE)
    traj = simulate(Pendulum(LENGTH, damping=DAMPING), Step(T_STEP, 0.0, A_STEP), t, theta0=0.0)
    a_est, var = estimate_batch("lowpass", t, traj.theta, rate_hz=RATE, **CONFIG)
    streams = chain_streams(
        t, traj.theta, traj.theta_dot, traj.accel, a_est, var, estimator="lowpass", rate_hz=RATE
    )
    write_chain_bag(tmp_path / "live", streams, custom_data={})
    bag = read_bag(tmp_path / "live")
    reads = _chunk_reads(monkeypatch)
    result = analyze_bag(bag, config=CONFIG)
    assert result.estimator == "lowpass" and result.recorded_figures is not None
    assert result.recorded_figures.estimator == "lowpass"
    chunks = sorted({b.ref.at for ch in bag._channels.values() for b in ch.blocks if isinstance(b, Lazy)})
    reports = next(ch for ch in bag._channels.values() if ch.topic == bm.TOPIC_DIAGNOSTICS).blocks
    first_report = next(b.ref.at for b in reports if isinstance(b, Lazy))
    assert len(chunks) > 5 and sorted(reads) == sorted([*chunks, first_report])
    assert list(bag.raw_payloads(bm.TOPIC_DIAGNOSTICS)) == bag.raw(bm.TOPIC_DIAGNOSTICS)[1]  # raw's, in order


def _foreign_angles(msg: Any) -> None:
    """Edit: another robot's joint, with no position (position[0], which analyze decodes, is absent)."""
    msg.name = ["elbow_joint"]
    msg.position = np.zeros(0)
    msg.velocity = np.zeros(0)


@pytest.mark.usefixtures("small_chunks")
def test_the_contract_refuses_a_foreign_bag_before_its_decoding_breaks(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Angles naming another joint, with no position: the one-pass decode breaks on the missing
    position[0], but the refusal is the contract's line, which says why. A bag whose truth (a topic
    decode_chain was not asked to decode) carries another frame is refused too, from the same single pass."""
    generate_bag("lecture_constant", tmp_path / "bag", duration=2.0)
    source = read_bag(tmp_path / "bag")
    reads = _chunk_reads(monkeypatch)
    for name, topic, edit, problem in (
        ("elbow", bm.TOPIC_JOINT_STATES, _foreign_angles, "names joint(s) 'elbow_joint'"),
        ("odom", bm.TOPIC_ACCEL_TRUTH, _odom, "/car/accel/truth messages are not the pendulum chain's"),
    ):
        with BagWriter(tmp_path / name, custom_data=source.custom_data) as writer:
            for topic_name, info in source.topics.items():
                writer.add_topic(topic_name, info.msgtype)
            for topic_name, ns, data in source.iter_raw():
                if topic_name == topic:
                    msg = bm.deserialize(data, info_type := source.topics[topic_name].msgtype)
                    edit(msg)
                    data = bm.serialize(msg, info_type)
                writer.write(topic_name, ns, data)
        with pytest.raises(BagError, match=re.escape(problem)):
            analyze_bag(tmp_path / name)
        bag = read_bag(tmp_path / name)
        if name == "elbow":  # decoded alone, the angles break on the missing field
            with pytest.raises(BagError, match=re.escape("no field 'position[0]'")):
                bag.decode(bm.TOPIC_JOINT_STATES, fields=["position[0]"])
        reads.clear()
        with pytest.raises(BagError, match=re.escape(problem)):
            decode_chain(bag, {bm.TOPIC_CLOCK: (bm.CLOCK, None)})
        if name == "odom":  # the decoding did not break: one pass found every shape the contract checks
            assert len(reads) == len(set(reads)) > 5


def test_the_contract_takes_the_cars_frame_under_any_frame_prefix() -> None:
    """A namespaced chain stamps its truth and estimate in car1/base_link (its frame prefix): the chain's;
    another frame stays another robot's, prefixed or not."""
    assert frame_problem(unprefixed("car1/base_link")) is None
    assert frame_problem(unprefixed("fleet/car1/base_link")) is None
    assert frame_problem(unprefixed("base_link")) is None
    assert frame_problem(unprefixed("car1/odom")) is not None
    assert frame_problem(unprefixed("odom")) is not None


def _odom(msg: Any) -> None:
    """Edit: header.frame_id 'odom', another frame than the car's."""
    msg.header.frame_id = "odom"


def test_analyze_plot_draws_each_streams_reliability_diagram(
    step_bag: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``analyze --plot`` with a fixed lag: a fourth panel holds the reliability diagram of the recorded
    (live) estimate and of the fixed-lag re-run, each curve the stream's σ deciles (the very floats
    recording.reliability gives for that stream: exact), and the diagonal; the PNG is written. The text
    report states the 3σ share beside the 2σ share and the Gaussian reference once."""
    from pendulum_accel.recording import analysis_plot

    drawn: list[Any] = []
    save = analysis_plot._save

    def keep(fig: Any, out: Path | str) -> Path:
        """Note the figure's panels before it is saved and closed."""
        drawn.append(
            [(ax, [(line.get_label(), *line.get_data()) for line in ax.get_lines()]) for ax in fig.axes]
        )
        return save(fig, out)

    monkeypatch.setattr(analysis_plot, "_save", keep)
    png = tmp_path / "plot.png"
    args = ["analyze", str(step_bag), "--length", str(LENGTH), "--lag", "0.25", "--plot", str(png)]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    (panels,) = drawn
    assert len(panels) == 4
    ax, lines = panels[3]
    assert ax.get_xscale() == ax.get_yscale() == "log"
    by_label = {label: (x, y) for label, x, y in lines}
    result = analyze_bag(step_bag, config={"length": LENGTH}, lag=0.25)  # what the command computed
    assert result.recorded_figures is not None
    streams = {
        f"recorded ({result.recorded_figures.estimator})": result.recorded_figures,
        f"offline re-run ({result.estimator}, lag 0.25 s)": result.offline_figures,
    }
    for label, stream in streams.items():
        bins = analysis_plot.stream_reliability(result, stream)
        assert bins.predicted.size == 10  # deciles: 1,200 estimates and more each
        x, y = by_label[label]
        np.testing.assert_array_equal(x, bins.predicted)
        np.testing.assert_array_equal(y, bins.observed)
    (diagonal,) = [(x, y) for label, x, y in lines if label.startswith("calibrated")]
    np.testing.assert_array_equal(diagonal[0], diagonal[1])
    lines_of = [line for line in out.splitlines() if line.startswith("calibration")]
    assert len(lines_of) == 2  # re-run and recorded
    for line in lines_of:
        steady = line.split(";")[0]
        two = float(re.search(r"([\d.]+) % beyond 2σ", steady).group(1))  # type: ignore[union-attr]
        three = float(re.search(r"([\d.]+) % beyond 3σ", steady).group(1))  # type: ignore[union-attr]
        # 2σ printed to 0.1 % (off by ≤ 0.05), 3σ to 0.01 % (≤ 0.005), and the true 3σ share ≤ the 2σ one.
        assert 0.0 <= three <= two + 0.055
    notes = [line for line in out.splitlines() if "calibrated Gaussian" in line]
    assert len(notes) == 1
    assert float(re.search(r"([\d.]+) % beyond 3σ", notes[0]).group(1)) == 0.27  # type: ignore[union-attr]
