"""Estimators: batch equals streaming, accuracy against truth, stated variance, conditioning, bad input."""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import signal
from scipy.integrate import trapezoid
from scipy.special import ellipk

from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators import (
    DEFAULT_ESTIMATOR,
    ESTIMATORS,
    LIVE_ESTIMATORS,
    TEACHING_ESTIMATORS,
    TEACHING_NOTE,
    estimate_batch,
    estimator_line,
    make_estimator,
    method_options,
)
from pendulum_accel.estimators.base import wrap_clamp, wrap_clamp_array
from pendulum_accel.estimators.dynamic import DynamicEstimator
from pendulum_accel.estimators.kalman import PRESETS, KalmanEstimator
from pendulum_accel.estimators.lowpass import LowpassEstimator
from pendulum_accel.estimators.period_mean import PeriodMeanEstimator
from pendulum_accel.estimators.swing import swing_amplitude
from pendulum_accel.physics.params import STANDARD_GRAVITY, Pendulum
from pendulum_accel.physics.profiles import Constant, Step
from pendulum_accel.physics.simulate import simulate

G = STANDARD_GRAVITY
L = 0.5
SIGMA = 1e-3
RATE = 200.0
# The streaming methods; the offline-only smoother has its own tests (test_smoother.py).
METHODS = LIVE_ESTIMATORS
EPS = float(np.finfo(float).eps)


def two_path_tolerances(name: str, t: np.ndarray, theta: np.ndarray) -> tuple[float, float]:
    """(atol of a, atol of σ = √var) between the batch and the streaming paths of one record.

    Both paths form the same weighted sums of the same samples; they differ only in the order and grouping
    of the additions and in numpy's vectorised tan/exp/sqrt (SIMD, a few ulp) against libm's (per CPU: AVX2,
    FMA or SSE2 code). Two sums of at most N terms |θ| ≤ Θ differ by at most N·ε·Θ in a mean (the textbook
    (N − 1)u Σ|x| bound, u = ε/2, for each), so an angle differs by ≤ N ε Θ and a = g tan θ̄ by the gain
    g sec²Θ times that. dynamic's θ'' = Σ c₂ x (and θ' = Σ c₁ x) are W-term sums with weights far above 1:
    they differ by ≤ W ε Θ Σ|c₂| (+ c W ε Θ Σ|c₁|), which reach a through l/cos Θ. σ follows the angle it
    is evaluated at (for the teaching methods σ ∝ g sec²θ, and l/cos θ in dynamic's Σw²: |d ln σ/dθ| ≤
    3 tan Θ ≤ 3 sec²Θ; for kalman P_aa through its gain): 8 × the tolerance of a covers it.
    Measured on step_record (AVX-512 and under the CPU emulation of `make test`): a ≤ 2.1e-14, σ ≤ 2.2e-14
    apart, against ≈ 3e-12 and 2.4e-11 here; a wrong formula moves σ by far more than 2.4e-11 / 5.8e-4.
    """
    big = float(np.max(np.abs(theta)))
    a_atol = G / math.cos(min(big, 1.5)) ** 2 * t.size * EPS * big
    if name == "dynamic":
        est = make_estimator(name, length=L, noise_std=SIGMA, rate_hz=RATE)
        assert isinstance(est, DynamicEstimator)
        sums = float(np.sum(np.abs(est._c2)) + est.config.damping * np.sum(np.abs(est._c1)))
        a_atol += L / math.cos(min(big, 1.5)) * est.width * EPS * big * sums
    return a_atol, 8.0 * a_atol


def assert_same_estimates(
    name: str,
    t: np.ndarray,
    theta: np.ndarray,
    batch: tuple[np.ndarray, np.ndarray],
    streamed: tuple[np.ndarray, np.ndarray],
) -> None:
    """a and σ = √var of the two paths within two_path_tolerances."""
    a_atol, sigma_atol = two_path_tolerances(name, t, theta)
    np.testing.assert_allclose(batch[0], streamed[0], rtol=0.0, atol=a_atol)
    np.testing.assert_allclose(np.sqrt(batch[1]), np.sqrt(streamed[1]), rtol=0.0, atol=sigma_atol)


