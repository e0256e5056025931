"""Reading ω off a simulated swing, shared by the physics tests."""

from __future__ import annotations

import math

import numpy as np

from pendulum_accel.lecture.measure import mean_period


def omega_of_swing(t: np.ndarray, theta: np.ndarray, theta_dot: np.ndarray, center: float) -> float:
    """ω = 2π / period, the period timed from the crossings of θ = center (lecture.measure.mean_period)."""
    return 2.0 * math.pi / mean_period(t, theta - center, theta_dot)
