"""recording.coverage: the independent trials behind a share beyond 2σ, and its 95 % interval."""

from __future__ import annotations

import math
import re
import statistics

import numpy as np
import pytest
from scipy.stats import binomtest

from pendulum_accel.recording import coverage


def _ar1(phi: float, n: int, seed: int) -> np.ndarray:
    """x_k = φ x_{k−1} + √(1 − φ²) w_k, w white N(0, 1), started stationary: ρ_k = φ^k."""
    w = np.random.default_rng(seed).normal(size=n)
    x = np.empty(n)
    x[0] = w[0]
    scale = math.sqrt(1.0 - phi * phi)
    for i in range(1, n):
        x[i] = phi * x[i - 1] + scale * w[i]
    return x


@pytest.mark.parametrize("phi", [0.0, 0.5, 0.8])
def test_integrated_time_of_an_ar1_is_one_plus_phi_over_one_minus_phi(phi: float) -> None:
    """τ = 1 + 2 Σ φ^k = (1 + φ)/(1 − φ). Tolerance: the estimate's standard deviation is about
    τ √(2(2M + 1)/n) for a window of M lags (Sokal); Geyer's sequence stops near M ≈ 5τ, so at n = 200,000
    and τ ≤ 9 it is ≤ 9 · √(182/200,000) = 0.27, 3 % of τ: 12 % is four of them."""
    tau = coverage.integrated_time(_ar1(phi, 200_000, seed=7))
    expected = (1.0 + phi) / (1.0 - phi)
    assert tau == pytest.approx(expected, rel=0.12)


def test_the_square_of_a_gaussian_series_is_less_correlated() -> None:
    """The module's premise: for a Gaussian AR(1) corr(x_i², x_j²) = ρ², so τ of x² is (1 + φ²)/(1 − φ²),
    below τ of x (the exceedances the shares count are even functions of x too). Tolerance as above
    (τ ≤ 9)."""
    x = _ar1(0.8, 200_000, seed=11)
    tau_sq = coverage.integrated_time(x * x)
    assert tau_sq == pytest.approx((1.0 + 0.64) / (1.0 - 0.64), rel=0.12)
    assert tau_sq < coverage.integrated_time(x)


def test_a_whole_mask_is_the_whole_series() -> None:
    """A mask of every sample is one stretch: the same FFT over the same deviations, so the same τ to the bit;
    a non-finite sample ends a stretch (and is left out of the mean) whether or not a mask is given."""
    x = _ar1(0.8, 5_000, seed=3)
    assert coverage.integrated_time(x, np.ones(x.size, dtype=bool)) == coverage.integrated_time(x)
    y = x.copy()
    y[2_500] = np.nan
    assert coverage.integrated_time(y) == coverage.integrated_time(y, np.ones(y.size, dtype=bool))


def test_each_window_is_judged_by_its_own_errors() -> None:
    """A window of slow errors (AR(1), φ = 0.95: τ = 39) beside one of spikes (white, 100× its spread, as a
    step's first samples are): τ over both is set by the spikes (near 1); τ of the slow window alone is its
    own. Tolerance: 25 stretches of 800 samples (20,000 pairs-worth), τ 39, Sokal's σ ≈ τ √(2(2M+1)/n) with
    M ≈ 5τ: 39 · √(782/20,000) = 7.7, 20 %; 40 % is two of them."""
    rng = np.random.default_rng(5)
    slow = [_ar1(0.95, 800, seed=100 + k) for k in range(25)]
    spikes = [100.0 * rng.normal(size=200) for _ in range(25)]
    z = np.concatenate([part for pair in zip(slow, spikes, strict=True) for part in pair])
    steady = np.concatenate([np.r_[np.ones(800, bool), np.zeros(200, bool)] for _ in range(25)])
    assert coverage.integrated_time(z) < 2.0
    tau = coverage.integrated_time(z, steady)
    assert tau == pytest.approx(39.0, rel=0.4)
    trials = coverage.window_trials(z, steady)
    assert trials == coverage.effective_samples(steady, tau)
    assert trials < 0.05 * np.count_nonzero(steady)  # ≈ 20,000/39 = 513, not 20,000