@cache
def step_record(duration: float = 8.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, noisy θ, true a) for a 0 → 3 m/s² step at t = 2 s, undamped, 200 Hz, σ = 1e-3 rad."""
    t = np.arange(round(duration * RATE)) / RATE
    profile = Step(2.0, 0.0, 3.0)
    traj = simulate(Pendulum(length=L), profile, t, theta0=0.0, rtol=1e-10, atol=1e-12)
    noisy = traj.theta + SIGMA * np.random.default_rng(7).standard_normal(t.size)
    return t, noisy, profile(t)


def stream(name: str, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Feed samples one by one through ``update``; every sample must give an estimate."""
    est = make_estimator(name, length=L, noise_std=SIGMA, rate_hz=RATE)
    out = [est.update(ti, yi) for ti, yi in zip(t.tolist(), theta.tolist(), strict=True)]
    assert all(o is not None for o in out)
    return np.array([o.a for o in out if o]), np.array([o.variance for o in out if o])


@pytest.mark.parametrize("name", METHODS)
def test_batch_equals_streaming(name: str) -> None:
    t, theta, _ = step_record()
    a_stream, v_stream = stream(name, t, theta)
    a_batch, v_batch = estimate_batch(name, t, theta, length=L, noise_std=SIGMA, rate_hz=RATE)
    assert_same_estimates(name, t, theta, (a_batch, v_batch), (a_stream, v_stream))
    assert np.isfinite(a_batch).all() and (v_batch > 0.0).all()


@pytest.mark.parametrize("hole", [0.3, 1.5])
@pytest.mark.parametrize("name", METHODS)
def test_batch_equals_streaming_with_gaps_and_jitter(name: str, hole: float) -> None:
    """Irregular stamps and a hole (where some methods restart) give the same numbers both ways."""
    t, theta, _ = step_record()
    jitter = np.random.default_rng(3).uniform(-0.3, 0.3, t.size) / RATE
    keep = (t < 4.0) | (t > 4.0 + hole)
    t2, th2 = (t + jitter)[keep], theta[keep]
    a_stream, v_stream = stream(name, t2, th2)
    a_batch, v_batch = estimate_batch(name, t2, th2, length=L, noise_std=SIGMA, rate_hz=RATE)
    assert_same_estimates(name, t2, th2, (a_batch, v_batch), (a_stream, v_stream))


def test_dynamic_batch_equals_streaming_with_damping() -> None:
    """With c > 0 the fit's θ' enters a (and its weights the batch product): both paths still agree."""
    t, theta, _ = step_record()
    opts = {"length": L, "noise_std": SIGMA, "rate_hz": RATE, "damping": 0.4}
    est = make_estimator("dynamic", **opts)
    out = [est.update(ti, yi) for ti, yi in zip(t.tolist(), theta.tolist(), strict=True)]
    streamed = (np.array([o.a for o in out if o]), np.array([o.variance for o in out if o]))
    batch = estimate_batch("dynamic", t, theta, **opts)
    # two_path_tolerances' damping term (c Σ|c₁|) is for the undamped estimator: add it here.
    a_atol, _ = two_path_tolerances("dynamic", t, theta)
    big = float(np.max(np.abs(theta)))
    assert isinstance(est, DynamicEstimator)
    a_atol += L / math.cos(big) * est.width * EPS * big * 0.4 * float(np.sum(np.abs(est._c1)))
    np.testing.assert_allclose(batch[0], streamed[0], rtol=0.0, atol=a_atol)
    np.testing.assert_allclose(np.sqrt(batch[1]), np.sqrt(streamed[1]), rtol=0.0, atol=8.0 * a_atol)
    undamped, _ = estimate_batch("dynamic", t, theta, length=L, noise_std=SIGMA, rate_hz=RATE)
    assert np.max(np.abs(undamped - batch[0])) > 1e3 * a_atol  # the θ' term is really there


