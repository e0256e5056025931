"""Means of θ and θ² over one swing period, streaming and in batch: ``period_mean``'s average, shared.

The bob oscillates about θ_eq = atan(a/g) with period T = 2π/ω, ω² = √(g² + a²)/l, lengthened by
1/AGM(1, cos(A/2)) for a swing of amplitude A (from var θ, ``swing_amplitude``). T depends on a, so the
window is found in stages: T₀ = 2π√(l/g) gives a₁ = g tan(mean θ) and A₁, T(a₁, A₁) gives a₂ and A₂,
and so on. The means are exact integrals of the piecewise-linear θ(t) and θ²(t) over (t − T, t],
accumulated by the trapezoid rule, so irregular sampling is handled; a hole of a quarter of T₀ (or
``max_gap``) restarts.

Over one period the swing averages out of the mean: ``period_mean`` publishes g tan(mean θ).
"""

from __future__ import annotations

import math
from typing import NamedTuple, TypeVar

import numpy as np

from pendulum_accel.estimators.base import EstimatorConfig, segments, wrap_clamp, wrap_clamp_array

_AGM_STEPS = 6  # quadratic convergence: exact to rounding for cos(A/2) ≥ 0.5
HORIZON = 1.25  # history kept, in T₀: the longest window a large swing can ask for
_PRUNE_EVERY = 32  # samples between looks at what the history can drop


Num = TypeVar("Num", float, np.ndarray)


def interp_integral(i_j: Num, y_j: Num, y_next: Num, d: Num, h: Num) -> Num:
    """I_j + ∫ from t_j to t_j + d of the line through (t_j, y_j) and (t_j + h, y_next)."""
    result: Num = i_j + y_j * d + (y_next - y_j) * d * d / (2.0 * h)
    return result


