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
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from scipy import linalg

from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators.base import (
    Estimate,
    Estimator,
    EstimatorConfig,
    accel_gain,
    check_batch_input,
    wrap_clamp,
)
from pendulum_accel.physics.params import require_finite, require_positive

_MAX_STEP = 0.01  # s; longer gaps are propagated in sub-steps so RK4 stays accurate


class KalmanEstimator(Estimator):
    """EKF on [θ, θ', a]; â = x₃ and var_a = P₃₃. RK4 state propagation, 2nd-order Jacobian exponential."""

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
        self.reset()

    def reset(self) -> None:
        """Forget the state; the next sample initialises it at rest."""
        self._last_t: float | None = None
        self._x = [0.0, 0.0, 0.0]
        self._p = [0.0] * 6  # P00 P01 P02 P11 P12 P22
        self._nis = 1.0  # running mean of ν²/S
        self._q_now = self.q_accel

    def _initialise(self, theta: float) -> None:
        """x = [θ, 0, g tan θ]; P = diag(σ², (ω₀ A)², (g sec²θ A)²) with A = init_angle_std."""
        cfg = self.config
        th, _ = wrap_clamp(theta, cfg.clamp_angle)
        amp = self.init_angle_std
        self._x = [theta, 0.0, cfg.gravity * math.tan(th)]
        w0 = cfg.omega(0.0)
        ga = accel_gain(th, cfg.gravity)
        self._p = [cfg.sigma**2, 0.0, 0.0, (w0 * amp) ** 2, 0.0, (ga * amp) ** 2]
        self._nis, self._q_now = 1.0, self.q_accel

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
        p00, p01, p02, p11, p12, p22 = self._p
        # Rows of F P (third row of F is [0, 0, 1]).
        a00 = f00 * p00 + f01 * p01 + f02 * p02
        a01 = f00 * p01 + f01 * p11 + f02 * p12
        a02 = f00 * p02 + f01 * p12 + f02 * p22
        a10 = f10 * p00 + f11 * p01 + f12 * p02
        a11 = f10 * p01 + f11 * p11 + f12 * p12
        a12 = f10 * p02 + f11 * p12 + f12 * p22
        self._p = [
            a00 * f00 + a01 * f01 + a02 * f02,
            a00 * f10 + a01 * f11 + a02 * f12,
            a02,
            a10 * f10 + a11 * f11 + a12 * f12 + self.q_rate * dt,
            a12,
            p22 + self._q_now * dt,
        ]

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

    def update(self, t: float, theta: float) -> Estimate | None:
        """Predict to t (sub-steps ≤ 10 ms), correct with θ; â = x₃ clamped to g tan(clamp), var = P₃₃."""
        if not self._accepts(t, theta, self._last_t):
            return None
        if self._last_t is None or t - self._last_t > self.reset_gap:
            self._initialise(theta)
        else:
            dt = t - self._last_t
            steps = max(1, math.ceil(dt / _MAX_STEP))
            for _ in range(steps):
                self._predict(dt / steps)
            self._correct(theta, dt)
        x, p = self._x, self._p
        # NaN and inf propagate through a sum: one test covers all nine numbers.
        if not math.isfinite(x[0] + x[1] + x[2] + p[0] + p[1] + p[2] + p[3] + p[4] + p[5]):
            self._initialise(theta)  # a diverged filter restarts rather than publish inf/NaN
        self._last_t = t
        a = self._x[2]
        clamped = abs(a) > self._a_max
        if clamped:
            a = math.copysign(self._a_max, a)
        return Estimate(a, self._p[5], clamped)

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