@pytest.mark.parametrize("name", ESTIMATORS)
def test_teaching_estimators_say_so(name: str) -> None:
    """The run summary's line and the node's start-up description say a teaching estimator's σ counts
    noise and bias only; the default's line gives its reason instead."""
    teaching = ESTIMATORS[name].teaching
    assert (name in TEACHING_ESTIMATORS) == teaching
    assert (TEACHING_NOTE in estimator_line(name)) == teaching
    if name != "smoother":  # offline only: no node describes it
        described = make_estimator(name, length=L, noise_std=SIGMA, rate_hz=RATE).describe()
        assert described.endswith(TEACHING_NOTE) == teaching
    assert set(TEACHING_ESTIMATORS) == {"instant", "period_mean", "lowpass", "dynamic"}
    assert DEFAULT_ESTIMATOR not in TEACHING_ESTIMATORS


@pytest.mark.parametrize("name", METHODS)
def test_static_tilt_is_unbiased_and_variance_is_stated(name: str) -> None:
    """Bob at rest at θ_eq(2 m/s²) with white noise: mean within 4 standard errors, scatter as reported."""
    a_true = 2.0
    t = np.arange(round(60.0 * RATE)) / RATE
    theta = math.atan(a_true / G) + SIGMA * np.random.default_rng(11).standard_normal(t.size)
    a_hat, var = estimate_batch(name, t, theta, length=L, noise_std=SIGMA, rate_hz=RATE)
    steady = t > 10.0
    err = a_hat[steady] - a_true
    reported = math.sqrt(float(np.mean(var[steady])))
    # Successive estimates are correlated; 4 σ_a over √(samples per 2 s) bounds the mean's scatter.
    assert abs(float(np.mean(err))) < 4.0 * reported / math.sqrt(50.0 / 2.0)
    measured = float(np.std(err))
    if name == "kalman":
        # P_aa also allows for a drifting a (q_a); for a constant a the actual error is smaller.
        assert 0.1 * reported < measured <= reported
    else:
        # Noise and bias are the whole error at rest. Errors further apart than the method's memory M
        # (1 sample; one period, 1.4 s; the filter's 1/Σh² = 1020 samples; the fit's 0.6 s) are
        # independent, so the 50 s hold K = 50/M of them and the measured scatter is within 3/√(2K) of
        # σ (3 standard errors of a sample standard deviation): ±2 % (instant) to ±67 % (lowpass). The
        # variance's calibration is tested precisely in test_calibration.py (χ² over 1500 runs).
        memory = {"instant": 1.0 / RATE, "period_mean": 1.42, "lowpass": 1020.0 / RATE, "dynamic": 0.6}
        assert measured == pytest.approx(reported, rel=3.0 / math.sqrt(2.0 * 50.0 / memory[name]))


def test_instant_variance_is_conditioning_times_noise() -> None:
    """var_a = (g sec²θ)² σ² exactly (no bias fields set): nothing for the swing; a = g tan θ."""
    est = make_estimator("instant", length=L, noise_std=SIGMA)
    for k, theta in enumerate((0.0, 0.3, -1.0, 1.4)):
        out = est.update(float(k), theta)
        assert out is not None
        # the same libm tan/cos and ≤ 5 roundings each way: within 5 ε ≈ 1.1e-15 (relative)
        assert out.a == pytest.approx(G * math.tan(theta), rel=5 * EPS)
        assert out.variance == pytest.approx((G / math.cos(theta) ** 2 * SIGMA) ** 2, rel=10 * EPS)
        assert not out.clamped


def _exact_period_swing(amplitude: float, accel: float = 3.0) -> tuple[np.ndarray, np.ndarray, float]:
    """(t, θ, T) over one exact libration period T of a swing of ``amplitude`` about θ_eq."""
    pend = Pendulum(length=L)
    omega = pend.omega(accel)
    period = 4.0 * float(ellipk(math.sin(amplitude / 2.0) ** 2)) / omega  # exact libration period
    t = np.linspace(0.0, period, 20001)
    theta0 = pend.equilibrium_angle(accel) + amplitude
    theta = simulate(pend, Constant(accel), t, theta0=theta0, rtol=1e-12, atol=1e-13).theta
    return t, theta, period


