"""The smoother and the fixed-lag knob: offline only, never worse than the filter, lag → smoother; angles
across ±90° give a result, never a traceback or a non-finite number beside a finite one."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pendulum_accel.bag import messages as bm
from pendulum_accel.cli.main import main
from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators import ekf_kernels as kern
from pendulum_accel.estimators import estimate_batch, estimator_line, make_estimator
from pendulum_accel.estimators.kalman import (
    LAG_REVISION_WEIGHT,
    LAG_VARIANCE_POWER,
    KalmanEstimator,
    imm_smoother,
)
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Step, Table
from pendulum_accel.physics.simulate import simulate
from pendulum_accel.recording.analyze import analyze_bag
from pendulum_accel.recording.changes import after_change
from pendulum_accel.recording.generate import generate_bag
from test.bag_edits import rewritten
from test.conftest import REPO

L, C, SIGMA, RATE = 0.05, 19.8, 2e-3, 200.0  # the short damped design (scene udds)
CFG = {"length": L, "damping": C, "noise_std": SIGMA, "rate_hz": RATE}


@cache
def drive() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, noisy θ, true a): 30 s of smooth pull-away, cruise and braking, seed 3."""
    profile = Table(
        times=(0.0, 3.0, 6.0, 12.0, 15.0, 20.0, 24.0, 30.0), accels=(0.0, 1.5, 1.2, 0.0, 0.0, -2.0, 0.0, 0.0)
    )
    t = np.arange(round(30.0 * RATE)) / RATE
    theta = simulate(Pendulum(length=L, damping=C), profile, t, theta0=0.0, rtol=1e-10, atol=1e-12).theta
    noisy = np.asarray(theta) + SIGMA * np.random.default_rng(3).standard_normal(t.size)
    return t, noisy, np.asarray(profile(t))


def rms(a: np.ndarray, truth: np.ndarray, t: np.ndarray) -> float:
    """RMS of â − a for t ≥ 2 s (after the start-up)."""
    keep = t >= 2.0
    return math.sqrt(float(np.mean((a - truth)[keep] ** 2)))


def test_smoother_is_offline_only() -> None:
    """Streaming update of the smoother is refused with a one-line ParameterError naming the live knob."""
    est = make_estimator("smoother", **CFG)
    with pytest.raises(ParameterError, match="smoother is offline only; use lag for live"):
        est.update(0.0, 0.0)


def test_smoother_beats_the_filter_and_its_variance_is_smaller() -> None:
    """Using later data too, the smoother's RMS is below the filter's; on the same q_a so is its variance:
    Pˢ = P⁺ + G (Pˢ₊ − P⁻₊) Gᵀ with Pˢ₊ ≤ P⁻₊ never exceeds P⁺ (1e-9 relative: the recursion's rounding)."""
    t, theta, truth = drive()
    q = make_estimator("kalman", **CFG).q_accel  # type: ignore[attr-defined]
    a_f, v_f = estimate_batch("kalman", t, theta, **CFG, q_accel=q)  # the single model at that q_a
    a_s, v_s = estimate_batch("smoother", t, theta, **CFG, q_accel=q)
    assert np.all(v_s <= v_f * (1.0 + 1e-9))  # same model: the smoothed variance never exceeds the filtered
    assert rms(a_s, truth, t) < rms(a_f, truth, t)
    a_imm, _ = estimate_batch("kalman", t, theta, **CFG)  # the live default (IMM)
    a_s, v_s = estimate_batch("smoother", t, theta, **CFG)  # RTS at the smoothed mode mix (imm_smoother)
    assert rms(a_s, truth, t) < rms(a_imm, truth, t)
    assert np.all(np.isfinite(a_s)) and np.all(v_s > 0.0)


