"""The ramp-onset GLR test: its compiled running sums against a direct evaluation, and its inputs."""

from __future__ import annotations

import numpy as np
import pytest

from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators import make_estimator
from pendulum_accel.estimators.kalman import KalmanEstimator
from pendulum_accel.estimators.onset import OnsetTest


def _test(threshold: float) -> OnsetTest:
    """The test of the quiet steady filter, l = 1 m at 200 Hz, onsets 0.1–0.4 s back."""
    filt = make_estimator("kalman", length=1.0, noise_std=1e-3, rate_hz=200.0)
    assert isinstance(filt, KalmanEstimator)
    transition, gain, _ = filt.steady_state(0.0)
    return OnsetTest(transition, gain, 200.0, 0.4, 0.1, threshold)


def test_running_sums_equal_the_direct_glr() -> None:
    """The compiled running sums equal Σ_{k≤i} g_k ν_{n−i+k} written out for every onset age i; the error
    reported is that of the largest λ = (Σ g ν)²/(S Σ g²) over ages ≥ 20; a ramp's own innovations give
    back its rate."""
    test = _test(threshold=1e-300)
    g, h, energy = test._g, test._h, test._energy
    rng = np.random.default_rng(5)
    nus = rng.normal(0.0, 1e-3, 150)
    s = 1e-6
    found = None
    for nu in nus:
        found = test.push(float(nu), s)
    assert found is not None  # a vanishing threshold: the likeliest onset is always reported
    # The sums for each onset age i are Σ_{k=0}^{i} g_k ν_{n−i+k}: checked at the last sample.
    n = nus.size - 1
    direct = np.array([sum(g[k] * nus[n - i + k] for k in range(i + 1)) for i in range(g.size)])
    # the recursion adds the same products in another order: ≤ n ε Σ|g ν| (n ≤ 100: 2e-14 relative to
    # the sum of |terms|); rtol 1e-12 of the sum itself leaves cancellation a factor 50
    np.testing.assert_allclose(test._sums, direct, rtol=1e-12, atol=1e-18)
    stat = direct**2 / (s * energy)
    age = 20 + int(np.argmax(stat[20:]))
    slope = direct[age] / energy[age]
    assert found == pytest.approx((slope * h[age]) ** 2 + s / energy[age] * h[age] ** 2, rel=1e-12)
    # A noiseless ramp of rate 2 begun 50 samples ago: its sums give ĵ = 2.
    test.clear()
    for k in range(51):
        test.push(2.0 * float(g[k]), s)
    # Σ 2 g_k² / Σ g_k² over 51 terms, both sums in one order: ≤ 51 ε each (2.3e-14 relative)
    assert test._sums[50] / energy[50] == pytest.approx(2.0, rel=1e-12)


def test_onset_test_refuses_impossible_settings() -> None:
    """A window shorter than its minimum age, a non-positive rate or threshold: one sentence."""
    eye, gain = np.eye(3), np.array([0.5, 0.1, 0.01])
    for args in ((100.0, 0.1, 0.2, 14.0), (0.0, 0.4, 0.1, 14.0), (100.0, 0.4, 0.1, 0.0)):
        with pytest.raises(ParameterError, match="onset test needs"):
            OnsetTest(eye, gain, *args)