def _tangent_and_angle_means(amplitude: float, accel: float = 3.0) -> tuple[float, float]:
    """Over one exact period of a swing of ``amplitude`` about θ_eq: (mean g tan θ, g tan(mean θ)) / a − 1."""
    t, theta, period = _exact_period_swing(amplitude, accel)
    mean_tan = trapezoid(G * np.tan(theta), t) / period
    mean_angle = trapezoid(theta, t) / period
    return mean_tan / accel - 1.0, G * math.tan(mean_angle) / accel - 1.0


def test_averaging_tan_is_biased_but_averaging_angle_is_not() -> None:
    """Mean g tan θ is +0.5 % high at 0.1 rad, +16 % at 0.5 rad (a = 3 m/s²); mean θ is exact."""
    tan_small, angle_small = _tangent_and_angle_means(0.1)
    tan_large, angle_large = _tangent_and_angle_means(0.5)
    assert tan_small == pytest.approx(0.005, abs=0.001)  # measured +0.55 %
    assert tan_large == pytest.approx(0.16, abs=0.005)  # measured +15.98 %
    assert abs(angle_small) < 1e-6 and abs(angle_large) < 1e-6


@pytest.mark.parametrize("amplitude", [0.1, 0.5])
def test_period_mean_is_unbiased_on_a_large_swing(amplitude: float) -> None:
    """period_mean averages θ over the swing's exact period: within 1e-4 of a on average (not +16 %)."""
    pend = Pendulum(length=L)
    t = np.arange(round(30.0 * RATE)) / RATE
    theta = simulate(pend, Constant(3.0), t, theta0=pend.equilibrium_angle(3.0) + amplitude).theta
    a_hat, _ = estimate_batch("period_mean", t, theta, length=L, noise_std=SIGMA, rate_hz=RATE)
    settled = t > 5.0
    assert abs(float(np.mean(a_hat[settled])) / 3.0 - 1.0) < 1e-4  # measured 3e-8 (0.1 rad), 8e-6 (0.5 rad)
    assert np.max(np.abs(a_hat[settled] - 3.0)) < 2e-3  # measured 6e-6 and 3e-4 m/s²
    tan_bias = float(np.mean(G * np.tan(theta[settled]))) / 3.0 - 1.0
    assert tan_bias > 0.8 * (1.0 + (3.0 / G) ** 2) * amplitude**2 / 2.0  # naive: ≈ sec²θ_eq A²/2 high


@pytest.mark.parametrize(("amplitude", "tolerance"), [(0.3, 5e-6), (0.77, 2e-4), (2.0, 7e-3)])
def test_swing_amplitude_from_the_variance_of_an_exact_swing(amplitude: float, tolerance: float) -> None:
    """A from var θ over one exact period: within 2e-4 at braking's 0.77 rad (measured 9e-5), where the
    sinusoid's √(2 var θ) is 0.32 % high; 0.54 % at 2 rad (√(2 var θ): 2.7 %)."""
    t, theta, period = _exact_period_swing(amplitude)
    mean = trapezoid(theta, t) / period
    variance = trapezoid(theta * theta, t) / period - mean * mean
    error = abs(swing_amplitude(variance) / amplitude - 1.0)
    assert error < tolerance
    assert math.sqrt(2.0 * variance) / amplitude - 1.0 > 4.0 * error  # the sinusoid's is high


