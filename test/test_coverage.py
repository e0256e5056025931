"""recording.coverage: the independent trials behind a share beyond 2σ, and its 95 % interval."""

from __future__ import annotations

import math

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
