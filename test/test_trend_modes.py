"""kalman's trend modes: auto's integrated walks of a beside its random-walk modes (kalman.AUTO_TRENDS).

The kernel (ekf_kernels.predict_trend, trend_noise, the four-state IMM) against the exact discretisation
and the textbook augmented-state IMM; the estimator's streaming against its batch; a random-walk mode
never carrying a trend; and what the model is for: a ramp the random walk lags."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import expm

from pendulum_accel.estimators import ekf_kernels as kern
from pendulum_accel.estimators import estimate_batch, make_estimator
from pendulum_accel.estimators.kalman import (
    AUTO_MODES,
    AUTO_TRENDS,
    PRESETS,
    SMOOTHER_REVISION_WEIGHT,
    SMOOTHER_VARIANCE_POWER,
    KalmanEstimator,
    imm_smoother,
    lag_variance,
)
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Ramp
from pendulum_accel.physics.simulate import simulate
from test.test_smoother import CFG, _imm_fixed_lag_reference, drive

TREND = CFG  # the default, auto, has trend modes


def test_trend_noise_is_van_loans_integral_for_the_chain_it_models() -> None:
    """Q of trend_noise against Van Loan's block exponential of the chain it is derived for (θ' = ω,
    ω' = j₁₂ a, a' = j + w_a, j' = w_j; no restoring term, no damping, q_ω = 0), where its formulas are
    exact. Error argument: J is nilpotent, so every block of expm is a polynomial in h; scipy's expm is
    accurate to a few ulps of the block's norm (≤ about 1 here: h = 0.5 s, j₁₂ = 2, q ≤ 3) and the entries
    compared are ≥ 1e-4, so rtol 1e-9 leaves four orders of magnitude above the rounding."""
    j12, h, q_a, q_j = 2.0, 0.5, 0.7, 3.0
    jac = np.zeros((4, 4))
    jac[0, 1], jac[1, 2], jac[2, 3] = 1.0, j12, 1.0
    qc = np.diag([0.0, 0.0, q_a, q_j])
    block = np.zeros((8, 8))
    block[:4, :4], block[:4, 4:], block[4:, 4:] = -jac, qc, jac.T
    e = expm(block * h)
    f = e[4:, 4:].T
    expected = f @ e[:4, 4:]
    q = np.empty((4, 4))
    kern.trend_noise(q, j12, h, q_a, q_j, 0.0)
    np.testing.assert_allclose(q, expected, rtol=1e-9, atol=0.0)
    np.testing.assert_array_equal(q, q.T)


def test_the_four_state_fixed_lag_pass_is_the_textbook_augmented_state_imm() -> None:
    """run_imm with trend modes (two random-walk modes, each with its trend partner) against the augmented-
    state IMM written out in full (test_smoother's reference, four states), on 3 s of the drive at lags 0,
    7 and 40 samples. Error argument as for the three-state test there: the same algebra in a different
    rounding order, n = 600 stable steps, κ ≤ 1e4 from μ spanning 1e-12 … 1: ≤ 1e-9 relative."""
    t, theta, _ = drive()
    t, theta = t[:600], theta[:600]
    est = make_estimator("kalman", **CFG)
    assert isinstance(est, KalmanEstimator)
    qs, jerks, rates = kern.with_trends(
        np.array([1e-4, 1e-1]), kern.chain_rates(2, 2.0, 1.0), np.array([10.0, 10.0]), 5.0
    )
    lags = np.array([0, 7, 40], dtype=np.int64)
    a, var, _ = kern.imm_pass(t, theta, est._params, qs, rates, lags, False, jerks)
    for col, lag in enumerate(lags):
        ref_a, ref_v = _imm_fixed_lag_reference(t, theta, est._params, qs, rates, int(lag), jerks)
        done = ~np.isnan(ref_a)
        assert done.sum() == t.size - max(int(lag), 1)
        np.testing.assert_allclose(a[done, col], ref_a[done], rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(var[done, col], ref_v[done], rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("lag", [0.0, 0.25])
def test_streaming_equals_batch(lag: float) -> None:
    """The live update and the batch pass run the same compiled step: equal to the last bit."""
    t, theta, _ = drive()
    est = make_estimator("kalman", **TREND, lag=lag)
    out = [est.update(ti, yi) for ti, yi in zip(t.tolist(), theta.tolist(), strict=True)]
    emitted = [o for o in out if o is not None]
    a_b, v_b = estimate_batch("kalman", t, theta, **TREND, lag=lag)
    n = len(emitted)
    assert n == t.size - round(lag * CFG["rate_hz"])
    np.testing.assert_array_equal([o.a for o in emitted], a_b[:n])
    np.testing.assert_array_equal([o.variance for o in emitted], v_b[:n])
    assert np.isfinite(a_b).all() and (v_b > 0.0).all()


def test_a_random_walk_mode_never_carries_a_trend() -> None:
    """After every sample the random-walk modes (q_j = 0) hold j = 0 with no covariance: the mixing zeroes
    what a trend partner hands them, and their prediction adds none."""
    t, theta, _ = drive()
    est = make_estimator("kalman", **TREND)
    assert isinstance(est, KalmanEstimator)
    walks = est._jerks == 0.0
    assert 0 < np.count_nonzero(~walks) < walks.size
    m, band, d = (int(v) for v in est._ibuf[:3])
    state = kern.imm_arrays(est._buf, m, band, d)  # the live estimator's IMM state (ekf_kernels.ImmArrays)
    modes = band + np.arange(m)  # mode j's column
    j_rows = [kern.P03, kern.P13, kern.P23, kern.P33]  # its covariance's j row
    for ti, yi in zip(t[:400].tolist(), theta[:400].tolist(), strict=True):
        est.update(ti, yi)
        assert not state.X[3, modes[walks]].any() and not state.P[np.ix_(j_rows, modes[walks])].any()
    assert np.abs(state.X[3, modes[~walks]]).max() > 0.0  # the trend modes do carry one


def test_the_trend_modes_follow_a_ramp_the_random_walks_lag() -> None:
    """a(t) rising 0.3 m/s³ for 20 s through l = 0.1 m, ζ 0.05 (c = 2ζω₀), 200 Hz, σ = 0.1 mrad: a trend mode
    holds the ramp, auto's random-walk modes alone lag it. Measured (t ≥ 5 s): 0.0018 against 0.0139 m/s²
    (7.5×), deterministic for the seed; asserted 5×."""
    length, rate, sigma = 0.1, 200.0, 1e-4
    damping = 2.0 * 0.05 * math.sqrt(9.80665 / length)
    t = np.arange(round(20.0 * rate)) / rate
    profile = Ramp(0.0, 20.0, 0.0, 6.0)
    traj = simulate(Pendulum(length=length, damping=damping), profile, t, theta0=0.0, rtol=1e-10, atol=1e-12)
    theta = traj.theta + sigma * np.random.default_rng(5).standard_normal(t.size)
    cfg = {"length": length, "damping": damping, "noise_std": sigma, "rate_hz": rate}
    late = t >= 5.0
    truth = profile(t)[late]
    both = estimate_batch("kalman", t, theta, **cfg)[0][late]
    est = make_estimator("kalman", **cfg)
    assert isinstance(est, KalmanEstimator)
    qs, _, rates = PRESETS["auto"].imm(walks_only=True)
    walks = kern.imm_pass(t, theta, est._params, qs, rates, np.zeros(1, np.int64))[0][late, 0]
    rms_both = float(np.sqrt(np.mean((both - truth) ** 2)))
    assert rms_both < 0.2 * float(np.sqrt(np.mean((walks - truth) ** 2)))


def test_the_smoother_is_the_random_walks_and_the_mode_probabilities_take_the_trend_modes() -> None:
    """There is no four-state backward pass: the smoother is imm_smoother over auto's random-walk modes
    alone, to the last bit. μ has a column per IMM mode (10 + the partners) and sums to 1 within 2.5e-11:
    each of at most 20 may be lifted to the floor of 1e-12 after the normalisation
    (ekf_kernels._update_modes), 2e-11 at most, plus rounding; describe names the trend modes."""
    t, theta, _ = drive()
    est = make_estimator("kalman", **TREND)
    assert isinstance(est, KalmanEstimator)
    a_s, v_s = estimate_batch("smoother", t, theta, **TREND)
    qs, _, rates = PRESETS["auto"].imm(walks_only=True)
    a_w, v_w, var_f, a_f = imm_smoother(t, theta, est._params, qs, rates)
    np.testing.assert_array_equal(a_s, a_w)
    np.testing.assert_array_equal(
        v_s, lag_variance(v_w, var_f, a_w, a_f, SMOOTHER_VARIANCE_POWER, SMOOTHER_REVISION_WEIGHT)
    )
    mu = est.mode_probabilities(t, theta)
    assert mu.shape == (t.size, len(AUTO_MODES) + sum(1 for q in AUTO_TRENDS if q > 0.0))
    np.testing.assert_allclose(mu.sum(axis=1), 1.0, rtol=0.0, atol=2.5e-11)
    assert "trend mode" in est.describe()
    assert 0.0 < est.noise_equivalent_samples(0.0) < math.inf