def test_default_is_a_known_method_and_meets_its_targets() -> None:
    """With the lab_steps preset the default follows a 0 → 3 m/s² step to 2 % within 2 s: from then on its
    RMS is below that band and at most 2 % of samples leave it (the IMM's manoeuvre mode keeps a few % of
    probability, whose noise crosses the band now and then: 0.5 % measured). Its steady RMS is no larger
    than g·tanθ's nor than 1.5× the standard deviation it publishes."""
    assert DEFAULT_ESTIMATOR in ESTIMATORS
    t, theta, truth = step_record(14.0)
    cfg = {"length": L, "noise_std": SIGMA, "rate_hz": RATE}
    a_hat, var = estimate_batch(DEFAULT_ESTIMATOR, t, theta, **cfg, preset="lab_steps")
    err = a_hat - truth
    band = 0.02 * 3.0
    settled = t >= 4.0
    assert math.sqrt(float(np.mean(err[settled] ** 2))) < band
    assert float(np.mean(np.abs(err[settled]) > band)) < 0.02
    steady = t > 7.0
    rms = math.sqrt(float(np.mean(err[steady] ** 2)))
    # The random-walk model expects a to wander, so on a constant a P_aa is an upper bound of the error
    # variance; 1.5× leaves room for the 1000-sample RMS's own scatter (a few % at N_eff ≈ 10 samples).
    assert rms < 1.5 * math.sqrt(float(np.mean(var[steady])))
    a_tan, _ = estimate_batch("instant", t, theta, **cfg)
    assert rms < math.sqrt(float(np.mean((a_tan - truth)[steady] ** 2)))


def test_kalman_is_exact_without_noise() -> None:
    """With the model right and no noise the EKF locks onto a constant a despite a 0.3 rad swing."""
    pend = Pendulum(length=L)
    t = np.arange(round(10.0 * RATE)) / RATE
    theta = simulate(pend, Constant(-2.0), t, theta0=0.3, rtol=1e-12, atol=1e-13).theta
    a_hat, _ = estimate_batch("kalman", t, theta, length=L, noise_std=SIGMA, rate_hz=RATE)
    assert np.max(np.abs(a_hat[t > 5.0] + 2.0)) < 1e-6


def test_dynamic_inverts_the_equation_of_motion() -> None:
    """Noise-free 0.1 rad swing at a = 1 m/s²: the Savitzky-Golay inversion is within 0.01 m/s² of a."""
    pend = Pendulum(length=L)
    t = np.arange(round(6.0 * RATE)) / RATE
    theta = simulate(pend, Constant(1.0), t, theta0=pend.equilibrium_angle(1.0) + 0.1).theta
    a_hat, _ = estimate_batch("dynamic", t, theta, length=L, noise_std=SIGMA, rate_hz=RATE)
    assert np.max(np.abs(a_hat[t > 1.0] - 1.0)) < 0.01


def test_noise_equivalent_samples_match_their_definitions() -> None:
    """lowpass: N = 1/Σh² (impulse response); period_mean: N = T f; instant: 1; kalman: EWMA-like > 1."""
    low = make_estimator("lowpass", length=L, noise_std=SIGMA, rate_hz=RATE)
    assert isinstance(low, LowpassEstimator)
    b, a = signal.butter(2, low.cutoff_hz, fs=RATE)
    impulse = np.zeros(200_000)
    impulse[0] = 1.0
    h = signal.lfilter(b, a, impulse)
    assert low.noise_equivalent_samples(0.0) == pytest.approx(1.0 / float(np.sum(h**2)), rel=1e-6)
    butterworth_delay = math.sqrt(2.0) / (2 * math.pi * low.cutoff_hz)  # 2nd order, at DC
    assert low.nominal_delay(0.0) == pytest.approx(butterworth_delay, rel=1e-3)
    pm = make_estimator("period_mean", length=L, noise_std=SIGMA, rate_hz=RATE)
    assert pm.noise_equivalent_samples(0.0) == pytest.approx(2 * math.pi * math.sqrt(L / G) * RATE)
    assert make_estimator("instant", length=L).noise_equivalent_samples(3.0) == 1.0
    # kalman: N = (Σw)²/Σw² of its steady gain's impulse response, long (EWMA-like) for a slow q_a and
    # shrinking as q_a grows (a faster filter averages fewer samples).
    n_eff = [
        make_estimator("kalman", length=L, noise_std=SIGMA, rate_hz=RATE, q_accel=q).noise_equivalent_samples(
            3.0
        )
        for q in (1e-5, 1e-3, 1e-1)
    ]
    assert n_eff[0] > 5.0 and n_eff[0] > n_eff[1] > n_eff[2]


