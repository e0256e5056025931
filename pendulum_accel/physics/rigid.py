"""Rigid pendulum in the car frame, reduced coordinate θ (the lecture's second approach).

Car-frame Lagrangian (per the lecture, written in our REP-103 signs; bob at x = −l sin θ, z = −l cos θ,
car velocity v(t) with v' = a):

    L = ½ m (l² θ'² − 2 v l θ' cos θ) + m g l cos θ  [+ ½ m v², a total time derivative]

Euler–Lagrange:  θ'' = −(g/l) sin θ + (a/l) cos θ − c θ'   (c: linear damping, acts tangentially)
Tension:         T = m (l θ'² + g cos θ + a sin θ)          (radial balance, unchanged by damping)
Invariant (constant a, c = 0), per unit mass:  E = ½ l² θ'² − g l cos θ − a l sin θ.

On a road of constant grade β (the car pitched nose-up by β, climbing for β > 0) the car's x axis is
(cos β, sin β) in the world's (horizontal, up) plane and its z axis (−sin β, cos β), so gravity reads
(−g sin β, −g cos β) in the car frame, and the bob feels the specific force (−a − g sin β, −g cos β):

    θ'' = −(g cos β / l) sin θ + ((a + g sin β) / l) cos θ − c θ'
    T   = m (l θ'² + g cos β cos θ + (a + g sin β) sin θ)

which is the level-road pendulum with g → g cos β and a → a + g sin β (``level_equivalent``). At rest
tan θ = (a + g sin β)/(g cos β): at a = 0 that is tan θ = tan β, the steady angle a level car reaches at
a = g tan β. Only a scene with a grade goes through this substitution; a level one runs unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np
from numpy.typing import ArrayLike

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics.params import Pendulum, require_finite
from pendulum_accel.physics.profiles import AccelProfile, Offset

ArrayAccel = Callable[[float], "float | np.ndarray"]


def theta_ddot(p: Pendulum, theta: ArrayLike, theta_dot: ArrayLike, accel: ArrayLike) -> np.ndarray:
    """θ'' = −(g/l) sin θ + (a/l) cos θ − c θ'."""
    th = np.asarray(theta, dtype=float)
    result: np.ndarray = (
        -p.gravity * np.sin(th) + np.asarray(accel) * np.cos(th)
    ) / p.length - p.damping * np.asarray(theta_dot, dtype=float)
    return result


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
    result: np.ndarray = p.mass * (p.length * w * w + p.gravity * np.cos(th) + np.asarray(accel) * np.sin(th))
    return result


def energy(p: Pendulum, theta: ArrayLike, theta_dot: ArrayLike, accel: ArrayLike) -> np.ndarray:
    """E = ½ l² θ'² − g l cos θ − a l sin θ  (J/kg; conserved for constant a and c = 0)."""
    th = np.asarray(theta, dtype=float)
    w = np.asarray(theta_dot, dtype=float)
    length = p.length
    result: np.ndarray = length * (
        0.5 * length * w * w - p.gravity * np.cos(th) - np.asarray(accel) * np.sin(th)
    )
    return result


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


def level_equivalent(p: Pendulum, profile: AccelProfile, grade: float) -> tuple[Pendulum, AccelProfile]:
    """(p with g cos β, a(t) + g sin β): the level-road problem with the motion of grade β (rad, nose-up > 0).

    β = 0 returns ``p`` and ``profile`` themselves; |β| must be < π/2 (the car on a road, not a wall).
    """
    beta = require_finite("grade", grade)
    if beta == 0.0:
        return p, profile
    if not abs(beta) < 0.5 * math.pi:
        raise ParameterError(f"grade must be between -pi/2 and pi/2 rad, got {beta!r}")
    tilted = replace(p, gravity=p.gravity * math.cos(beta))
    return tilted, Offset(profile, p.gravity * math.sin(beta))