def _geyer_direct(z: np.ndarray, mask: np.ndarray) -> float:
    """integrated_time's definition written out: ρ_k = Σ over the stretches of Σ_i d_i d_{i+k} (both in one
    stretch) / Σ d², d = z − mean over the mask; τ = −1 + 2 Σ Γ_m while positive, each capped by the last."""
    d = z - z[mask].mean()
    stretches, cur = [], []
    for i in range(z.size):
        if mask[i]:
            cur.append(d[i])
        elif cur:
            stretches.append(np.array(cur))
            cur = []
    if cur:
        stretches.append(np.array(cur))
    longest = max(seg.size for seg in stretches)
    lagged = [
        [float(np.dot(seg[: max(seg.size - k, 0)], seg[k:])) for seg in stretches] for k in range(longest)
    ]
    cov = np.array([sum(row) for row in lagged])
    rho = cov / cov[0]
    total, cap = 0.0, math.inf
    for m in range(longest // 2):
        gamma = rho[2 * m] + rho[2 * m + 1]
        if gamma <= 0.0:
            break
        cap = min(cap, gamma)
        total += cap
    return max(1.0, 2.0 * total - 1.0)


def test_pairs_never_span_a_gap() -> None:
    """Against the definition summed pair by pair: stretches of 7 to 60 samples of a slow AR(1), between
    gaps whose samples are huge (a change's spikes, left out by the mask). Tolerance: the FFT's
    autocovariance differs from the direct sums by rounding, O(ε log n) of Σ d² (≈ 1e-15 here); Γ's capped
    sum adds at most a few hundred such terms, so 1e-9 relative is far above it."""
    rng = np.random.default_rng(9)
    z = _ar1(0.9, 600, seed=4)
    mask = np.ones(z.size, dtype=bool)
    for start, length in ((40, 3), (47, 9), (120, 30), (300, 1), (360, 5), (560, 20)):
        mask[start : start + length] = False
        z[start : start + length] = 1e3 * rng.normal(size=length)
    assert coverage.integrated_time(z, mask) == pytest.approx(_geyer_direct(z, mask), rel=1e-9)
    assert coverage.integrated_time(z, mask) > 5.0  # the slow series' own τ (19), not the spikes'


def test_integrated_time_is_one_for_series_it_cannot_judge() -> None:
    """Too short, constant, or all non-finite: one trial a sample (no correlation to estimate)."""
    assert coverage.integrated_time(np.array([1.0, 2.0, 3.0])) == 1.0
    assert coverage.integrated_time(np.full(100, 4.0)) == 1.0
    assert coverage.integrated_time(np.full(100, np.inf)) == 1.0


def test_effective_samples_counts_each_stretch_as_at_least_one_trial() -> None:
    """Stretches of 3, 10 and 1 samples at τ = 2: max(1, 1.5) + 5 + max(1, 0.5) = 7.5 (exact in binary)."""
    mask = np.array([1, 1, 1, 0, 0, *([1] * 10), 0, 1], dtype=bool)
    assert list(coverage.stretch_lengths(mask)) == [3, 10, 1]
    assert coverage.effective_samples(mask, 2.0) == 7.5
    assert coverage.effective_samples(mask, 1.0) == 14.0  # uncorrelated: every sample a trial
    assert coverage.effective_samples(np.zeros(5, dtype=bool), 2.0) == 0.0


@pytest.mark.parametrize(("k", "n"), [(0, 10), (3, 10), (28, 100), (50, 50), (1, 1000)])
def test_wilson_interval_matches_scipy(k: int, n: int) -> None:
    """At whole n the interval is scipy's (binomtest(...).proportion_ci(method='wilson')): the same
    closed form in a dozen operations, so 1e-12 absolute covers their different order of rounding."""
    lo, hi = coverage.wilson(k / n, n)
    ref = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
    assert lo == pytest.approx(float(ref.low), abs=1e-12)
    assert hi == pytest.approx(float(ref.high), abs=1e-12)


@pytest.mark.parametrize("n", [22.172715418453166, 0.3, 1.0, 7.7, 1e6])
def test_wilson_interval_holds_the_share_at_0_and_1(n: float) -> None:
    """At p̂ = 0 the lower bound is 0 and at p̂ = 1 the upper is 1, exactly: the square root's rounding once
    left 1.2e-17 > 0 at n = 22.17 (a fleet row's steady share, whose interval then missed it)."""
    assert coverage.wilson(0.0, n)[0] == 0.0
    assert coverage.wilson(1.0, n)[1] == 1.0
    for share in (0.0, 0.3, 1.0):
        lo, hi = coverage.wilson(share, n)
        assert lo <= share <= hi


def test_share_interval_cells_are_null_where_a_figure_is_missing() -> None:
    """The cells hold the share, its trials and wilson's interval at them (the same call, so equal); a
    missing share (no samples) nulls every cell, missing trials null the trials and the interval only."""
    low, high = coverage.wilson(0.25, 12.5)
    cells = coverage.share_interval_cells(0.25, 12.5, "share", "trials")
    assert cells == {"share": 0.25, "trials": 12.5, "share_low": low, "share_high": high}
    assert coverage.share_interval_cells(math.nan, math.nan, "s", "t") == dict.fromkeys(
        ("s", "t", "s_low", "s_high")
    )
    assert coverage.share_interval_cells(0.25, math.nan, "s", "t") == {
        "s": 0.25,
        **dict.fromkeys(("t", "s_low", "s_high")),
    }


def test_verdict_needs_the_interval_to_miss_the_band() -> None:
    """28 % at 3 trials could be 12 % (unsure); at 1,000 it cannot (out). 0 % at 1,000 trials is out (the
    upper end is z²/(n + z²) = 0.38 %); at 100 it reaches 3.7 %, so unsure. 5 % is in; no trials: '—'."""
    assert coverage.verdict(0.28, 3.0) == "unsure"
    assert coverage.verdict(0.28, 1000.0) == "out"
    assert coverage.verdict(0.0, 1000.0) == "out"
    assert coverage.verdict(0.0, 100.0) == "unsure"
    assert coverage.verdict(0.05, 2.0) == "in"
    assert coverage.verdict(math.nan, 10.0) == "—"
    assert coverage.verdict(0.3, 0.0) == "—"


def _gaussian_quantiles(n: int) -> np.ndarray:
    """u_i = Φ⁻¹((i + ½)/n), i = 0 … n−1: a standard normal sample with no sampling error. A tail
    {|u| > k} then holds round(n Φ(−k)) points a side, so its share is within 1/n of 2 Φ(−k)."""
    inv = statistics.NormalDist().inv_cdf
    return np.array([inv((i + 0.5) / n) for i in range(n)])


def test_the_share_beyond_3sigma_sits_beside_the_2sigma_share() -> None:
    """NeesStats of a calibrated Gaussian's NEES u²: 4.55 % beyond 2σ, 0.27 % beyond 3σ, median 0.455.
    Tolerance 1/n each: the quantile sample's two tails are each off by at most half a point
    (_gaussian_quantiles). The median averages the u² of the grid points at probabilities 0.75 ∓ ½/n, each
    off the true one by |Δu²| = 2|u| (½/n)/φ(u) = 2 · 0.674 · 0.5/(0.318 n) ≤ 2.2/n; 4/n is that with room.
    """
    n = 2000
    stats = coverage.NeesStats.of(_gaussian_quantiles(n) ** 2, trials=float(n))
    assert stats.share_2sigma == pytest.approx(coverage.GAUSS_2SIGMA, abs=1.0 / n)
    assert stats.share_3sigma == pytest.approx(coverage.GAUSS_3SIGMA, abs=1.0 / n)
    assert stats.median == pytest.approx(coverage.GAUSS_NEES_MEDIAN, abs=4.0 / n)
    # The references themselves, to the digits the reports print (0.27 %, 4.55 %, 0.455).
    assert round(100 * coverage.GAUSS_3SIGMA, 2) == 0.27 and round(100 * coverage.GAUSS_2SIGMA, 2) == 4.55
    assert round(coverage.GAUSS_NEES_MEDIAN, 3) == 0.455
    # The text gives both shares; parsed, not compared as text.
    text = stats.share_text()
    two = float(re.search(r"([\d.]+) % beyond 2σ", text).group(1))  # type: ignore[union-attr]
    three = float(re.search(r"([\d.]+) % beyond 3σ", text).group(1))  # type: ignore[union-attr]
    assert two == pytest.approx(100 * stats.share_2sigma, abs=0.05)  # printed to 0.1 %: half a digit
    assert three == pytest.approx(100 * stats.share_3sigma, abs=0.005)  # printed to 0.01 %


def test_nees_cells_carry_the_3sigma_share_and_null_it_without_samples() -> None:
    """Four NEES of which one exceeds 9 and two exceed 4: share_3sigma 1/4 beside share_2sigma 2/4 (exact
    binary fractions), under nees_fields' keys; no window: every cell null, the 3σ share too."""
    stats = coverage.NeesStats.of(np.array([0.5, 5.0, 10.0, 1.0]), trials=2.0)
    cells = coverage.nees_cells(stats)
    assert cells.share_2sigma == 0.5 and cells.share_3sigma == 0.25
    fields = coverage.nees_fields("nees_steady", stats)
    assert fields["nees_steady_share_3sigma"] == 0.25 and fields["nees_steady_share_2sigma"] == 0.5
    assert set(coverage.nees_fields("k", None).values()) == {None}
    assert coverage.nees_cells(coverage.NeesStats.of(np.array([np.nan]))).share_3sigma is None
