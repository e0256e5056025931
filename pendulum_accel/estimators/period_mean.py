"""``period_mean``: the time average of θ over one oscillation period, then a = g tan θ̄.

The bob oscillates symmetrically about θ_eq = atan(a/g) (the potential is gravity rotated by θ_eq),
so the mean *angle* over a period is θ_eq whatever the amplitude. The mean of g tan θ is not: by
Jensen's inequality it is biased high, +0.5 % at 0.1 rad amplitude and +16 % at 0.5 rad (a = 3 m/s²).

The period T = 2π/ω with ω² = √(g² + a²)/l depends on the estimate itself, so the average is done
in stages: first over T₀ = 2π√(l/g) (the small-swing period at a = 0) to get a₁ and the swing
amplitude A₁ (from the variance of θ, A² ≈ 2 var θ), then over T(a₁, A₁) for a₂ and A₂, then over
T(a₂, A₂) (each stage cuts the period error ~20×; ``stages`` = 3 by default). A swing of amplitude A
lasts longer than 2π/ω: the exact libration period is T = (2π/ω)/AGM(1, cos(A/2)) (= 4K(sin²(A/2))/ω);
``exact_period=False`` keeps the small-swing 2π/ω (0.6 % short at A = 0.3 rad,
which leaves a residual swing in the average). The averages are exact integrals of the
piecewise-linear θ(t) and θ²(t) over [t − T, t], accumulated by the trapezoid rule, so irregular
sampling is handled; a hole longer than a quarter of T₀ (or ``max_gap``) restarts the average.
"""

from __future__ import annotations

import math
from typing import ClassVar, TypeVar

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators.base import (
    Estimate,
    Estimator,
    EstimatorConfig,
    accel_gain,
    accel_gain_array,
    check_batch_input,
    segments,
    wrap_clamp,
    wrap_clamp_array,
)

_AGM_STEPS = 6  # quadratic convergence: exact to rounding for cos(A/2) ≥ 0.5
_HORIZON = 1.25  # history kept, in T₀: the longest window a large swing can ask for


Num = TypeVar("Num", float, np.ndarray)


def _interp_integral(i_j: Num, y_j: Num, y_next: Num, d: Num, h: Num) -> Num:
    """I_j + ∫ from t_j to t_j + d of the line through (t_j, y_j) and (t_j + h, y_next)."""
    return i_j + y_j * d + (y_next - y_j) * d * d / (2.0 * h)


