"""Integrators: order of accuracy, exact landing on samples, breakpoints, stability refusal, batches."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pendulum_accel.errors import ParameterError, StabilityError
from pendulum_accel.physics.integrators import (
    ADAPTIVE_METHODS,
    FIXED_STEP_METHODS,
    integrate,
    stability_limit,
)
from pendulum_accel.physics.kernels import RK8_A, RK8_B
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Step, scalar_accel
from pendulum_accel.physics.rigid import rigid_rhs
from test.figures import assert_figure
from test.rounding import stepped_atol


def oscillator(t: float, y: np.ndarray) -> np.ndarray:
    """y'' = -y as [q, v]."""
    return np.stack((y[1], -y[0]))


def oscillator_error(method: str, dt: float, t_end: float = 2.0) -> float:
    """Max |q - cos t| at 11 samples on [0, t_end]."""
    t = np.linspace(0.0, t_end, 11)
    result = integrate(oscillator, np.array([1.0, 0.0]), t, method, dt)
    return float(np.max(np.abs(result.y[0] - np.cos(t))))


@pytest.mark.parametrize(
    ("method", "order"), [("euler", 1), ("symplectic_euler", 1), ("verlet", 2), ("rk4", 4)]
)
def test_order_of_accuracy(method, order):
    """Halving dt divides the error by 2^p: measured order within 0.15 of p."""
    e1 = oscillator_error(method, 2e-3)
    e2 = oscillator_error(method, 1e-3)
    measured = math.log2(e1 / e2)
    assert abs(measured - order) < 0.15, (method, measured)


def test_rk8_is_eighth_order():
    """RK8 (DOP853's 8th-order weights, fixed step): halving hω = 0.4 divides the error by 2^(8 ± 0.3)."""
    e1 = oscillator_error("rk8", 0.4, t_end=20.0)
    e2 = oscillator_error("rk8", 0.2, t_end=20.0)
    assert abs(math.log2(e1 / e2) - 8.0) < 0.3, math.log2(e1 / e2)


def test_rk8_stability_limit_is_where_its_amplification_passes_one():
    """|R(iy)| ≤ 1 for 0 < y ≤ 5.96 and > 1 just past it, R(z) = 1 + z bᵀ (I − zA)⁻¹ 1 from the tableau."""
    a, b = np.asarray(RK8_A), np.asarray(RK8_B)

    def gain(y: float) -> float:
        z = 1j * y
        return float(abs(1.0 + z * b @ np.linalg.solve(np.eye(b.size) - z * a, np.ones(b.size))))

    limit = stability_limit("rk8")
    assert limit == 5.96
    assert max(gain(y) for y in np.linspace(0.01, limit, 600)) <= 1.0 + 1e-14
    assert gain(limit + 0.01) > 1.0


@pytest.mark.parametrize("method", ADAPTIVE_METHODS)
def test_adaptive_methods_meet_tolerance(method):
    """solve_ivp methods at rtol=1e-10 reproduce cos t to 1e-7 over 10 s (Radau/LSODA 1e-6)."""
    t = np.linspace(0.0, 10.0, 101)
    result = integrate(oscillator, np.array([1.0, 0.0]), t, method, rtol=1e-10, atol=1e-12)
    tol = 1e-6 if method in ("Radau", "LSODA") else 1e-7
    assert np.max(np.abs(result.y[0] - np.cos(t))) < tol
    assert result.nfev > 0


@pytest.mark.parametrize("method", FIXED_STEP_METHODS)
def test_lands_on_irregular_samples(method):
    """Irregular samples that dt does not divide: output times are the inputs, errors stay O(dt^p)."""
    t = np.array([0.0, 0.013, 0.1, 0.37, 0.371, 1.0])
    result = integrate(oscillator, np.array([1.0, 0.0]), t, method, 1e-4)
    np.testing.assert_array_equal(result.t, t)
    assert result.y.shape == (2, t.size)
    assert np.max(np.abs(result.y[0] - np.cos(t))) < 2e-4


def test_breakpoint_splitting_keeps_rk4_accuracy():
    """Splitting at the step time keeps RK4 (dt 1 ms) within 1e-10; without it the jump costs > 1e-7."""
    p = Pendulum(1.0)
    profile = Step(0.5037, 0.0, 5.0)  # not on the 0.01 s step grid
    rhs = rigid_rhs(p, scalar_accel(profile, 0.0, 2.0))
    t = np.linspace(0.0, 2.0, 21)
    ref = integrate(rhs, np.array([0.2, 0.0]), t, "DOP853", rtol=1e-13, atol=1e-15, breakpoints=(0.5037,))
    split = integrate(rhs, np.array([0.2, 0.0]), t, "rk4", 1e-3, breakpoints=(0.5037,))
    unsplit = integrate(rhs, np.array([0.2, 0.0]), t, "rk4", 1e-3)
    assert np.max(np.abs(split.y - ref.y)) < 1e-10
    assert np.max(np.abs(unsplit.y - ref.y)) > 1e-7


def test_jump_is_read_from_each_side():
    """At a breakpoint a(t) comes from the segment's own side: a step at a sample time costs nothing."""
    p = Pendulum(1.0)
    profile = Step(1.0, 0.0, 5.0)
    rhs = rigid_rhs(p, scalar_accel(profile, 0.0, 2.0))
    t = np.linspace(0.0, 2.0, 21)  # contains t = 1.0
    ref = integrate(rhs, np.array([0.2, 0.0]), t, "DOP853", rtol=1e-13, atol=1e-15, breakpoints=(1.0,))
    fixed = integrate(rhs, np.array([0.2, 0.0]), t, "rk4", 1e-3, breakpoints=(1.0,))
    assert np.max(np.abs(fixed.y - ref.y)) < 1e-10


def test_stability_limits():
    """Documented limits: RK4 2√2, Verlet and symplectic Euler 2, adaptive none."""
    assert stability_limit("rk4") == pytest.approx(2.8284271247461903)
    assert stability_limit("verlet") == 2.0
    assert stability_limit("symplectic_euler") == 2.0
    assert stability_limit("DOP853") is None


@pytest.mark.parametrize(
    ("method", "limit"),
    [("rk4", 2.8284271247461903), ("rk8", 5.96), ("verlet", 2.0), ("symplectic_euler", 2.0)],
)
def test_refuses_past_limit_and_is_bounded_below(method, limit):
    """hω = 1.01·limit is refused naming h, ω and limit; hω = 0.98·limit runs 2000 steps, bounded."""
    omega = 3.0
    t = np.array([0.0, 2000 * 0.98 * limit / omega])

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        return np.stack((y[1], -omega * omega * y[0]))

    with pytest.raises(StabilityError) as info:
        integrate(rhs, np.array([1.0, 0.0]), t, method, 1.01 * limit / omega, omega=omega)
    message = str(info.value)
    assert "h=" in message
    assert_figure(message, "ω=", omega, rel=0.0)  # the ω given, printed
    assert_figure(message, "stability limit ", limit, rel=0.0)
    result = integrate(rhs, np.array([1.0, 0.0]), t, method, 0.98 * limit / omega, omega=omega)
    # Linear analysis: RK4 decays; leapfrog schemes keep |q| ≤ 1/√(1-(hω/2)²) ≈ 5 at hω = 1.96.
    assert np.all(np.isfinite(result.y))
    assert np.max(np.abs(result.y[0])) < 6.0


def test_euler_refused_when_growth_too_large():
    """Explicit Euler always gains energy; a run that would more than double the amplitude is refused."""
    t = np.array([0.0, 10.0])
    with pytest.raises(StabilityError, match="Euler"):  # (1 + 0.01)^(1000/2) ≈ 145
        integrate(oscillator, np.array([1.0, 0.0]), 10 * t, "euler", 0.1, omega=1.0)
    ok = integrate(oscillator, np.array([1.0, 0.0]), t, "euler", 1e-3, omega=1.0)
    assert abs(ok.y[0, -1] - math.cos(10.0)) < 0.02


@pytest.mark.parametrize("method", FIXED_STEP_METHODS)
def test_batch_equals_single_runs(method):
    """A (2, 5) batch steps like five separate runs (to their rounding: same scheme, same steps)."""
    p = Pendulum(0.8, damping=0.3)
    rhs = rigid_rhs(p, lambda t: 2.0)
    y0 = np.array([np.linspace(-2.0, 2.5, 5), np.linspace(1.0, -1.0, 5)])
    t = np.linspace(0.0, 1.0, 6)
    batch = integrate(rhs, y0, t, method, 0.01)
    assert batch.y.shape == (2, 5, 6)
    for j in range(5):
        single = integrate(rhs, y0[:, j], t, method, 0.01)
        # math.sin (single) and np.sin (batch) may differ in the last bit: test.rounding over the run's
        # evaluations, Θ = max |y|, growth 1 + ωT (ω = √(√(g² + a²)/l), T = 1 s)
        atol = stepped_atol(single.nfev, float(np.max(np.abs(single.y))), 1.0 + p.omega(2.0))
        np.testing.assert_allclose(batch.y[:, j, :], single.y, rtol=0, atol=atol)


def test_batch_adaptive_matches_single():
    """DOP853 on a batch agrees with separate runs to 1e-9 (shared steps, same tolerance)."""
    p = Pendulum(1.0)
    rhs = rigid_rhs(p, lambda t: 1.0)
    y0 = np.array([[0.1, 1.0, 2.5], [0.0, 0.5, -1.0]])
    t = np.linspace(0.0, 3.0, 7)
    batch = integrate(rhs, y0, t, "DOP853")
    for j in range(3):
        single = integrate(rhs, y0[:, j], t, "DOP853")
        np.testing.assert_allclose(batch.y[:, j, :], single.y, rtol=0, atol=1e-9)


def test_damped_verlet_is_second_order():
    """With damping (a velocity-dependent force) the corrected Verlet still converges at order 2 ± 0.15."""
    c = 0.7

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        return np.stack((y[1], -y[0] - c * y[1]))

    wd = math.sqrt(1 - c * c / 4)
    t = np.linspace(0.0, 2.0, 5)
    exact = np.exp(-c * t / 2) * (np.cos(wd * t) + c / (2 * wd) * np.sin(wd * t))
    errors = [
        np.max(np.abs(integrate(rhs, np.array([1.0, 0.0]), t, "verlet", h).y[0] - exact))
        for h in (2e-3, 1e-3)
    ]
    assert abs(math.log2(errors[0] / errors[1]) - 2.0) < 0.15


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"method": "leapfrog"}, "unknown integration method"),
        ({"method": "rk4"}, "needs dt"),
        ({"method": "rk4", "dt": -1.0}, "dt must be"),
        ({"method": "rk4", "dt": float("nan")}, "dt must be"),
        ({"method": "DOP853", "rtol": 0.0}, "rtol"),
        ({"method": "DOP853", "t_eval": np.array([0.0, 1.0, 1.0])}, "strictly increasing"),
        ({"method": "DOP853", "t_eval": np.array([0.0, np.nan])}, "finite"),
        ({"method": "DOP853", "y0": np.array([np.inf, 0.0])}, "initial state"),
        ({"method": "verlet", "dt": 0.1, "y0": np.array([1.0, 2.0, 3.0])}, "even size"),
    ],
)
def test_bad_arguments(kwargs, needle):
    """Each bad argument is a ParameterError naming it."""
    args = {"t_eval": np.array([0.0, 1.0]), "y0": np.array([1.0, 0.0]), **kwargs}
    with pytest.raises(ParameterError, match=needle):
        integrate(oscillator, args.pop("y0"), args.pop("t_eval"), **args)