def test_fixed_lag_over_the_whole_record_is_the_rts_smoother() -> None:
    """A lag as long as the recording gives every sample all the data: on the single model (q_a given), the
    fixed-interval RTS result.

    Both are the same linear-Gaussian algebra on the same linearisation (F, K); they differ in rounding only,
    which the RTS gain's (P⁻)⁻¹ (condition ≈ P_aa/P_θθ ≈ 1e7 here) magnifies to ~1e-9 relative: 1e-6 m/s²
    is far above that and far below any modelling difference (the smoother gains ~1e-2 m/s² on the filter).
    """
    t, theta, _ = drive()
    q = make_estimator("kalman", **CFG).q_accel  # type: ignore[attr-defined]
    a_s, v_s = estimate_batch("smoother", t, theta, **CFG, q_accel=q)
    a_l, v_l = estimate_batch("kalman", t, theta, **CFG, q_accel=q, lag=float(t[-1] + 1.0))
    np.testing.assert_allclose(a_l, a_s, rtol=0.0, atol=1e-6)
    np.testing.assert_allclose(v_l, v_s, rtol=1e-6, atol=0.0)


def test_lag_trades_latency_for_accuracy() -> None:
    """RMS falls as the lag grows from 0 (the filter) to 0.5 s, and a 0.5 s lag is within 10 % of the smoother
    (the smoother's memory at this q_a is ≈ 0.2 s: past ~2 memories the rest of the data adds < 10 %)."""
    t, theta, truth = drive()
    est = make_estimator("kalman", **CFG)
    assert isinstance(est, KalmanEstimator)
    lags = (0, 10, 40, 100)  # samples: 0, 0.05, 0.2, 0.5 s
    a, _ = est.lagged(t, theta, lags)
    errors = [rms(a[:, m], truth, t) for m in range(len(lags))]
    assert errors[0] > errors[1] > errors[2] >= errors[3]
    a_s, _ = estimate_batch("smoother", t, theta, **CFG, q_accel=est.q_accel)
    assert errors[3] < 1.1 * rms(a_s, truth, t)


def test_lag_variance_map_matches_smooth_motion_and_keeps_the_filters_where_the_future_adds_nothing() -> None:
    """The published fixed-lag variance min(P_f (P_lag/P_f)^γ + κ (â_lag − â_f)², P_lag) (kalman.lag_variance)
    against the IMM's raw combination P_lag, at 0.25 s on the smooth drive: the formula sample by sample (to
    rounding, argued below), never wider than P_lag, the filter's own at the recording's last sample (no
    future there: ratio 1 and no revision, exactly), and a share of errors beyond 2σ inside issue 33's
    1–12 %, where the raw variance over-covers the smooth drive (0.3 % beyond 2σ; the map: 5.5 %)."""
    t, theta, truth = drive()
    est = make_estimator("kalman", **CFG)
    assert isinstance(est, KalmanEstimator)
    n = round(0.25 * RATE)
    a, var = est.lagged(t, theta, (0, n))
    a_raw, raw, _ = kern.imm_pass(
        t, theta, est._params, est._qs, est._rates, np.array([0, n]), False, est._jerks
    )
    np.testing.assert_array_equal(a[:, 1], a_raw[:, 1])  # CFG has no clamp in reach: â as the pass gives it
    # CFG states no sensor bias: the published var adds nothing. Each side forms r = P_lag/P_f (½ ulp), r^γ
    # (≤ 4 ulp in numpy's SIMD pow, e.g. SVML on AVX-512; < 1 ulp in glibc), two products and d² (½ ulp
    # each) and a sum of two positive terms (½ ulp, no cancellation), then the exact min: under 8 ulp ≈
    # 1.8e-15 apart relative; 1e-13 is 50 times that.
    ratio = np.clip(raw[:, 1] / raw[:, 0], 0.0, 1.0)
    revision = a_raw[:, 1] - a_raw[:, 0]
    formula = np.minimum(raw[:, 0] * ratio**LAG_VARIANCE_POWER + LAG_REVISION_WEIGHT * revision**2, raw[:, 1])
    np.testing.assert_allclose(var[:, 1], formula, rtol=1e-13, atol=0.0)
    assert np.all(var[:, 1] <= raw[:, 1])  # the min is exact: no rounding between it and P_lag
    assert var[-1, 1] == var[-1, 0]
    keep = t >= 2.0
    err2 = (a[:, 1] - truth)[keep] ** 2
    assert 0.01 <= float(np.mean(err2 > 4.0 * var[keep, 1])) <= 0.12
    assert float(np.mean(err2 > 4.0 * raw[keep, 1])) < 0.01


