"""One bag is one draw: the calibration of a bag's scene over other sensor seeds (``analyze --seeds``)."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.bag.reader import read_bag
from pendulum_accel.cli.main import main
from pendulum_accel.estimators import DEFAULT_ESTIMATOR, estimate_batch
from pendulum_accel.recording import coverage
from pendulum_accel.recording.analyze import analyze_bag
from pendulum_accel.recording.changes import after_change
from pendulum_accel.recording.coverage import NeesStats, nees_windows
from pendulum_accel.recording.generate import chain_streams, write_chain_bag
from pendulum_accel.recording.seed_spread import WindowSpread, seed_spread, with_seed
from pendulum_accel.recording.settings import estimator_options
from pendulum_accel.recording.stored_scene import stored_scene
from pendulum_accel.scene_run import run_scene
from test.conftest import strict_json

AT_REST = Path(__file__).resolve().parent.parent / "bags" / "at_rest"
BRAKING = AT_REST.with_name("braking")  # a step of a: both windows hold samples, some beyond 2σ
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
    assert spread.pooled.interval() is None  # no trials given: no interval is claimed


def test_window_spread_adds_the_seeds_trials_and_takes_wilson_at_the_sum() -> None:
    """Independent runs: the pooled share rests on Σ trials_i of the parts with samples (an empty part's
    count is left out with it), and its interval is coverage.wilson at that sum. Exact: the trials are
    small binary fractions, so their sum rounds nowhere, and wilson gets the very same arguments."""
    parts = [np.array([0.0, 5.0, 0.0, 0.0]), np.array([5.0, 5.0, 0.0, 0.0]), np.array([]), np.array([1.0])]
    spread = WindowSpread.of(parts, [1.5, 2.25, 7.0, 1.0])
    assert spread is not None
    assert spread.pooled.trials == 1.5 + 2.25 + 1.0
    assert spread.pooled.share_2sigma == 3 / 9
    assert spread.pooled.interval() == coverage.wilson(3 / 9, 4.75)


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
    (steady, _), _ = nees_windows(run.t, a - run.accel_true, var, run.t, run.accel_true, run.t[0] + SKIP)
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
    assert spread["seeds"] == 3
    assert spread["nees_steady_share_2sigma"] == expected.steady.pooled.share_2sigma
    assert spread["nees_steady_share_p10"] <= spread["nees_steady_share_p90"]
    # At rest nothing changes: the after-change window is null under every key a single bag has.
    single = strict_json(_json_of(capsys, AT_REST))
    after_keys = [k for k in spread if k.startswith("nees_after_change_")]
    assert {k for k in single if k.startswith("nees_after_change_")} < set(after_keys)
    assert all(spread[k] is None for k in after_keys)
    assert main(["analyze", str(AT_REST), "--skip", str(SKIP), "--seeds", "2"]) == 0
    assert "calibration over 2 sensor seeds of the scene" in capsys.readouterr().out


def _json_of(capsys: pytest.CaptureFixture[str], bag: Path) -> str:
    """``analyze BAG --skip SKIP --json``'s output."""
    assert main(["analyze", str(bag), "--skip", str(SKIP), "--json"]) == 0
    return capsys.readouterr().out


def _parts(bag: Path, seeds: int) -> dict[str, list[tuple[int, int, float]]]:
    """Per window, per seed: (samples, samples beyond 2σ, independent trials) of the bag's scene at that
    seed, counted here from coverage's primitives: NEES = e²/var at t ≥ t₀ + SKIP, τ over the window's
    finite stretches, n_eff = Σ max(1, L/τ) over them."""
    scene = stored_scene(read_bag(bag))
    assert scene is not None
    out: dict[str, list[tuple[int, int, float]]] = {"steady": [], "after_change": []}
    for seed in range(seeds):
        run = run_scene(with_seed(scene, seed))
        a, var = estimate_batch(
            DEFAULT_ESTIMATOR, run.t, run.theta_measured, **estimator_options(scene, DEFAULT_ESTIMATOR)
        )
        keep = run.t >= run.t[0] + SKIP
        with np.errstate(divide="ignore", invalid="ignore"):
            nees = np.where(var > 0.0, (a - run.accel_true) ** 2 / var, np.nan)[keep]
        after = after_change(run.t, run.t, run.accel_true)[keep]
        for window, mask in (("steady", ~after), ("after_change", after)):
            mask = mask & np.isfinite(nees)
            tau = coverage.integrated_time(nees, mask)
            counted = (int(mask.sum()), int((nees[mask] > 4.0).sum()), coverage.effective_samples(mask, tau))
            out[window].append(counted)
    return out


