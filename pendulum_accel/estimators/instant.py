"""``instant``: a = g tan θ from each sample alone — no delay, no averaging (N = 1)."""

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
    check_batch_input,
    wrap_clamp,
    wrap_clamp_array,
)


class InstantEstimator(Estimator):
    """a = g tan θ, var_a = (g sec²θ)² σ². Exact only when the bob is at rest relative to the car."""

    name: ClassVar[str] = "instant"
    summary: ClassVar[str] = "a = g tan θ per sample"

    def __init__(self, config: EstimatorConfig) -> None:
        """No state beyond the last time stamp."""
        super().__init__(config)
        self._last_t: float | None = None

    def reset(self) -> None:
        """Forget the last time stamp."""
        self._last_t = None

    def update(self, t: float, theta: float) -> Estimate | None:
        """a = g tan θ_c with θ_c = θ clamped below 90°; var = (g sec²θ_c)² σ²."""
        if not self._accepts(t, theta, self._last_t):
            return None
        self._last_t = t
        cfg = self.config
        th, clamped = wrap_clamp(theta, cfg.clamp_angle)
        gain = accel_gain(th, cfg.gravity)
        return Estimate(cfg.gravity * math.tan(th), (gain * cfg.sigma) ** 2, clamped)

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vectorised a = g tan θ_c, var = (g sec²θ_c)² σ²."""
        t, theta = check_batch_input(t, theta)
        cfg = self.config
        th, _ = wrap_clamp_array(theta, cfg.clamp_angle)
        return cfg.gravity * np.tan(th), (accel_gain_array(th, cfg.gravity) * cfg.sigma) ** 2

    def noise_equivalent_samples(self, accel: float) -> float:
        """N = 1: each estimate uses one sample."""
        return 1.0

    def nominal_delay(self, accel: float) -> float:
        """Zero delay."""
        return 0.0
