"""Reading a period off a sampled swing, the way a student would with a stopwatch: zero crossings."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicHermiteSpline

from pendulum_accel.errors import ParameterError


def zero_crossings(t: ArrayLike, y: ArrayLike, dydt: ArrayLike) -> NDArray[np.float64]:
    """Times where y = 0, from the cubic Hermite interpolant through the samples (y, y').

    Using the simulator's y' makes each crossing accurate to O(dt⁴) rather than the O(dt³) of a
    straight line between samples, so a few hundred samples per period time it to ~1e-9 s.
    """
    tt = np.asarray(t, dtype=float)
    yy = np.asarray(y, dtype=float)
    dd = np.asarray(dydt, dtype=float)
    if tt.ndim != 1 or tt.shape != yy.shape or tt.shape != dd.shape or tt.size < 2:
        raise ParameterError(
            f"t, y and dy/dt must be 1-D arrays of one length ≥ 2, got {tt.shape}, {yy.shape}, {dd.shape}"
        )
    roots = CubicHermiteSpline(tt, yy, dd).roots(extrapolate=False)
    # A root exactly on a sample is reported by both neighbouring pieces.
    return np.unique(np.round(roots, 12))


def mean_period(t: ArrayLike, y: ArrayLike, dydt: ArrayLike) -> float:
    """Period = 2 (t_last − t_first)/(n − 1) over the n zero crossings of y (two per period)."""
    crossings = zero_crossings(t, y, dydt)
    if crossings.size < 3:
        raise ParameterError(f"need at least 3 zero crossings to time a period, found {crossings.size}")
    return float(2.0 * (crossings[-1] - crossings[0]) / (crossings.size - 1))


def period(t: ArrayLike, theta: ArrayLike, theta_dot: ArrayLike | None = None) -> float:
    """Period of a sampled swing: mean spacing of the upward crossings of its mid level (max + min)/2.

    Upward crossings only, so a swing about any centre, lopsided at large amplitude, is timed right.
    ``theta_dot`` (e.g. the CSV's column) makes each crossing O(dt⁴) accurate; without it the rate is
    estimated with np.gradient. ParameterError when fewer than two upward crossings are found.
    """
    tt = np.asarray(t, dtype=float)
    yy = np.asarray(theta, dtype=float)
    dd = np.gradient(yy, tt) if theta_dot is None else np.asarray(theta_dot, dtype=float)
    if tt.ndim != 1 or tt.shape != yy.shape or tt.shape != dd.shape or tt.size < 2:
        raise ParameterError(
            f"t, theta and theta_dot must be 1-D arrays of one length ≥ 2, "
            f"got {tt.shape}, {yy.shape}, {dd.shape}"
        )
    level = 0.5 * (float(np.max(yy)) + float(np.min(yy)))
    spline = CubicHermiteSpline(tt, yy - level, dd)
    roots = np.unique(np.round(spline.roots(extrapolate=False), 12))
    upward = roots[spline(roots, 1) > 0.0]
    if upward.size < 2:
        raise ParameterError(f"need at least 2 upward crossings to time a period, found {upward.size}")
    return float((upward[-1] - upward[0]) / (upward.size - 1))
