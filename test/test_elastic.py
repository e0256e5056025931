"""Elastic string: stretch and tension from deformation, convergence to the rigid pendulum as k grows."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics.elastic import elastic_energy, elastic_jacobian, elastic_rhs, quasi_static_radius
from pendulum_accel.physics.params import STANDARD_GRAVITY, Pendulum
from pendulum_accel.physics.profiles import Constant, Step
from pendulum_accel.physics.simulate import choose_method, simulate

G = STANDARD_GRAVITY


def difference_to_rigid(k: float) -> tuple[float, float]:
    """(max |θ_elastic − θ_rigid|, max |T_elastic − T_rigid| / (m g)) over 3 s, a = 3 m/s², 1 rad swing."""
    t = np.linspace(0.0, 3.0, 301)
    rigid = simulate(Pendulum(1.0, mass=0.5), Constant(3.0), t, theta0=1.0)
    elastic = simulate(Pendulum(1.0, mass=0.5, stiffness=k), Constant(3.0), t, theta0=1.0, model="elastic")
    assert rigid.tension is not None and elastic.tension is not None
    return (
        float(np.max(np.abs(elastic.theta - rigid.theta))),
        float(np.max(np.abs(elastic.tension - rigid.tension))) / (0.5 * G),
    )


def test_tends_to_rigid_as_k_grows():
    """The θ difference falls like 1/k: log-log slope in [−1.15, −0.85] over k = 1e3…1e6, and < 1e-4 rad
    at 1e6.

    The tension difference falls too (below 1e-2 m g at k = 1e6): the string starts quasi-statically.
    """
    ks = np.array([1e3, 1e4, 1e5, 1e6])
    diffs = np.array([difference_to_rigid(k) for k in ks])
    slope = np.polyfit(np.log10(ks), np.log10(diffs[:, 0]), 1)[0]
    assert -1.15 <= slope <= -0.85, diffs
    assert diffs[-1, 0] < 1e-4
    assert np.all(np.diff(diffs[:, 1]) < 0.0)
    assert diffs[-1, 1] < 1e-2


@pytest.mark.parametrize("a", [0.0, 4.0, -9.0])
def test_static_stretch_and_tension(a):
    """Hanging at θ_eq: stretch = m√(g²+a²)/k and T = k·stretch = m√(g²+a²), held for 2 s (rel 1e-6)."""
    p = Pendulum(0.5, mass=0.2, stiffness=2e3)
    tr = simulate(p, Constant(a), np.linspace(0.0, 2.0, 201), theta0=p.equilibrium_angle(a), model="elastic")
    assert tr.stretch is not None and tr.tension is not None and tr.stretch_rate is not None
    expected = 0.2 * math.hypot(G, a)
    np.testing.assert_allclose(tr.tension, expected, rtol=1e-6)
    np.testing.assert_allclose(tr.stretch, expected / 2e3, rtol=1e-6)
    assert np.max(np.abs(tr.stretch_rate)) < 1e-6 * expected / 2e3 * math.sqrt(2e3 / 0.2)


def test_energy_conserved_for_constant_a():
    """E = ½(r'² + r²θ'²) − g r cos θ − a r sin θ + (k/2m)(r−l)² changes by < 1e-6 g l over 5 s (auto
    method)."""
    p = Pendulum(1.0, stiffness=1e5)
    t = np.linspace(0.0, 5.0, 501)
    tr = simulate(p, Constant(2.0), t, theta0=1.2, theta_dot0=0.3, model="elastic")
    assert tr.stretch is not None and tr.stretch_rate is not None
    y = np.array([1.0 + tr.stretch, tr.theta, tr.stretch_rate, tr.theta_dot])
    e = elastic_energy(p, y, 2.0)
    assert np.max(np.abs(e - e[0])) < 1e-6 * G


def test_stiff_string_picks_a_stiff_solver_and_copes():
    """k/m = 1e8 (ω_r = 1e4 rad/s): 'auto' picks LSODA and a 1 s run with a step in a(t) stays within
    1e-5 rad of rigid."""
    p = Pendulum(1.0, stiffness=1e8)
    assert choose_method(p, "elastic", "auto") == "LSODA"
    assert choose_method(Pendulum(1.0, stiffness=50.0), "elastic", "auto") == "DOP853"
    t = np.linspace(0.0, 1.0, 101)
    profile = Step(0.3, 0.0, 3.0)
    tr = simulate(p, profile, t, theta0=0.4, model="elastic")
    rigid = simulate(Pendulum(1.0), profile, t, theta0=0.4)
    assert tr.method == "LSODA"
    assert np.max(np.abs(tr.theta - rigid.theta)) < 1e-5


def test_jacobian_matches_finite_differences():
    """The analytic ∂f/∂y agrees with central differences to 1e-6 (relative to 1 + |J|)."""
    p = Pendulum(1.2, mass=0.7, damping=0.1, stiffness=1e4)
    f = elastic_rhs(p, lambda t: 3.0)
    jac = elastic_jacobian(p, lambda t: 3.0)(0.0, np.array([1.21, 0.4, 0.02, -0.3]))
    y = np.array([1.21, 0.4, 0.02, -0.3])
    numeric = np.empty((4, 4))
    for i in range(4):
        e = np.zeros(4)
        e[i] = 1e-6
        numeric[:, i] = (f(0.0, y + e) - f(0.0, y - e)) / 2e-6
    assert np.max(np.abs(numeric - jac) / (1.0 + np.abs(jac))) < 1e-6


def test_quasi_static_start_balances_radial_force():
    """r₀ makes r'' = 0 at the start: r θ'² + g cos θ + a sin θ = (k/m)(r₀ − l) to 1e-12 (rel)."""
    p = Pendulum(1.0, mass=2.0, stiffness=500.0)
    r0 = quasi_static_radius(p, 0.7, 1.5, 2.0)
    f = elastic_rhs(p, lambda t: 2.0)(0.0, np.array([r0, 0.7, 0.0, 1.5]))
    assert abs(f[2]) < 1e-12 * G


def test_missing_or_too_soft_stiffness():
    """No k, or k too soft to hold a spinning bob, is a ParameterError naming stiffness."""
    with pytest.raises(ParameterError, match="stiffness"):
        simulate(Pendulum(1.0), Constant(0.0), np.array([0.0, 1.0]), theta0=0.1, model="elastic")
    with pytest.raises(ParameterError, match="stiffness"):
        quasi_static_radius(Pendulum(1.0, stiffness=1.0), 0.0, 10.0, 0.0)
