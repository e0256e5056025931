"""``instant``: a = g tan θ from each sample alone — no delay, no averaging (N = 1).

Its error is what it ignores: with θ'' = −(g/l) sin θ + (a/l) cos θ − c θ', g tan θ − a =
−l(θ'' + c θ')/cos θ, the swing. It teaches the reading itself and why it needs more than one sample.

Variance: (g sec²θ)² σ² + (g sec²θ)² E[b²] — noise and bias only: it does not count the swing or the
lag, so in motion it is over-confident (docs/estimators.md).
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
    check_batch_input,
    wrap_clamp,
    wrap_clamp_array,
)


class InstantEstimator(Estimator):
    """a = g tan θ; var = (g sec²θ)²(σ² + E[b²])."""

    name: ClassVar[str] = "instant"
    summary: ClassVar[str] = "a = g tan θ per sample"
    teaching: ClassVar[bool] = True

    def __init__(self, config: EstimatorConfig) -> None:
        """The last time stamp and the sensor's turn-on."""
        super().__init__(config)
        self.reset()

    def reset(self) -> None:
        """Forget the last time stamp and the turn-on."""
        self._last_t: float | None = None
        self._first_t = 0.0

    def update(self, t: float, theta: float) -> Estimate | None:
        """a = g tan θ_c, θ_c = θ clamped below 90°; var = (g sec²θ_c)²(σ² + E[b²](t − t₀))."""
        if not self._accepts(t, theta, self._last_t):
            return None
        if self._last_t is None:
            self._first_t = t
        self._last_t = t
        cfg = self.config
        th, clamped = wrap_clamp(theta, cfg.clamp_angle)
        gain = accel_gain(th, cfg.gravity)
        var = gain * gain * cfg.sigma**2 + bias_variance(cfg, th, t - self._first_t)
        return Estimate(cfg.gravity * math.tan(th), var, clamped)

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vectorised a = g tan θ_c and the same variance as ``update``."""
        t, theta = check_batch_input(t, theta)
        cfg = self.config
        th, _ = wrap_clamp_array(theta, cfg.clamp_angle)
        gain = accel_gain_array(th, cfg.gravity)
        var = gain * gain * cfg.sigma**2
        if t.size:
            var = var + bias_variance_array(cfg, th, t - t[0])
        return cfg.gravity * np.tan(th), var

    def noise_equivalent_samples(self, accel: float) -> float:
        """N = 1: each estimate uses one sample."""
        return 1.0

    def nominal_delay(self, accel: float) -> float:
        """Zero delay."""
        return 0.0