def test_lagged_streaming_equals_batch_and_is_stamped_with_the_described_sample() -> None:
    """Streaming with lag N emits nothing for N samples, then â of sample k − N stamped t[k − N], equal to the
    batch column (same compiled step: equal to rounding, 1e-12 m/s² of headroom)."""
    t, theta, _ = drive()
    lag = 0.25
    est = make_estimator("kalman", **CFG, lag=lag)
    out = [est.update(ti, yi) for ti, yi in zip(t.tolist(), theta.tolist(), strict=True)]
    n = round(lag * RATE)
    assert all(o is None for o in out[:n]) and all(o is not None for o in out[n:])
    emitted = [o for o in out if o is not None]
    times = np.array([o.time for o in emitted])
    np.testing.assert_array_equal(times, t[: t.size - n])
    a_b, v_b = estimate_batch("kalman", t, theta, **CFG, lag=lag)
    np.testing.assert_allclose([o.a for o in emitted], a_b[: t.size - n], rtol=0.0, atol=1e-12)
    np.testing.assert_allclose([o.variance for o in emitted], v_b[: t.size - n], rtol=1e-12, atol=0.0)


def test_lag_is_checked_and_only_kalman_has_it() -> None:
    """A negative lag and a lag for a method without one are refused with a one-line ParameterError."""
    with pytest.raises(ParameterError, match="lag must be >= 0"):
        make_estimator("kalman", **CFG, lag=-0.1)
    with pytest.raises(ParameterError, match="has no option 'lag'"):
        make_estimator("instant", **CFG, lag=0.5)
    with pytest.raises(ParameterError, match="has no option 'lag'"):
        make_estimator("smoother", **CFG, lag=0.5)  # it has the whole recording
    with pytest.raises(ParameterError, match="unknown preset"):
        make_estimator("kalman", **CFG, preset="boat")


def test_export_and_analyze_offer_the_smoother_and_the_lag(tmp_path: Path) -> None:
    """``export`` adds the smoother's series on the angle's stamps (finite, one per angle); ``analyze`` runs
    ``--estimator smoother`` and ``--lag``, and refuses a lag for a method without one in one line."""
    pytest.importorskip("pandas")
    golden = REPO / "bags" / "step_start"
    assert main(["export", str(golden), "--out", str(tmp_path), "--merged"]) == 0
    merged = (tmp_path / "merged.csv").read_text().splitlines()
    header = merged[0].split(",")
    col = header.index("/car/accel/smoothed/a")
    values = [float(row.split(",")[col]) for row in merged[1:]]
    assert len(values) == len(merged) - 1 and all(math.isfinite(v) for v in values)
    smooth = analyze_bag(golden, estimator="smoother")
    lagged = analyze_bag(golden, estimator="kalman", lag=0.3)
    assert lagged.config["lag"] == 0.3 and np.isfinite(lagged.accel_est).all()
    # The smoother has the whole recording, more later data than a 0.3 s lag: not worse (5 % slack: its
    # single model at the smoothed mode mix is not the lag's IMM, so it is not a strict inequality).
    assert smooth.stats.rms <= lagged.stats.rms * 1.05
    assert main(["analyze", str(golden), "--estimator", "instant", "--lag", "0.3"]) == 2


