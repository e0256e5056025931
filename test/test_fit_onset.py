"""The fit-window ramp-onset test (``dynamic``'s): its least squares, its allowance for the swing, and what it
does for ``dynamic``'s published variance over a ramp."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators import dynamic, make_estimator
from pendulum_accel.estimators.dynamic import DynamicEstimator
from pendulum_accel.estimators.fit_onset import FitOnsetTest
from pendulum_accel.estimators.swing import agm_cos_half
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Constant, Ramp
from pendulum_accel.physics.simulate import simulate

RATE = 200.0
LENGTH = 1.0
SIGMA = 1e-3


def _dynamic() -> DynamicEstimator:
    """``dynamic`` at l = 1 m, σ = 1e-3 rad, 200 Hz (a 121-sample window)."""
    est = make_estimator("dynamic", length=LENGTH, noise_std=SIGMA, rate_hz=RATE)
    assert isinstance(est, DynamicEstimator)
    return est


def _test() -> FitOnsetTest:
    """The test as ``dynamic`` builds it, onsets 0.1–0.5 s back, λ > 20."""
    est = _dynamic()
    return FitOnsetTest(RATE, est._c0, est._c2, min_age=0.1, max_age=0.5, threshold=20.0)


def _swing(omega: float, amplitude: float, tau: np.ndarray, phase: float = 0.7) -> np.ndarray:
    """θ_eq + A cos(ωτ + φ), θ_eq = 0.2 rad."""
    return 0.2 + amplitude * np.cos(omega * tau + phase)


def test_a_ramp_in_a_swing_gives_back_its_rate_age_and_the_fits_error() -> None:
    """A noiseless swing plus the linear response to a ramp of rate 1.5 m/s³ begun 0.3 s ago: the test
    finds that onset and reports ê = ĵ h with ĵ = 1.5, and var ê = (l/cos θ)² σ² h²/u_mᵀu_m."""
    test = _test()
    omega = math.sqrt(9.80665 / LENGTH)
    tau = test._tau
    age = 0.3
    since = np.maximum(tau + age, 0.0)
    cos_th = math.cos(0.2)
    window = (
        _swing(omega, 0.1, tau) + cos_th / LENGTH * 1.5 * (omega * since - np.sin(omega * since)) / omega**3
    )
    found = test.error(window, omega, 0.0, LENGTH / cos_th, SIGMA)
    assert found is not None
    basis = test.basis(omega)
    m = int(np.argmin(np.abs(test._ages - age)))
    h = float(basis.response[m])
    # ω rounded to 1e-3 for the basis: the shape differs by that much, the fitted rate by less.
    assert found[0] == pytest.approx(1.5 * h, rel=1e-3)
    # the same closed-form variance, a few products and one quotient both ways: ~10 ε relative
    assert found[1] == pytest.approx((LENGTH / cos_th * SIGMA * h) ** 2 / float(basis.energy[m]), rel=1e-12)
    # The fit's error is the ramp missing from its centre: at 0.3 s, about −j × 0.3 s.
    assert -0.3 * 1.5 * 1.1 < found[0] < -0.3 * 1.5 * 0.8


def test_noise_on_a_swing_rarely_passes() -> None:
    """White noise on a steady swing: λ passes 20 in under 0.5 % of 4000 windows (χ²₁ maximised over the
    ages tried)."""
    test = _test()
    omega = math.sqrt(9.80665 / LENGTH)
    tau = test._tau
    rng = np.random.default_rng(2)
    alarms = 0
    for k in range(4000):
        window = _swing(omega, 0.3, tau, phase=0.01 * k) + SIGMA * rng.standard_normal(tau.size)
        alarms += test.error(window, omega, 0.3**3 / 192.0, LENGTH / math.cos(0.2), SIGMA) is not None
    assert alarms < 20


def test_a_large_swing_passes_only_without_its_third_harmonic() -> None:
    """The exact libration of a 0.6 rad swing about θ_eq (l = 0.5 m, a = −4 m/s², braking's), with its own
    period: never taken for a ramp with the allowance A₃² G_m, in over half the windows without it."""
    est = make_estimator("dynamic", length=0.5, noise_std=SIGMA, rate_hz=RATE)
    assert isinstance(est, DynamicEstimator)
    test = FitOnsetTest(RATE, est._c0, est._c2, min_age=0.1, max_age=0.5, threshold=20.0)
    theta_eq, amplitude = math.atan2(-4.0, 9.80665), 0.6
    t = np.arange(round(4.0 * RATE)) / RATE
    theta = simulate(
        Pendulum(length=0.5), Constant(-4.0), t, theta0=theta_eq + amplitude, rtol=1e-11, atol=1e-12
    )
    omega = math.sqrt(math.hypot(9.80665, 4.0) / 0.5) * agm_cos_half(amplitude)
    lever = 0.5 / math.cos(theta_eq)
    windows = [theta.theta[i - est.width + 1 : i + 1] for i in range(est.width - 1, t.size, 5)]
    with_third = [test.error(w, omega, amplitude**3 / 192.0, lever, SIGMA) for w in windows]
    without = [test.error(w, omega, 0.0, lever, SIGMA) for w in windows]
    assert all(found is None for found in with_third)
    assert sum(found is not None for found in without) > 0.5 * len(windows)


def test_a_window_too_short_tests_nothing_and_bad_settings_are_refused() -> None:
    """At 5 Hz a quadratic fit has 3 samples, no room for an onset behind the swing's three functions:
    ``error`` is None. A zero threshold, min_age > max_age or a zero rate: one sentence."""
    slow = make_estimator("dynamic", length=LENGTH, noise_std=SIGMA, rate_hz=5.0, polyorder=2)
    assert isinstance(slow, DynamicEstimator)
    test = FitOnsetTest(5.0, slow._c0, slow._c2, min_age=0.1, max_age=0.5, threshold=20.0)
    assert test.error(np.zeros(slow.width), 3.0, 0.0, 1.0, SIGMA) is None
    est = _dynamic()
    for rate, min_age, max_age, threshold in (
        (RATE, 0.1, 0.5, 0.0),
        (RATE, 0.6, 0.5, 20.0),
        (0.0, 0.1, 0.5, 20.0),
    ):
        with pytest.raises(ParameterError, match="fit onset test needs"):
            FitOnsetTest(rate, est._c0, est._c2, min_age=min_age, max_age=max_age, threshold=threshold)


def _ramp_violations(seed: int) -> tuple[int, float | None]:
    """``dynamic`` on l = 1 m at rest, a ramping 0 → 1.8 m/s² over 5–6 s (200 Hz, σ = 1e-3 rad): the
    samples in 5–7 s beyond 2σ, and when the onset test first held a variance."""
    t = np.arange(round(8.0 * RATE)) / RATE
    traj = simulate(Pendulum(length=LENGTH), Ramp(5.0, 6.0, 0.0, 1.8), t, theta0=0.0, rtol=1e-10, atol=1e-12)
    theta = traj.theta + SIGMA * np.random.default_rng(seed).standard_normal(t.size)
    est = _dynamic()
    beyond, found = 0, None
    for ti, ai, yi in zip(t.tolist(), traj.accel.tolist(), theta.tolist(), strict=True):
        out = est.update(ti, yi)
        assert out is not None
        if not 5.0 < ti < 7.0:
            continue
        if found is None and est._onset_var > 0.0:
            found = ti
        beyond += abs(out.a - ai) > 2.0 * math.sqrt(out.variance)
    return beyond, found


def test_the_onset_test_covers_a_ramp_sooner(monkeypatch: pytest.MonkeyPatch) -> None:
    """A 1.8 m/s³ ramp: the test fires 0.15–0.3 s in and leaves at most 0.26 s beyond 2σ (the first ~0.2 s,
    which the angle cannot show yet); without it the lag term alone leaves 0.35 s or more."""
    for seed in range(3):
        beyond, found = _ramp_violations(seed)
        assert found is not None and 5.15 < found < 5.3, (seed, found)
        assert beyond <= 0.26 * RATE, (seed, beyond)
    monkeypatch.setattr(dynamic, "_ONSET_THRESHOLD", math.inf)
    for seed in range(3):
        beyond, found = _ramp_violations(seed)
        assert found is None and beyond >= 0.35 * RATE, (seed, beyond)


@pytest.mark.parametrize("rate", [1000.0, 10000.0])
def test_fast_sensors_are_tested_on_block_means(rate: float) -> None:
    """At 1 and 10 kHz the test runs on means of round(rate/200) samples: its shapes stay at ~120 points
    (not the 601 or 6001 of the window), a ramp in a swing gives back its rate within 2 %, and white noise
    passes in under 0.5 % of 1000 windows."""
    est = make_estimator("dynamic", length=LENGTH, noise_std=SIGMA, rate_hz=rate)
    assert isinstance(est, DynamicEstimator)
    test = FitOnsetTest(rate, est._c0, est._c2, min_age=0.1, max_age=0.5, threshold=20.0)
    omega = math.sqrt(9.80665 / LENGTH)
    basis = test.basis(omega)
    assert basis.u.shape[0] <= 121 and basis.u.shape[1] <= 81
    tau = (np.arange(est.width) - (est.width - 1)) / rate
    since = np.maximum(tau + 0.3, 0.0)
    cos_th, lever = math.cos(0.2), LENGTH / math.cos(0.2)
    ramp = cos_th / LENGTH * 1.5 * (omega * since - np.sin(omega * since)) / omega**3
    found = test.error(_swing(omega, 0.1, tau) + ramp, omega, 0.0, lever, SIGMA)
    assert found is not None
    m = int(np.argmin(np.abs(test._ages - 0.3)))
    assert found[0] == pytest.approx(1.5 * float(basis.response[m]), rel=0.02)
    rng = np.random.default_rng(4)
    alarms = sum(
        test.error(
            _swing(omega, 0.3, tau, phase=0.01 * k) + SIGMA * rng.standard_normal(tau.size),
            omega,
            0.3**3 / 192.0,
            lever,
            SIGMA,
        )
        is not None
        for k in range(1000)
    )
    assert alarms <= 5
