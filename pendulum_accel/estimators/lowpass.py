"""``lowpass``: a Butterworth IIR low-pass (scipy.signal.butter) on θ, then a = g tan θ_f.

The cut-off sits well below the oscillation frequency ω/2π so the swing is attenuated by
(f_c/f_osc)^order; the price is the filter's group delay, √2/(2π f_c) at DC for order 2.
Streaming runs the same direct-form-II-transposed recursion as scipy.signal.lfilter, started in
steady state on the first sample (lfilter_zi), so the batch path is lfilter itself.

Variance: (g sec²θ_f)² (σ² w_k + E[b²]), w_k = (1 − Σ_{j<k} h_j)² + Σ_{j<k} h_j² the exact noise gain
k samples after a (re)start (the first sample stands in for all the past the filter was started with),
→ Σh² in steady state — noise and bias only: it does not count the swing it lets through or its lag,
so in motion it is over-confident (docs/estimators.md).
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators.base import (
    Estimate,
    Estimator,
    EstimatorConfig,
    accel_gain,
    accel_gain_array,
    bias_variance,
    bias_variance_array,
    check_batch_input,
    segments,
    wrap_clamp,
    wrap_clamp_array,
)
from pendulum_accel.physics.lazy import lazy_module
from pendulum_accel.physics.params import require_positive

linalg = lazy_module("scipy.linalg")
signal = lazy_module("scipy.signal")  # imported on first use: start-up (docs/portability.md)

_TABLE_TOL = 1e-12  # the start-up noise gain is tabulated until the start's weight falls below this
_TABLE_MAX = 1_000_000  # samples


class LowpassEstimator(Estimator):
    """a = g tan(θ_f), θ_f = Butterworth[θ]; var = (g sec²θ_f)²(σ²w_k + E[b²]), module doc."""

    name: ClassVar[str] = "lowpass"
    summary: ClassVar[str] = "g tan(Butterworth low-pass of θ)"
    teaching: ClassVar[bool] = True

    def __init__(self, config: EstimatorConfig, *, cutoff_hz: float | None = None, order: int = 2) -> None:
        """Design the filter; default f_c = f_osc(a=0)/8 = √(g/l)/(16π)."""
        super().__init__(config)
        f_osc = config.omega(0.0) / (2.0 * math.pi)
        self.cutoff_hz = f_osc / 8.0 if cutoff_hz is None else require_positive("cutoff_hz", cutoff_hz)
        if self.cutoff_hz >= 0.5 * config.rate_hz:
            raise ParameterError(
                f"cutoff_hz must be below the Nyquist rate {0.5 * config.rate_hz}, got {cutoff_hz}"
            )
        if int(order) != order or not 1 <= order <= 8:
            raise ParameterError(f"order must be an integer 1..8, got {order!r}")
        self.order = int(order)
        b, a = signal.butter(self.order, self.cutoff_hz, btype="low", fs=config.rate_hz)
        self._b = np.asarray(b, dtype=float)
        self._a = np.asarray(a, dtype=float)
        self._zi = signal.lfilter_zi(self._b, self._a)
        self._bl = [float(x) for x in self._b]
        self._al = [float(x) for x in self._a]
        self._zil = [float(x) for x in self._zi]
        self._noise_gain = self._white_noise_gain()
        self._startup = self._startup_gain()
        self.reset()

    def _white_noise_gain(self) -> float:
        """Σ h_k² of the impulse response = D² + C X Cᵀ with X the Lyapunov solution X = A X Aᵀ + B Bᵀ."""
        A, B, C, D = signal.tf2ss(self._b, self._a)
        X = linalg.solve_discrete_lyapunov(A, B @ B.T)
        return float(D[0, 0] ** 2 + (C @ X @ C.T)[0, 0])

    def _startup_gain(self) -> np.ndarray:
        """w_k = (1 − S_{k−1})² + Σ_{j<k} h_j² (S_k = Σ_{j≤k} h_j), until the start's weight is < 1e-12.

        (1 − S_{k−1}) is the weight of the first sample, which lfilter_zi extends into the past.
        """
        radius = float(np.max(np.abs(np.roots(self._a))))
        size = _TABLE_MAX if radius >= 1.0 else int(min(_TABLE_MAX, math.log(_TABLE_TOL) / math.log(radius)))
        impulse = np.zeros(max(size, 2))
        impulse[0] = 1.0
        first, _ = signal.lfilter(self._b, self._a, impulse, zi=self._zi)
        h = signal.lfilter(self._b, self._a, impulse)
        past = np.concatenate(([0.0], np.cumsum(h * h)[:-1]))
        result: np.ndarray = first * first + past
        return result

    def reset(self) -> None:
        """Empty the filter state; the next sample re-initialises it in steady state."""
        self._z: list[float] = []
        self._last_t: float | None = None
        self._first_t = 0.0
        self._count = 0

    def _restart(self) -> None:
        """After a hole: the filter starts over, the sensor's turn-on stays."""
        self._z = []
        self._count = 0

    def update(self, t: float, theta: float) -> Estimate | None:
        """lfilter step y = b₀x + z₀, z_i = z_{i+1} + b_{i+1}x − a_{i+1}y; a = g tan y;
        var = (g sec²y)²(σ²w_k + E[b²])."""
        if not self._accepts(t, theta, self._last_t):
            return None
        if self._last_t is None:
            self._first_t = t
        elif t - self._last_t > self.config.gap:
            self._restart()
        self._last_t = t
        b, a, z = self._bl, self._al, self._z
        if not z:
            z.extend(zi * theta for zi in self._zil)
        y = z[0] + b[0] * theta
        n = len(z)
        for i in range(n - 1):
            z[i] = z[i + 1] + b[i + 1] * theta - a[i + 1] * y
        z[n - 1] = b[n] * theta - a[n] * y
        weight = float(self._startup[min(self._count, self._startup.size - 1)])
        self._count += 1
        cfg = self.config
        th, clamped = wrap_clamp(y, cfg.clamp_angle)
        gain = accel_gain(th, cfg.gravity)
        var = gain * gain * cfg.sigma**2 * weight + bias_variance(cfg, th, t - self._first_t)
        return Estimate(cfg.gravity * math.tan(th), var, clamped)

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """scipy.signal.lfilter per gap-free segment, zi = lfilter_zi·θ₀; the same variance as ``update``."""
        t, theta = check_batch_input(t, theta)
        cfg = self.config
        y = np.empty_like(theta)
        count = np.empty(theta.size, dtype=int)
        for seg in segments(t, cfg.gap):
            x = theta[seg]
            y[seg], _ = signal.lfilter(self._b, self._a, x, zi=self._zi * x[0])
            count[seg] = np.arange(x.size)
        th, _ = wrap_clamp_array(y, cfg.clamp_angle)
        gain = accel_gain_array(th, cfg.gravity)
        weight = self._startup[np.minimum(count, self._startup.size - 1)]
        var = gain * gain * cfg.sigma**2 * weight
        if t.size:
            var = var + bias_variance_array(cfg, th, t - t[0])
        return cfg.gravity * np.tan(th), var

    def noise_equivalent_samples(self, accel: float) -> float:
        """N = 1/Σh²: white-noise variance reduction of the filter."""
        return 1.0 / self._noise_gain

    def nominal_delay(self, accel: float) -> float:
        """Group delay at DC from scipy.signal.group_delay, in seconds."""
        _, gd = signal.group_delay((self._b, self._a), w=[0.0], fs=self.config.rate_hz)
        return float(gd[0]) / self.config.rate_hz