POOLED = re.compile(
    r"(steady|after a change) pooled NEES mean \S+, ([\d.]+) % beyond 2σ "
    r"\(n=(\d+), about (\d+) independent: 95 % ([\d.]+)–([\d.]+) %\)"
)


def test_analyze_seeds_pools_the_trials_of_independent_runs(capsys: pytest.CaptureFixture[str]) -> None:
    """braking over 3 seeds: the pooled trials are the sum of each seed's (counted here from the parts),
    the pooled share Σ exceedances / Σ n, and its interval coverage.wilson at the summed trials, under the
    keys a single bag's --json uses; the text line prints the same figures."""
    seeds = 3
    assert main(["analyze", str(BRAKING), "--skip", str(SKIP), "--seeds", str(seeds), "--json"]) == 0
    figures = strict_json(capsys.readouterr().out)
    assert figures["estimator"] == DEFAULT_ESTIMATOR
    spread = figures["seed_spread"]
    single = {k for k in figures if k.startswith("nees_")}
    assert single <= set(spread), "the pooled figures carry every key of a single bag's"
    parts = _parts(BRAKING, seeds)
    for window, counts in parts.items():
        key = f"nees_{window}"
        n, beyond = sum(c[0] for c in counts), sum(c[1] for c in counts)
        assert n > 0 and (beyond > 0 or window == "steady")  # braking errs beyond 2σ after its step
        # Three float additions, each rounding by at most 2⁻⁵³ of the sum: 1e-12 relative is far above.
        assert spread[f"{key}_trials"] == pytest.approx(math.fsum(c[2] for c in counts), rel=1e-12)
        assert spread[f"{key}_trials"] < n  # correlated errors: fewer independent trials than samples
        assert spread[f"{key}_share_2sigma"] == pytest.approx(beyond / n, rel=1e-12)  # a ratio of counts
        # Wilson's ends are sums of terms in p̂, z²/n and z √(p̂(1 − p̂)/n) (z² < 4, p̂ ≤ 1): relative changes
        # δ ≤ 1e-12 of p̂ and n move them by at most about 4δ, far below 1e-10.
        low, high = coverage.wilson(beyond / n, spread[f"{key}_trials"])
        assert spread[f"{key}_share_2sigma_low"] == pytest.approx(low, rel=0, abs=1e-10)
        assert spread[f"{key}_share_2sigma_high"] == pytest.approx(high, rel=0, abs=1e-10)
    assert main(["analyze", str(BRAKING), "--skip", str(SKIP), "--seeds", str(seeds)]) == 0
    printed = {m[1]: m.groups()[1:] for m in POOLED.finditer(capsys.readouterr().out)}
    assert set(printed) == {"steady", "after a change"}
    for label, window in (("steady", "steady"), ("after a change", "after_change")):
        share, count, trials, low, high = (float(x) for x in printed[label])
        key = f"nees_{window}"
        assert count == sum(c[0] for c in parts[window])
        # Printed to 0.1 % and to the whole trial: each within half its last digit (and float rounding).
        assert abs(trials - spread[f"{key}_trials"]) <= 0.5 + 1e-9
        for text, value in ((share, "share_2sigma"), (low, "share_2sigma_low"), (high, "share_2sigma_high")):
            assert abs(text - 100 * spread[f"{key}_{value}"]) <= 0.05 + 1e-9


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
