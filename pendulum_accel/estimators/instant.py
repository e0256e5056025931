"""``instant``: a = g tan θ from each sample alone — no delay, no averaging (N = 1).

Its error is exactly what it ignores: with θ'' = −(g/l) sin θ + (a/l) cos θ − c θ', g tan θ − a =
−l(θ'' + c θ')/cos θ, the swing. The published variance is (g sec²θ)² (σ² + E[b²]) plus that swing's
mean square, estimated causally from the angle itself: (g sec²θ̄)² (var θ − σ²)⁺ over the last swing
period (``swing.SwingWindow``, two stages), θ̄ the mean angle over it. A swing is a deterministic
sinusoid: with its mean square as variance the mean NEES is 1 but no error exceeds √2 σ, so the
share beyond 2σ is 0 wherever the swing dominates.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np

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
    wrap_clamp,
    wrap_clamp_array,
)
from pendulum_accel.estimators.swing import SwingWindow

_STAGES = 2  # T₀, then T(a₁, A₁): a 1 % longer or shorter window changes var θ by < 1 %


class InstantEstimator(Estimator):
    """a = g tan θ; var = (g sec²θ)²(σ² + E[b²]) + (g sec²θ̄)²(var θ − σ²)⁺ over the last swing period."""

    name: ClassVar[str] = "instant"
    summary: ClassVar[str] = "a = g tan θ per sample"

    def __init__(self, config: EstimatorConfig) -> None:
        """The last time stamp, the sensor's turn-on and the swing window that sizes the error."""
        super().__init__(config)
        self._swing = SwingWindow(config, stages=_STAGES)
        self.reset()

    def reset(self) -> None:
        """Forget the last time stamp, the turn-on and the swing window."""
        self._last_t: float | None = None
        self._first_t = 0.0
        self._swing.reset()

    def swing_variance(self, mean: float, variance: float) -> float:
        """(g sec²θ̄)² (var θ − σ²)⁺ ≤ error_cap: the mean-square swing in g tan θ, θ̄ = mean θ clamped."""
        cfg = self.config
        th, _ = wrap_clamp(mean, cfg.clamp_angle)
        return capped(accel_gain(th, cfg.gravity) ** 2 * max(variance - cfg.sigma**2, 0.0), cfg.error_cap)

    def update(self, t: float, theta: float) -> Estimate | None:
        """a = g tan θ_c with θ_c = θ clamped below 90°; var = (g sec²θ_c)²(σ² + E[b²]) + swing term."""
        if not self._accepts(t, theta, self._last_t):
            return None
        if self._last_t is None:
            self._first_t = t
        self._last_t = t
        cfg = self.config
        th, clamped = wrap_clamp(theta, cfg.clamp_angle)
        gain = accel_gain(th, cfg.gravity)
        means, _ = self._swing.push(t, theta)
        var = (
            (gain * cfg.sigma) ** 2
            + bias_variance(cfg, th, t - self._first_t)
            + self.swing_variance(means.mean, means.variance)
        )
        return Estimate(cfg.gravity * math.tan(th), var, clamped)

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vectorised a = g tan θ_c and the same variance as ``update``."""
        t, theta = check_batch_input(t, theta)
        cfg = self.config
        th, _ = wrap_clamp_array(theta, cfg.clamp_angle)
        var = (accel_gain_array(th, cfg.gravity) * cfg.sigma) ** 2
        if t.size:
            var = var + bias_variance_array(cfg, th, t - t[0])
            mean, mean_sq, _, _ = self._swing.batch(t, theta)
            th_bar, _ = wrap_clamp_array(mean, cfg.clamp_angle)
            swing = np.maximum(mean_sq - mean * mean, 0.0)
            excess = accel_gain_array(th_bar, cfg.gravity) ** 2 * np.maximum(swing - cfg.sigma**2, 0.0)
            var = var + capped_array(excess, cfg.error_cap)
        return cfg.gravity * np.tan(th), var

    def noise_equivalent_samples(self, accel: float) -> float:
        """N = 1: each estimate uses one sample."""
        return 1.0

    def nominal_delay(self, accel: float) -> float:
        """Zero delay."""
        return 0.0
