"""Rigid pendulum in reduced coordinates: the lecture's results, tension, invariant, gauge term."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from pendulum_accel.physics.integrators import integrate
from pendulum_accel.physics.params import STANDARD_GRAVITY, Pendulum
from pendulum_accel.physics.profiles import Constant, Sinusoid
from pendulum_accel.physics.rigid import car_frame_lagrangian, energy, rigid_rhs, tension
from pendulum_accel.physics.simulate import simulate
from test.swing import omega_of_swing

G = STANDARD_GRAVITY


@pytest.mark.parametrize("a", [-2.0 * G, -3.0, 0.0, 3.0, 2.0 * G])
def test_equilibrium_tan_theta_and_tension(a):
    """At θ_eq: tan θ_eq = a/g, the bob stays put (|Δθ| < 1e-12 over 10 s), T = m√(g²+a²) (rel 1e-12)."""
    p = Pendulum(0.7, mass=0.3)
    theta_eq = p.equilibrium_angle(a)
    assert math.tan(theta_eq) == pytest.approx(a / G, rel=1e-14, abs=1e-15)
    tr = simulate(p, Constant(a), np.linspace(0.0, 10.0, 101), theta0=theta_eq)
    assert np.max(np.abs(tr.theta - theta_eq)) < 1e-12
    assert tr.tension is not None
    # at θ_eq within 1e-12 rad: T moves by ≤ m √(g² + a²)·1e-12, i.e. rel 1e-12 (θ'² ≤ 1e-24 negligible)
    np.testing.assert_allclose(tr.tension, 0.3 * math.hypot(G, a), rtol=1e-12)


@pytest.mark.parametrize("a", [0.0, 2.0, -5.0, 15.0])
def test_small_oscillation_frequency_from_simulated_period(a):
    """ω measured over ~30 periods of a 1e-3 rad swing matches ω² = √(g²+a²)/l to 1e-6 (rel)."""
    p = Pendulum(1.3)
    omega = (math.hypot(G, a) / p.length) ** 0.5
    t = np.linspace(0.0, 30 * 2 * math.pi / omega, 30001)
    theta_eq = p.equilibrium_angle(a)
    tr = simulate(p, Constant(a), t, theta0=theta_eq + 1e-3)
    assert omega_of_swing(t, tr.theta, tr.theta_dot, theta_eq) == pytest.approx(omega, rel=1e-6)


def test_a_to_zero_recovers_sqrt_g_over_l():
    """ω(a) → √(g/l) as a → 0: ω(a) − √(g/l) shrinks like a² (ratio within 2% of 4 for a halved)."""
    p = Pendulum(0.9)
    base = math.sqrt(G / p.length)
    deviations = []
    for a in (1.0, 0.5, 0.0):
        omega_a = (math.hypot(G, a) / p.length) ** 0.5
        t = np.linspace(0.0, 20 * 2 * math.pi / omega_a, 20001)
        theta_eq = p.equilibrium_angle(a)
        tr = simulate(p, Constant(a), t, theta0=theta_eq + 1e-3)
        deviations.append(omega_of_swing(t, tr.theta, tr.theta_dot, theta_eq) - base)
    assert abs(deviations[2]) < 1e-6 * base
    # ω² = √(g²+a²)/l ⇒ ω − √(g/l) ≈ √(g/l) a²/(4g²): quadratic in a.
    assert deviations[0] / deviations[1] == pytest.approx(4.0, rel=0.02)


def test_energy_invariant_conserved():
    """Constant a, undamped, large swing: E drifts by < 1e-9 g l over 20 s with DOP853 defaults."""
    p = Pendulum(1.0)
    a = 4.0
    tr = simulate(p, Constant(a), np.linspace(0.0, 20.0, 2001), theta0=2.0, theta_dot0=0.5)
    e = energy(p, tr.theta, tr.theta_dot, a)
    assert np.max(np.abs(e - e[0])) < 1e-9 * G * p.length


def test_damping_dissipates_energy():
    """With c > 0 and constant a, E never increases (by more than 1e-12) and ends lower."""
    p = Pendulum(1.0, damping=0.2)
    tr = simulate(p, Constant(2.0), np.linspace(0.0, 10.0, 1001), theta0=1.5)
    e = energy(p, tr.theta, tr.theta_dot, 2.0)
    assert np.all(np.diff(e) < 1e-12)
    assert e[-1] < e[0] - 1.0


@pytest.mark.parametrize("damping", [0.0, 0.5])
def test_tension_matches_newton_in_inertial_frame(damping):
    """T = m(lθ'² + g cos θ + a sin θ) equals m (r̈·û + g cos θ) from the bob path (tol 1e-5 m g).

    r̈ is the inertial acceleration (car a plus the second difference of the car-frame position), û the
    unit vector from bob to pivot; damping acts tangentially and so drops out of the radial balance.
    """
    p = Pendulum(0.8, mass=1.7, damping=damping)
    profile = Sinusoid(4.0, 0.4, offset=1.0)
    h = 2.5e-4
    t = np.arange(0.0, 4.0 + h / 2, h)
    tr = simulate(p, profile, t, theta0=1.2, theta_dot0=-0.5)
    x = -p.length * np.sin(tr.theta)
    z = -p.length * np.cos(tr.theta)
    x_dd = (x[2:] - 2 * x[1:-1] + x[:-2]) / h**2 + tr.accel[1:-1]
    z_dd = (z[2:] - 2 * z[1:-1] + z[:-2]) / h**2
    th = tr.theta[1:-1]
    newton = p.mass * (x_dd * np.sin(th) + z_dd * np.cos(th) + G * np.cos(th))
    assert tr.tension is not None
    np.testing.assert_allclose(tr.tension[1:-1], newton, rtol=1e-6, atol=1e-5 * p.mass * G)


Lagrangian = Callable[[float, float, float], float]


def euler_lagrange_rhs(lagrangian: Lagrangian, h: float = 1e-4) -> Callable[[float, np.ndarray], np.ndarray]:
    """θ'' = (L_θ − L_θ't − L_θ'θ θ')/L_θ'θ', each partial derivative a central finite difference of L."""

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        th, w = float(y[0]), float(y[1])

        def L(a: float, b: float, c: float) -> float:
            return lagrangian(th + a, w + b, t + c)

        L_th = (L(h, 0, 0) - L(-h, 0, 0)) / (2 * h)
        L_ww = (L(0, h, 0) - 2 * L(0, 0, 0) + L(0, -h, 0)) / h**2
        L_wt = (L(0, h, h) - L(0, h, -h) - L(0, -h, h) + L(0, -h, -h)) / (4 * h * h)
        L_wth = (L(h, h, 0) - L(-h, h, 0) - L(h, -h, 0) + L(-h, -h, 0)) / (4 * h * h)
        return np.array([w, (L_th - L_wt - L_wth * w) / L_ww])

    return rhs


def test_total_derivative_term_changes_nothing():
    """EOMs derived numerically from L with and without ½ m v² (and with d/dt[m l v cos θ]) agree to 1e-6 rad.

    The car's a(t) = 3 + 2 sin(2π·0.5 t), so v(t) = 3t + 2(1 − cos(πt))/π is not constant. All three match
    θ'' = −(g/l) sin θ + (a/l) cos θ to 1e-6 rad over 3 s; a term that is *not* a total derivative,
    ½ m v² sin θ · 1e-3, moves the motion by more than 1e-3 rad (the check has teeth).
    """
    p = Pendulum(1.1, mass=0.6)
    m, length = p.mass, p.length

    def a_of(t: float) -> float:
        return 3.0 + 2.0 * math.sin(math.pi * t)

    def v_of(t: float) -> float:
        return 3.0 * t + 2.0 * (1.0 - math.cos(math.pi * t)) / math.pi

    def base(th: float, w: float, t: float) -> float:
        return float(car_frame_lagrangian(p, th, w, v_of(t), total_derivative_term=False))

    def with_term(th: float, w: float, t: float) -> float:
        return float(car_frame_lagrangian(p, th, w, v_of(t), total_derivative_term=True))

    def with_other_gauge(th: float, w: float, t: float) -> float:
        # d/dt [m l v cos θ] = m l (a cos θ − v θ' sin θ)
        return base(th, w, t) + m * length * (a_of(t) * math.cos(th) - v_of(t) * w * math.sin(th))

    def not_a_gauge(th: float, w: float, t: float) -> float:
        return base(th, w, t) + 1e-3 * 0.5 * m * v_of(t) ** 2 * math.sin(th)

    t = np.linspace(0.0, 3.0, 31)
    y0 = np.array([0.4, 0.1])

    def run(rhs: Callable[[float, np.ndarray], np.ndarray]) -> np.ndarray:
        # Fixed steps: the finite-difference noise in the derived θ'' would stall an adaptive controller.
        return integrate(rhs, y0, t, "rk4", 5e-3).y[0]

    reference = run(rigid_rhs(p, a_of))
    plain = run(euler_lagrange_rhs(base))
    gauged = run(euler_lagrange_rhs(with_term))
    other = run(euler_lagrange_rhs(with_other_gauge))
    broken = run(euler_lagrange_rhs(not_a_gauge))
    assert np.max(np.abs(plain - reference)) < 1e-6
    assert np.max(np.abs(gauged - plain)) < 1e-6
    assert np.max(np.abs(other - plain)) < 1e-6
    assert np.max(np.abs(broken - plain)) > 1e-3


def test_rhs_handles_batches():
    """rigid_rhs on a (2, n) state equals n single evaluations exactly."""
    p = Pendulum(1.0, damping=0.1)
    rhs = rigid_rhs(p, lambda t: 2.0)
    y = np.array([[0.1, 1.0, -2.0], [0.3, 0.0, 1.0]])
    batch = rhs(0.0, y)
    for j in range(3):
        np.testing.assert_array_equal(batch[:, j], rhs(0.0, y[:, j]))


def test_tension_formula_values():
    """T = m(lθ'² + g cos θ + a sin θ) at hand-computed points (rel 1e-15)."""
    p = Pendulum(2.0, mass=3.0)
    # ≤ 4 roundings of terms of one sign plus sin/cos at exact points (0, π/2 to 1 ulp): within 4.5 ε
    assert float(tension(p, 0.0, 0.0, 5.0)) == pytest.approx(3.0 * G, rel=1e-15)
    assert float(tension(p, math.pi / 2, 1.0, 5.0)) == pytest.approx(3.0 * (2.0 + 5.0), rel=1e-15)
    assert float(energy(p, 0.0, 1.0, 0.0)) == pytest.approx(0.5 * 4.0 - G * 2.0, rel=1e-15)
