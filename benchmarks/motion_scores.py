"""How the real-motion benchmarks score an estimator on simulated runs: the pooled error figures (Score), the
fixed-q kalman filter and its q scan, and the sums the fits judge a published variance by.

Every figure leaves out the first WARMUP s of a run (the filters start from one sample). The share beyond
2σ is judged against a Gaussian's (GAUSS_2SIGMA), in steady state and after a change of a(t)
(recording.changes.after_change), with the independent trials behind it (recording.coverage).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from benchmarks.motion_designs import Design, Run
from pendulum_accel.estimators import make_estimator
from pendulum_accel.estimators.kalman import KalmanEstimator
from pendulum_accel.recording import coverage
from pendulum_accel.recording.changes import after_change
from pendulum_accel.recording.delay import group_delay

WARMUP = 2.0  # s left out at the start of every run: the filters start from one sample
Q_GRID = tuple(float(q) for q in np.logspace(-4, 2, 19))  # (m/s²)²/s, 3 per decade
GAUSS_2SIGMA = coverage.GAUSS_2SIGMA  # P(|z| > 2) of a standard normal: the one definition, in coverage
SHARE_FLOOR = 1e-4  # a share of 0 counts as 0.01 % (the log stays finite; 0 is as wrong as 0.01 %)


@dataclass
class Score:
    """Pooled figures of one estimator on one profile × design (over seeds)."""

    rms: float
    max_err: float
    delay: float
    nees: float
    beyond_steady: float
    beyond_after: float
    n_steady: int
    n_after: int
    eff_steady: float = 0.0  # independent trials behind beyond_steady (recording.coverage)
    eff_after: float = 0.0
    nees_median: float = math.nan  # a Gaussian error's: 0.455; far below, σ bounds the error, not its spread
    beyond3_steady: float = math.nan  # share with |e| > 3σ (NEES > 9) in steady state; a Gaussian's: 0.27 %
    beyond3_after: float = math.nan  # the same within CHANGE_WINDOW s after a change of a(t)

    @staticmethod
    def of(runs: Sequence[Run], outputs: Sequence[tuple[np.ndarray, np.ndarray]], rate_hz: float) -> Score:
        """Pool e = â − a and NEES = e²/var over the runs (t ≥ WARMUP); the shares' effective trials
        (coverage.window_trials of each run's NEES: each window at its own τ)."""
        errs, nees, steady, after, delays, steady3, after3 = [], [], [], [], [], [], []
        eff_steady, eff_after = 0.0, 0.0
        for run, (a, var) in zip(runs, outputs, strict=True):
            keep = run.t >= WARMUP
            e = (a - run.accel)[keep]
            with np.errstate(divide="ignore", invalid="ignore"):
                z = np.where(var[keep] > 0.0, e * e / var[keep], np.inf)
            after_mask = after_change(run.t, run.t, run.accel)[keep]
            errs.append(e)
            nees.append(z)
            steady.append(z[~after_mask] > 4.0)
            after.append(z[after_mask] > 4.0)
            steady3.append(z[~after_mask] > 9.0)
            after3.append(z[after_mask] > 9.0)
            eff_steady += coverage.window_trials(z, ~after_mask)
            eff_after += coverage.window_trials(z, after_mask)
            delays.append(group_delay(a[keep], run.accel[keep], rate_hz))
        e_all = np.concatenate(errs)
        z_all = np.concatenate(nees)
        s_all, c_all = np.concatenate(steady), np.concatenate(after)
        s3_all, c3_all = np.concatenate(steady3), np.concatenate(after3)
        return Score(
            rms=float(np.sqrt(np.mean(e_all**2))),
            max_err=float(np.max(np.abs(e_all))),
            # A profile whose truth is constant has no delay (NaN): the others' median (the same value
            # when every profile varies, as every corpus profile does).
            delay=float(np.nanmedian(delays)) if np.isfinite(delays).any() else math.nan,
            nees=float(np.mean(z_all)),
            nees_median=float(np.median(z_all)),
            beyond_steady=float(np.mean(s_all)) if s_all.size else math.nan,
            beyond_after=float(np.mean(c_all)) if c_all.size else math.nan,
            n_steady=int(s_all.size),
            n_after=int(c_all.size),
            eff_steady=eff_steady,
            eff_after=eff_after,
            beyond3_steady=float(np.mean(s3_all)) if s3_all.size else math.nan,
            beyond3_after=float(np.mean(c3_all)) if c3_all.size else math.nan,
        )


def pooled_rms(runs: Sequence[Run], estimates: Sequence[np.ndarray]) -> float:
    """RMS of â − a over the runs, t ≥ WARMUP."""
    sq = [((a - r.accel)[r.t >= WARMUP]) ** 2 for r, a in zip(runs, estimates, strict=True)]
    return float(np.sqrt(np.mean(np.concatenate(sq))))


def kalman_q(design: Design, q: float, lag: float = 0.0) -> KalmanEstimator:
    """The kalman estimator of ``design`` at a fixed q_a."""
    est = make_estimator("kalman", **design.settings(), q_accel=q, lag=lag)
    assert isinstance(est, KalmanEstimator)
    return est


def q_scan(
    runs: Sequence[Run], design: Design, grid: Sequence[float] = Q_GRID, *, smoothed: bool = False
) -> np.ndarray:
    """Σ (â − a)² over the runs (t ≥ WARMUP) of the fixed-q filter (``smoothed``: its RTS smoother) at every
    q of the grid."""
    out = np.zeros(len(grid))
    for i, q in enumerate(grid):
        est = kalman_q(design, q)
        run_pass = est.smoothed if smoothed else est.batch
        for r in runs:
            out[i] += float(np.sum(((run_pass(r.t, r.theta)[0] - r.accel)[r.t >= WARMUP]) ** 2))
    return out


def calibration_counts(e: np.ndarray, beyond: np.ndarray, after: np.ndarray) -> np.ndarray:
    """[Σ e², beyond ∧ steady, steady, beyond ∧ after, after]: one run's row of the sums the fits pool
    (RMS from the first, ``calibration_miss`` from the rest)."""
    return np.array(
        [
            float(np.sum(e * e)),
            np.count_nonzero(beyond & ~after),
            np.count_nonzero(~after),
            np.count_nonzero(beyond & after),
            np.count_nonzero(after),
        ],
        dtype=float,
    )


def calibration_miss(counts: Sequence[float] | np.ndarray) -> float:
    """Σ |ln(share / GAUSS_2SIGMA)| over the steady and after-change shares of an imm_scan row."""
    miss = 0.0
    for beyond, n in ((counts[1], counts[2]), (counts[3], counts[4])):
        if n > 0:
            miss += abs(math.log(max(beyond / n, SHARE_FLOOR) / GAUSS_2SIGMA))
    return miss


def scored(runs: Sequence[Run]) -> int:
    """Samples scored over the runs (t ≥ WARMUP)."""
    return sum(int(np.count_nonzero(r.t >= WARMUP)) for r in runs)


def share3_cell(share: float) -> str:
    """'p̂ %' of a share beyond 3σ, to 0.01 % (a Gaussian's is 0.27 %); '—' where there are no samples."""
    return f"{100 * share:.2f} %" if math.isfinite(share) else "—"


def share_cell(share: float, n_eff: float) -> str:
    """'p̂ % (n_eff)': a share beyond 2σ with the independent trials behind it (recording.coverage)."""
    return f"{100 * share:.1f} % ({n_eff:.0f})" if math.isfinite(share) else "—"
