"""``lowpass``: a Butterworth IIR low-pass (scipy.signal.butter) on θ, then a = g tan θ_f.

The cut-off sits well below the oscillation frequency ω/2π so the swing is attenuated by
(f_c/f_osc)^order; the price is the filter's group delay, √2/(2π f_c) at DC for order 2.
Streaming runs the same direct-form-II-transposed recursion as scipy.signal.lfilter, started in
steady state on the first sample (lfilter_zi), so the batch path is lfilter itself.

The published variance is (g sec²θ_f)² (σ² w_k + E[b²]) plus the filter's own error:
* w_k = (1 − Σ_{j<k} h_j)² + Σ_{j<k} h_j², the exact noise gain k samples after a (re)start (the
  first sample stands in for all the past the filter was started with), → Σh² in steady state;
* what it leaves out, measured against a one-period mean θ̄ of the raw angle (``swing.SwingWindow``,
  no swing and a delay of T/2 where the filter's is √2/(2π f_c), 3.6 s at l = 1 m): e = θ_f − θ̄
  holds both the swing it lets through, |H(ω)| of it, and its lag while a changes (the start from
  rest included). θ̄ lags too, so e misses T/2 of a ramp and, when a turns, can cross zero while
  the filter is still far behind; e' = e − ¾ e₄ takes θ̄'s own lag out, e₄ = 4(θ̄ − mean_{T/4} θ̄)
  being T/2 × the rate for a ramp (``period_mean``'s; the full e₄ is exact for a ramp but overshoots
  by up to half a step for a period after one). (g sec²θ_f)² max(((|e| + x/2)² − 4(σ²/n + s))⁺,
  (e'² − 29σ²/n − 9s)⁺) is added, n the samples in the period: e counts beyond 2σ of its noise-only
  spread (σ²/n, θ̄'s, plus s), e' beyond 3σ of its (¹³⁄₄ σ²/n + s). θ_f's own noise is far smaller
  than θ̄'s once the filter has settled, but not in its first seconds, when the first sample still
  weighs (1 − S_{k−1}) in it: s = σ²(w_k − Σh²)⁺, that start-up part, which the noise term already
  counts (without it at_rest's NEES was 0.34 over 2–4 s and 0.57 over 2–10 s, 40 seeds; now 0.80, 0.84).
* x = ``swing.change_excess`` of the raw angle's period change (d, q): θ_f − θ_eq = e − (θ_eq − θ̄),
  and θ̄'s own lag is d/2 for a ramp, which the raw angle shows as soon as the bob moves while e
  (θ̄ not having moved yet) still reads 0 after a step. x/2 rather than x: with x the after-change
  NEES fell to 0.2–0.3 on the bundled scenes for a 0.8 % lower share beyond 2σ on braking (tuned there).
  The first ~0.1 s after a step (braking) stays beyond 2σ: the bob has not moved enough yet.
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
    capped,
    capped_array,
    check_batch_input,
    segments,
    wrap_clamp,
    wrap_clamp_array,
)
from pendulum_accel.estimators.swing import SwingWindow, Trail, change_excess, period_changes, trail_means
from pendulum_accel.physics.lazy import lazy_module
from pendulum_accel.physics.params import require_positive

linalg = lazy_module("scipy.linalg")
signal = lazy_module("scipy.signal")  # imported on first use: start-up (docs/portability.md)

_REF_LAG = 0.75  # the share of θ̄'s own lag, e₄, taken out of e'
_SHORT = 0.25  # e₄'s window, in swing periods
# e² counts beyond 4 × its noise-only variance (2σ), e'² beyond 9 × (3σ: it is the noisier, and the
# filter's own noise is so small that any leak of the reference's shows). In units of σ²/n, with the
# noise-only variances θ̄: 1, e' ≈ 4θ̄ − 3 mean_{T/4} θ̄: 13/4. θ_f's own noise is far smaller once the
# filter has settled; its start-up part is added to both per sample (``lag_variance``).
_SIGMAS_E, _SIGMAS_E_PRIME = 2.0, 3.0
_NOISE_E, _NOISE_E_PRIME = _SIGMAS_E**2, _SIGMAS_E_PRIME**2 * 13.0 / 4.0
_STAGES = 3  # the reference mean must leave less swing than the filter (as period_mean)
_TABLE_TOL = 1e-12  # the start-up noise gain is tabulated until the start's weight falls below this
_TABLE_MAX = 1_000_000  # samples


class LowpassEstimator(Estimator):
    """a = g tan(θ_f), θ_f = Butterworth[θ]; var = (g sec²θ_f)²(σ²w_k + E[b²] + lag), module doc."""

    name: ClassVar[str] = "lowpass"
    summary: ClassVar[str] = "g tan(Butterworth low-pass of θ)"

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
        self._swing = SwingWindow(config, stages=_STAGES)
        self._means = Trail(self._swing.horizon)
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
        return first * first + past

    def reset(self) -> None:
        """Empty the filter state; the next sample re-initialises it in steady state."""
        self._z: list[float] = []
        self._last_t: float | None = None
        self._first_t = 0.0
        self._count = 0
        self._swing.reset()
        self._means.reset()
        self._hint = 0
        self._change_hints = [0] * 5

    def _restart(self) -> None:
        """After a hole: the filter starts over, the sensor's turn-on and the swing window stay."""
        self._z = []
        self._count = 0

    def lag_variance(
        self, theta_f: float, mean: float, quarter: float, n: float, change: float, weight: float
    ) -> float:
        """max(((|e| + x/2)² − 4(σ²/n + s))⁺, (e'² − 29σ²/n − 9s)⁺) (rad²), e = θ_f − θ̄,
        e' = e − ¾·4(θ̄ − mean_{T/4} θ̄), s = σ²(w_k − Σh²)⁺ θ_f's start-up noise.

        ``quarter`` = mean_{T/4} θ̄; x = ``change``, ``swing.change_excess`` of the period change; w_k =
        ``weight``, the noise gain k samples after a start (module doc).
        """
        sigma2 = self.config.sigma**2
        noise = sigma2 / n
        startup = sigma2 * max(weight - self._noise_gain, 0.0)
        e = theta_f - mean
        e_prime = e - _REF_LAG * (mean - quarter) / _SHORT
        if not math.isfinite(e * e + e_prime * e_prime + change):
            return math.inf  # angles beyond ~1e154 rad: capped by the caller, as in ``batch``
        reach = abs(e) + 0.5 * change
        return max(
            reach * reach - _NOISE_E * (noise + startup),
            e_prime * e_prime - _NOISE_E_PRIME * noise - _SIGMAS_E_PRIME**2 * startup,
            0.0,
        )

    def update(self, t: float, theta: float) -> Estimate | None:
        """lfilter step y = b₀x + z₀, z_i = z_{i+1} + b_{i+1}x − a_{i+1}y; a = g tan y, var: module doc."""
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
        means, restarted = self._swing.push(t, theta)
        if restarted:
            self._means.reset()
        k = self._means.append(t, means.mean)
        over_quarter, _, _, self._hint = self._means.means(k, _SHORT * means.window, self._hint)
        self._means.prune(k)
        d, q, n_w = self._swing.period_change(means.mean, means.window, self._change_hints)
        rho = math.exp(-0.5 * cfg.damping * means.window)
        excess = float(change_excess(d, q, n_w, rho, cfg.sigma))
        lag = self.lag_variance(y, means.mean, over_quarter, means.n, excess, weight)
        var = gain * gain * cfg.sigma**2 * weight + capped(gain * gain * lag, cfg.error_cap)
        var += bias_variance(cfg, th, t - self._first_t)
        return Estimate(cfg.gravity * math.tan(th), var, clamped)

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """scipy.signal.lfilter per gap-free segment, zi = lfilter_zi·θ₀; same variance rule as ``update``."""
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
        if not t.size:
            return cfg.gravity * np.tan(th), weight
        mean, _, n, window = self._swing.batch(t, theta)
        noise = cfg.sigma**2 / n
        e = y - mean
        over_quarter = trail_means(t, mean, _SHORT * window, self._swing.restart_gap)
        e_prime = e - _REF_LAG * (mean - over_quarter) / _SHORT
        d, q, n_w, rho = period_changes(t, theta, mean, window, self._swing)
        reach = np.abs(e) + 0.5 * change_excess(d, q, n_w, rho, cfg.sigma)
        startup = cfg.sigma**2 * np.maximum(weight - self._noise_gain, 0.0)
        lag = np.maximum(
            np.maximum(
                reach * reach - _NOISE_E * (noise + startup),
                e_prime * e_prime - _NOISE_E_PRIME * noise - _SIGMAS_E_PRIME**2 * startup,
            ),
            0.0,
        )
        var = gain * gain * cfg.sigma**2 * weight + capped_array(gain * gain * lag, cfg.error_cap)
        var = var + bias_variance_array(cfg, th, t - t[0])
        return cfg.gravity * np.tan(th), var

    def noise_equivalent_samples(self, accel: float) -> float:
        """N = 1/Σh²: white-noise variance reduction of the filter."""
        return 1.0 / self._noise_gain

    def nominal_delay(self, accel: float) -> float:
        """Group delay at DC from scipy.signal.group_delay, in seconds."""
        _, gd = signal.group_delay((self._b, self._a), w=[0.0], fs=self.config.rate_hz)
        return float(gd[0]) / self.config.rate_hz
