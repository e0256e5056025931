"""Golden bags in bags/: one per bundled scene, small, complete, and replayed offline within tolerances.

Offline replay = ``analyze_bag``: the default estimator re-run on the recorded angles. Stated
tolerances for it on every bundled scene (noise σ = 1 mrad or less at 100-200 Hz):
  - settles (|â − a| ≤ 0.1 m/s² for good) within 1 s of the truth's last change;
  - after settling: |bias| ≤ 0.01 m/s² plus the sensor bias's reach (``bias_allowance``), RMS ≤ 0.03 m/s²;
  - the re-run reproduces the /car/accel/estimate stored in the bag to 1e-9 m/s².
A failure of the last check after a change to a scene or an estimator means: run ``make bags``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import Reader

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import read_bag
from pendulum_accel.planner import plan_scene
from pendulum_accel.recording.analyze import analyze_bag
from pendulum_accel.recording.stored_scene import stored_scene_name
from pendulum_accel.scene import list_scenes, scene_from_yaml
from test.figures import assert_same_figures

BAGS = Path(__file__).resolve().parent.parent / "bags"
SCENES = {scene.name: scene for scene in list_scenes()}
MAX_TOTAL_BYTES = 5_000_000
# The estimator benchmark's target (issue 7): the default settles within 2 s of a 0 → 3 m/s² step. The lab
# scenes' preset, lab_steps, settles step_start in 1.49 s where car took 0.49 s: its manoeuvre mode keeps
# some weight for a second after a step, for a lower RMS (0.30 against 0.38 m/s²) and an honest variance.
SETTLE_S = 2.0
BIAS = 0.01
RMS = 0.03
REPLAY_ATOL = 1e-9
# The plan's figures are error estimates: round-off measured from runs one ulp apart and sensitivities
# from a tangent run (conditioning), which another CPU rounds differently (3.75e-11 printed 3.8e-11 here
# and 3.7e-11 on an AMD EPYC). Beyond the printed half-units 10 % is allowed: the planner applies safety
# factors ≥ 2 to these figures, so a change within 10 % never changes its choice (the words, compared
# exactly), and a planner change that matters moves a figure by more.
PLAN_FIGURE_REL = 0.1
STALE = "golden bag out of date with the scenes/estimators: regenerate with `make bags`"


def test_one_small_complete_bag_per_bundled_scene() -> None:
    """Every bundled scene has bags/<scene>/ (metadata.yaml + .mcap); a few MB in all."""
    total = 0
    for name in SCENES:
        folder = BAGS / name
        assert (folder / "metadata.yaml").is_file(), f"missing golden bag {folder}: run `make bags`"
        assert (folder / f"{name}.mcap").is_file()
        total += sum(p.stat().st_size for p in folder.iterdir())
    assert total <= MAX_TOTAL_BYTES


@pytest.mark.parametrize("name", sorted(SCENES))
def test_golden_bag_content(name: str) -> None:
    """Complete; the contract's topics (string only where the scene computes it) and the viewers' (Imu,
    markers, URDF), as a live recording holds them; scene and plan stored."""
    bag = read_bag(BAGS / name, salvage=False)
    scene = SCENES[name]
    types = {**bm.TOPIC_TYPES, **bm.VIEWER_TOPIC_TYPES}
    expected = {t for t in types if t != bm.TOPIC_STRING}
    if scene.wants_tension or scene.wants_stretch:
        expected.add(bm.TOPIC_STRING)
    assert set(bag.topics) == expected
    for topic, info in bag.topics.items():
        assert info.msgtype == types[topic] and info.count > 0
    assert bag.topics[bm.TOPIC_IMU].count == bag.topics[bm.TOPIC_ACCEL_ESTIMATE].count
    assert bag.topics[bm.TOPIC_ROBOT_DESCRIPTION].count == 1
    stored = scene_from_yaml(bag.custom_data["pendulum_accel.scene"])
    assert stored_scene_name(bag) == name == stored.name
    assert stored.pendulum == scene.pendulum and stored.sensor == scene.sensor
    # The plan line is today's planner's for the stored scene: a planner change means `make bags`.
    # Its words and counts exactly; its figures as numbers (test.figures), not as printed last digits.
    assert_same_figures(
        plan_scene(stored).explain(), bag.custom_data["pendulum_accel.plan"], PLAN_FIGURE_REL, STALE
    )
    n = bag.topics[bm.TOPIC_JOINT_STATES].count
    assert n == pytest.approx(min(stored.duration, scene.duration) * scene.sensor.rate_hz + 1, abs=1)
    with Reader(BAGS / name) as reader:  # rosbag2's own view agrees
        assert {c.topic: c.msgcount for c in reader.connections} == {
            t: i.count for t, i in bag.topics.items()
        }


# a(t) settles on a level road; a sinusoidal drive (resonant_drive) never does, so it has no settled figures.
SETTLING = sorted(n for n, s in SCENES.items() if s.grade == 0.0 and s.profile.kind != "sinusoid")


def bias_allowance(name: str) -> float:
    """BIAS plus what the scene's sensor bias can reach by its end, 2 g σ_rw √T: an estimator cannot tell
    a bias from a tilt (it publishes it as variance, EstimatorConfig), so its settled error includes the
    bias random walk's draw b(T) ~ N(0, σ_rw² T), within 2σ for 95 % of seeds. stop_and_go (σ_rw = 1e-4
    rad/√s, 30 s) reads 0.0097–0.0101 m/s² in its last second with the random-walk IMM and with trend
    modes alike: its draw; every other scene has none."""
    scene = SCENES[name]
    return BIAS + 2.0 * scene.pendulum.gravity * scene.sensor.bias_random_walk * np.sqrt(scene.duration)


@pytest.mark.parametrize("name", SETTLING)
def test_golden_bag_settles_within_tolerance(name: str) -> None:
    """analyze (default estimator) against the recorded truth: settling, bias (``bias_allowance``) and RMS
    as stated above."""
    result = analyze_bag(BAGS / name)
    assert result.settling_time is not None and result.settling_time <= SETTLE_S
    settled = result.settled_stats
    assert settled.n >= 100
    assert abs(settled.bias) <= bias_allowance(name)
    assert settled.rms <= RMS


# resonant_drive is driven at the swing's own frequency and is chaotic (the butterfly lecture: λ ≈ 0.5 /s);
# past its first swing over the top (|θ| > π/2, sample 412 of 3001) the bob is above the pivot, where
# a = g tan θ has no meaning, and the filter's last-bit differences between CPUs (libm's sin/cos with or
# without FMA, `make pytest-emulated`) grew there to 0.9 m/s² by 18 s. Sample-for-sample equality holds
# up to that first pass; after it the re-run must still cover every sample with a finite estimate.
CHAOTIC = {"resonant_drive"}


@pytest.mark.parametrize("name", sorted(SCENES))
def test_golden_bag_replays_offline(name: str) -> None:
    """The offline re-run is the estimate the bag recorded, sample for sample (CHAOTIC: up to the bob's
    first pass over the top, finite after it)."""
    result = analyze_bag(BAGS / name)
    est = read_bag(BAGS / name).decode(bm.TOPIC_ACCEL_ESTIMATE, bm.ACCEL_WITH_COVARIANCE_STAMPED)
    at = np.searchsorted(result.t, est.stamp)
    np.testing.assert_allclose(result.t[at], est.stamp, rtol=0, atol=1e-9)
    recorded, rerun = est["accel.accel.linear.x"], result.accel_est[at]
    compared = rerun.size
    if name in CHAOTIC:
        over = np.abs(result.theta[at]) > np.pi / 2
        compared = int(np.argmax(over)) if over.any() else rerun.size
        assert compared >= 100, compared  # the check still covers the first seconds
        assert np.all(np.isfinite(rerun))
    np.testing.assert_allclose(recorded[:compared], rerun[:compared], rtol=0, atol=REPLAY_ATOL, err_msg=STALE)


def test_hill_bag_reads_g_tan_beta_where_the_truth_is_zero() -> None:
    """The graded scene's bag: truth a = 0, the recorded estimate settles at g tan β (tilt reads as a)."""
    hill = SCENES["hill"]
    result = analyze_bag(BAGS / "hill")
    assert np.all(result.accel_true == 0.0)
    late = result.t >= result.t[-1] - 10.0
    expected = hill.pendulum.gravity * np.tan(hill.grade)
    assert abs(float(np.mean(result.accel_est[late])) - expected) <= 0.01


@pytest.mark.parametrize("name", ["hill", "resonant_drive"])
def test_a_bag_that_never_settles_shows_no_nan(name: str, capsys: pytest.CaptureFixture[str]) -> None:
    """The two golden bags whose error never settles: analyze's text says 'never' and '—' for the settled
    figures (n = 0), and no word of it is nan or inf, as a user would otherwise read "+nan m/s²"."""
    from pendulum_accel.cli.main import main

    assert main(["analyze", str(BAGS / name)]) == 0
    out = capsys.readouterr().out
    words = {w.strip("+-(),:;").lower() for w in out.split()}
    assert not words & {"nan", "inf", "infinity"}
    settled = {line.split(":")[0]: line.split(":", 1)[1].split() for line in out.splitlines()
               if line.startswith("settled ")}  # fmt: skip
    assert settled["settled bias"] == ["—", "—"] and settled["settled RMS"] == ["—", "—"]
    assert settled["settled max"] == ["—", "(n=0)", "—", "(n=0)"]