def test_smooth_modes_is_the_chains_forward_backward() -> None:
    """ekf_kernels.smooth_modes on the filtered probabilities of a hidden Markov chain (its transitions Π the
    chain's own, _chain_step) gives the textbook forward-backward posteriors p(s_k | y_1..n), computed here
    independently with the backward messages β.

    Tolerance: both sides are sums of a few hundred products of probabilities in [0, 1], each step normalised,
    so each carries at most ~n·m ulp of relative rounding (n 300 samples, m 3 modes: ~1e-13); 1e-10 absolute
    on probabilities is far above that and far below any error in the recursion (a wrong Π index or a
    missing normalisation moves them by 1e-2 or more)."""
    rng = np.random.default_rng(7)
    n, m, dt = 300, 3, 0.01
    rates = kern.chain_rates(m, 0.5, 0.2)
    pi = np.empty((m, m))
    kern._chain_step(rates, dt, pi)
    like = rng.uniform(0.05, 1.0, (n, m))  # any emission likelihoods
    alpha = np.empty((n, m))
    alpha[0] = like[0] / like[0].sum()
    for k in range(1, n):
        alpha[k] = like[k] * (alpha[k - 1] @ pi)
        alpha[k] /= alpha[k].sum()
    beta = np.ones((n, m))
    for k in range(n - 2, -1, -1):
        beta[k] = pi @ (like[k + 1] * beta[k + 1])
        beta[k] /= beta[k].sum()
    expected = alpha * beta
    expected /= expected.sum(axis=1, keepdims=True)
    t = np.arange(n) * dt
    mu = alpha.copy()
    kern.smooth_modes(t, mu, rates, 1.0, kern.chain_band(rates))
    np.testing.assert_allclose(mu, expected, rtol=0.0, atol=1e-10)
    # A gap past reset_gap cuts the chain: the sample before it keeps its filtered μ.
    t_gap = t.copy()
    t_gap[150:] += 5.0
    mu = alpha.copy()
    kern.smooth_modes(t_gap, mu, rates, 1.0, kern.chain_band(rates))
    assert np.array_equal(mu[149], alpha[149])


def test_the_smoothers_variance_tells_the_truth_across_a_step() -> None:
    """On a step of a (2 m/s² at 10 s, the short damped design, 4 seeds pooled) the smoother's published
    variance describes its errors both within 2 s of the change and in the steady stretches: mean NEES
    within a factor 4 of 1 (σ within a factor 2 of the error's spread). The fixed-lag pass it replaced
    carried the level after the step back across it with a calm mode's variance: NEES 2000-4000 there."""
    prof = Step(10.0, 0.0, 2.0)
    t = np.arange(round(20.0 * RATE)) / RATE
    theta = simulate(Pendulum(length=L, damping=C), prof, t, theta0=0.0, rtol=1e-10, atol=1e-12).theta
    truth = np.asarray(prof(t))
    after = after_change(t, t, truth)
    steady = ~after & (t >= 2.0)
    z_after, z_steady = [], []
    for seed in range(4):
        noisy = np.asarray(theta) + SIGMA * np.random.default_rng(seed).standard_normal(t.size)
        a, var = estimate_batch("smoother", t, noisy, **CFG)
        z = (a - truth) ** 2 / var
        z_after.append(z[after])
        z_steady.append(z[steady])
    for z in (np.concatenate(z_after), np.concatenate(z_steady)):
        assert 0.25 <= float(np.mean(z)) <= 4.0


def test_the_smoother_leaves_no_hole_where_its_single_model_pass_breaks_down() -> None:
    """Angles jumping across ±90° every sample drive the single-model pass out of its model (its RTS leaves
    holes there); those samples get the IMM filter's estimate, so every published â and variance is finite
    and every variance positive."""
    t = np.arange(2000) / 100.0
    theta = np.where(np.arange(2000) % 2 == 0, 1.5, -1.5)
    est = make_estimator("kalman", length=0.5, noise_std=1e-3, rate_hz=100.0)
    assert isinstance(est, KalmanEstimator)
    qs, rates = est._walks  # the smoother's IMM: the random-walk modes alone
    mu = kern.imm_pass(t, theta, est._params, qs, rates, np.zeros(1, np.int64), True)[2]
    kern.smooth_modes(t, mu, rates, 1.0, kern.chain_band(rates))
    keep = kern.run_pass(t, theta, est._params, mu @ qs)[2:]
    assert np.isnan(kern.rts(*keep)[0]).any()  # the holes this test is about
    published = estimate_batch("smoother", t, theta, length=0.5, noise_std=1e-3, rate_hz=100.0)
    for a, var in (imm_smoother(t, theta, est._params, qs, rates)[:2], published):
        assert np.all(np.isfinite(a)) and np.all(np.isfinite(var)) and np.all(var > 0.0)


