"""generate: a bag straight from a scene holds exactly the scene run's numbers, on the contract's topics."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.cli.main import main
from pendulum_accel.overrides import apply_overrides
from pendulum_accel.recording.generate import generate_bag
from pendulum_accel.scene import load_scene, scene_from_yaml
from pendulum_accel.scene_run import run_scene


def test_generated_bag_holds_the_scene_run(tmp_path: Path) -> None:
    """elastic_string (tension + stretch): every column equals run_scene's arrays, stamps = round(t·1e9)."""
    scene = load_scene("elastic_string")
    result = generate_bag(scene, tmp_path / "bag", duration=1.0)
    run = run_scene(dataclasses.replace(scene, duration=1.0))
    bag = read_bag(tmp_path / "bag", salvage=False)
    n = run.t.size
    assert result.counts == {t: i.count for t, i in bag.topics.items()}
    assert result.sim_duration == pytest.approx(1.0)
    ns = bm.seconds_to_ns(run.t)
    js = bag.decode(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)
    np.testing.assert_array_equal(js.log_time_ns, ns)
    np.testing.assert_array_equal(
        js["header.stamp.sec"].astype(np.int64) * 10**9 + js["header.stamp.nanosec"], ns
    )
    np.testing.assert_array_equal(js["position[0]"], run.theta_measured)
    # The published rate is measured (differences of the measured θ), not the simulator's exact θ'.
    np.testing.assert_array_equal(js["velocity[0]"], run.theta_dot_measured)
    truth = bag.decode(bm.TOPIC_ACCEL_TRUTH, bm.ACCEL_STAMPED)
    np.testing.assert_array_equal(truth["accel.linear.x"], run.accel_true)
    string = bag.decode(bm.TOPIC_STRING, bm.JOINT_STATE)
    assert run.tension is not None and run.stretch is not None and run.stretch_rate is not None
    np.testing.assert_array_equal(string["effort[0]"], run.tension)
    np.testing.assert_array_equal(string["position[0]"], run.stretch)
    np.testing.assert_array_equal(string["velocity[0]"], run.stretch_rate)
    clock = bag.decode(bm.TOPIC_CLOCK, bm.CLOCK)
    # The elastic scene samples at 200 Hz; /clock ticks at 100 Hz: every other sample, from t = 0.
    np.testing.assert_array_equal(clock.log_time_ns, ns[::2])
    est = bag.decode(bm.TOPIC_ACCEL_ESTIMATE, bm.ACCEL_WITH_COVARIANCE_STAMPED)
    assert 0 < len(est) <= n and np.all(np.isfinite(est["accel.accel.linear.x"]))
    assert np.all(est["accel.covariance[0]"] > 0)
    reports = [bm.deserialize(p, bm.DIAGNOSTIC_ARRAY) for p in bag.raw(bm.TOPIC_DIAGNOSTICS)[1]]
    assert all(isinstance(r, bm.DiagnosticArrayMsg) for r in reports)
    names = {r.status[0].name for r in reports if isinstance(r, bm.DiagnosticArrayMsg)}
    assert names == {"accel_estimator"} and bag.topics[bm.TOPIC_DIAGNOSTICS].count == 2  # t = 0 s and 1 s


def test_cli_generate_never_overwrites(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A second generate to the same path fails with one line unless --overwrite; no string topic here."""
    out = str(tmp_path / "bag")
    assert main(["generate", "step_start", "--out", out, "--duration", "2"]) == 0
    assert "x real time" in capsys.readouterr().out
    before = (tmp_path / "bag" / "bag.mcap").read_bytes()
    assert main(["generate", "step_start", "--out", out]) == 2
    assert "exists already" in capsys.readouterr().err
    assert (tmp_path / "bag" / "bag.mcap").read_bytes() == before
    assert main(["generate", "step_start", "--out", out, "--duration", "2", "--overwrite"]) == 0
    bag = read_bag(out)
    assert bm.TOPIC_STRING not in bag.topics
    assert bag.duration_s == pytest.approx(2.0)
    assert main(["generate", "no_such_scene", "--out", str(tmp_path / "x")]) == 2
    assert "no_such_scene" in capsys.readouterr().err


def test_cli_generate_takes_set_like_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """--set NAME=VALUE (the override table `run` and `simulate` use): the bag's stored scene and its data
    carry the values; an out-of-range one is one line, exit 2, and nothing written."""
    out = tmp_path / "bag"
    code = main(
        ["generate", "step_start", "--out", str(out), "--set", "duration=1.5", "--set", "noise_std=0"]
    )
    assert code == 0, capsys.readouterr().err
    bag = read_bag(out)
    assert bag.duration_s == pytest.approx(1.5)  # integer stamps at 100 Hz: 1.5 s exactly to 1 ns
    stored = scene_from_yaml(bag.custom_data["pendulum_accel.scene"])
    assert stored.duration == 1.5 and stored.sensor.noise_std == 0.0
    expected = run_scene(apply_overrides(load_scene("step_start"), {"duration": 1.5, "noise_std": 0.0}))
    angles = bag.decode(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)["position[0]"]
    np.testing.assert_array_equal(angles, expected.theta_measured)
    capsys.readouterr()
    assert main(["generate", "step_start", "--out", str(tmp_path / "bad"), "--set", "length=2000"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "length" in err and not (tmp_path / "bad").exists()
