"""Rigid pendulum in the car frame, reduced coordinate θ (the lecture's second approach).

Car-frame Lagrangian (per the lecture, written in our REP-103 signs; bob at x = −l sin θ, z = −l cos θ,
car velocity v(t) with v' = a):

    L = ½ m (l² θ'² − 2 v l θ' cos θ) + m g l cos θ  [+ ½ m v², a total time derivative]

Euler–Lagrange:  θ'' = −(g/l) sin θ + (a/l) cos θ − c θ'   (c: linear damping, acts tangentially)
Tension:         T = m (l θ'² + g cos θ + a sin θ)          (radial balance, unchanged by damping)
Invariant (constant a, c = 0), per unit mass:  E = ½ l² θ'² − g l cos θ − a l sin θ.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from pendulum_accel.physics.params import Pendulum

ArrayAccel = Callable[[float], "float | np.ndarray"]


def theta_ddot(p: Pendulum, theta: ArrayLike, theta_dot: ArrayLike, accel: ArrayLike) -> np.ndarray:
    """θ'' = −(g/l) sin θ + (a/l) cos θ − c θ'."""
    th = np.asarray(theta, dtype=float)
    return (-p.gravity * np.sin(th) + np.asarray(accel) * np.cos(th)) / p.length - p.damping * np.asarray(
        theta_dot, dtype=float
    )


def rigid_rhs(p: Pendulum, accel: ArrayAccel) -> Callable[[float, np.ndarray], np.ndarray]:
    """f(t, [θ, θ']) = [θ', θ''(θ, θ', a(t))]; the state may be a batch of shape (2, n)."""

    g_l, inv_l, c = p.gravity / p.length, 1.0 / p.length, p.damping

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        """[θ', −(g/l) sin θ + (a(t)/l) cos θ − c θ']."""
        if y.ndim == 1:  # Python floats: numpy scalars would cost more than the arithmetic
            th, w = y.tolist()
            return np.array((w, -g_l * math.sin(th) + accel(t) * inv_l * math.cos(th) - c * w))
        return np.stack((y[1], theta_ddot(p, y[0], y[1], accel(t))))

    return rhs


def tension(p: Pendulum, theta: ArrayLike, theta_dot: ArrayLike, accel: ArrayLike) -> np.ndarray:
    """T = m (l θ'² + g cos θ + a sin θ)  (N)."""
    th = np.asarray(theta, dtype=float)
    w = np.asarray(theta_dot, dtype=float)
    return p.mass * (p.length * w * w + p.gravity * np.cos(th) + np.asarray(accel) * np.sin(th))


def energy(p: Pendulum, theta: ArrayLike, theta_dot: ArrayLike, accel: ArrayLike) -> np.ndarray:
    """E = ½ l² θ'² − g l cos θ − a l sin θ  (J/kg; conserved for constant a and c = 0)."""
    th = np.asarray(theta, dtype=float)
    w = np.asarray(theta_dot, dtype=float)
    length = p.length
    return length * (0.5 * length * w * w - p.gravity * np.cos(th) - np.asarray(accel) * np.sin(th))


def car_frame_lagrangian(
    p: Pendulum,
    theta: ArrayLike,
    theta_dot: ArrayLike,
    car_velocity: ArrayLike,
    *,
    total_derivative_term: bool = True,
) -> np.ndarray:
    """L = ½ m (l² θ'² − 2 v l θ' cos θ) + m g l cos θ + ½ m v² (the last term only if asked)."""
    th = np.asarray(theta, dtype=float)
    w = np.asarray(theta_dot, dtype=float)
    v = np.asarray(car_velocity, dtype=float)
    m, length = p.mass, p.length
    kinetic = 0.5 * m * (length * length * w * w - 2.0 * v * length * w * np.cos(th))
    lagrangian = kinetic + m * p.gravity * length * np.cos(th)
    if total_derivative_term:
        lagrangian = lagrangian + 0.5 * m * v * v
    return np.asarray(lagrangian)
