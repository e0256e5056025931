"""``instant``: a = g tan θ from each sample alone — no delay, no averaging (N = 1).

Its error is exactly what it ignores: with θ'' = −(g/l) sin θ + (a/l) cos θ − c θ', g tan θ − a =
−l(θ'' + c θ')/cos θ, the swing. The published variance is (g sec²θ)² (σ² + E[b²]) plus that swing's
mean square, estimated causally from the angle itself: (g sec²θ̄)² (var θ − σ²)⁺ over the last swing
period (``swing.SwingWindow``, two stages), θ̄ the mean angle over it. A swing is a deterministic
sinusoid: with its mean square as variance the mean NEES is 1 but no error exceeds √2 σ, so the
share beyond 2σ is 0 wherever the swing dominates.

That linearised swing term misses what the swing does to g tan θ once it is large (tan is convex,
unbounded past 90° when the bob goes over the top) and a change of a within the period (the bob
swings about the new θ_eq with an amplitude of the step). Both show in the spread of â itself over
the same period, so the term published is max((g sec²θ̄)²(var θ − σ²)⁺, (var_T â − (g sec²θ)²σ²)⁺),
var_T â = mean_T â² − (mean_T â)² over the last swing period: the larger of the two, never below
the linearised one. Within the first period after a step of θ_eq by Δ the error is still the
part of the step the bob has not followed, g Δ cos ωt, while the window holds too little of the new
swing to show it: the raw angle's rate change q ≈ 2πΔ sin ωt (``swing.change_excess``, x) does, and
x/2 covers g Δ cos ωt from ωt ≈ 0.3 on, so (g sec²θ̄ x/2)² is a third candidate for the maximum
(x/2 rather than x, tuned on the bundled scenes: x lowers the after-change NEES median to 0.03–0.15
for 1 % fewer misses). Right after a step of a the angle has not moved yet and no own-data term can
know: the first ~0.1 s after each step of braking stays beyond 2σ.
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
from pendulum_accel.estimators.swing import SwingWindow, Trail, change_excess, period_changes, trail_moments

_STAGES = 2  # T₀, then T(a₁, A₁): a 1 % longer or shorter window changes var θ by < 1 %


class InstantEstimator(Estimator):
    """a = g tan θ; var = (g sec²θ)²(σ² + E[b²]) + max(swing, spread of â, (g sec²θ̄ x/2)²) (module doc)."""

    name: ClassVar[str] = "instant"
    summary: ClassVar[str] = "a = g tan θ per sample"

    def __init__(self, config: EstimatorConfig) -> None:
        """The last time stamp, the sensor's turn-on and the swing window that sizes the error."""
        super().__init__(config)
        self._swing = SwingWindow(config, stages=_STAGES)
        self._outputs = Trail(self._swing.horizon)
        self.reset()

    def reset(self) -> None:
        """Forget the last time stamp, the turn-on and the swing window."""
        self._last_t: float | None = None
        self._first_t = 0.0
        self._swing.reset()
        self._outputs.reset()
        self._hint = 0
        self._change_hints = [0] * 5

    def swing_variance(self, mean: float, variance: float) -> float:
        """(g sec²θ̄)² (var θ − σ²)⁺ ≤ error_cap: the mean-square swing in g tan θ, θ̄ = mean θ clamped."""
        cfg = self.config
        th, _ = wrap_clamp(mean, cfg.clamp_angle)
        return capped(accel_gain(th, cfg.gravity) ** 2 * max(variance - cfg.sigma**2, 0.0), cfg.error_cap)

    def update(self, t: float, theta: float) -> Estimate | None:
        """a = g tan θ_c, θ_c = θ clamped below 90°; var = (g sec²θ_c)²(σ² + E[b²]) + the max (module doc)."""
        if not self._accepts(t, theta, self._last_t):
            return None
        if self._last_t is None:
            self._first_t = t
        self._last_t = t
        cfg = self.config
        th, clamped = wrap_clamp(theta, cfg.clamp_angle)
        gain = accel_gain(th, cfg.gravity)
        accel = cfg.gravity * math.tan(th)
        means, restarted = self._swing.push(t, theta)
        if restarted:
            self._outputs.reset()
        k = self._outputs.append(t, accel)
        m1, m2, _, self._hint = self._outputs.means(k, means.window, self._hint)
        self._outputs.prune(k)
        noise = (gain * cfg.sigma) ** 2
        spread = max(m2 - m1 * m1 - noise, 0.0)
        d, q, n_w = self._swing.period_change(means.mean, means.window, self._change_hints)
        rho = math.exp(-0.5 * cfg.damping * means.window)
        th_bar, _ = wrap_clamp(means.mean, cfg.clamp_angle)
        change = 0.5 * accel_gain(th_bar, cfg.gravity) * float(change_excess(d, q, n_w, rho, cfg.sigma))
        spread = max(spread, change * change)
        var = (
            noise
            + bias_variance(cfg, th, t - self._first_t)
            + capped(max(self.swing_variance(means.mean, means.variance), spread), cfg.error_cap)
        )
        return Estimate(accel, var, clamped)

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vectorised a = g tan θ_c and the same variance as ``update``."""
        t, theta = check_batch_input(t, theta)
        cfg = self.config
        th, _ = wrap_clamp_array(theta, cfg.clamp_angle)
        var = (accel_gain_array(th, cfg.gravity) * cfg.sigma) ** 2
        var_noise = var
        if t.size:
            var = var + bias_variance_array(cfg, th, t - t[0])
            mean, mean_sq, _, window = self._swing.batch(t, theta)
            th_bar, _ = wrap_clamp_array(mean, cfg.clamp_angle)
            swing = np.maximum(mean_sq - mean * mean, 0.0)
            excess = accel_gain_array(th_bar, cfg.gravity) ** 2 * np.maximum(swing - cfg.sigma**2, 0.0)
            accel = cfg.gravity * np.tan(th)
            m1, m2 = trail_moments(t, accel, window, self._swing.restart_gap)
            spread = np.maximum(m2 - m1 * m1 - var_noise, 0.0)
            d, q, n_w, rho = period_changes(t, theta, mean, window, self._swing)
            change = 0.5 * accel_gain_array(th_bar, cfg.gravity) * change_excess(d, q, n_w, rho, cfg.sigma)
            spread = np.maximum(spread, change * change)
            var = var + capped_array(np.maximum(excess, spread), cfg.error_cap)
        return cfg.gravity * np.tan(th), var

    def noise_equivalent_samples(self, accel: float) -> float:
        """N = 1: each estimate uses one sample."""
        return 1.0

    def nominal_delay(self, accel: float) -> float:
        """Zero delay."""
        return 0.0