def test_the_imm_states_the_delay_of_its_stationary_mode_mix_and_the_range_over_its_modes() -> None:
    """auto's delay is Σ π_j d_j, π the mode chain's stationary law (πᵀG = 0, Σ π = 1) and d_j each IMM
    mode's steady-filter delay (a trend mode's on its four states), between the most agile mode's and the
    calmest's; describe() says so. Tolerances: π from a least-squares solve of at most 20 × 20 with rates
    ≤ 1 /s (round-off ~1e-15, 1e-12 allowed on πᵀG); the mix's Σ π m_j / Σ π w_j equals Σ π d_j exactly
    when every mode's DC gain Σ w_j is the same (g sec²θ: each filter is unbiased at rest), which the DAREs
    give to ~1e-12 relative (1e-6 allowed). The random walks' own chain is birth-death:
    π_{i+1}/π_i = τ_down/τ_up (1e-9 relative)."""
    est = make_estimator("kalman", length=L, noise_std=SIGMA, rate_hz=RATE)
    assert isinstance(est, KalmanEstimator) and len(est.modes) > 2
    pi = est.stationary_modes()
    gen = est._rates - np.diag(est._rates.sum(axis=1))
    np.testing.assert_allclose(pi @ gen, 0.0, atol=1e-12)
    assert float(pi.sum()) == pytest.approx(1.0, abs=1e-12) and (pi > 0.0).all()
    auto = PRESETS["auto"]
    assert auto.down_time is not None
    walks = make_estimator("kalman", length=L, noise_std=SIGMA, rate_hz=RATE, preset="car")
    assert isinstance(walks, KalmanEstimator)
    walks._rates = auto.imm(walks_only=True)[2]  # auto's random walks alone: a birth-death chain
    walks._qs = np.array(auto.modes)
    pw = walks.stationary_modes()
    np.testing.assert_allclose(pw[1:] / pw[:-1], auto.down_time / auto.switch_time, rtol=1e-9)
    delays = []
    for q_a, q_j in zip(est._qs, est._jerks, strict=True):
        F, K, _ = est.steady_state(0.0, float(q_a), float(q_j))
        M = (np.eye(K.size) - np.outer(K, np.eye(K.size)[0])) @ F
        inv = np.linalg.inv(np.eye(K.size) - M)
        delays.append(float((M @ inv @ inv @ K)[2] / (inv @ K)[2]) / RATE)
    mixed = est.nominal_delay(0.0)
    assert mixed == pytest.approx(float(np.dot(pi, delays)), rel=1e-6)
    single = [
        make_estimator("kalman", length=L, noise_std=SIGMA, rate_hz=RATE, q_accel=q).nominal_delay(0.0)
        for q in est.modes
    ]
    agile, calm = est.mode_delays(0.0)
    assert agile == pytest.approx(single[-1], rel=1e-9) and calm == pytest.approx(single[0], rel=1e-9)
    assert min(delays) <= mixed <= max(delays)
    assert "stationary probabilities" in est.describe()


@pytest.mark.parametrize("name", METHODS)
@pytest.mark.parametrize("theta", [math.radians(89.99), math.pi / 2, math.radians(100.0), math.pi, -1e6])
def test_near_and_past_90_degrees_is_clamped_never_inf(name: str, theta: float) -> None:
    est = make_estimator(name, length=L, noise_std=SIGMA, rate_hz=RATE)
    outs = [est.update(k / RATE, theta) for k in range(400)]
    assert all(o is not None and math.isfinite(o.a) and math.isfinite(o.variance) for o in outs)
    if name != "kalman":  # the EKF's state is the acceleration itself, clamped only if it runs away
        inside = abs(math.remainder(theta, 2 * math.pi)) < math.radians(89.0)
        assert inside or any(o is not None and o.clamped for o in outs)


@pytest.mark.parametrize("name", METHODS)
def test_streaming_ignores_nonfinite_and_out_of_order_samples(name: str) -> None:
    est = make_estimator(name, length=L, noise_std=SIGMA, rate_hz=RATE)
    assert est.update(0.0, 0.1) is not None
    assert est.update(0.005, math.nan) is None
    assert est.update(0.005, math.inf) is None
    assert est.update(math.nan, 0.1) is None
    assert est.update(0.0, 0.1) is None  # not later than the last accepted sample
    out = est.update(0.010, 0.1)
    assert out is not None and math.isfinite(out.a)