def _across_90() -> Callable[[Any], None]:
    """Edit: θ alternating −1.6, +1.6 rad (across ±90°) from one message to the next."""
    count = itertools.count()

    def edit(msg: Any) -> None:
        """In place."""
        msg.position = np.array([1.6 if next(count) % 2 else -1.6])

    return edit


def test_the_smoother_on_angles_across_90_degrees_gives_a_result(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A bag whose angles jump across ±90° every sample: analyze and export give a result, not a traceback
    (run in-process: an exception fails the test as a traceback would)."""
    generate_bag("lecture_constant", tmp_path / "bag", duration=2.0)
    alt90 = str(rewritten(tmp_path / "bag", tmp_path / "alt90", bm.TOPIC_JOINT_STATES, _across_90()))
    assert main(["analyze", alt90, "--estimator", "smoother", "--json"]) == 0
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    assert main(["export", alt90, "--out", str(tmp_path / "t")]) == 0
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    table = np.genfromtxt(tmp_path / "t" / "car__accel__smoothed.csv", delimiter=",", names=True)
    columns = table.dtype.names
    assert columns is not None
    a, var = table[columns[1]], table[columns[2]]
    # Each sample is an estimate with a positive, finite variance, or a hole (both NaN): never inf,
    # never a zero or negative variance beside a number.
    assert np.array_equal(np.isnan(a), np.isnan(var))
    assert np.all(np.isfinite(a[~np.isnan(a)])) and np.all(var[~np.isnan(var)] > 0.0)
    assert np.all(np.isfinite(var[~np.isnan(var)]))


def test_the_rts_pass_keeps_the_filtered_estimate_where_the_prior_has_no_inverse() -> None:
    n = 4
    eye = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    xpo = np.arange(3 * n, dtype=float).reshape(n, 3)
    ppr = eye.copy()
    ppr[2] = 0.0  # singular prior at sample 2: nothing can be carried back from it to sample 1
    a, v = kern.rts(xpo.copy(), ppr, xpo, eye.copy(), eye.copy(), np.zeros(n, dtype=np.bool_))
    assert a[1] == xpo[1, 2] and v[1] == 1.0  # the filtered value and variance, exactly
    assert np.all(np.isfinite(a)) and np.all(v > 0.0)


def test_the_summary_line_explains_the_estimator() -> None:
    """The run summary's estimator line says why the default was chosen, and that another one was chosen."""
    assert estimator_line("kalman").startswith("estimator: kalman (the pendulum EKF")
    assert "real-motion validation" in estimator_line("kalman")
    assert estimator_line("smoother") == "estimator: smoother (chosen; the default is kalman)"


def test_the_imm_pass_without_mode_probabilities_gives_the_same_estimates() -> None:
    """run_imm without keep_mu (μ not held, 8 B a mode a sample) runs the same compiled steps in the same
    order: â and var equal to the last bit those with μ kept."""
    t, theta, _ = drive()
    est = make_estimator("smoother", **CFG)
    assert isinstance(est, KalmanEstimator)
    lags = np.array([0, round(RATE)], dtype=np.int64)
    args = (t, theta, est._params, est._qs, est._rates, lags)
    a_kept, v_kept, mus = kern.imm_pass(*args, True, est._jerks)
    a, v, none = kern.imm_pass(*args, False, est._jerks)
    assert mus.shape == (t.size, est._qs.size) and none.shape == (0, est._qs.size)
    np.testing.assert_array_equal(a, a_kept)
    np.testing.assert_array_equal(v, v_kept)


def _imm_fixed_lag_reference(
    t: np.ndarray,
    y: np.ndarray,
    params: np.ndarray,
    qs: np.ndarray,
    rates: np.ndarray,
    lag: int,
    jerks: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(â_{k−N|k}, var) of the IMM fixed-lag smoother written the textbook way, for a test to hold the kernel
    against: each mode's state is augmented with the N last a's, z = [θ, θ', a_k, a_{k−1} … a_{k−N}], with its
    full covariance; IMM mixing on the whole of z, the EKF prediction (ekf_kernels.predict) on the x block
    and F on its cross-covariances, the Kalman update of z with H = e₁. No ring, no band, no shortcut.
    With ``jerks`` (trend modes, ekf_kernels.with_trends) x is [θ, θ', a, j], predicted by predict_trend,
    and a random-walk mode's j row and column are zeroed after the mixing."""
    g, length, c, r, q_rate = params[0], params[1], params[2], params[3], params[4]
    m = qs.size
    d = 3 if jerks is None else 4
    x, p = np.zeros(3), np.zeros((3, 3))
    kern.initialise(x, p, float(y[0]), g, length, r, params[7], params[8])
    zs, ps = [], []
    for j in range(m):
        zs.append(np.zeros(d))
        ps.append(np.zeros((d, d)))
        zs[j][:3], ps[j][:3, :3] = x, p
        if jerks is not None and jerks[j] > 0.0:
            ps[j][3, 3] = kern.INIT_JERK_STD**2
    mu = np.full(m, 1.0 / m)
    pi, f, work = np.empty((m, m)), np.empty((d, d)), np.empty((3, 4, 4))
    out_a, out_v = np.full(t.size, np.nan), np.full(t.size, np.nan)
    for k in range(1, t.size):
        kern._chain_step(rates, float(t[k] - t[k - 1]), pi)
        cj = pi.T @ mu
        w = pi * mu[:, None] / cj[None, :]
        logl = np.empty(m)
        new_z, new_p = [], []
        for j in range(m):
            z0 = sum(w[i, j] * zs[i] for i in range(m))
            p0 = sum(w[i, j] * (ps[i] + np.outer(zs[i] - z0, zs[i] - z0)) for i in range(m))
            if jerks is not None and jerks[j] == 0.0:  # a random walk carries no trend
                z0[3], p0[3, :], p0[:, 3] = 0.0, 0.0, 0.0
            # Prediction: x ← f(x), the old a_k joins the history, the oldest a leaves it.
            xk, pk = z0[:d].copy(), p0[:d, :d].copy()
            dt = float(t[k] - t[k - 1])
            if jerks is None:
                kern.predict(xk, pk, f, dt, g, 1.0 / length, c, q_rate, qs[j])
            else:
                kern.predict_trend(xk, pk, f, dt, g, 1.0 / length, c, q_rate, qs[j], jerks[j], work)
            keep = min(k, lag)  # a's kept in the history after this step
            hist_z = np.concatenate(([z0[2]], z0[d:]))[:keep]
            idx = np.concatenate(([2], np.arange(d, z0.size)))[:keep]
            z = np.concatenate((xk, hist_z))
            pz = np.empty((z.size, z.size))
            pz[:d, :d] = pk
            pz[:d, d:] = f @ p0[:d, idx]
            pz[d:, :d] = pz[:d, d:].T
            pz[d:, d:] = p0[np.ix_(idx, idx)]
            s = pz[0, 0] + r
            nu = float(y[k] - z[0])
            gain = pz[:, 0] / s
            new_z.append(z + gain * nu)
            new_p.append(pz - np.outer(gain, gain) * s)
            logl[j] = -0.5 * (nu * nu / s + math.log(s)) + math.log(cj[j])
        zs, ps = new_z, new_p
        mu = np.exp(logl - logl.max())
        mu = np.maximum(mu / mu.sum(), 1e-12)
        if k >= lag:
            last = 2 if lag == 0 else d - 1 + lag
            a = sum(mu[j] * zs[j][last] for j in range(m))
            out_a[k - lag] = a
            out_v[k - lag] = sum(mu[j] * (ps[j][last, last] + (zs[j][last] - a) ** 2) for j in range(m))
    return out_a, out_v


def test_the_imm_fixed_lag_pass_is_the_textbook_augmented_state_imm() -> None:
    """run_imm's fixed lag (a ring per mode, mixing restricted to the blocks the update reads, vector loops
    over the buffer) against the augmented-state IMM written out in full (above), on 3 s of the drive
    through three modes of auto's chain, at lags 0, 7 and 40 samples.

    The two do the same algebra in a different order of rounding (numpy's products against scalar loops):
    each step differs by a few ulps, the filter is stable, so the differences stay of order n ε κ with n =
    600 steps and κ the spread of the mixed quantities (≤ 1e4 here: μ spans 1e-12 … 1): ≤ 1e-9 relative
    (3e-13 seen). That is far below any change of algebra: leaving out one mixing term (the spread of the
    modes' a in the cross-covariance) moves the lagged â by more than 1e-6 of itself."""
    t, theta, _ = drive()
    t, theta = t[:600], theta[:600]
    est = make_estimator("kalman", **CFG)
    assert isinstance(est, KalmanEstimator)
    qs = np.array([1e-4, 1e-2, 1.0])
    rates = kern.chain_rates(qs.size, 2.0, 1.0)
    lags = np.array([0, 7, 40], dtype=np.int64)
    a, var, _ = kern.imm_pass(t, theta, est._params, qs, rates, lags)
    for col, lag in enumerate(lags):
        ref_a, ref_v = _imm_fixed_lag_reference(t, theta, est._params, qs, rates, int(lag))
        done = ~np.isnan(ref_a)  # the reference leaves the last N samples out (no flush), and sample 0
        assert done.sum() == t.size - max(int(lag), 1)
        np.testing.assert_allclose(a[done, col], ref_a[done], rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(var[done, col], ref_v[done], rtol=1e-9, atol=1e-15)


def test_the_imm_on_irregular_stamps_is_the_textbook_imm() -> None:
    """Stamps jittered by up to 0.5 ms give 300 distinct Δt, more than the step keeps Π for
    (ekf_kernels.PI_SLOTS): each Π formed anew or taken from the slot of its own Δt must be the Π of that
    Δt. The IMM filter (lag 0) and a lag against the textbook augmented-state IMM (above), which forms Π
    at every sample; tolerance as argued there (the same algebra in another rounding order)."""
    t, theta, _ = drive()
    t, theta = t[:300], theta[:300]
    t = t + 5e-4 * np.random.default_rng(11).uniform(-1.0, 1.0, t.size)
    assert np.unique(np.diff(t)).size > 4 * kern.PI_SLOTS
    est = make_estimator("kalman", **CFG)
    assert isinstance(est, KalmanEstimator)
    qs = np.array([1e-4, 1e-2, 1.0])
    rates = kern.chain_rates(qs.size, 2.0, 1.0)
    lags = np.array([0, 7], dtype=np.int64)
    a, var, _ = kern.imm_pass(t, theta, est._params, qs, rates, lags)
    for col, lag in enumerate(lags):
        ref_a, ref_v = _imm_fixed_lag_reference(t, theta, est._params, qs, rates, int(lag))
        done = ~np.isnan(ref_a)
        np.testing.assert_allclose(a[done, col], ref_a[done], rtol=1e-9, atol=1e-15)
        np.testing.assert_allclose(var[done, col], ref_v[done], rtol=1e-9, atol=1e-15)


def test_a_given_q_a_runs_the_one_model_filter() -> None:
    """With q_accel the estimator runs the IMM kernel with that one mode (μ = 1, nothing to mix): its
    â and var are the one-model filter's (ekf_kernels.run_pass, whose passes the RTS smoother keeps). Both
    do the same IEEE operations in the same order, with no fused multiply-add (numba compiles without
    fast-math), so they agree to the last bit here; 1e-12 relative allows a compiler that fused one of
    them a few ulps (3e-16 each, over a stable filter that does not amplify them), and is far below
    any change of algebra (a mixing term or a gain off by one sample moves â by more than 1e-6)."""
    t, theta, _ = drive()
    q = 0.05
    a, var = estimate_batch("kalman", t, theta, **CFG, q_accel=q)  # CFG states no bias: var adds none
    est = make_estimator("kalman", **CFG, q_accel=q)
    assert isinstance(est, KalmanEstimator)
    a_one, v_one, *_ = kern.run_pass(t, theta, est._params, np.empty(0))
    np.testing.assert_allclose(a, a_one, rtol=1e-12, atol=0.0)
    np.testing.assert_allclose(var, v_one, rtol=1e-12, atol=0.0)