def _window_means(
    t: np.ndarray,
    theta: np.ndarray,
    i1: np.ndarray,
    i2: np.ndarray,
    window: np.ndarray | float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mean θ, mean θ², n) over (t_k − T, t_k] for every k; over [t₀, t_k] while t_k − T < t₀."""
    k = np.arange(t.size)
    start = t - window
    partial = start < t[0]
    j = np.clip(np.searchsorted(t, start, side="right") - 1, 0, max(t.size - 2, 0))
    jn = np.minimum(j + 1, t.size - 1)
    d = start - t[j]
    h = np.where(jn > j, t[jn] - t[j], 1.0)
    sq = theta * theta
    full1 = (i1 - _interp_integral(i1[j], theta[j], theta[jn], d, h)) / window
    full2 = (i2 - _interp_integral(i2[j], sq[j], sq[jn], d, h)) / window
    span = np.where(k > 0, t - t[0], 1.0)
    part1 = np.where(k > 0, (i1 - i1[0]) / span, theta)
    part2 = np.where(k > 0, (i2 - i2[0]) / span, sq)
    count = np.where(partial, k + 1, k - j).astype(float)
    return np.where(partial, part1, full1), np.where(partial, part2, full2), count


def _agm_cos_half(amplitude: float) -> float:
    """AGM(1, cos(A/2)) with a fixed number of steps; the libration period is (2π/ω)/AGM."""
    a, b = 1.0, math.cos(0.5 * amplitude)
    for _ in range(_AGM_STEPS):
        a, b = 0.5 * (a + b), math.sqrt(a * b)
    return a


def _agm_cos_half_array(amplitude: np.ndarray) -> np.ndarray:
    """Vectorised :func:`_agm_cos_half`, the same operations."""
    a, b = np.ones_like(amplitude), np.cos(0.5 * amplitude)
    for _ in range(_AGM_STEPS):
        a, b = 0.5 * (a + b), np.sqrt(a * b)
    return a


class PeriodMeanEstimator(Estimator):
    """a = g tan(θ̄), θ̄ = mean θ over one swing period T(â, A); var = (g sec²θ̄)² σ²/n, n = samples in T."""

    name: ClassVar[str] = "period_mean"
    summary: ClassVar[str] = "g tan(mean θ over one swing period)"

    def __init__(self, config: EstimatorConfig, *, exact_period: bool = True, stages: int = 3) -> None:
        """Empty history; T₀ = 2π√(l/g); ``exact_period`` lengthens T for the swing amplitude."""
        super().__init__(config)
        self.exact_period = bool(exact_period)
        if int(stages) != stages or not 2 <= stages <= 5:
            raise ParameterError(f"stages must be an integer 2..5, got {stages!r}")
        self.stages = int(stages)
        self._t0_window = config.period(0.0)
        self._horizon = _HORIZON * self._t0_window
        # A hole of a quarter swing or more leaves nothing to average the swing out with: start over.
        self._restart_gap = max(config.gap, 0.25 * self._t0_window)
        self.reset()

    def reset(self) -> None:
        """Forget the history."""
        self._t: list[float] = []
        self._th: list[float] = []
        self._i1: list[float] = []
        self._i2: list[float] = []
        self._base = 0  # absolute index of list element 0
        self._first_t = 0.0
        self._jh = 0  # window-start hint (absolute index) for the horizon
        self._hints = [0] * self.stages  # and for each stage

    def _window(self, k: int, window: float, hint: int) -> tuple[float, float, float, int]:
        """(mean θ, mean θ², n, j) over (t_k − T, t_k]; j = start sample, searched from ``hint``."""
        ts, base = self._t, self._base
        tk, i1k, i2k = ts[-1], self._i1[-1], self._i2[-1]
        start = tk - window
        if start < self._first_t:
            if k == 0:
                th = self._th[-1]
                return th, th * th, 1.0, base
            span = tk - self._first_t
            return (i1k - self._i1[0]) / span, (i2k - self._i2[0]) / span, float(k + 1), base
        j = max(hint, base)
        while j > base and ts[j - base] > start:
            j -= 1
        while j + 1 < k and ts[j + 1 - base] <= start:
            j += 1
        p = j - base
        d, h = start - ts[p], ts[p + 1] - ts[p]
        y, yn = self._th[p], self._th[p + 1]
        mean1 = (i1k - _interp_integral(self._i1[p], y, yn, d, h)) / window
        mean2 = (i2k - _interp_integral(self._i2[p], y * y, yn * yn, d, h)) / window
        return mean1, mean2, float(k - j), j

    def _swing_period(self, a1: float, mean1: float, mean2: float) -> float:
        """T(a₁) = 2π/ω(a₁), divided by AGM(1, cos(A/2)) with A = √(2 var θ) when exact_period; ≤ horizon."""
        cfg = self.config
        window = 2.0 * math.pi / math.sqrt(math.hypot(cfg.gravity, a1) / cfg.length)
        if self.exact_period:
            amplitude = math.sqrt(2.0 * max(mean2 - mean1 * mean1, 0.0))
            window = window / _agm_cos_half(min(amplitude, 2.0))
        return min(window, self._horizon)

    def update(self, t: float, theta: float) -> Estimate | None:
        """Append θ; average over T₀ for a₁ and A, then over T(a₁, A); a = g tan θ̄, var = (g sec²θ̄)² σ²/n."""
        last_t = self._t[-1] if self._t else None
        if not self._accepts(t, theta, last_t):
            return None
        if last_t is not None and t - last_t > self._restart_gap:
            self.reset()
            last_t = None
        cfg = self.config
        k = self._base + len(self._t)
        if last_t is None:
            self._first_t = t
            i1 = i2 = 0.0
        else:
            dt, prev = t - last_t, self._th[-1]
            i1 = self._i1[-1] + 0.5 * (theta + prev) * dt
            i2 = self._i2[-1] + 0.5 * (theta * theta + prev * prev) * dt
        self._t.append(t)
        self._th.append(theta)
        self._i1.append(i1)
        self._i2.append(i2)

        hints = self._hints
        window = self._t0_window
        for stage in range(self.stages):
            mean, sq, n, hints[stage] = self._window(k, window, hints[stage])
            th, clamped = wrap_clamp(mean, cfg.clamp_angle)
            if stage + 1 < self.stages:
                window = self._swing_period(cfg.gravity * math.tan(th), mean, sq)
        self._prune(k)
        gain = accel_gain(th, cfg.gravity)
        return Estimate(cfg.gravity * math.tan(th), (gain * cfg.sigma) ** 2 / n, clamped)

    def _prune(self, k: int) -> None:
        """Drop samples before t_k − horizon once they are half the history (amortised O(1))."""
        _, _, _, self._jh = self._window(k, self._horizon, self._jh)
        drop = self._jh - self._base
        if drop > 64 and drop * 2 > len(self._t):
            del self._t[:drop], self._th[:drop], self._i1[:drop], self._i2[:drop]
            self._base = self._jh

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Vectorised staged window means per gap-free segment, the same formulas as ``update``."""
        t, theta = check_batch_input(t, theta)
        accel, var = np.empty(t.size), np.empty(t.size)
        for seg in segments(t, self._restart_gap):
            accel[seg], var[seg] = self._batch_segment(t[seg], theta[seg])
        return accel, var

    def _batch_segment(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(â, var_a) for one gap-free stretch of samples."""
        cfg = self.config
        dt = np.diff(t)
        sq = theta * theta
        i1 = np.concatenate(([0.0], np.cumsum(0.5 * (theta[1:] + theta[:-1]) * dt)))
        i2 = np.concatenate(([0.0], np.cumsum(0.5 * (sq[1:] + sq[:-1]) * dt)))
        window: np.ndarray | float = self._t0_window
        for stage in range(self.stages):
            mean, mean_sq, n = _window_means(t, theta, i1, i2, window)
            th, _ = wrap_clamp_array(mean, cfg.clamp_angle)
            if stage + 1 < self.stages:
                a_stage = cfg.gravity * np.tan(th)
                window = 2.0 * math.pi / np.sqrt(np.hypot(cfg.gravity, a_stage) / cfg.length)
                if self.exact_period:
                    amplitude = np.sqrt(2.0 * np.maximum(mean_sq - mean * mean, 0.0))
                    window = window / _agm_cos_half_array(np.minimum(amplitude, 2.0))
                window = np.minimum(window, self._horizon)
        gain = accel_gain_array(th, cfg.gravity)
        return cfg.gravity * np.tan(th), (gain * cfg.sigma) ** 2 / n

    def noise_equivalent_samples(self, accel: float) -> float:
        """N = T(a)·f: the samples in one small-swing period at the nominal rate."""
        return self.config.period(accel) * self.config.rate_hz

    def nominal_delay(self, accel: float) -> float:
        """T(a)/2, the centre of the averaging window."""
        return 0.5 * self.config.period(accel)
