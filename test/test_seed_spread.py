"""One bag is one draw: the calibration of a bag's scene over other sensor seeds (``analyze --seeds``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.bag.reader import read_bag
from pendulum_accel.cli.main import main
from pendulum_accel.estimators import DEFAULT_ESTIMATOR, estimate_batch
from pendulum_accel.recording.analyze import NeesStats, analyze_bag, nees_split, stored_scene
from pendulum_accel.recording.generate import chain_streams, write_chain_bag
from pendulum_accel.recording.seed_spread import WindowSpread, seed_spread, with_seed
from pendulum_accel.recording.settings import estimator_options
from pendulum_accel.scene_run import run_scene
from test.conftest import strict_json

AT_REST = Path(__file__).resolve().parent.parent / "bags" / "at_rest"
SKIP = 2.0


def test_window_spread_pools_the_seeds_and_takes_percentiles_of_their_shares() -> None:
    """Pooled NEES over every finite sample; p10/p90 of each seed's share beyond 2σ; empty seeds left out."""
    parts = [
        np.array([0.0, 5.0, 0.0, 0.0]),
        np.array([5.0, 5.0, 0.0, 0.0]),
        np.array([]),
        np.array([np.nan, 1.0]),
    ]
    spread = WindowSpread.of(parts)
    assert spread is not None
    assert spread.pooled == NeesStats.of(np.array([0.0, 5.0, 0.0, 0.0, 5.0, 5.0, 0.0, 0.0, 1.0]))
    assert spread.pooled.share_2sigma == pytest.approx(3 / 9)
    low, high = np.percentile([0.25, 0.5, 0.0], [10.0, 90.0])
    assert (spread.share_low, spread.share_high) == (pytest.approx(low), pytest.approx(high))
    assert WindowSpread.of([np.array([]), np.array([np.nan])]) is None


def test_the_scene_stored_in_a_bag_reproduces_it_at_its_own_seed() -> None:
    """Re-simulating the stored scene at the bag's seed gives the bag's own calibration: the other seeds are
    draws of the same experiment, not a different one."""
    bag = read_bag(AT_REST)
    scene = stored_scene(bag)
    assert scene is not None
    analysis = analyze_bag(bag, skip=SKIP)
    own = analysis.calibration
    assert own is not None
    run = run_scene(with_seed(scene, scene.sensor.seed))
    np.testing.assert_array_equal(run.theta_measured, analysis.theta)  # the very same noise draw
    np.testing.assert_allclose(run.t, analysis.t, rtol=0, atol=1e-9)  # stamps: whole nanoseconds in the bag
    options = estimator_options(scene, DEFAULT_ESTIMATOR)
    a, var = estimate_batch(DEFAULT_ESTIMATOR, run.t, run.theta_measured, **options)
    steady, _ = nees_split(run.t, a - run.accel_true, var, run.t, run.accel_true, run.t[0] + SKIP)
    # The nanosecond stamps may tip a threshold of the adaptive filter on a sample or two.
    mine = NeesStats.of(steady)
    assert mine.n == own.steady.n and abs(mine.share_2sigma - own.steady.share_2sigma) <= 2 / mine.n
    assert mine.mean == pytest.approx(own.steady.mean, rel=0.01)


def test_analyze_seeds_prints_the_pooled_figures_and_one_seeds_range(
    capsys: pytest.CaptureFixture[str],
) -> None:
    """`analyze --seeds 3 --json` carries the spread over seeds 0–2 with the bag's estimator settings; the
    text report prints it as one line."""
    assert main(["analyze", str(AT_REST), "--skip", str(SKIP), "--seeds", "3", "--json"]) == 0
    spread = strict_json(capsys.readouterr().out)["seed_spread"]
    scene = stored_scene(read_bag(AT_REST))
    assert scene is not None
    expected = seed_spread(scene, DEFAULT_ESTIMATOR, estimator_options(scene, DEFAULT_ESTIMATOR), 3, SKIP)
    assert expected.steady is not None and expected.after_change is None
    assert spread["seeds"] == 3 and spread["after_change"] is None
    assert spread["steady"]["share_2sigma"] == expected.steady.pooled.share_2sigma
    assert spread["steady"]["share_p10"] <= spread["steady"]["share_p90"]
    assert main(["analyze", str(AT_REST), "--skip", str(SKIP), "--seeds", "2"]) == 0
    assert "calibration over 2 sensor seeds of the scene" in capsys.readouterr().out


def test_analyze_seeds_needs_a_stored_scene(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A bag without its scene cannot be re-simulated: one sentence, exit 2; a negative count likewise."""
    t = np.arange(0.0, 4.0, 0.01)
    theta = np.random.default_rng(3).normal(0.0, 1e-3, t.size)
    a_est, var = estimate_batch(DEFAULT_ESTIMATOR, t, theta, length=1.0, noise_std=1e-3, rate_hz=100.0)
    streams = chain_streams(
        t, theta, np.zeros(t.size), np.zeros(t.size), a_est, var, estimator=DEFAULT_ESTIMATOR, rate_hz=100.0
    )
    bare = tmp_path / "bare"
    write_chain_bag(bare, streams, custom_data={})
    assert main(["analyze", str(bare), "--length", "1.0", "--seeds", "2"]) == 2
    assert "stores none" in capsys.readouterr().err
    assert main(["analyze", str(AT_REST), "--seeds", "-1"]) == 2
    assert "--seeds must be >= 0" in capsys.readouterr().err
