"""``dynamic``: invert the equation of motion, a = (l (θ'' + c θ') + g sin θ)/cos θ.

θ, θ' and θ'' come from one Savitzky-Golay least-squares polynomial fit over the last W samples
(scipy.signal.savgol_coeffs), evaluated at the window centre: causal (only past samples), with a
fixed delay of (W − 1)/2 samples and no phase distortion. A second derivative amplifies noise by
~1/(W dt)²; the window length is the noise/bandwidth knob. Linearised, the estimate is a weighted
sum of the W angles, so its noise variance is σ² Σ w_k² with w = (l/cos θ)(c₂ + c c₁) + g sec²θ c₀.

The published variance adds to that the sensor bias, (g sec²θ)² E[b²], and the two errors the fit
makes, both estimated from the method's own data:
* the swing the polynomial does not follow: for θ = A cos ωt the fit's θ, θ', θ'' are off by
  R₀ = Σc₀ cos ωτ − 1, R₁ = Σc₁ sin ωτ − ω, R₂ = Σc₂ cos ωτ + ω² (τ the samples' times from the
  centre; each a power series in ω² from the order the polynomial no longer fits exactly), so â is
  off by a sinusoid of mean square ((l/cos θ) R₂ + g sec²θ R₀)² + ((l/cos θ) c R₁)² times A²/2 =
  (var θ − σ²)⁺, var θ and ω = 2π/T over the last swing period (``swing.SwingWindow``);
* the lag while a changes: â is a at the window centre, D = (W − 1)/2 samples ago, so it trails a
  ramp by D × its rate, which is â − mean(â over the last 2D) for a ramp. Its square counts beyond
  9 × the noise variance (3σ, as kalman's motion term: â − mean(â) carries about â's own noise).
Before the window has filled the estimate is g tan θ, and the swing term is ``instant``'s.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from scipy import signal

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
from pendulum_accel.estimators.swing import SwingWindow, Trail, trail_means
from pendulum_accel.physics.params import require_positive

_LAG_THRESHOLD = 9.0  # the lag term counts beyond 9 × its noise-only variance (3σ, as kalman's)
_SWING_STAGES = 2  # T₀, then T(a₁, A₁)
_SERIES_TOL = 1e-20  # x^{2j}/(2j)! of the fit-error series' last term at the fastest swing


class DynamicEstimator(Estimator):
    """a = (l(θ'' + c θ') + g sin θ)/cos θ from a centred Savitzky-Golay fit of W samples."""

    name: ClassVar[str] = "dynamic"
    summary: ClassVar[str] = "(l θ'' + g sin θ)/cos θ with Savitzky-Golay derivatives"

    def __init__(self, config: EstimatorConfig, *, window_s: float = 0.6, polyorder: int = 4) -> None:
        """Savitzky-Golay coefficients for θ, θ', θ'' at the centre of a window_s window (nominal rate)."""
        super().__init__(config)
        window_s = require_positive("window_s", window_s)
        width = round(window_s * config.rate_hz) | 1  # odd, so the centre is a sample
        # savgol_coeffs fits raw powers of the sample index: beyond order 6 the fit is ill-conditioned.
        if int(polyorder) != polyorder or not 2 <= polyorder <= min(6, width - 1):
            raise ParameterError(f"polyorder must be an integer in 2..{min(6, width - 1)}, got {polyorder!r}")
        self.width = width
        self.polyorder = int(polyorder)
        dt = 1.0 / config.rate_hz
        pos = width // 2
        self._c0 = signal.savgol_coeffs(width, self.polyorder, deriv=0, pos=pos, use="dot")
        self._c1 = signal.savgol_coeffs(width, self.polyorder, deriv=1, delta=dt, pos=pos, use="dot")
        self._c2 = signal.savgol_coeffs(width, self.polyorder, deriv=2, delta=dt, pos=pos, use="dot")
        coeffs = np.stack([self._c0, self._c1, self._c2])
        self._gram = coeffs @ coeffs.T
        self._coeffs = coeffs.T.copy()  # (W, 3) for one matrix-vector product per sample
        self._buffer = np.zeros(2 * width)
        r0, r1, r2 = self._fit_error_series(config)
        # Highest power first, for Horner's rule.
        self._series_even = list(zip(reversed(r0), reversed(r2), strict=True))
        self._series_odd = list(reversed(r1))
        self._delay = (width // 2) * dt
        self._swing = SwingWindow(config, stages=_SWING_STAGES)
        self._outputs = Trail(2.0 * self._delay)
        self.reset()

    def _fit_error_series(self, config: EstimatorConfig) -> tuple[list[float], list[float], list[float]]:
        """Coefficients of R₀, R₁/ω, R₂ as power series in ω², zero up to the order the fit is exact.

        R = Σ_j (−1)^j ω^{2j} P_j/(2j)! with P_j = Σ c τ^{2j} (c₀, c₂);
        R₁/ω = Σ_j (−1)^j ω^{2j} Σ c₁ τ^{2j+1}/(2j+1)!; enough terms for the fastest swing the clamp
        allows, ω² = g/(l cos θ_max).
        """
        tau = (np.arange(self.width) - self.width // 2) / config.rate_hz
        x_max = math.sqrt(config.gravity / (config.length * math.cos(config.clamp_angle))) * float(tau[-1])
        terms = 2
        while x_max ** (2 * terms) / math.factorial(2 * terms) > _SERIES_TOL:
            terms += 1
        r0, r1, r2 = [], [], []
        for j in range(terms + 1):
            sign = -1.0 if j % 2 else 1.0
            exact = 2 * j <= self.polyorder
            r0.append(0.0 if exact else sign * float(self._c0 @ tau ** (2 * j)) / math.factorial(2 * j))
            r2.append(0.0 if exact else sign * float(self._c2 @ tau ** (2 * j)) / math.factorial(2 * j))
            odd = 2 * j + 1 <= self.polyorder
            r1.append(0.0 if odd else sign * float(self._c1 @ tau ** (2 * j + 1)) / math.factorial(2 * j + 1))
        return r0, r1, r2

    def fit_error_gain(self, theta: float, omega: float) -> float:
        """((l/cos θ) R₂ + g sec²θ R₀)² + ((l/cos θ) c R₁)²: â's mean-square error per A²/2 of swing at ω."""
        cfg = self.config
        y = omega * omega
        r0 = r2 = 0.0
        for c0, c2 in self._series_even:
            r0, r2 = r0 * y + c0, r2 * y + c2
        lever = cfg.length / math.cos(theta)
        real = lever * r2 + accel_gain(theta, cfg.gravity) * r0
        if not cfg.damping:
            return real * real
        r1 = 0.0
        for c1 in self._series_odd:
            r1 = r1 * y + c1
        imag = lever * cfg.damping * r1 * omega
        return real * real + imag * imag

    def _fit_error_gain_array(self, theta: np.ndarray, omega: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`fit_error_gain`, the same operations."""
        cfg = self.config
        y = omega * omega
        r0 = np.zeros_like(y)
        r2 = np.zeros_like(y)
        for c0, c2 in self._series_even:
            r0, r2 = r0 * y + c0, r2 * y + c2
        lever = cfg.length / np.cos(theta)
        real = lever * r2 + accel_gain_array(theta, cfg.gravity) * r0
        if not cfg.damping:
            return real * real
        r1 = np.zeros_like(y)
        for c1 in self._series_odd:
            r1 = r1 * y + c1
        imag = lever * cfg.damping * r1 * omega
        return real * real + imag * imag

    def reset(self) -> None:
        """Empty the window and forget the sensor's turn-on."""
        self._restart()
        self._last_t: float | None = None
        self._first_t = 0.0
        self._swing.reset()

    def _restart(self) -> None:
        """Empty the fit window and the output history (after a hole); the turn-on stays."""
        self._filled = 0
        self._head = 0
        self._outputs.reset()
        self._hint = 0

    def _accel(self, th: float, th_d: float, th_dd: float) -> tuple[float, float, bool]:
        """(a, var_a, clamped) from the fitted θ, θ', θ''."""
        cfg = self.config
        thc, clamped = wrap_clamp(th, cfg.clamp_angle)
        cos_th = math.cos(thc)
        lever = cfg.length / cos_th
        a = (cfg.length * (th_dd + cfg.damping * th_d) + cfg.gravity * math.sin(thc)) / cos_th
        v0, v1, v2 = accel_gain(thc, cfg.gravity), lever * cfg.damping, lever
        g = self._gram
        quad = (
            v0 * v0 * g[0, 0]
            + v1 * v1 * g[1, 1]
            + v2 * v2 * g[2, 2]
            + 2.0 * (v0 * v1 * g[0, 1] + v0 * v2 * g[0, 2] + v1 * v2 * g[1, 2])
        )
        return a, cfg.sigma**2 * quad, clamped

    def update(self, t: float, theta: float) -> Estimate | None:
        """Push θ; once full, fit and invert; var = σ²Σw² + (g sec²θ)²E[b²] + fit error + (lag² − 9σ²Σw²)⁺."""
        if not self._accepts(t, theta, self._last_t):
            return None
        if self._last_t is None:
            self._first_t = t
        elif t - self._last_t > self.config.gap:
            self._restart()
        self._last_t = t
        width = self.width
        # Each sample is written twice so the last W samples are always one contiguous slice.
        self._buffer[self._head] = theta
        self._buffer[self._head + width] = theta
        self._head = (self._head + 1) % width
        self._filled += 1
        cfg = self.config
        means, _ = self._swing.push(t, theta)
        swing = max(means.variance - cfg.sigma**2, 0.0)
        if self._filled < width:
            th, clamped = wrap_clamp(theta, cfg.clamp_angle)
            gain = accel_gain(th, cfg.gravity)
            a, var = cfg.gravity * math.tan(th), (gain * cfg.sigma) ** 2
            th_bar, _ = wrap_clamp(means.mean, cfg.clamp_angle)
            model = accel_gain(th_bar, cfg.gravity) ** 2 * swing
        else:
            fit = self._buffer[self._head : self._head + width] @ self._coeffs
            th_fit, th_d, th_dd = (float(x) for x in fit)
            a, var, clamped = self._accel(th_fit, th_d, th_dd)
            th, _ = wrap_clamp(th_fit, cfg.clamp_angle)
            model = self.fit_error_gain(th, 2.0 * math.pi / means.window) * swing
        k = self._outputs.append(t, a)
        mean, _, _, self._hint = self._outputs.means(k, 2.0 * self._delay, self._hint)
        self._outputs.prune(k)
        lag = a - mean
        excess = max(lag * lag - _LAG_THRESHOLD * var, 0.0)
        var += capped(model + excess, cfg.error_cap) + bias_variance(cfg, th, t - self._first_t)
        return Estimate(a, var, clamped)

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Sliding-window products per gap-free segment; the same formulas as ``update``."""
        t, theta = check_batch_input(t, theta)
        cfg = self.config
        th_c, _ = wrap_clamp_array(theta, cfg.clamp_angle)
        accel = cfg.gravity * np.tan(th_c)
        gain = accel_gain_array(th_c, cfg.gravity)
        var = (gain * cfg.sigma) ** 2
        if not t.size:
            return accel, var
        mean, mean_sq, _, window = self._swing.batch(t, theta)
        swing = np.maximum(np.maximum(mean_sq - mean * mean, 0.0) - cfg.sigma**2, 0.0)
        th_bar, _ = wrap_clamp_array(mean, cfg.clamp_angle)
        model = accel_gain_array(th_bar, cfg.gravity) ** 2 * swing
        width = self.width
        for seg in segments(t, cfg.gap):
            x = theta[seg]
            if x.size < width:
                continue
            fits = np.lib.stride_tricks.sliding_window_view(x, width) @ self._coeffs
            th, _ = wrap_clamp_array(fits[:, 0], cfg.clamp_angle)
            cos_th = np.cos(th)
            lever = cfg.length / cos_th
            a = (cfg.length * (fits[:, 2] + cfg.damping * fits[:, 1]) + cfg.gravity * np.sin(th)) / cos_th
            v0, v1, v2 = accel_gain_array(th, cfg.gravity), lever * cfg.damping, lever
            g = self._gram
            quad = (
                v0 * v0 * g[0, 0]
                + v1 * v1 * g[1, 1]
                + v2 * v2 * g[2, 2]
                + 2.0 * (v0 * v1 * g[0, 1] + v0 * v2 * g[0, 2] + v1 * v2 * g[1, 2])
            )
            start = seg.start + width - 1
            accel[start : seg.stop] = a
            var[start : seg.stop] = cfg.sigma**2 * quad
            th_c[start : seg.stop] = th
            omega = 2.0 * math.pi / window[start : seg.stop]
            model[start : seg.stop] = self._fit_error_gain_array(th, omega) * swing[start : seg.stop]
        lag = accel - trail_means(t, accel, 2.0 * self._delay, cfg.gap)
        excess = np.maximum(lag * lag - _LAG_THRESHOLD * var, 0.0)
        var = var + capped_array(model + excess, cfg.error_cap)
        return accel, var + bias_variance_array(cfg, th_c, t - t[0])

    def noise_equivalent_samples(self, accel: float) -> float:
        """N = (g sec²θ_eq)²/Σw²: the weights' white-noise gain relative to one sample at θ_eq."""
        theta = math.atan2(accel, self.config.gravity)
        _, var, _ = self._accel(theta, 0.0, 0.0)
        return (accel_gain(theta, self.config.gravity) * self.config.sigma) ** 2 / var

    def nominal_delay(self, accel: float) -> float:
        """(W − 1)/2 samples: the fit is evaluated at the window centre."""
        return (self.width // 2) / self.config.rate_hz
