"""The presets' fits on the real-motion training split (``python -m benchmarks.real_motion --fit``).

``--fit`` fits on the training split only, pooled over the seeds, on grids, and prints the values to put in
``estimators.kalman.PRESETS``: auto's chain (up and down times, AUTO_CHAINS), its trend partners
(TREND_SPANS × TREND_FACTORS, ``kalman.AUTO_TRENDS``) and its fixed-lag variance map (LAG_POWERS ×
LAG_WEIGHTS, ``kalman.LAG_VARIANCE_POWER`` and ``LAG_REVISION_WEIGHT``) on every training profile;
each prior preset's (car, robot, lab_steps) single q_a with the least RMS (geometric mean over both
designs) and IMM (modes, switch time) on its own training profiles (PRESET_OF). Each IMM is the candidate
whose own variance is best calibrated on training (share beyond 2σ, steady and after changes, closest to a
Gaussian's 4.6 %) among those within 5 % of the least RMS.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence

import numpy as np

from benchmarks.motion_designs import PROFILES, Design, Run, designs, runs_for
from benchmarks.motion_scores import (
    Q_GRID,
    SHARE_FLOOR,
    WARMUP,
    calibration_counts,
    calibration_miss,
    kalman_q,
    q_scan,
    scored,
)
from pendulum_accel.estimators import ekf_kernels as kern
from pendulum_accel.estimators.kalman import PRESETS, imm_smoother, lag_samples, lag_variance
from pendulum_accel.recording import coverage
from pendulum_accel.recording.changes import after_change


def imm_scan(
    runs: Sequence[Run], design: Design, candidates: Sequence[tuple[tuple[float, ...], float]]
) -> np.ndarray:
    """Per (modes, switch_time) candidate, over the runs (t ≥ WARMUP) of the IMM with its own variance:
    [Σ (â − a)², beyond 2σ steady, steady samples, beyond 2σ after a change, samples after a change]."""
    params = kalman_q(design, 1.0)._params
    out = np.zeros((len(candidates), 5))
    for i, (modes, switch) in enumerate(candidates):
        for r in runs:
            rates = kern.chain_rates(len(modes), switch)
            lags = np.zeros(1, np.int64)
            a, var, _ = kern.imm_pass(r.t, r.theta, params, np.array(modes), rates, lags)
            keep = r.t >= WARMUP
            e = (a[:, 0] - r.accel)[keep]
            beyond = e * e > 4.0 * var[keep, 0]
            out[i] += calibration_counts(e, beyond, after_change(r.t, r.t, r.accel)[keep])
    return out


IMM_CANDIDATES = tuple(
    ((q_lo, q_hi), switch)
    for q_lo in (1e-4, 1e-3)
    for q_hi in (0.03, 0.1, 0.3, 1.0)
    for switch in (2.0, 5.0, 10.0, 20.0, 50.0, 200.0)
)
# The IMM's fit on training: among the candidates whose RMS is within RMS_SLACK of the best candidate's (half
# of the 1.1× allowance over the hindsight EKF), the one whose own variance puts the share of errors
# beyond 2σ closest to a Gaussian's (Σ over designs × {steady, after a change} of |ln(share / GAUSS_2SIGMA)|).
RMS_SLACK = 1.05


def _training_runs(seeds: int, quick: bool) -> Iterator[tuple[np.ndarray, list[Run]]]:
    """(the fitted design's EKF params, the runs) of every training profile through each fitted design."""
    for design in designs():
        params = kalman_q(design, 1.0)._params
        for profile in PROFILES:
            if profile.role == "train":
                yield params, runs_for(profile, design, seeds, quick)


def fit_presets(
    seeds: int, quick: bool
) -> dict[str, tuple[float, list[float], tuple[tuple[float, ...], float], list[tuple[float, float]]]]:
    """Per preset, on its training profiles only, pooled over the seeds: the single q_a (argmin over Q_GRID
    of the geometric mean over the designs of the filter's RMS) and the IMM (of IMM_CANDIDATES within
    RMS_SLACK of the least such RMS, the one with the least calibration miss, Σ over the designs); returns
    (q_a, mean RMS per q, (modes, switch_time), (mean RMS, calibration miss) per candidate)."""
    out: dict[str, tuple[float, list[float], tuple[tuple[float, ...], float], list[tuple[float, float]]]] = {}
    for preset in (p for p in PRESETS if p != "auto"):  # auto: fit_auto, fit_trends
        logs = np.zeros(len(Q_GRID))
        logs_imm = np.zeros(len(IMM_CANDIDATES))
        miss = np.zeros(len(IMM_CANDIDATES))
        used = 0
        for design in designs():
            sq, counts, n = np.zeros(len(Q_GRID)), np.zeros((len(IMM_CANDIDATES), 5)), 0
            for profile in PROFILES:
                if profile.role == "train" and profile.preset == preset:
                    runs = runs_for(profile, design, seeds, quick)
                    sq += q_scan(runs, design)
                    counts += imm_scan(runs, design, IMM_CANDIDATES)
                    n += scored(runs)
            if n:
                logs += 0.5 * np.log(sq / n)
                logs_imm += 0.5 * np.log(counts[:, 0] / n)
                miss += [calibration_miss(row) for row in counts]
                used += 1
        if used:
            scores = [math.exp(x) for x in logs / used]
            rms_imm = np.exp(logs_imm / used)
            eligible = rms_imm <= RMS_SLACK * rms_imm.min()
            best_imm = IMM_CANDIDATES[int(np.argmin(np.where(eligible, miss, np.inf)))]
            table = [(float(r), float(m)) for r, m in zip(rms_imm, miss, strict=True)]
            out[preset] = (Q_GRID[int(np.argmin(scores))], scores, best_imm, table)
    return out


AUTO_CHAINS = tuple((up, down) for up in (2.0, 3.0, 6.0) for down in (0.5, 1.0, 2.0))
"""(up, down) times (s) of auto's birth-death chain tried by ``fit_auto`` (ekf_kernels.chain_rates)."""


def fit_auto(seeds: int, quick: bool) -> tuple[tuple[float, float], list[tuple[float, float]]]:
    """auto's chain on every training profile (all kinds), both designs, pooled over the seeds: of
    AUTO_CHAINS within RMS_SLACK of the least RMS (geometric mean over profiles × designs), the one with the
    least calibration miss (Σ over profiles × designs); returns ((up, down), (mean RMS, miss) per chain).
    The chain is fitted on the random-walk modes alone, before their trend partners (``fit_trends``)."""
    modes = np.array(PRESETS["auto"].modes)
    logs = np.zeros(len(AUTO_CHAINS))
    miss = np.zeros(len(AUTO_CHAINS))
    used = 0
    for params, runs in _training_runs(seeds, quick):
        used += 1
        for i, (up, down) in enumerate(AUTO_CHAINS):
            counts = _imm_counts(runs, params, modes, None, kern.chain_rates(modes.size, up, down))
            logs[i] += 0.5 * math.log(counts[0] / scored(runs))
            miss[i] += calibration_miss(counts)
    rms = np.exp(logs / max(used, 1))
    eligible = rms <= RMS_SLACK * rms.min()
    best = AUTO_CHAINS[int(np.argmin(np.where(eligible, miss, np.inf)))]
    return best, [(float(r), float(m)) for r, m in zip(rms, miss, strict=True)]


MAX_TREND_PARTNERS = 4
"""At most this many of auto's modes get a trend partner: the cost bound. Each partner is a four-state mode;
with four, the IMM's pass costs about 4.0 µs a sample against 2.5 µs for the random walks alone (run_imm at
200 Hz): the streaming update stays ≤ 2× the two-mode presets' (1.6×, docs/benchmarks/estimators.md), and
analyze keeps 6.0× a plain rosbags loop where the random walks alone gave 7.8× (docs/benchmarks/bags.md)."""
TREND_SPANS = tuple(
    (lo, hi)
    for lo in range(len(PRESETS["auto"].modes))
    for hi in range(lo + 1, min(lo + MAX_TREND_PARTNERS, len(PRESETS["auto"].modes)) + 1)
)
"""(first, past-the-last) index of the auto modes that get a trend partner, tried by ``fit_trends``."""
TREND_FACTORS = (3.0, 10.0, 30.0, 100.0)
"""q_j of a trend partner over its mode's q_a ((m/s³)²/s per (m/s²)²/s), tried by ``fit_trends``."""


def trend_candidate(span: tuple[int, int], factor: float) -> tuple[float, ...]:
    """kalman.MotionPreset.trends for a span of auto's modes: q_j = factor · q_a inside it, 0 outside."""
    return tuple(factor * q if span[0] <= k < span[1] else 0.0 for k, q in enumerate(PRESETS["auto"].modes))


def fit_trends(seeds: int, quick: bool) -> tuple[tuple[float, ...], list[tuple[float, float, float]]]:
    """auto's trend partners on every training profile (all kinds), both designs, pooled over the seeds: of
    TREND_SPANS × TREND_FACTORS, the candidates whose every training cell (profile × design) has an RMS
    within RMS_SLACK of auto's random walks alone, then of those within RMS_SLACK of the least RMS
    (geometric mean over profiles × designs), the one with the least calibration miss (Σ over profiles ×
    designs); returns (trends, (mean RMS over the walks', worst cell's, miss) per candidate)."""
    auto = PRESETS["auto"]
    walks, _, rates = auto.imm(walks_only=True)
    cands = [trend_candidate(span, f) for span in TREND_SPANS for f in TREND_FACTORS]
    logs = np.zeros(len(cands))
    worst = np.zeros(len(cands))
    miss = np.zeros(len(cands))
    used = 0
    for params, runs in _training_runs(seeds, quick):
        used += 1
        base = _imm_counts(runs, params, walks, None, rates)
        for i, trends in enumerate(cands):
            qs, jerks, both = kern.with_trends(walks, rates, np.array(trends), auto.cross_time)
            counts = _imm_counts(runs, params, qs, jerks, both)
            ratio = math.sqrt(counts[0] / base[0])
            logs[i] += math.log(ratio)
            worst[i] = max(worst[i], ratio)
            miss[i] += calibration_miss(counts)
    rms = np.exp(logs / max(used, 1))
    safe = worst <= RMS_SLACK
    eligible = safe & (rms <= RMS_SLACK * rms[safe].min())
    best = cands[int(np.argmin(np.where(eligible, miss, np.inf)))]
    return best, [(float(r), float(w), float(m)) for r, w, m in zip(rms, worst, miss, strict=True)]


def _imm_counts(
    runs: Sequence[Run], params: np.ndarray, qs: np.ndarray, jerks: np.ndarray | None, rates: np.ndarray
) -> np.ndarray:
    """calibration_counts of the IMM's own variance over the runs (t ≥ WARMUP), pooled."""
    counts = np.zeros(5)
    for r in runs:
        a, var, _ = kern.imm_pass(r.t, r.theta, params, qs, rates, np.zeros(1, np.int64), False, jerks)
        keep = r.t >= WARMUP
        e = (a[:, 0] - r.accel)[keep]
        counts += calibration_counts(e, e * e > 4.0 * var[keep, 0], after_change(r.t, r.t, r.accel)[keep])
    return counts


LAG_POWERS = tuple(round(1.0 + 0.1 * i, 1) for i in range(31))
"""γ = 1.0 … 4.0 of the variance maps P_f (P_lag/P_f)^γ + κ d² tried by ``fit_lag_map`` and
``fit_smoother_map``."""
FIT_LAGS = (0.25, 1.0)  # s: the live fixed lag the issue names, and a lag past which the curve flattens


LAG_WEIGHTS = (0.0, 0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0)
"""κ of the variance maps min(P_f (P_lag/P_f)^γ + κ d², P_lag) tried by ``fit_lag_map`` and
``fit_smoother_map`` (0: the power alone)."""

GAUSS_MEDIAN_NEES = coverage.GAUSS_NEES_MEDIAN  # the median of χ²₁: the one definition, in coverage
NEES_DECADES = np.linspace(-12.0, 12.0, 2401)  # log10 bin edges of the fits' NEES histograms (2.3 % a bin)


def map_miss(counts: np.ndarray, nees_mean: float, nees_median: float) -> float:
    """calibration_miss + |ln mean NEES| + |ln(median NEES / 0.455)|: the shares beyond 2σ (steady, after
    changes) against a Gaussian's, the mean NEES against 1, and the median against a Gaussian's: the tail,
    the mean and the body of the errors a published variance describes."""
    return (
        calibration_miss(counts)
        + abs(math.log(max(nees_mean, SHARE_FLOOR)))
        + abs(math.log(max(nees_median, SHARE_FLOOR) / GAUSS_MEDIAN_NEES))
    )


MapSums = tuple[np.ndarray, np.ndarray, np.ndarray]  # map_counts' three arrays, pooled over runs


def map_counts(
    e: np.ndarray,
    var_filter: np.ndarray,
    var_lag: np.ndarray,
    a_lag: np.ndarray,
    a_filter: np.ndarray,
    after: np.ndarray,
) -> MapSums:
    """(calibration_counts, Σ NEES, histogram of log10 NEES over NEES_DECADES) of e against
    kalman.lag_variance(var_lag, var_filter, a_lag, a_filter, γ, κ) for every (γ, κ) of LAG_POWERS ×
    LAG_WEIGHTS: the sums fit_lag_map and fit_smoother_map pool (a histogram pools, a median does not). The
    fit scores the very function the estimators publish, not a copy of its formula."""
    shape = (len(LAG_POWERS), len(LAG_WEIGHTS))
    counts, nees = np.zeros((*shape, 5)), np.zeros(shape)
    hist = np.zeros((*shape, NEES_DECADES.size - 1))
    for g, power in enumerate(LAG_POWERS):
        for k, weight in enumerate(LAG_WEIGHTS):
            z = e * e / lag_variance(var_lag, var_filter, a_lag, a_filter, power, weight)
            counts[g, k] = calibration_counts(e, z > 4.0, after)
            nees[g, k] = float(np.sum(z))
            bins = np.searchsorted(NEES_DECADES, np.log10(np.maximum(z, 1e-300)), side="right") - 1
            hist[g, k] = np.bincount(np.clip(bins, 0, NEES_DECADES.size - 2), minlength=NEES_DECADES.size - 1)
    return counts, nees, hist


def _median_nees(hist: np.ndarray) -> float:
    """The median of a NEES histogram over NEES_DECADES: the centre (in log10) of the bin holding it."""
    k = int(np.searchsorted(np.cumsum(hist), 0.5 * float(np.sum(hist))))
    return float(10.0 ** (0.5 * (NEES_DECADES[k] + NEES_DECADES[k + 1])))


def _map_fit(cells: Iterator[MapSums]) -> tuple[tuple[float, float], np.ndarray]:
    """((γ, κ), miss per pair): Σ over the cells (each its pooled map_counts) of map_miss, the least."""
    miss = np.zeros((len(LAG_POWERS), len(LAG_WEIGHTS)))
    for counts, nees, hist in cells:
        for g in range(len(LAG_POWERS)):
            for k in range(len(LAG_WEIGHTS)):
                cell = counts[g, k]
                miss[g, k] += map_miss(cell, nees[g, k] / (cell[2] + cell[4]), _median_nees(hist[g, k]))
    best_g, best_k = (int(i) for i in np.unravel_index(int(np.argmin(miss)), miss.shape))
    return (LAG_POWERS[best_g], LAG_WEIGHTS[best_k]), miss


def _pooled(parts: Iterator[MapSums]) -> MapSums:
    """The element-wise sums of map_counts over runs (the seeds of one cell)."""
    counts, nees, hist = next(parts)
    for c, z, h in parts:
        counts, nees, hist = counts + c, nees + z, hist + h
    return counts, nees, hist


def fit_lag_map(seeds: int, quick: bool) -> tuple[tuple[float, float], np.ndarray]:
    """(γ, κ) of kalman.lag_variance on every training profile (all kinds), both designs, lags FIT_LAGS,
    pooled over the seeds: of LAG_POWERS × LAG_WEIGHTS the pair with the least map_miss (Σ over profiles ×
    designs × lags); returns ((γ, κ), the miss per pair as a LAG_POWERS × LAG_WEIGHTS array). The IMM is
    auto's whole: random-walk modes and trend partners."""
    modes, jerks, rates = PRESETS["auto"].imm()

    def per_lag(runs: list[Run], params: np.ndarray, lags: np.ndarray) -> Iterator[list[MapSums]]:
        for r in runs:
            a, var, _ = kern.imm_pass(r.t, r.theta, params, modes, rates, lags, False, jerks)
            keep = r.t >= WARMUP
            after = after_change(r.t, r.t, r.accel)[keep]
            yield [
                map_counts(
                    (a[:, m] - r.accel)[keep], var[keep, 0], var[keep, m], a[keep, m], a[keep, 0], after
                )
                for m in range(1, lags.size)
            ]

    def cells() -> Iterator[MapSums]:
        for design in designs():
            params = kalman_q(design, 1.0)._params
            lags = np.array([0, *(lag_samples(lag, design.rate_hz) for lag in FIT_LAGS)], dtype=np.int64)
            for profile in PROFILES:
                if profile.role == "train":
                    by_run = list(per_lag(runs_for(profile, design, seeds, quick), params, lags))
                    for m in range(len(FIT_LAGS)):
                        yield _pooled(run[m] for run in by_run)

    return _map_fit(cells())


def fit_smoother_map(seeds: int, quick: bool) -> tuple[tuple[float, float], np.ndarray]:
    """(γ, κ) of the smoother's variance min(P_f (Pˢ/P_f)^γ + κ (âˢ − â_f)², Pˢ) (kalman.imm_smoother, P_f
    and â_f its single-model pass's filtered ones) on every training profile (all kinds), both designs, pooled
    over the seeds: of LAG_POWERS × LAG_WEIGHTS the pair with the least map_miss (Σ over profiles × designs);
    returns ((γ, κ), the miss per pair). The smoother's IMM is auto's random-walk modes alone."""
    modes, _, rates = PRESETS["auto"].imm(walks_only=True)

    def per_run(runs: list[Run], params: np.ndarray) -> Iterator[MapSums]:
        for r in runs:
            a, var_s, var_f, a_f = imm_smoother(r.t, r.theta, params, modes, rates)
            keep = r.t >= WARMUP
            after = after_change(r.t, r.t, r.accel)[keep]
            yield map_counts((a - r.accel)[keep], var_f[keep], var_s[keep], a[keep], a_f[keep], after)

    def cells() -> Iterator[MapSums]:
        for design in designs():
            params = kalman_q(design, 1.0)._params
            for profile in PROFILES:
                if profile.role == "train":
                    yield _pooled(per_run(runs_for(profile, design, seeds, quick), params))

    return _map_fit(cells())


def print_fits(seeds: int, quick: bool) -> None:
    """Run every fit (fit_presets, fit_auto, fit_trends, fit_lag_map, fit_smoother_map) and print each one's
    value and its candidates' scores: ``python -m benchmarks.real_motion --fit``."""
    for preset, (q, scores, imm, scores_imm) in fit_presets(seeds, quick).items():
        curve = ", ".join(f"{g:.2g}:{s:.3g}" for g, s in zip(Q_GRID, scores, strict=True))
        print(f"{preset}: single q_a = {q:.3g} (m/s²)²/s   [geometric-mean RMS per q: {curve}]")
        cands = ", ".join(
            f"{c}: RMS {r:.3g} miss {m:.2f}" for c, (r, m) in zip(IMM_CANDIDATES, scores_imm, strict=True)
        )
        print(f"{preset}: IMM modes {imm[0]}, switch_time {imm[1]} s   [per candidate: {cands}]")
    chain, per_chain = fit_auto(seeds, quick)
    cands = ", ".join(
        f"{c}: RMS {r:.3g} miss {m:.2f}" for c, (r, m) in zip(AUTO_CHAINS, per_chain, strict=True)
    )
    print(f"auto: chain up {chain[0]:g} s, down {chain[1]:g} s   [per (up, down): {cands}]")
    trends, per_trend = fit_trends(seeds, quick)
    cands = ", ".join(
        f"{span} ×{f:g}: RMS {r:.3f} worst {w:.2f} miss {m:.1f}"
        for (span, f), (r, w, m) in zip(
            ((s, f) for s in TREND_SPANS for f in TREND_FACTORS), per_trend, strict=True
        )
    )
    print(f"auto: trend partners q_j {trends}   [per (span, factor), over the walks alone: {cands}]")
    for name, fit in (("fixed-lag", fit_lag_map), ("smoother", fit_smoother_map)):
        (power, weight), per_pair = fit(seeds, quick)
        best = np.argsort(per_pair, axis=None)[:10]
        cands = ", ".join(
            f"({LAG_POWERS[g]:g}, {LAG_WEIGHTS[k]:g}): {per_pair[g, k]:.1f}"
            for g, k in zip(*np.unravel_index(best, per_pair.shape), strict=True)
        )
        print(f"auto: {name} variance map γ {power:g} κ {weight:g}   [least misses, (γ, κ): {cands}]")
