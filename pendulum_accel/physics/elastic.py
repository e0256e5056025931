"""Elastic string: the bob on a radial spring V(r) = ½ k (r − l)² (the lecture's V(r) picture), 2 DOF.

Car-frame Lagrangian in polar coordinates (x = −r sin θ, z = −r cos θ, fictitious force −m a along x):

    L = ½ m (r'² + r² θ'²) + m g r cos θ + m a r sin θ − ½ k (r − l)²

Euler–Lagrange, with linear air drag −m c v on the bob:

    r''  = r θ'² + g cos θ + a sin θ − (k/m)(r − l) − c r'
    θ''  = (−g sin θ + a cos θ − 2 r' θ') / r − c θ'

Tension from deformation T = k (r − l) (negative means the spring is compressed), stretch r − l,
stretch rate r'. Invariant (constant a, c = 0), per unit mass:
E = ½ (r'² + r² θ'²) − g r cos θ − a r sin θ + (k/2m)(r − l)².
The radial mode has ω_r = √(k/m); when ω_r ≫ ω the system is stiff.
As k → ∞ the motion tends to the rigid pendulum's, with a difference O(m g/(k l)).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics.params import Pendulum

ArrayAccel = Callable[[float], "float | np.ndarray"]


def stiffness_of(p: Pendulum) -> float:
    """k (N/m) of the pendulum, or ParameterError when it has none."""
    if p.stiffness is None:
        raise ParameterError("the elastic model needs the pendulum's stiffness k (N/m), got None")
    return p.stiffness


def radial_omega(p: Pendulum) -> float:
    """ω_r = √(k/m), the string's radial frequency (rad/s)."""
    return math.sqrt(stiffness_of(p) / p.mass)


def quasi_static_radius(p: Pendulum, theta: float, theta_dot: float, accel: float) -> float:
    """r₀ = (k l + m (g cos θ + a sin θ)) / (k − m θ'²): the stretch that balances the radial forces."""
    k = stiffness_of(p)
    denom = k - p.mass * theta_dot * theta_dot
    r0 = (k * p.length + p.mass * (p.gravity * math.cos(theta) + accel * math.sin(theta))) / denom
    if denom <= 0.0 or r0 <= 0.0:
        raise ParameterError(
            f"stiffness k={k!r} N/m is too soft to hold the bob at θ={theta!r}, θ'={theta_dot!r} "
            f"(needs k > m θ'² and a positive radius)"
        )
    return r0


def elastic_rhs(p: Pendulum, accel: ArrayAccel) -> Callable[[float, np.ndarray], np.ndarray]:
    """f(t, [r, θ, r', θ']) = [r', θ', r'', θ''] from the polar Euler–Lagrange equations above."""
    k_m = stiffness_of(p) / p.mass
    g, c, length = p.gravity, p.damping, p.length

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        """[r', θ', r θ'² + g cos θ + a sin θ − (k/m)(r−l) − c r', (a cos θ − g sin θ − 2r'θ')/r − cθ']."""
        # A single state runs on Python floats: numpy scalars would cost more than the arithmetic.
        single = y.ndim == 1
        r, th, rd, w = y.tolist() if single else y
        a = accel(t)
        s, co = (math.sin(th), math.cos(th)) if single else (np.sin(th), np.cos(th))
        r_dd = r * w * w + g * co + a * s - k_m * (r - length) - c * rd
        th_dd = (-g * s + a * co - 2.0 * rd * w) / r - c * w
        return np.array((rd, w, r_dd, th_dd)) if single else np.stack((rd, w, r_dd, th_dd))

    return rhs


def elastic_jacobian(p: Pendulum, accel: ArrayAccel) -> Callable[[float, np.ndarray], np.ndarray]:
    """J(t, y) = ∂f/∂y of ``elastic_rhs`` for one state [r, θ, r', θ'] (4×4), for the implicit solvers."""
    k_m = stiffness_of(p) / p.mass
    g, c = p.gravity, p.damping

    def jac(t: float, y: np.ndarray) -> np.ndarray:
        """Analytic partial derivatives of [r', θ', r'', θ''] with respect to [r, θ, r', θ']."""
        r, th, rd, w = (float(v) for v in y)
        a = float(accel(t))
        s, co = math.sin(th), math.cos(th)
        tangential = -g * s + a * co - 2.0 * rd * w
        return np.array(
            [
                [0.0, 0.0, 1.0, 0.0],
                [0.0, 0.0, 0.0, 1.0],
                [w * w - k_m, -g * s + a * co, -c, 2.0 * r * w],
                [-tangential / (r * r), (-g * co - a * s) / r, -2.0 * w / r, -2.0 * rd / r - c],
            ]
        )

    return jac


def string_tension(p: Pendulum, r: ArrayLike) -> np.ndarray:
    """T = k (r − l)  (N)."""
    return stiffness_of(p) * (np.asarray(r, dtype=float) - p.length)


def elastic_energy(p: Pendulum, y: np.ndarray, accel: ArrayLike) -> np.ndarray:
    """E = ½ (r'² + r² θ'²) − g r cos θ − a r sin θ + (k/2m)(r − l)²  (J/kg)."""
    r, th, rd, w = y[0], y[1], y[2], y[3]
    a = np.asarray(accel)
    kinetic = 0.5 * (rd * rd + r * r * w * w)
    spring = 0.5 * stiffness_of(p) / p.mass * (r - p.length) ** 2
    return np.asarray(kinetic - p.gravity * r * np.cos(th) - a * r * np.sin(th) + spring)
