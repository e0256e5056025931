"""Lagrange-multiplier model: agrees with the reduced model, μ = −T/l, no constraint drift."""

from __future__ import annotations

import numpy as np
import pytest

from pendulum_accel.physics import multiplier as mm
from pendulum_accel.physics.integrators import integrate
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Braking, Sinusoid, scalar_accel
from pendulum_accel.physics.rigid import tension
from pendulum_accel.physics.simulate import simulate


@pytest.mark.parametrize("damping", [0.0, 0.3])
def test_agrees_with_reduced_model(damping):
    """θ within 1e-8 rad and tension within 1e-8 m g of the reduced model over 10 s, large swings,
    varying a."""
    p = Pendulum(0.9, mass=0.4, damping=damping)
    profile = Sinusoid(5.0, 0.35, offset=1.0)
    t = np.linspace(0.0, 10.0, 1001)
    rigid = simulate(p, profile, t, theta0=2.2, theta_dot0=0.5, model="rigid")
    cart = simulate(p, profile, t, theta0=2.2, theta_dot0=0.5, model="multiplier")
    assert rigid.tension is not None and cart.tension is not None and cart.multiplier is not None
    assert np.max(np.abs(cart.theta - rigid.theta)) < 1e-8
    assert np.max(np.abs(cart.theta_dot - rigid.theta_dot)) < 1e-7
    assert np.max(np.abs(cart.tension - rigid.tension)) < 1e-8 * p.mass * p.gravity


def test_multiplier_is_minus_tension_over_length():
    """μ = −T/l with T = m(lθ'² + g cos θ + a sin θ) evaluated on the multiplier model's own θ, θ' (rel
    1e-9)."""
    p = Pendulum(1.7, mass=2.0)
    profile = Braking(v0=20.0, decel=6.0, t_start=1.0)
    t = np.linspace(0.0, 8.0, 801)
    tr = simulate(p, profile, t, theta0=0.3, theta_dot0=1.0, model="multiplier")
    assert tr.multiplier is not None
    expected = -tension(p, tr.theta, tr.theta_dot, tr.accel) / p.length
    scale = p.mass * p.gravity / p.length
    assert np.max(np.abs(tr.multiplier - expected)) < 1e-9 * scale


def test_state_conversion_round_trip():
    """θ, θ' → (x, z, x', z') → θ, θ' is the identity to 1e-15 and puts the bob at x = −l sin θ, z = −l
    cos θ."""
    p = Pendulum(2.0)
    theta = np.array([-3.0, -0.5, 0.0, 1.0, 3.1])
    theta_dot = np.array([0.5, -1.0, 2.0, 0.0, 4.0])
    y = mm.cartesian_state(p, theta, theta_dot)
    # l·sin θ and back through atan2 on |y| ≤ 2: one np.sin/cos/atan2 (≤ 4 ulp of ≤ 2, 1.8e-15 at most) —
    # the same numpy call both ways here, so equal but for the products (1 ulp, 4.4e-16)
    np.testing.assert_allclose(y[0], -2.0 * np.sin(theta), atol=1e-15)
    np.testing.assert_allclose(y[1], -2.0 * np.cos(theta), atol=1e-15)
    back, back_dot = mm.angle_state(y)
    np.testing.assert_allclose(back, theta, atol=1e-15)
    np.testing.assert_allclose(back_dot, theta_dot, atol=1e-15)


@pytest.mark.parametrize(("method", "dt"), [("DOP853", None), ("rk4", 0.02), ("verlet", 0.01)])
def test_no_constraint_drift_over_100_s(method, dt):
    """|r − l| ≤ 1e-9 l at every sample over 100 s, rotating bob, varying a (DOP853: Baumgarte; fixed:
    projection)."""
    p = Pendulum(1.0)
    profile = Sinusoid(3.0, 0.3)
    t = np.linspace(0.0, 100.0, 1001)
    project = None if dt is None else mm.project_to_circle(p)
    result = integrate(
        mm.multiplier_rhs(p, scalar_accel(profile, 0.0, 100.0)),
        mm.cartesian_state(p, 2.5, 3.0),
        t,
        method,
        dt,
        omega=p.omega(3.0),
        project=project,
    )
    assert np.max(np.abs(mm.constraint_residual(p, result.y))) <= 1e-9 * p.length


def test_projection_is_what_holds_rk4_on_the_circle():
    """Without projection RK4 drifts past 1e-9 l in 100 s, so the projection in the test above matters."""
    p = Pendulum(1.0)
    profile = Sinusoid(3.0, 0.3)
    t = np.linspace(0.0, 100.0, 101)
    result = integrate(
        mm.multiplier_rhs(p, scalar_accel(profile, 0.0, 100.0)),
        mm.cartesian_state(p, 2.5, 3.0),
        t,
        "rk4",
        0.01,
    )
    assert np.max(np.abs(mm.constraint_residual(p, result.y))) > 1e-9 * p.length
