"""The lecture's closed-form results, in this package's sign convention (θ_ours = −θ_lecture).

These are what a student compares the simulator against, so they are written out here from
the lecture, independently of the models in :mod:`pendulum_accel.physics`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.special import ellipk

from pendulum_accel.physics.params import Pendulum

FloatArray = NDArray[np.float64]


def equilibrium_angle(p: Pendulum, accel: ArrayLike) -> FloatArray:
    """tan θ = a/g (lecture: tan θ' = −a/g, θ' = −θ)."""
    result: FloatArray = np.arctan2(np.asarray(accel, dtype=float), p.gravity)
    return result


def rest_tension(p: Pendulum, accel: ArrayLike) -> FloatArray:
    """T = m √(g² + a²)."""
    result: FloatArray = p.mass * np.hypot(p.gravity, np.asarray(accel, dtype=float))
    return result


def omega_squared(p: Pendulum, accel: ArrayLike) -> FloatArray:
    """ω² = √(g² + a²)/l."""
    result: FloatArray = np.hypot(p.gravity, np.asarray(accel, dtype=float)) / p.length
    return result


def small_angle_period(p: Pendulum, accel: ArrayLike) -> FloatArray:
    """T₀ = 2π/ω with ω² = √(g² + a²)/l."""
    return 2.0 * np.pi / np.sqrt(omega_squared(p, accel))


def exact_period(p: Pendulum, accel: ArrayLike, amplitude: ArrayLike) -> FloatArray:
    """T = 4 K(m)/ω, m = sin²(A/2), A = swing amplitude about θ_eq (valid for A < π)."""
    m = np.sin(0.5 * np.asarray(amplitude, dtype=float)) ** 2
    result: FloatArray = 4.0 * ellipk(m) / np.sqrt(omega_squared(p, accel))
    return result


def multiplier_from_tension(p: Pendulum, tension: ArrayLike) -> FloatArray:
    """μ = −T/l (constraint term (μ/2)(x² + z² − l²) in the Lagrangian)."""
    return -np.asarray(tension, dtype=float) / p.length