def integrals(t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """I_k = Σ_{i≤k} ½(x_i + x_{i−1})(t_i − t_{i−1}), I_0 = 0 (the same sums as :meth:`Trail.append`)."""
    return np.concatenate(([0.0], np.cumsum(0.5 * (x[1:] + x[:-1]) * np.diff(t))))


def window_means(
    t: np.ndarray,
    theta: np.ndarray,
    i1: np.ndarray,
    i2: np.ndarray,
    window: np.ndarray | float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mean θ, mean θ², n) over (t_k − T, t_k] for every k; over [t₀, t_k] while t_k − T < t₀."""
    size = t.size
    if size < 2:
        return theta.astype(float, copy=True), theta * theta, np.ones(size)
    start = t - window
    j = np.searchsorted(t, start, side="right") - 1
    np.clip(j, 0, size - 2, out=j)
    tj, y, yn = t[j], theta[j], theta[j + 1]
    d, h = start - tj, t[j + 1] - tj
    mean1 = (i1 - interp_integral(i1[j], y, yn, d, h)) / window
    mean2 = (i2 - interp_integral(i2[j], y * y, yn * yn, d, h)) / window
    count = np.arange(size, dtype=float) - j
    # While the window reaches before t₀ (the first ~T·f samples): the mean over [t₀, t_k] instead.
    partial = np.flatnonzero(start < t[0])
    later = partial[partial > 0]
    span = t[later] - t[0]
    mean1[later] = (i1[later] - i1[0]) / span
    mean2[later] = (i2[later] - i2[0]) / span
    mean1[0], mean2[0] = theta[0], theta[0] * theta[0]
    count[partial] = partial + 1.0
    return mean1, mean2, count


def swing_amplitude(variance: Num) -> Num:
    """A from a libration's var θ (≥ 0): 2 var θ = A²(1 + A²/96 + O(A⁴)), so A² = 2 var θ/(1 + var θ/48).

    The swing lingers near its turning points, so A² = 2 var θ (a sinusoid's) overstates A: by 0.3 % at
    A = 0.77 rad (braking's swing), which made T 0.02 % long and left a swing of 1.5e-3 m/s² in
    ``period_mean``. The correction leaves 0.01 % at 0.77 rad and 0.5 % at 2 rad (test_swing.py
    checks it against the exact pendulum).
    """
    result: Num = (2.0 * variance / (1.0 + variance / 48.0)) ** 0.5
    return result


def agm_cos_half(amplitude: float) -> float:
    """AGM(1, cos(A/2)) with a fixed number of steps; the libration period is (2π/ω)/AGM."""
    a, b = 1.0, math.cos(0.5 * amplitude)
    for _ in range(_AGM_STEPS):
        a, b = 0.5 * (a + b), math.sqrt(a * b)
    return a


def agm_cos_half_array(amplitude: np.ndarray) -> np.ndarray:
    """Vectorised :func:`agm_cos_half`, the same operations."""
    a, b = np.ones_like(amplitude), np.cos(0.5 * amplitude)
    for _ in range(_AGM_STEPS):
        a, b = 0.5 * (a + b), np.sqrt(a * b)
    return a


class Trail:
    """Streaming samples (t, θ), trapezoid integrals of θ and θ²: means over (t_k − T, t_k], T ≤ horizon."""

    def __init__(self, horizon: float) -> None:
        """Keep at least ``horizon`` s of history."""
        self.horizon = horizon
        self.reset()

    def reset(self) -> None:
        """Forget the history."""
        self._t: list[float] = []
        self._x: list[float] = []
        self._i1: list[float] = []
        self._i2: list[float] = []
        self._base = 0  # absolute index of list element 0
        self._first_t = 0.0
        self._jh = 0  # window-start hint (absolute index) for the horizon

    @property
    def last_t(self) -> float | None:
        """Stamp of the newest sample, None when empty."""
        return self._t[-1] if self._t else None

    def append(self, t: float, x: float) -> int:
        """Add sample (t, x), t later than the last; return its absolute index k."""
        k = self._base + len(self._t)
        if not self._t:
            self._first_t = t
            i1 = i2 = 0.0
        else:
            dt, prev = t - self._t[-1], self._x[-1]
            i1 = self._i1[-1] + 0.5 * (x + prev) * dt
            i2 = self._i2[-1] + 0.5 * (x * x + prev * prev) * dt
        self._t.append(t)
        self._x.append(x)
        self._i1.append(i1)
        self._i2.append(i2)
        return k

    def means(self, k: int, window: float, hint: int) -> tuple[float, float, float, int]:
        """(mean x, mean x², n, j) over (t_k − T, t_k], k the newest; j = start sample, searched from hint."""
        ts, base = self._t, self._base
        tk, i1k, i2k = ts[-1], self._i1[-1], self._i2[-1]
        start = tk - window
        if start < self._first_t:
            if k == 0:
                x = self._x[-1]
                return x, x * x, 1.0, base
            span = tk - self._first_t
            return (i1k - self._i1[0]) / span, (i2k - self._i2[0]) / span, float(k + 1), base
        p, d, h, j = self._locate(k, start, max(hint, base))
        y, yn = self._x[p], self._x[p + 1]
        mean1 = (i1k - interp_integral(self._i1[p], y, yn, d, h)) / window
        mean2 = (i2k - interp_integral(self._i2[p], y * y, yn * yn, d, h)) / window
        return mean1, mean2, float(k - j), j

    def _locate(self, k: int, start: float, j: int) -> tuple[int, float, float, int]:
        """(p, d, h, j): j the sample at or before ``start`` (searched from j, below k), p its place in the
        kept history, d = start − t_j and h = t_{j+1} − t_j for the interpolation."""
        ts, base = self._t, self._base
        while j > base and ts[j - base] > start:
            j -= 1
        while j + 1 < k and ts[j + 1 - base] <= start:
            j += 1
        p = j - base
        return p, start - ts[p], ts[p + 1] - ts[p], j

    def prune(self, k: int) -> None:
        """Every 32nd sample, drop samples before t_k − horizon once they are half the history (O(1))."""
        if k % _PRUNE_EVERY:
            return
        _, _, _, self._jh = self.means(k, self.horizon, self._jh)
        drop = self._jh - self._base
        if drop > 64 and drop * 2 > len(self._t):
            del self._t[:drop], self._x[:drop], self._i1[:drop], self._i2[:drop]
            self._base = self._jh


class SwingMeans(NamedTuple):
    """Means of θ and θ² over the last swing period, the samples n in it and its length T (s)."""

    mean: float
    mean_sq: float
    n: float
    window: float


class SwingWindow:
    """Streaming staged window over one swing period T(a, A) (module doc); restarts after a long hole."""

    def __init__(self, config: EstimatorConfig, *, stages: int = 3, exact_period: bool = True) -> None:
        """T₀ = 2π√(l/g); ``stages`` windows; ``exact_period`` lengthens T for the swing amplitude."""
        self.config = config
        self.stages = stages
        self.exact_period = exact_period
        self.t0_window = config.period(0.0)
        self.horizon = HORIZON * self.t0_window
        # A hole of a quarter swing or more leaves nothing to average the swing out with: start over.
        self.restart_gap = max(config.gap, 0.25 * self.t0_window)
        self.trail = Trail(self.horizon)
        self.reset()

    def reset(self) -> None:
        """Forget the history."""
        self.trail.reset()
        self._hints = [0] * self.stages

    def swing_period(self, a1: float, mean1: float, mean2: float) -> float:
        """T(a₁) = 2π/ω(a₁), divided by AGM(1, cos(A/2)) with A = swing_amplitude(var θ) when exact_period;
        ≤ horizon."""
        cfg = self.config
        window = 2.0 * math.pi / math.sqrt(math.hypot(cfg.gravity, a1) / cfg.length)
        if self.exact_period:
            amplitude = swing_amplitude(max(mean2 - mean1 * mean1, 0.0))
            window = window / agm_cos_half(min(amplitude, 2.0))
        return min(window, self.horizon)

    def push(self, t: float, theta: float) -> tuple[SwingMeans, bool]:
        """Append (t, θ) (t later than the last); (means over the last stage's window, restarted)."""
        last_t = self.trail.last_t
        restarted = last_t is not None and t - last_t > self.restart_gap
        if restarted:
            self.reset()
        trail, hints, cfg = self.trail, self._hints, self.config
        k = trail.append(t, theta)
        window = self.t0_window
        for stage in range(self.stages):
            mean, sq, n, hints[stage] = trail.means(k, window, hints[stage])
            if stage + 1 < self.stages:
                th, _ = wrap_clamp(mean, cfg.clamp_angle)
                window = self.swing_period(cfg.gravity * math.tan(th), mean, sq)
        trail.prune(k)
        return SwingMeans(mean, sq, n, window), restarted

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, ...]:
        """(mean θ, mean θ², n, T) arrays, per stretch between restarts; the same formulas as ``push``."""
        out = tuple(np.empty(t.size) for _ in range(4))
        for seg in segments(t, self.restart_gap):
            for dst, src in zip(out, self._batch_segment(t[seg], theta[seg]), strict=True):
                dst[seg] = src
        return out

    def _batch_segment(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, ...]:
        """(mean θ, mean θ², n, T) for one stretch without a restart."""
        cfg = self.config
        i1, i2 = integrals(t, theta), integrals(t, theta * theta)
        window: np.ndarray | float = self.t0_window
        for stage in range(self.stages):
            mean, mean_sq, n = window_means(t, theta, i1, i2, window)
            if stage + 1 < self.stages:
                th, _ = wrap_clamp_array(mean, cfg.clamp_angle)
                a_stage = cfg.gravity * np.tan(th)
                window = 2.0 * math.pi / np.sqrt(np.hypot(cfg.gravity, a_stage) / cfg.length)
                if self.exact_period:
                    amplitude = swing_amplitude(np.maximum(mean_sq - mean * mean, 0.0))
                    window = window / agm_cos_half_array(np.minimum(amplitude, 2.0))
                window = np.minimum(window, self.horizon)
        return mean, mean_sq, n, np.broadcast_to(window, t.shape)
