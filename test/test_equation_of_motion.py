"""One equation of motion, θ'' = −(g/l) sin θ + (a/l) cos θ − c θ', at home in physics.rigid.theta_ddot.

The copies that stay for speed (numba's scalar kernel, the Kalman filter's per-sample RK4 and its
Jacobian, the sweep's amplitude-phase batch form, the benchmark's mpmath reference) are each held to
theta_ddot here on random states.
"""

from __future__ import annotations

import mpmath
import numpy as np
import pytest

from benchmarks.work_precision_cases import mp_theta_ddot
from pendulum_accel.estimators.ekf_kernels import predict
from pendulum_accel.physics.kernels import Kernel, _rigid_rhs
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Constant
from pendulum_accel.physics.rigid import theta_ddot
from pendulum_accel.sweep import batch_rigid_rhs

N_STATES = 200


def _states(seed: int) -> list[tuple[Pendulum, float, float, float]]:
    """(pendulum, θ, θ', a) with l ∈ [0.1, 5] m, c ∈ [0, 1] 1/s, θ ∈ [−7, 7], θ' ∈ [−5, 5], a ∈ [−20, 20]."""
    rng = np.random.default_rng(seed)
    return [
        (
            Pendulum(float(rng.uniform(0.1, 5.0)), damping=float(rng.uniform(0.0, 1.0))),
            float(rng.uniform(-7.0, 7.0)),
            float(rng.uniform(-5.0, 5.0)),
            float(rng.uniform(-20.0, 20.0)),
        )
        for _ in range(N_STATES)
    ]


def _scale(p: Pendulum, theta_dot: float, accel: float) -> float:
    """A bound on the terms of θ'': rounding is relative to it, not to a θ'' that may cancel to 0."""
    return (p.gravity + abs(accel)) / p.length + p.damping * abs(theta_dot)


def test_compiled_kernel_rhs_is_theta_ddot() -> None:
    """physics.kernels' scalar rigid rhs gives [θ', theta_ddot] to rounding."""
    out = np.empty((1, 2))
    for p, th, w, a in _states(1):
        _rigid_rhs(Kernel.rigid(p, Constant(a)).par, a, np.array([th, w]), out, 0)
        assert out[0, 0] == w
        assert out[0, 1] == pytest.approx(float(theta_ddot(p, th, w, a)), abs=1e-14 * _scale(p, w, a))


def test_sweep_batch_rhs_with_a_shared_profile_is_theta_ddot() -> None:
    """sweep.batch_rigid_rhs with a scalar a(t) (the profile path) gives theta_ddot per variant."""
    for p, th, w, a in _states(2)[:40]:
        lengths = np.array([p.length, 2.0 * p.length])
        y = np.array([[th, -th], [w, 0.5 * w]])
        f = batch_rigid_rhs(lengths, p.gravity, p.damping, Constant(a).scalar)(0.0, y)
        for i, length in enumerate(lengths):
            q = Pendulum(float(length), damping=p.damping)
            expected = float(theta_ddot(q, y[0, i], y[1, i], a))
            assert f[1, i] == pytest.approx(expected, abs=1e-13 * _scale(q, y[1, i], a))


def _predict(p: Pendulum, x: np.ndarray, cov: np.ndarray, dt: float) -> np.ndarray:
    """The Kalman filter's compiled prediction (ekf_kernels.predict) without process noise; returns F."""
    f = np.empty((3, 3))
    predict(x, cov, f, dt, p.gravity, 1.0 / p.length, p.damping, 0.0, 0.0)
    return f


def test_kalman_prediction_is_an_rk4_step_of_theta_ddot() -> None:
    """The filter's state prediction is one classic RK4 step of [θ', theta_ddot(θ, θ', a)], a held."""
    dt = 5e-3  # one sub-step (≤ MAX_STEP)
    for p, th, w, a in _states(3):
        x = np.array([th, w, a])
        _predict(p, x, np.zeros((3, 3)), dt)

        def f(y: np.ndarray, p: Pendulum = p, a: float = a) -> np.ndarray:
            return np.array([y[1], float(theta_ddot(p, y[0], y[1], a))])

        y0 = np.array([th, w])
        k1 = f(y0)
        k2 = f(y0 + 0.5 * dt * k1)
        k3 = f(y0 + 0.5 * dt * k2)
        k4 = f(y0 + dt * k3)
        expected = y0 + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        np.testing.assert_allclose(x[:2], expected, rtol=0, atol=1e-13 * (1.0 + _scale(p, w, a)))
        assert x[2] == a


def test_kalman_jacobian_is_that_of_theta_ddot() -> None:
    """From P = I without noise, the prediction gives F Fᵀ, F = I + J dt + J² dt²/2, J from theta_ddot."""
    dt, eps = 5e-3, 1e-6
    for p, th, w, a in _states(4)[:50]:
        x = np.array([th, w, a])
        cov = np.eye(3)
        f = _predict(p, x, cov, dt)
        row = [
            (float(theta_ddot(p, *(x0 + eps * e))) - float(theta_ddot(p, *(x0 - eps * e)))) / (2.0 * eps)
            for x0 in [np.array([th, w, a])]
            for e in np.eye(3)
        ]
        jac = np.array([[0.0, 1.0, 0.0], row, [0.0, 0.0, 0.0]])
        step = np.eye(3) + jac * dt + jac @ jac * (0.5 * dt * dt)
        # Central differences of theta_ddot (|∂²/∂x²| ≲ (g + |a|)/l, eps = 1e-6) are good to ~1e-10: 1e-8.
        np.testing.assert_allclose(f, step, rtol=0, atol=1e-8)
        np.testing.assert_allclose(cov, step @ step.T, rtol=0, atol=1e-8)


def test_benchmark_mpmath_reference_rhs_is_theta_ddot() -> None:
    """benchmarks.work_precision_cases.mp_theta_ddot at 30 digits rounds to theta_ddot."""
    with mpmath.workdps(30):
        for p, th, w, a in _states(5):
            value = mp_theta_ddot(*(mpmath.mpf(v) for v in (th, w, a, p.gravity, p.length, p.damping)))
            assert float(value) == pytest.approx(float(theta_ddot(p, th, w, a)), abs=1e-14 * _scale(p, w, a))
