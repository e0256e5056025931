"""``period_mean``: the time average of θ over one oscillation period, then a = g tan θ̄.

The bob oscillates symmetrically about θ_eq = atan(a/g) (the potential is gravity rotated by θ_eq),
so the mean *angle* over a period is θ_eq whatever the amplitude. The mean of g tan θ is not: by
Jensen's inequality it is biased high, +0.5 % at 0.1 rad amplitude and +16 % at 0.5 rad (a = 3 m/s²).

The period T = 2π/ω with ω² = √(g² + a²)/l depends on the estimate itself, so the average is done
in stages: first over T₀ = 2π√(l/g) (the small-swing period at a = 0) to get a₁ and the swing
amplitude A₁ (from the variance of θ, 2 var θ = A²(1 + A²/96): ``swing.swing_amplitude``), then over
T(a₁, A₁) for a₂ and A₂, then over T(a₂, A₂) (each stage cuts the period error ~20×; ``stages`` = 3 by
default). A swing of amplitude A lasts longer than 2π/ω: the exact libration period is
T = (2π/ω)/AGM(1, cos(A/2)) (= 4K(sin²(A/2))/ω); ``exact_period=False`` keeps the small-swing 2π/ω.
The averages are exact integrals of the piecewise-linear θ(t) and θ²(t) over [t − T, t] (trapezoid
rule), so irregular sampling is handled; a hole longer than a quarter of T₀ (or ``max_gap``) restarts
the average (``swing.SwingWindow``).

Variance: (g sec²θ̄)² (σ²/n + E[b²]), n the samples in the window — noise and bias only: it does not
count the swing or the lag (T/2 while a changes), so in motion it is over-confident (docs/estimators.md).
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
    wrap_clamp,
    wrap_clamp_array,
)
from pendulum_accel.estimators.swing import SwingWindow


class PeriodMeanEstimator(Estimator):
    """a = g tan(θ̄), θ̄ = mean θ over one swing period T(â, A); var = (g sec²θ̄)²(σ²/n + E[b²])."""

    name: ClassVar[str] = "period_mean"
    summary: ClassVar[str] = "g tan(mean θ over one swing period)"
    teaching: ClassVar[bool] = True

    def __init__(self, config: EstimatorConfig, *, exact_period: bool = True, stages: int = 3) -> None:
        """Empty history; T₀ = 2π√(l/g); ``exact_period`` lengthens T for the swing amplitude."""
        super().__init__(config)
        self.exact_period = bool(exact_period)
        if int(stages) != stages or not 2 <= stages <= 5:
            raise ParameterError(f"stages must be an integer 2..5, got {stages!r}")
        self.stages = int(stages)
        self._swing = SwingWindow(config, stages=self.stages, exact_period=self.exact_period)
        self.reset()

    def reset(self) -> None:
        """Forget the history."""
        self._swing.reset()
        self._last_t: float | None = None
        self._first_t = 0.0

    def update(self, t: float, theta: float) -> Estimate | None:
        """Append θ; average over T₀ for a₁ and A, then over T(a₁, A); a = g tan θ̄, var as the class says."""
        if not self._accepts(t, theta, self._last_t):
            return None
        if self._last_t is None:
            self._first_t = t
        self._last_t = t
        cfg = self.config
        means, _ = self._swing.push(t, theta)
        th, clamped = wrap_clamp(means.mean, cfg.clamp_angle)
        gain = accel_gain(th, cfg.gravity)
        var = gain * gain * cfg.sigma**2 / means.n + bias_variance(cfg, th, t - self._first_t)
        return Estimate(cfg.gravity * math.tan(th), var, clamped)

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vectorised staged window means per stretch between restarts, the same formulas as ``update``."""
        t, theta = check_batch_input(t, theta)
        cfg = self.config
        mean, _, n, _ = self._swing.batch(t, theta)
        th, _ = wrap_clamp_array(mean, cfg.clamp_angle)
        gain = accel_gain_array(th, cfg.gravity)
        if not t.size:
            return cfg.gravity * np.tan(th), np.empty(0)
        var = gain * gain * cfg.sigma**2 / n + bias_variance_array(cfg, th, t - t[0])
        return cfg.gravity * np.tan(th), var

    def noise_equivalent_samples(self, accel: float) -> float:
        """N = T(a)·f: the samples in one small-swing period at the nominal rate."""
        return self.config.period(accel) * self.config.rate_hz

    def nominal_delay(self, accel: float) -> float:
        """T(a)/2, the centre of the averaging window."""
        return 0.5 * self.config.period(accel)
