"""Rigid pendulum in Cartesian car-frame coordinates with a Lagrange multiplier (lecture's first approach).

Lagrangian (car frame, bob at (x, z), pivot at the origin, fictitious force −m a along x):

    L = ½ m (x'² + z'²) − m g z − m a x + μ f,   f = ½ (x² + z² − l²)   (the lecture's ½ scaling)

Euler–Lagrange:  m x'' = μ x − m a − m c x',   m z'' = μ z − m g − m c z',   f = 0.
Differentiating f twice (f'' = x x'' + z z'' + x'² + z'² = 0) gives the multiplier in closed form:

    μ = m (a x + g z − (x'² + z'²) + c (x x' + z z')) / (x² + z²),   and on the circle μ = −T/l

with T = m (l θ'² + g cos θ + a sin θ). The index reduction lets f drift, so the dynamics use
Baumgarte's f'' + 2α f' + β² f = 0 (α = β = ω, the small-oscillation frequency) and every stop is
projected back onto the circle (x, z) → l (x, z)/r with the radial velocity removed.
θ is recovered as atan2(−x, −z), θ' = (z x' − x z')/r².
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from pendulum_accel.physics.params import Pendulum

ArrayAccel = Callable[[float], "float | np.ndarray"]


def cartesian_state(p: Pendulum, theta: ArrayLike, theta_dot: ArrayLike) -> np.ndarray:
    """[x, z, x', z'] = [−l sin θ, −l cos θ, −l cos θ θ', l sin θ θ']."""
    th = np.asarray(theta, dtype=float)
    w = np.asarray(theta_dot, dtype=float)
    s, c = np.sin(th), np.cos(th)
    length = p.length
    return np.stack((-length * s, -length * c, -length * c * w, length * s * w))


def angle_state(y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(θ, θ') = (atan2(−x, −z), (z x' − x z')/(x² + z²)) from [x, z, x', z']."""
    x, z, xd, zd = y[0], y[1], y[2], y[3]
    return np.arctan2(-x, -z), (z * xd - x * zd) / (x * x + z * z)


def multiplier(p: Pendulum, y: np.ndarray, accel: ArrayLike) -> np.ndarray:
    """μ = m (a x + g z − (x'² + z'²) + c (x x' + z z')) / (x² + z²)   (N/m; μ = −T/l on the circle)."""
    x, z, xd, zd = y[0], y[1], y[2], y[3]
    a = np.asarray(accel)
    radial_speed = x * xd + z * zd
    num = a * x + p.gravity * z - (xd * xd + zd * zd) + p.damping * radial_speed
    result: np.ndarray = p.mass * num / (x * x + z * z)
    return result


def multiplier_rhs(p: Pendulum, accel: ArrayAccel) -> Callable[[float, np.ndarray], np.ndarray]:
    """f(t, [x, z, x', z']) = [x', z', μ̃x/m − a − c x', μ̃z/m − g − c z'] with Baumgarte-stabilised μ̃."""
    alpha = beta = p.omega(0.0)
    g, c, length = p.gravity, p.damping, p.length

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        """Cartesian equations of motion with μ̃ from f'' + 2α f' + β² f = 0."""
        # A single state runs on Python floats: numpy scalars would cost more than the arithmetic.
        x, z, xd, zd = y.tolist() if y.ndim == 1 else y
        a = accel(t)
        r2 = x * x + z * z
        f = 0.5 * (r2 - length * length)
        f_dot = x * xd + z * zd
        mu_over_m = (
            a * x + g * z - (xd * xd + zd * zd) + c * f_dot - 2.0 * alpha * f_dot - beta * beta * f
        ) / r2
        out = (xd, zd, mu_over_m * x - a - c * xd, mu_over_m * z - g - c * zd)
        return np.array(out) if y.ndim == 1 else np.stack(out)

    return rhs


def project_to_circle(p: Pendulum) -> Callable[[np.ndarray], np.ndarray]:
    """y ↦ y with (x, z) scaled onto r = l and the radial part of (x', z') removed."""
    length = p.length

    def project(y: np.ndarray) -> np.ndarray:
        """(x, z) ← l (x, z)/r;  v ← v − (v·r̂) r̂."""
        x, z, xd, zd = y[0], y[1], y[2], y[3]
        r = np.hypot(x, z)
        ux, uz = x / r, z / r
        radial = xd * ux + zd * uz
        return np.stack((length * ux, length * uz, xd - radial * ux, zd - radial * uz))

    return project


def constraint_residual(p: Pendulum, y: np.ndarray) -> np.ndarray:
    """r − l = √(x² + z²) − l  (m)."""
    return np.asarray(np.hypot(y[0], y[1]) - p.length)
