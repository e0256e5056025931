"""recording.reliability: the bins of a reliability diagram (published σ in deciles against the RMS error)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pendulum_accel.recording.reliability import DECILES, reliability_bins

N = 20_000  # samples: 2,000 a decile


def _calibrated(seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """(e, σ): σ log-uniform over two decades, e = σ z with z standard normal: a σ that tells the truth."""
    rng = np.random.default_rng(seed)
    sigma = 10.0 ** rng.uniform(-3.0, -1.0, N)
    return sigma * rng.standard_normal(N), sigma


def test_a_calibrated_gaussian_lies_on_the_diagonal_and_a_sigma_twice_too_wide_at_half() -> None:
    """Each decile's observed/predicted = √(Σ σ² z² / Σ σ²). Tolerance: Σ σ² z²/Σ σ² is a weighted mean of
    m = 2,000 χ²₁ draws with weights varying by 10^(0.2) ≈ 1.6 within a decile (σ spans a factor 10^0.2), so
    its relative standard error is ≤ √(2 · 1.6/m) = 4.0 %, and the root's half that, 2.0 %: 8 % is four of
    them over ten deciles. Published 2σ instead: the same order, the same bins, predicted doubled exactly,
    so every ratio is the calibrated one halved (to rounding: 1e-12 for sums of 2,000 squares)."""
    e, sigma = _calibrated()
    bins = reliability_bins(e, sigma**2)
    assert bins.predicted.size == DECILES and bins.samples.tolist() == [N // DECILES] * DECILES
    assert np.all(np.diff(bins.predicted) > 0.0)  # deciles in ascending σ
    ratio = bins.observed / bins.predicted
    np.testing.assert_allclose(ratio, 1.0, atol=0.08)
    wide = reliability_bins(e, (2.0 * sigma) ** 2)
    np.testing.assert_allclose(wide.observed / wide.predicted, 0.5 * ratio, rtol=1e-12)
    np.testing.assert_allclose(wide.observed / wide.predicted, 0.5, atol=0.04)


def test_a_decile_holds_the_samples_of_its_own_sigma() -> None:
    """Ten σ levels of 3 samples each, e = ±σ√(3/2) and 0 (mean e² = σ²) in shuffled order: every bin is one
    level, observed = predicted = that σ (exact but for rounding: three squares, 1e-15)."""
    levels = np.repeat(np.arange(1.0, 11.0), 3)
    pattern = np.tile([math.sqrt(1.5), 0.0, -math.sqrt(1.5)], 10)
    order = np.random.default_rng(1).permutation(levels.size)
    bins = reliability_bins((levels * pattern)[order], (levels**2)[order])
    np.testing.assert_allclose(bins.predicted, np.arange(1.0, 11.0), rtol=1e-14)
    np.testing.assert_allclose(bins.observed, np.arange(1.0, 11.0), rtol=1e-14)


def test_unusable_samples_are_left_out_and_few_samples_give_fewer_bins() -> None:
    """NaN errors, NaN or non-positive variances are dropped; 3 usable samples give 3 bins of one; none give
    empty arrays; unequal sizes and bins < 1 are refused."""
    e = np.array([1.0, np.nan, 2.0, 3.0, 4.0, 5.0])
    var = np.array([1.0, 1.0, np.nan, 0.0, 4.0, 9.0])
    bins = reliability_bins(e, var)
    assert bins.samples.tolist() == [1, 1, 1]
    assert bins.predicted.tolist() == [1.0, 2.0, 3.0] and bins.observed.tolist() == [1.0, 4.0, 5.0]
    empty = reliability_bins(np.array([np.nan]), np.array([1.0]))
    assert empty.predicted.size == empty.observed.size == empty.samples.size == 0
    with pytest.raises(ValueError, match="differ in size"):
        reliability_bins(np.zeros(3), np.ones(4))
    with pytest.raises(ValueError, match="bins"):
        reliability_bins(np.zeros(3), np.ones(3), bins=0)
