"""``kalman``: an extended Kalman filter on x = [θ, θ', a] with the pendulum as its process model.

    θ'' = −(g/l) sin θ + (a/l) cos θ − c θ',   a' = w,  E[w²] = q_a (a random walk),
    y = θ + v,  E[v²] = σ².

Because the model knows how a swing looks, the filter separates the oscillation from the tilt that
a produces and needs neither a full period nor a delay line. q_a ((m/s²)²/s) trades noise for
speed. A car's acceleration is mostly steady with occasional manoeuvres, so q_a is adaptive: the
small ``q_accel`` (long memory, low noise) while the innovations are white, ``q_boost`` while the
normalised innovation squared ν²/S, averaged over ``boost_tau``, exceeds ``boost_nis`` (E = 1 when
the model fits; a change of a makes the innovations grow). With the defaults a 0 → 3 m/s² step
settles to 2 % in ~0.65 s and the steady RMS is ~6e-4 m/s² at σ = 1e-3 rad, 200 Hz, l = 0.5 m
(``python -m benchmarks.estimators``); ``q_boost=0`` gives the plain fixed-q_a filter.
The small q_ω ((rad/s)²/s) absorbs unmodelled damping. Written with scalar arithmetic: a 3×3
filter costs less in floats than in numpy calls.

The published variance is not the filter's P₃₃, which describes its q_a model (a random walk a
car does not follow: 60× too large at rest, far too small in a manoeuvre). It is the sum of
* the angle noise carried through the gains actually applied (a second covariance P_n propagated
  with the same F and the Joseph form (I − KH) P_n (I − KH)ᵀ + K σ² Kᵀ, no process noise);
* the sensor bias the filter cannot tell from a tilt, (g sec²θ)² E[b²](t) (EstimatorConfig);
* a motion term for the error a change of a leaves, the larger of
  - the lag while the filter is still moving â: (L ŝ)², ŝ its own rate of correcting â (k₃ν/Δt
    averaged over 50 ms, counted only beyond 3σ of its noise-only spread), L = 0.6 s, held with a
    0.05 s decay, or a 0.4 s one once q_a has stayed boosted for over 1 s: an a(t) that keeps
    moving (resonant_drive), whose error peaks where the correction rate crosses zero;
  - what is left of it afterwards: a third covariance P_m, propagated like P_n (same F, same gains,
    Joseph form without measurement noise) and raised on its a entry to (L_m ŝ)², L_m = 0.05 s,
    whenever that is larger; and, once q_a is quiet again, to (L_q ŝ_q)², ŝ_q the same rate averaged
    over 0.5 s of quiet mode (beyond 3σ of its noise), L_q = 0.25 s: the slow corrections of a
    residual the 50 ms rate cannot tell from noise. P_m decays exactly as fast as the filter actually
    removes an error of â: within ~0.1 s while boosted, over seconds in the quiet mode.
  - a ramp of a that has just begun, in quiet mode: a generalised likelihood ratio test on the
    innovations against the quiet filter's response to a ramp (``estimators.onset``) finds it ~0.1 s before
    their power does, and adds 4 × the error the fitted ramp implies.
  A change of a only enters once the angle reveals it: the first ~0.15 s of a ramp and the first
  samples after a step are beyond 2σ whatever the variance (README, "Calibration").
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators import onset
from pendulum_accel.estimators.base import (
    Estimate,
    Estimator,
    EstimatorConfig,
    accel_gain,
    bias_variance,
    check_batch_input,
    wrap_clamp,
)
from pendulum_accel.estimators.onset import OnsetTest
from pendulum_accel.physics.lazy import lazy_module
from pendulum_accel.physics.params import require_finite, require_positive

linalg = lazy_module("scipy.linalg")  # imported on first use: start-up (docs/portability.md)

_MAX_STEP = 0.01  # s; longer gaps are propagated in sub-steps so RK4 stays accurate
# The published variance's motion term (see ``_lag_term``): tuned on the bundled scenes with
# ``python -m benchmarks.calibration``.
_LAG_SPAN = 0.6  # s: error ≈ this × the rate at which the filter is still moving â
_RESIDUAL_SPAN = 0.05  # s: the same for the residual covariance P_m's a entry
_QUIET_SLOPE_TAU = 0.5  # s: averaging time of the rate in quiet mode (and the quiet time before it counts)
_QUIET_SPAN = 0.25  # s: residual ≈ this × that slow rate
_SLOPE_TAU = 0.05  # s: averaging time of that rate
_SLOPE_THRESHOLD = 9.0  # rate² must exceed this × its noise-only expectation (a 3σ test)
_HOLD_TAU = 0.05  # s: the lag term decays no faster than this once the rate drops
# A manoeuvre that keeps q_a boosted longer than any single change of a takes to absorb is an a(t) that
# keeps moving (a drive at the swing's resonance): there the error is largest where the correction rate
# crosses zero, a quarter cycle after it peaks, so the held term decays over a longer time.
_SUSTAINED = 1.0  # s of unbroken boost after which a manoeuvre counts as sustained
_HOLD_TAU_SUSTAINED = 0.4  # s: the lag term's decay time then
# The onset test (``_onset_term``): a ramp of a that has just begun, found in the quiet filter's innovations
# before their power gives it away. Tuned on the bundled scenes with ``python -m benchmarks.calibration``.
_ONSET_WINDOW = 0.4  # s: the onsets tried lie this far back at most
_ONSET_MIN_AGE = 0.1  # s: younger onsets fit a step's first samples or noise, not a ramp
_ONSET_THRESHOLD = 14.0  # GLR statistic beyond which an onset counts as found (χ²₁ for one onset tried)
_ONSET_TAU = 0.05  # s: what it adds decays this fast once the test no longer passes
_ONSET_TAU_BOOSTED = 0.1  # s: its decay once q_a is boosted, while the lag term catches up
_ONSET_MARGIN = 4.0  # the variance added is this × the error the fitted ramp implies (it keeps growing)


def _propagate(
    p: list[float], f: tuple[float, float, float, float, float, float], q_rate_dt: float, q_accel_dt: float
) -> list[float]:
    """F P Fᵀ + diag(0, q_ω dt, q_a dt); P = [P00 P01 P02 P11 P12 P22], F rows 0-1 given, row 2 = e₃."""
    f00, f01, f02, f10, f11, f12 = f
    p00, p01, p02, p11, p12, p22 = p
    # Rows of F P (third row of F is [0, 0, 1]).
    a00 = f00 * p00 + f01 * p01 + f02 * p02
    a01 = f00 * p01 + f01 * p11 + f02 * p12
    a02 = f00 * p02 + f01 * p12 + f02 * p22
    a10 = f10 * p00 + f11 * p01 + f12 * p02
    a11 = f10 * p01 + f11 * p11 + f12 * p12
    a12 = f10 * p02 + f11 * p12 + f12 * p22
    return [
        a00 * f00 + a01 * f01 + a02 * f02,
        a00 * f10 + a01 * f11 + a02 * f12,
        a02,
        a10 * f10 + a11 * f11 + a12 * f12 + q_rate_dt,
        a12,
        p22 + q_accel_dt,
    ]


def _joseph(p: list[float], k0: float, k1: float, k2: float, r: float) -> list[float]:
    """(I − KH) P (I − KH)ᵀ + K r Kᵀ with H = [1, 0, 0]: P after a correction with any gain K."""
    p00, p01, p02, p11, p12, p22 = p
    m0 = 1.0 - k0
    return [
        m0 * m0 * p00 + k0 * k0 * r,
        m0 * (p01 - k1 * p00) + k0 * k1 * r,
        m0 * (p02 - k2 * p00) + k0 * k2 * r,
        p11 - 2.0 * k1 * p01 + k1 * k1 * (p00 + r),
        p12 - k2 * p01 - k1 * p02 + k1 * k2 * (p00 + r),
        p22 - 2.0 * k2 * p02 + k2 * k2 * (p00 + r),
    ]


class KalmanEstimator(Estimator):
    """EKF on [θ, θ', a]; â = x₃, var_a = noise + bias + motion terms (module doc); RK4 propagation."""

    name: ClassVar[str] = "kalman"
    summary: ClassVar[str] = "EKF on [θ, θ', a] with the pendulum equation as process model"

    def __init__(
        self,
        config: EstimatorConfig,
        *,
        q_accel: float = 1e-5,
        q_boost: float = 1e-2,
        boost_nis: float = 3.0,
        boost_tau: float = 0.05,
        q_rate: float = 1e-4,
        init_angle_std: float = 0.3,
        reset_gap: float = 1.0,
    ) -> None:
        """q_accel/q_boost: steady/manoeuvre random-walk density of a; q_rate: of θ'; A₀ = init_angle_std."""
        super().__init__(config)
        self.q_accel = require_positive("q_accel", q_accel)
        self.q_boost = require_finite("q_boost", q_boost)
        self.q_rate = require_finite("q_rate", q_rate)
        for name, value in (("q_boost", self.q_boost), ("q_rate", self.q_rate)):
            if value < 0.0:
                raise ParameterError(f"{name} must be >= 0, got {value!r}")
        self.boost_nis = require_positive("boost_nis", boost_nis)
        self.boost_tau = require_positive("boost_tau", boost_tau)
        self.init_angle_std = require_positive("init_angle_std", init_angle_std)
        self.reset_gap = require_positive("reset_gap", reset_gap)
        # Plain floats for the per-sample code.
        self._g, self._l_inv, self._c = config.gravity, 1.0 / config.length, config.damping
        self._r = config.sigma**2
        self._a_max = config.gravity * math.tan(config.clamp_angle)
        onset.warm_cache()
        self.reset()

    def reset(self) -> None:
        """Forget the state; the next sample initialises it at rest."""
        self._last_t: float | None = None
        self._x = [0.0, 0.0, 0.0]
        self._p = [0.0] * 6  # P00 P01 P02 P11 P12 P22
        self._pn = [0.0] * 6  # the same entries, angle noise only, propagated with the gains applied
        self._first_t: float | None = None  # sensor turn-on, for the bias variance
        self._slope = 0.0  # running mean of k₃ν/Δt
        self._slope_noise = 0.0  # running mean of k₃²S/Δt², its noise-only expectation per sample
        self._hold = 0.0  # the held lag term
        self._quiet_slope = self._quiet_slope_noise = self._quiet_time = 0.0  # the same over quiet mode
        self._pm = [0.0] * 6  # the residual motion covariance, propagated with the gains applied
        self._nis = 1.0  # running mean of ν²/S
        self._boost_time = 0.0  # how long q_a has been boosted without a break (s)
        self._q_now = self.q_accel
        self._onset: OnsetTest | None = None  # built at the first correction, from the steady filter
        self._onset_var = 0.0  # the onset test's variance, while it holds

    def _initialise(self, theta: float) -> None:
        """x = [θ, 0, g tan θ]; P = diag(σ², (ω₀ A)², (g sec²θ A)²) with A = init_angle_std."""
        cfg = self.config
        th, _ = wrap_clamp(theta, cfg.clamp_angle)
        amp = self.init_angle_std
        self._x = [theta, 0.0, cfg.gravity * math.tan(th)]
        w0 = cfg.omega(0.0)
        ga = accel_gain(th, cfg.gravity)
        self._p = [cfg.sigma**2, 0.0, 0.0, (w0 * amp) ** 2, 0.0, (ga * amp) ** 2]
        # The start-up uncertainty (an unknown swing) is real error, so P_n starts from P too.
        self._pn = list(self._p)
        self._slope = self._slope_noise = self._hold = 0.0
        self._quiet_slope = self._quiet_slope_noise = self._quiet_time = 0.0
        self._pm = [0.0] * 6
        self._nis, self._q_now = 1.0, self.q_accel
        self._boost_time = self._onset_var = 0.0
        if self._onset is not None:
            self._onset.clear()

    def _predict(self, dt: float) -> None:
        """x ← RK4(x, dt); P ← F P Fᵀ + Q with F = I + J dt + J² dt²/2, Q = diag(0, q_ω dt, q_a dt).

        θ'' = (a cos θ − g sin θ)/l − c θ' (physics.rigid.theta_ddot), written out inline: this runs
        once per sample; ``test/test_equation_of_motion.py`` holds the step and J to theta_ddot.
        """
        th, om, ac = self._x
        g, l_inv, c = self._g, self._l_inv, self._c
        cos_th, sin_th = math.cos(th), math.sin(th)
        # Jacobian J = [[0, 1, 0], [j10, -c, j12], [0, 0, 0]] at the prior state.
        j10 = -(g * cos_th + ac * sin_th) * l_inv
        j12 = cos_th * l_inv
        h2 = 0.5 * dt * dt
        # F = I + J dt + J² dt²/2; J² = [[j10, -c, j12], [-c j10, j10 + c², -c j12], [0, 0, 0]].
        f00, f01, f02 = 1.0 + j10 * h2, dt - c * h2, j12 * h2
        f10, f11, f12 = j10 * dt - c * j10 * h2, 1.0 - c * dt + (j10 + c * c) * h2, j12 * dt - c * j12 * h2
        half = 0.5 * dt
        w1 = (ac * cos_th - g * sin_th) * l_inv - c * om
        th2, om2 = th + half * om, om + half * w1
        w2 = (ac * math.cos(th2) - g * math.sin(th2)) * l_inv - c * om2
        th3, om3 = th + half * om2, om + half * w2
        w3 = (ac * math.cos(th3) - g * math.sin(th3)) * l_inv - c * om3
        th4, om4 = th + dt * om3, om + dt * w3
        w4 = (ac * math.cos(th4) - g * math.sin(th4)) * l_inv - c * om4
        sixth = dt / 6.0
        self._x = [
            th + sixth * (om + 2.0 * om2 + 2.0 * om3 + om4),
            om + sixth * (w1 + 2.0 * w2 + 2.0 * w3 + w4),
            ac,
        ]
        f = (f00, f01, f02, f10, f11, f12)
        self._p = _propagate(self._p, f, self.q_rate * dt, self._q_now * dt)
        self._pn = _propagate(self._pn, f, 0.0, 0.0)
        self._pm = _propagate(self._pm, f, 0.0, 0.0)

    def _correct(self, theta: float, dt: float) -> None:
        """K = P Hᵀ/S, x ← x + K ν, P ← P − K Kᵀ S (H = [1, 0, 0], S = P₀₀ + σ²); then pick the next q_a."""
        p00, p01, p02, p11, p12, p22 = self._p
        s = p00 + self._r
        k0, k1, k2 = p00 / s, p01 / s, p02 / s
        innovation = theta - self._x[0]
        # At least ~10 samples in the average, or χ²₁ scatter alone would trigger the boost at low rates.
        self._nis += min(0.1, dt / self.boost_tau) * (innovation * innovation / s - self._nis)
        boosted = self._nis > self.boost_nis and self.q_boost > self.q_accel
        self._q_now = self.q_boost if boosted else self.q_accel
        x = self._x
        self._x = [x[0] + k0 * innovation, x[1] + k1 * innovation, x[2] + k2 * innovation]
        self._p = [
            p00 - k0 * p00,
            p01 - k0 * p01,
            p02 - k0 * p02,
            p11 - k1 * p01,
            p12 - k1 * p02,
            p22 - k2 * p02,
        ]
        self._pn = _joseph(self._pn, k0, k1, k2, self._r)
        self._pm = _joseph(self._pm, k0, k1, k2, 0.0)
        self._lag_term(k2 * innovation, k2 * k2 * s, dt)
        self._onset_term(innovation, s, dt)

    def _lag_term(self, correction: float, correction_var: float, dt: float) -> None:
        """Hold ← max(L² X, hold·e^{−Δt/τ_h}), P_m₃₃ ← max(P_m₃₃, L_m² X, L_q² X_q);
        X = (ŝ² − 9 E_noise[ŝ²])⁺, ŝ = EWMA of k₃ν/Δt over 50 ms; X_q the same over 0.5 s of quiet mode."""
        alpha = min(1.0, dt / _SLOPE_TAU)
        self._slope += alpha * (correction / dt - self._slope)
        self._slope_noise += alpha * (correction_var / (dt * dt) - self._slope_noise)
        # An EWMA of white values of variance v has variance v α/(2 − α).
        noise = self._slope_noise * alpha / (2.0 - alpha)
        excess = max(0.0, self._slope * self._slope - _SLOPE_THRESHOLD * noise)
        self._boost_time = self._boost_time + dt if self._q_now > self.q_accel else 0.0
        hold_tau = _HOLD_TAU_SUSTAINED if self._boost_time > _SUSTAINED else _HOLD_TAU
        self._hold = max(excess * _LAG_SPAN**2, self._hold * math.exp(-dt / hold_tau))
        self._pm[5] = max(self._pm[5], excess * _RESIDUAL_SPAN**2)
        if self._q_now > self.q_accel:  # boosted: the 50 ms rate covers it; start the quiet average afresh
            self._quiet_slope = self._quiet_slope_noise = self._quiet_time = 0.0
            return
        beta = min(1.0, dt / _QUIET_SLOPE_TAU)
        self._quiet_slope += beta * (correction / dt - self._quiet_slope)
        self._quiet_slope_noise += beta * (correction_var / (dt * dt) - self._quiet_slope_noise)
        self._quiet_time += dt
        if self._quiet_time > _QUIET_SLOPE_TAU:  # the averages have filled
            noise_q = self._quiet_slope_noise * beta / (2.0 - beta)
            excess_q = max(0.0, self._quiet_slope * self._quiet_slope - _SLOPE_THRESHOLD * noise_q)
            self._pm[5] = max(self._pm[5], excess_q * _QUIET_SPAN**2)

    def _onset_term(self, innovation: float, s: float, dt: float) -> None:
        """V_o ← max(V_o e^{−Δt/τ}, M (ê² + var(ĵ) h(k̂)²)) when the GLR λ(k̂) = (Σ g ν)²/(S Σ g²) of a ramp
        begun k̂ samples ago passes the threshold; ĵ = Σ g ν / Σ g², ê = ĵ h(k̂) (``estimators.onset``). In
        quiet mode only: once q_a is boosted V_o decays over 0.1 s while the lag term catches up."""
        if self._q_now > self.q_accel:  # boosted: the innovations no longer follow the quiet response
            self._onset_var *= math.exp(-dt / _ONSET_TAU_BOOSTED)
            if self._onset is not None:
                self._onset.clear()
            return
        if self._onset is None:
            transition, gain, _ = self.steady_state(0.0)
            self._onset = OnsetTest(
                transition, gain, self.config.rate_hz, _ONSET_WINDOW, _ONSET_MIN_AGE, _ONSET_THRESHOLD
            )
        found = self._onset.push(innovation, s)
        decayed = self._onset_var * math.exp(-dt / _ONSET_TAU)
        self._onset_var = decayed if found is None else max(decayed, _ONSET_MARGIN * found)

    def variance(self, t: float) -> float:
        """Published var(â) at time t: P_n₃₃ + (g sec²θ)² E[b²](t − t₀) + max(held lag, P_m₃₃, onset V_o)."""
        cfg = self.config
        th, _ = wrap_clamp(self._x[0], cfg.clamp_angle)
        elapsed = 0.0 if self._first_t is None else t - self._first_t
        return self._pn[5] + bias_variance(cfg, th, elapsed) + max(self._hold, self._pm[5], self._onset_var)

    def update(self, t: float, theta: float) -> Estimate | None:
        """Predict to t (sub-steps ≤ 10 ms), correct with θ; â = x₃ clamped to g tan(clamp), var = P₃₃."""
        if not self._accepts(t, theta, self._last_t):
            return None
        if self._first_t is None:
            self._first_t = t
        if self._last_t is None or t - self._last_t > self.reset_gap:
            self._initialise(theta)
        else:
            dt = t - self._last_t
            steps = max(1, math.ceil(dt / _MAX_STEP))
            for _ in range(steps):
                self._predict(dt / steps)
            self._correct(theta, dt)
        x, p = self._x, self._p
        # NaN and inf propagate through a sum: one test covers every number.
        if not math.isfinite(sum(x) + sum(p) + sum(self._pn) + sum(self._pm) + self._hold + self._onset_var):
            self._initialise(theta)  # a diverged filter restarts rather than publish inf/NaN
        self._last_t = t
        a = self._x[2]
        clamped = abs(a) > self._a_max
        if clamped:
            a = math.copysign(self._a_max, a)
        return Estimate(a, self.variance(t), clamped)

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Run ``update`` over the samples from a fresh filter (a Kalman filter is sequential by nature)."""
        t, theta = check_batch_input(t, theta)
        twin = KalmanEstimator(
            self.config,
            q_accel=self.q_accel,
            q_boost=self.q_boost,
            boost_nis=self.boost_nis,
            boost_tau=self.boost_tau,
            q_rate=self.q_rate,
            init_angle_std=self.init_angle_std,
            reset_gap=self.reset_gap,
        )
        accel = np.empty(t.size)
        var = np.empty(t.size)
        for i, (ti, yi) in enumerate(zip(t.tolist(), theta.tolist(), strict=True)):
            est = twin.update(ti, yi)
            assert est is not None  # inputs were checked finite and increasing
            accel[i], var[i] = est.a, est.variance
        return accel, var

    def steady_state(self, accel: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(F, K, P⁺) at rest at θ_eq(a) with q_a = q_accel: DARE prior P⁻, K = P⁻Hᵀ/S, P⁺ = (I − KH)P⁻."""
        cfg = self.config
        dt = 1.0 / cfg.rate_hz
        th = math.atan2(accel, cfg.gravity)
        jac = np.array(
            [
                [0.0, 1.0, 0.0],
                [
                    -(cfg.gravity * math.cos(th) + accel * math.sin(th)) / cfg.length,
                    -cfg.damping,
                    math.cos(th) / cfg.length,
                ],
                [0.0, 0.0, 0.0],
            ]
        )
        F = linalg.expm(jac * dt)
        Q = np.diag([0.0, self.q_rate * dt, self.q_accel * dt])
        H = np.array([[1.0, 0.0, 0.0]])
        R = np.array([[cfg.sigma**2]])
        prior = linalg.solve_discrete_are(F.T, H.T, Q, R)
        K = prior @ H.T / (H @ prior @ H.T + R)
        posterior = (np.eye(3) - K @ H) @ prior
        return F, K[:, 0], posterior

    def _closed_loop(self, accel: float) -> tuple[float, float, float]:
        """(Σw, Σw², Σ j w_j) of the steady filter's impulse response w_j = e₃ᵀ Mʲ K, M = (I − KH)F."""
        F, K, _ = self.steady_state(accel)
        H = np.array([[1.0, 0.0, 0.0]])
        M = (np.eye(3) - np.outer(K, H)) @ F
        inv = np.linalg.inv(np.eye(3) - M)
        total = float((inv @ K)[2])
        energy = float(linalg.solve_discrete_lyapunov(M, np.outer(K, K))[2, 2])
        moment = float((M @ inv @ inv @ K)[2])
        return total, energy, moment

    def noise_equivalent_samples(self, accel: float) -> float:
        """N = (Σw)²/Σw² of the steady-state gain's impulse response (an EWMA of gain k gives (2 − k)/k)."""
        total, energy, _ = self._closed_loop(accel)
        return total * total / energy

    def nominal_delay(self, accel: float) -> float:
        """Σ j w_j / Σ w_j samples: the DC group delay of the steady-state filter, in seconds."""
        total, _, moment = self._closed_loop(accel)
        return moment / total / self.config.rate_hz
