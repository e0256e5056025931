"""What one recording's calibration may look like: its scene re-simulated with other sensor seeds.

A recording holds one draw of its sensor's errors, and an estimator with seconds of memory makes only a
few independent errors in it, so one bag's share of errors beyond 2σ scatters widely around what the
published variance promises (at rest, kalman: 1–12 % over seeds where the pooled share is 5 %). Running
the bag's scene again with sensor seeds 0 … N−1 and the same estimator settings gives both figures: the
pooled calibration (what the variance promises) and the 10th–90th percentile of one seed's share (how
far a single bag may stray from it). ``pendulum-accel analyze BAG --seeds N`` prints them next to the
bag's own. The seeds are independent runs, so the pooled share rests on the sum of their independent
trials: n_eff = Σ_i n_eff,i, the share Σ exceedances / Σ n, its 95 % interval Wilson's at n_eff; the
share beyond 3σ pools the same way.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators import estimate_batch
from pendulum_accel.recording.changes import CHANGE_WINDOW
from pendulum_accel.recording.coverage import NeesStats, nees_windows
from pendulum_accel.scene import Scene
from pendulum_accel.scene_run import SceneRun, run_scene

PERCENTILES = (10.0, 90.0)


def with_seed(scene: Scene, seed: int) -> Scene:
    """``scene`` with its sensor's seed replaced."""
    return dataclasses.replace(scene, sensor=dataclasses.replace(scene.sensor, seed=seed))


@dataclass(frozen=True)
class WindowSpread:
    """One window (steady or after a change) over the seeds: pooled NEES figures, and the 10th and 90th
    percentile of one seed's share beyond 2σ."""

    pooled: NeesStats
    share_low: float
    share_high: float

    @classmethod
    def of(
        cls, parts: Sequence[NDArray[np.float64]], trials: Sequence[float] | None = None
    ) -> WindowSpread | None:
        """NeesStats of all parts' NEES together, with trials Σ trials_i over the parts that have a sample
        (independent runs: their independent trials add; NaN when ``trials`` is not given), and the
        percentiles of each part's share (NEES > 4); None when no part has a sample."""
        counts = [0.0] * len(parts) if trials is None else list(trials)
        kept = [(p[np.isfinite(p)], k) for p, k in zip(parts, counts, strict=True)]
        kept = [(p, k) for p, k in kept if p.size]
        if not kept:
            return None
        shares = [float(np.mean(p > 4.0)) for p, _ in kept]
        low, high = np.percentile(shares, PERCENTILES)
        total = math.nan if trials is None else math.fsum(k for _, k in kept)
        pooled = NeesStats.of(np.concatenate([p for p, _ in kept]), total)
        return cls(pooled, float(low), float(high))

    def text(self) -> str:
        """'pooled NEES mean m, x % beyond 2σ (n=N, about K independent: 95 % lo–hi %), y % beyond 3σ; one
        seed's share a–b %' (the pooled share beyond 3σ: Σ exceedances of NEES > 9 / Σ n)."""
        p = self.pooled
        lo, hi = 100 * self.share_low, 100 * self.share_high
        return f"pooled NEES mean {p.mean:.3g}, {p.share_text()}; one seed's share {lo:.1f}–{hi:.1f} %"


@dataclass(frozen=True)
class SeedSpread:
    """The bag's scene and estimator over ``seeds`` sensor seeds: both windows' spreads (None: no samples)."""

    seeds: int
    steady: WindowSpread | None
    after_change: WindowSpread | None

    def line(self) -> str:
        """'calibration over N seeds: steady …; ≤2 s after a change …'."""

        def part(w: WindowSpread | None) -> str:
            """One window's text, or 'no samples'."""
            return "no samples" if w is None else w.text()

        low, high = PERCENTILES
        return (
            f"calibration over {self.seeds} sensor seeds of the scene (p{low:g}–p{high:g}): "
            f"steady {part(self.steady)}; ≤{CHANGE_WINDOW:g} s after a change {part(self.after_change)}"
        )


def seed_spread(
    scene: Scene, estimator: str, config: Mapping[str, object], seeds: int, skip: float
) -> SeedSpread:
    """spread_over_runs of ``scene`` simulated with sensor seeds 0 … seeds − 1, one seed at a time (a
    generator: only one long run is held in memory at once)."""
    if seeds < 1:
        raise ParameterError(f"seeds must be >= 1, got {seeds!r}")
    runs = (run_scene(with_seed(scene, seed)) for seed in range(seeds))
    return spread_over_runs(runs, estimator, config, skip)


def spread_over_runs(
    runs: Iterable[SceneRun], estimator: str, config: Mapping[str, object], skip: float
) -> SeedSpread:
    """Run ``estimator`` (``config``) in batch on each of ``runs`` (one scene at other sensor seeds), split
    NEES = e²/var at t ≥ t₀ + skip into the two windows, each run's with its independent trials
    (recording.coverage.nees_windows), and pool each window over the runs (WindowSpread.of)."""
    steady: list[NDArray[np.float64]] = []
    after: list[NDArray[np.float64]] = []
    steady_trials: list[float] = []
    after_trials: list[float] = []
    for run in runs:
        a, var = estimate_batch(estimator, run.t, run.theta_measured, **config)
        (s, ks), (c, kc) = nees_windows(
            run.t, a - run.accel_true, var, run.t, run.accel_true, run.t[0] + skip
        )
        steady.append(s)
        after.append(c)
        steady_trials.append(ks)
        after_trials.append(kc)
    return SeedSpread(
        len(steady), WindowSpread.of(steady, steady_trials), WindowSpread.of(after, after_trials)
    )
