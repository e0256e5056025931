"""A generalised likelihood ratio test for a ramp of a that began k samples ago, on a filter's innovations.

For a steady-state filter (F, K) with H = [1, 0, 0], a ramp a(t) = j (t − t_k)⁺ leaves innovations
ν_{k+i} = j g_i and an error of â of j h_i after i samples (g, h from the filter's error recursion
ε ← (I − KH)(F ε + e₃ Δt j)). With white innovations of variance S, the least-squares ĵ for an onset k̂
samples back and its statistic λ = ĵ²/var(ĵ) = (Σ g ν)²/(S Σ g²) follow from running sums Σ g ν, kept
for every onset in the window at once. The sums are updated by a small compiled loop (numba): in numpy
calls the test cost ~15 µs a sample, three times the filter it serves.

``kalman`` uses it in quiet mode to widen its published variance over a ramp that has just begun, before
the innovation power gives the ramp away (README, "What var(â) accounts for").
"""

from __future__ import annotations

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics.lazy import njit


@njit(cache=True)
def _push(sums: np.ndarray, g: np.ndarray, energy: np.ndarray, nu: float, s: float, min_age: int) -> int:
    """sums_i ← sums_{i−1} + g_i ν (sums_0 = g_0 ν); returns the age i ≥ min_age of the largest
    λ_i = sums_i²/(S E_i)."""
    best, age = -1.0, min_age
    for i in range(sums.size - 1, 0, -1):
        sums[i] = sums[i - 1] + g[i] * nu
        if i >= min_age:
            stat = sums[i] * sums[i] / (s * energy[i])
            if stat > best:
                best, age = stat, i
    sums[0] = g[0] * nu
    return age


class OnsetTest:
    """Running GLR sums for ramp onsets 0 … window samples back; :meth:`push` returns a found ramp's error."""

    def __init__(
        self,
        transition: np.ndarray,
        gain: np.ndarray,
        rate_hz: float,
        window: float,
        min_age: float,
        threshold: float,
    ) -> None:
        """g_i, h_i for i < window·rate (Δt = 1/rate) from the error recursion, Σ_{i'≤i} g², empty sums."""
        if not (rate_hz > 0.0 and window > 0.0 and 0.0 <= min_age < window and threshold > 0.0):
            raise ParameterError(
                f"onset test needs rate > 0, 0 <= min_age < window, threshold > 0; got rate {rate_hz!r}, "
                f"window {window!r}, min_age {min_age!r}, threshold {threshold!r}"
            )
        dt = 1.0 / rate_hz
        size = max(2, round(window * rate_hz))
        self._min_age = min(size - 1, round(min_age * rate_hz))
        self._threshold = threshold
        response = np.zeros(size)
        error = np.zeros(size)
        eps = np.zeros(3)
        step = np.array([0.0, 0.0, dt])
        for i in range(size):
            eps = transition @ eps + step
            response[i] = eps[0]
            eps = eps - gain * eps[0]
            error[i] = eps[2]
        self._g, self._h = response, error
        self._energy = np.maximum(np.cumsum(response * response), np.finfo(float).tiny)
        self._sums = np.zeros(size)

    def clear(self) -> None:
        """Forget the innovations seen so far."""
        self._sums[:] = 0.0

    def push(self, innovation: float, s: float) -> float | None:
        """Add ν (variance S); (ĵ h)² + var(ĵ) h² at the likeliest onset if its λ passes the threshold,
        else None."""
        age = _push(self._sums, self._g, self._energy, innovation, s, self._min_age)
        energy = float(self._energy[age])
        total = float(self._sums[age])
        if not total * total / (s * energy) > self._threshold:
            return None
        slope = total / energy
        h = float(self._h[age])
        return (slope * h) ** 2 + s / energy * h * h


def warm_cache() -> None:
    """Compile the loop into numba's on-disk cache, or load it from there: ``make setup`` calls this once,
    and ``kalman``'s constructor each time, so that a live node pays the load (~0.1 s, more on a busy
    machine) before it says it is estimating, not at its second sample with input queueing behind it."""
    _push(np.zeros(2), np.ones(2), np.ones(2), 1e-3, 1e-6, 1)