def test_reset_restarts_from_scratch() -> None:
    """After reset() a replay gives bit-identical estimates (a looping bag)."""
    t, theta, _ = step_record()
    for name in METHODS:
        est = make_estimator(name, length=L, noise_std=SIGMA, rate_hz=RATE)
        first = [est.update(ti, yi) for ti, yi in zip(t[:600].tolist(), theta[:600].tolist(), strict=True)]
        est.reset()
        again = [est.update(ti, yi) for ti, yi in zip(t[:600].tolist(), theta[:600].tolist(), strict=True)]
        assert first == again, name


def test_period_mean_memory_stays_bounded() -> None:
    """O(1) per sample: the history never holds much more than one longest period."""
    est = make_estimator("period_mean", length=L, noise_std=SIGMA, rate_hz=RATE)
    assert isinstance(est, PeriodMeanEstimator)
    for k in range(20_000):
        est.update(k / RATE, 0.01 * math.sin(k / 50.0))
    longest = 2 * math.pi * math.sqrt(L / G) * RATE
    assert len(est._swing.trail._t) < 2 * longest + 130


@pytest.mark.parametrize(
    ("t", "theta", "words"),
    [
        ([0.0, 1.0], [0.0, math.nan], "theta must be finite"),
        ([0.0, math.inf], [0.0, 0.0], "t must be finite"),
        ([0.0, 1.0, 1.0], [0.0, 0.0, 0.0], "strictly increasing"),
        ([0.0, 1.0], [0.0], "equal length"),
    ],
)
def test_batch_rejects_bad_input_with_one_line(t: list[float], theta: list[float], words: str) -> None:
    with pytest.raises(ParameterError, match=words):
        estimate_batch("instant", np.array(t), np.array(theta), length=L)


def test_make_estimator_rejects_unknown_names_and_options() -> None:
    with pytest.raises(ParameterError, match=r"unknown estimator 'magic'.*kalman"):
        make_estimator("magic", length=L)
    with pytest.raises(ParameterError, match="no option 'window_s'"):
        make_estimator("kalman", length=L, window_s=1.0)
    with pytest.raises(ParameterError, match="length must be > 0"):
        make_estimator("kalman", length=-1.0)
    with pytest.raises(ParameterError, match="polyorder"):
        make_estimator("dynamic", length=L, polyorder=9)
    assert "q_accel" in method_options("kalman")
    assert make_estimator("lowpass", length=L, cutoff_hz=0.05, damping=0.1).config.damping == 0.1


@given(st.lists(st.floats(min_value=-1e7, max_value=1e7), min_size=1, max_size=50))
def test_scalar_and_array_angle_clamps_agree(angles: list[float]) -> None:
    """Streaming and batch paths wrap and clamp θ identically (so their estimates agree)."""
    limit = math.radians(89.0)
    arr, flags = wrap_clamp_array(np.array(angles), limit)
    for i, theta in enumerate(angles):
        value, clamped = wrap_clamp(theta, limit)
        assert value == arr[i] and clamped == flags[i]
        assert abs(value) <= limit


@pytest.mark.parametrize("name", ["period_mean", "lowpass", "dynamic", "kalman"])
def test_long_hole_restarts_the_estimate(name: str) -> None:
    """After 1.5 s without input the first estimate uses only the new sample: a = g tan θ."""
    est = make_estimator(name, length=L, noise_std=SIGMA, rate_hz=RATE)
    for k in range(400):
        est.update(k / RATE, 0.1 * math.sin(k / 30.0))
    out = est.update(400 / RATE + 1.5, 0.2)
    # lowpass starts in steady state through lfilter_zi, exact only to ~1e-11 with poles this close to 1
    assert out is not None and out.a == pytest.approx(G * math.tan(0.2), rel=1e-9)
