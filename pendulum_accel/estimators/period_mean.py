"""``period_mean``: the time average of θ over one oscillation period, then a = g tan θ̄.

The bob oscillates symmetrically about θ_eq = atan(a/g) (the potential is gravity rotated by θ_eq),
so the mean *angle* over a period is θ_eq whatever the amplitude. The mean of g tan θ is not: by
Jensen's inequality it is biased high, +0.5 % at 0.1 rad amplitude and +16 % at 0.5 rad (a = 3 m/s²).

The period T = 2π/ω with ω² = √(g² + a²)/l depends on the estimate itself, so the average is done
in stages: first over T₀ = 2π√(l/g) (the small-swing period at a = 0) to get a₁ and the swing
amplitude A₁ (from the variance of θ, 2 var θ = A²(1 + A²/96): ``swing.swing_amplitude``), then over
T(a₁, A₁) for a₂ and A₂, then over T(a₂, A₂) (each stage cuts the period error ~20×; ``stages`` = 3 by
default). A swing of amplitude A lasts longer than 2π/ω: the exact libration period is
T = (2π/ω)/AGM(1, cos(A/2)) (= 4K(sin²(A/2))/ω); ``exact_period=False`` keeps the small-swing 2π/ω
(0.6 % short at A = 0.3 rad, which leaves a residual swing in the average). The averages are exact
integrals of the piecewise-linear θ(t) and θ²(t) over [t − T, t], accumulated by the trapezoid
rule, so irregular sampling is handled; a hole longer than a quarter of T₀ (or ``max_gap``) restarts
the average (``swing.SwingWindow``, shared with the other methods).

The published variance is (g sec²θ̄)² (σ²/n + E[b²] + lag), n the samples in the window: the noise
of the mean, the sensor bias and what the average leaves in. While a changes the mean lags the newest
angle by T/2; the method measures that from its own outputs. For a ramp, θ̄ runs ahead of its own
mean over the last period by exactly the lag (e₁ = θ̄ − mean_T θ̄), and ahead of its mean over the
last quarter period by a quarter of it (e₄ = 4(θ̄ − mean_{T/4} θ̄)). e₁ also holds, in phase, any swing
the window leaves in θ̄ (a damped swing, a period estimate slightly off), but stays large for a
period after a change ends; e₄ forgets the change within T/4 but magnifies a left-over swing.
lag = min((e₁² − ⅔σ²/n)⁺, (e₄² − ⁸⁄₃σ²/n)⁺): each square less its expected noise-only part (for white
angle noise var e₁ = ⅔σ²/n, var e₄ = ⁸⁄₃σ²/n), the smaller of the two.

Both come from θ̄, which moves only as the change enters its window: after a step they are still
small when the lag is the whole step, and a ramp's e₁ builds up over a period. The raw angle shows
the change as soon as the bob moves: the published lag is max(min(e₁², e₄²) as above, x²),
x = max(|d| − 3σ_d, |q| − 4.5σ_q)⁺ from the period change d and the rate change q
(``swing.change_excess``; |d| ≥ the lag for a θ_eq monotone over the period, q covers the first
half period after a step). The first ~0.1 s after a step (braking) and ~0.25 s after a ramp starts
(stop_and_go) stay beyond 2σ: the bob has not moved enough yet.
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
    wrap_clamp,
    wrap_clamp_array,
)
from pendulum_accel.estimators.swing import SwingWindow, Trail, change_excess, period_changes, trail_means

_SHORT = 0.25  # e₄'s window, in swing periods


class PeriodMeanEstimator(Estimator):
    """a = g tan(θ̄), θ̄ = mean θ over one swing period T(â, A); var = (g sec²θ̄)²(σ²/n + E[b²] + lag).

    lag = max(min((e₁² − ⅔σ²/n)⁺, (e₄² − ⁸⁄₃σ²/n)⁺), change_excess(d, q)²) (module doc).
    """

    name: ClassVar[str] = "period_mean"
    summary: ClassVar[str] = "g tan(mean θ over one swing period)"

    def __init__(self, config: EstimatorConfig, *, exact_period: bool = True, stages: int = 3) -> None:
        """Empty history; T₀ = 2π√(l/g); ``exact_period`` lengthens T for the swing amplitude."""
        super().__init__(config)
        self.exact_period = bool(exact_period)
        if int(stages) != stages or not 2 <= stages <= 5:
            raise ParameterError(f"stages must be an integer 2..5, got {stages!r}")
        self.stages = int(stages)
        self._swing = SwingWindow(config, stages=self.stages, exact_period=self.exact_period)
        self._outputs = Trail(self._swing.horizon)
        self.reset()

    def reset(self) -> None:
        """Forget the history."""
        self._swing.reset()
        self._outputs.reset()
        self._hints = [0, 0]
        self._change_hints = [0] * 5
        self._last_t: float | None = None
        self._first_t = 0.0

    def lag_variance(self, mean: float, over_period: float, over_quarter: float, n: float) -> float:
        """min((e₁² − ⅔σ²/n)⁺, (e₄² − ⁸⁄₃σ²/n)⁺) (rad²), e₁ = θ̄ − mean_T θ̄, e₄ = 4(θ̄ − mean_{T/4} θ̄)."""
        noise = self.config.sigma**2 / n
        e1 = mean - over_period
        e4 = (mean - over_quarter) / _SHORT
        if not math.isfinite(e1 * e1 + e4 * e4):
            return math.inf  # angles beyond ~1e154 rad: capped by the caller, as in ``batch``
        return min(max(e1 * e1 - 2.0 / 3.0 * noise, 0.0), max(e4 * e4 - 2.0 / 3.0 / _SHORT * noise, 0.0))

    def update(self, t: float, theta: float) -> Estimate | None:
        """Append θ; average over T₀ for a₁ and A, then over T(a₁, A); a = g tan θ̄, var as the class says."""
        if not self._accepts(t, theta, self._last_t):
            return None
        if self._last_t is None:
            self._first_t = t
        self._last_t = t
        cfg = self.config
        means, restarted = self._swing.push(t, theta)
        if restarted:
            self._outputs.reset()
        outputs, hints = self._outputs, self._hints
        k = outputs.append(t, means.mean)
        over_period, _, _, hints[0] = outputs.means(k, means.window, hints[0])
        over_quarter, _, _, hints[1] = outputs.means(k, _SHORT * means.window, hints[1])
        outputs.prune(k)
        th, clamped = wrap_clamp(means.mean, cfg.clamp_angle)
        gain = accel_gain(th, cfg.gravity)
        d, q, n_w = self._swing.period_change(means.mean, means.window, self._change_hints)
        rho = math.exp(-0.5 * cfg.damping * means.window)
        excess = float(change_excess(d, q, n_w, rho, cfg.sigma))
        lag = max(self.lag_variance(means.mean, over_period, over_quarter, means.n), excess * excess)
        var = gain * gain * cfg.sigma**2 / means.n + capped(gain * gain * lag, cfg.error_cap)
        var += bias_variance(cfg, th, t - self._first_t)
        return Estimate(cfg.gravity * math.tan(th), var, clamped)

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vectorised staged window means per stretch between restarts, the same formulas as ``update``."""
        t, theta = check_batch_input(t, theta)
        cfg = self.config
        mean, _, n, window = self._swing.batch(t, theta)
        th, _ = wrap_clamp_array(mean, cfg.clamp_angle)
        gain = accel_gain_array(th, cfg.gravity)
        if not t.size:
            return cfg.gravity * np.tan(th), np.empty(0)
        noise = cfg.sigma**2 / n
        e1 = mean - trail_means(t, mean, window, self._swing.restart_gap)
        e4 = (mean - trail_means(t, mean, _SHORT * window, self._swing.restart_gap)) / _SHORT
        lag = np.minimum(
            np.maximum(e1 * e1 - 2.0 / 3.0 * noise, 0.0),
            np.maximum(e4 * e4 - 2.0 / 3.0 / _SHORT * noise, 0.0),
        )
        d, q, n_w, rho = period_changes(t, theta, mean, window, self._swing)
        excess = change_excess(d, q, n_w, rho, cfg.sigma)
        lag = np.maximum(lag, excess * excess)
        var = gain * gain * noise + capped_array(gain * gain * lag, cfg.error_cap)
        var = var + bias_variance_array(cfg, th, t - t[0])
        return cfg.gravity * np.tan(th), var

    def noise_equivalent_samples(self, accel: float) -> float:
        """N = T(a)·f: the samples in one small-swing period at the nominal rate."""
        return self.config.period(accel) * self.config.rate_hz

    def nominal_delay(self, accel: float) -> float:
        """T(a)/2, the centre of the averaging window."""
        return 0.5 * self.config.period(accel)
