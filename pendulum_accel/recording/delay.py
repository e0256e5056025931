"""How late an estimate follows the truth: the cross-correlation peak."""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

MAX_DELAY = 3.0  # s searched for the group delay: far beyond any method's latency (docs/estimators.md)


def _correlation(e: NDArray[np.float64], a: NDArray[np.float64], k: int) -> float:
    """Σ e(t) a(t − k samples) over the overlap."""
    return float(np.dot(e[k:], a[: a.size - k])) if k >= 0 else float(np.dot(e[:k], a[-k:]))


def truth_varies(truth: NDArray[np.float64]) -> bool:
    """max a − min a > 64 ε max|a|: the truth moves by more than the rounding of its own samples.

    A constant a(t) (a step's flat end after the warm-up, a lab bag's constant) has no delay to measure:
    a − mean a is rounding alone, and the cross-correlation's peak falls on any lag."""
    if truth.size < 2:
        return False
    scale = float(np.max(np.abs(truth)))
    return bool(float(np.ptp(truth)) > 64.0 * float(np.finfo(np.float64).eps) * scale)


def group_delay(est: NDArray[np.float64], truth: NDArray[np.float64], rate_hz: float) -> float:
    """τ (s) in [−MAX_DELAY, MAX_DELAY] maximising Σ (â(t) − mean â)(a(t − τ) − mean a) over samples at
    ``rate_hz``: the cross-correlation peak (a coarse scan, then every sample around its best); NaN where
    the truth does not vary (truth_varies)."""
    if not truth_varies(truth):
        return math.nan
    e = est - est.mean()
    a = truth - truth.mean()
    n = min(int(MAX_DELAY * rate_hz), e.size // 4)
    step = max(1, n // 60)
    best, best_k = -math.inf, 0
    for k in range(-n, n + 1, step):
        c = _correlation(e, a, k)
        if c > best:
            best, best_k = c, k
    for k in range(best_k - step, best_k + step + 1):
        if abs(k) <= n:
            c = _correlation(e, a, k)
            if c > best:
                best, best_k = c, k
    return best_k / rate_hz
