"""Compiled kernels: the same schemes and equations as the numpy loop, a(t) read from each interval's side."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pendulum_accel.physics.elastic import elastic_rhs
from pendulum_accel.physics.integrators import FIXED_STEP_METHODS, integrate
from pendulum_accel.physics.kernels import (
    ACCEL_LINEAR,
    METHOD_CODES,
    RK8_B,
    SLICE_STEPS,
    Kernel,
    accel_coefficients,
    run_kernel,
    step_slices,
)
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import (
    AccelProfile,
    Braking,
    Constant,
    Ramp,
    Sinusoid,
    Step,
    Table,
    scalar_accel,
)
from pendulum_accel.physics.rigid import rigid_rhs
from test.rounding import stepped_atol

PROFILES: dict[str, AccelProfile] = {
    "constant": Constant(2.0),
    "step": Step(0.33, 1.0, -2.0),
    "ramp": Ramp(0.2, 0.7, -1.0, 3.0),
    "table": Table((0.0, 0.25, 0.5, 0.8), (0.0, 2.5, 2.5, -1.0)),
    "braking": Braking(v0=1.0, decel=2.5, t_start=0.1),
    "sinusoid": Sinusoid(2.0, 1.5, offset=0.5, phase=0.3),
}
T = np.array([0.0, 0.1, 0.37, 0.5, 0.61, 1.0])


def _both(kernel: Kernel, rhs: object, y0: np.ndarray, method: str, dt: float, breaks: tuple[float, ...]):
    """(compiled, numpy) results of the same integrate() call."""
    fast = integrate(rhs, y0, T, method, dt, breakpoints=breaks, kernel=kernel)  # type: ignore[arg-type]
    slow = integrate(rhs, y0, T, method, dt, breakpoints=breaks)  # type: ignore[arg-type]
    return fast, slow


@pytest.mark.parametrize("profile_name", sorted(PROFILES))
@pytest.mark.parametrize("method", FIXED_STEP_METHODS)
def test_rigid_kernel_matches_the_numpy_loop(method: str, profile_name: str) -> None:
    """Damped rigid pendulum, every profile kind: compiled and numpy agree to their rounding, same f count."""
    p = Pendulum(1.3, damping=0.2)
    profile = PROFILES[profile_name]
    rhs = rigid_rhs(p, scalar_accel(profile, 0.0, 1.0))
    fast, slow = _both(
        Kernel.rigid(p, profile), rhs, np.array([1.0, -0.5]), method, 1e-3, profile.breakpoints()
    )
    # numba's libm sin/cos against numpy's SIMD ones: test.rounding over the run's evaluations, Θ = max |y|,
    # growth 1 + ωT with ω = √(√(g² + a²)/l) for |a| ≤ 3 m/s² (≈ 3.8 here)
    growth = 1.0 + p.omega(3.0) * float(T[-1])
    atol = stepped_atol(slow.nfev, float(np.max(np.abs(slow.y))), growth)
    np.testing.assert_allclose(fast.y, slow.y, rtol=0, atol=atol)
    assert fast.nfev == slow.nfev


@pytest.mark.parametrize("method", ["rk4", "rk8", "verlet"])
def test_elastic_kernel_matches_the_numpy_loop(method: str) -> None:
    """Elastic string (k = 1e4 N/m, damped) through a step in a(t): compiled and numpy agree to rounding."""
    p = Pendulum(1.0, damping=0.1, stiffness=1e4)
    profile = PROFILES["step"]
    rhs = elastic_rhs(p, scalar_accel(profile, 0.0, 1.0))
    y0 = np.array([1.001, 0.4, 0.0, 0.2])
    kernel = Kernel.elastic(p, profile)
    fast, slow = _both(kernel, rhs, y0, method, 2e-4, profile.breakpoints())
    # as above, growth 1 + √(k/m) T from the string's radial mode (√(1e4) = 100 1/s over 1 s)
    growth = 1.0 + math.sqrt(1e4 / p.mass) * float(T[-1])  # p.stiffness
    atol = stepped_atol(slow.nfev, float(np.max(np.abs(slow.y))), growth)
    np.testing.assert_allclose(fast.y, slow.y, rtol=0, atol=atol)


def test_a_jump_never_leaks_across_a_breakpoint() -> None:
    """Step at 0.33: the interval before reads a_before at both ends, the one after a_after (slope 0)."""
    profile = PROFILES["step"]
    nodes = np.array([0.0, 0.33, 0.5])
    kind, coef = accel_coefficients(profile, nodes) or (None, None)
    assert kind == ACCEL_LINEAR
    np.testing.assert_array_equal(coef, [[1.0, 0.0], [-2.0, 0.0]])


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=6, unique=True))
def test_linear_coefficients_reproduce_the_profile_inside_each_interval(cuts: list[float]) -> None:
    """For a table split at its knots and random extra cuts, coef reproduces a(t) at interval midpoints."""
    profile = Table((0.0, 0.25, 0.5, 0.8), (0.0, 2.5, 2.5, -1.0))
    nodes: np.ndarray = np.unique(np.array([0.0, 1.0, *profile.times, *cuts]))
    _, coef = accel_coefficients(profile, nodes) or (None, np.empty((0, 2)))
    mid = 0.5 * (nodes[:-1] + nodes[1:])
    np.testing.assert_allclose(coef[:, 0] + coef[:, 1] * (mid - nodes[:-1]), profile(mid), rtol=0, atol=1e-12)


def test_unknown_profile_kinds_fall_back_to_the_numpy_loop() -> None:
    """A profile class the kernels do not know gets no compiled form; integrate() still runs it."""

    class Doubled(Constant):
        """a = 2·a₀, through a __call__ the kernels cannot see."""

        def __call__(self, t: object) -> np.ndarray:
            return 2.0 * super().__call__(t)  # type: ignore[arg-type]

    profile = Doubled(1.0)
    assert isinstance(profile, Constant)  # so the fallback must come from exact type checks, not isinstance
    p = Pendulum(1.0)
    kernel = Kernel.rigid(p, profile)
    assert run_kernel(kernel, np.zeros(2), T, "rk4", 1e-2) is None
    result = integrate(rigid_rhs(p, profile.scalar), np.zeros(2), T, "rk4", 1e-2, kernel=kernel)
    reference = integrate(rigid_rhs(p, lambda t: 2.0), np.zeros(2), T, "rk4", 1e-2)
    # the same rigid_rhs and steps on the same floats (a = 2·1.0 is exact): equal but for rounding in how
    # a(t) is reached; 1e-15 is 4 ulp of the |θ| ≤ 0.25 rad reached
    np.testing.assert_allclose(result.y, reference.y, rtol=0, atol=1e-15)


@pytest.mark.parametrize("method", ["rk4", "rk8"])
def test_compensated_sum_cuts_the_accumulated_roundoff(method: str) -> None:
    """θ'' = 0 (g/l = 0 in the kernel's parameters), θ' = 7.3 rad/s for 100 000 steps: every increment δᵢ
    is the same float expression in the kernel and here, so the exact answer is θ0 + fsum(δᵢ). The plain
    sum θ += δ, as the kernels added before, drifts by hundreds of ulps of θ (≈ 730 rad); the compensated
    update stays within one ulp of the exact sum."""
    w = 7.3
    times = np.linspace(0.0, 100.0, 100_001)
    steps = np.diff(times)
    increments = (
        [h / 6.0 * (w + 2.0 * (w + w) + w) for h in steps.tolist()]
        if method == "rk4"
        else [h * sum_in_order(RK8_B.tolist(), w) for h in steps.tolist()]
    )
    exact = 0.25 + math.fsum(increments)
    plain = 0.25
    for increment in increments:
        plain += increment
    kernel = Kernel("rigid", np.array([0.0, 1.0, 0.0]), Constant(0.0))  # (g/l, 1/l, c): θ'' = 0
    result = run_kernel(kernel, np.array([0.25, w]), times, method, 1.0)
    assert result is not None
    theta = float(result[0][0, -1])
    ulp = math.ulp(exact)
    assert abs(theta - exact) <= ulp
    assert abs(plain - exact) >= 50.0 * ulp  # what compensation removes


def sum_in_order(weights: list[float], value: float) -> float:
    """Σ bᵢ value, added left to right from 0.0 as the kernel's RK8 loop adds its stages."""
    total = 0.0
    for weight in weights:
        total += weight * value
    return total


def test_sliced_kernel_runs_are_bit_identical(monkeypatch: pytest.MonkeyPatch) -> None:
    kernel = Kernel.rigid(Pendulum(0.7, damping=0.1), Sinusoid(amplitude=2.0, frequency_hz=0.3))
    nodes = np.linspace(0.0, 5.0, 501)
    y0 = np.array([0.3, 0.0])
    for method in METHOD_CODES:
        whole = run_kernel(kernel, y0, nodes, method, 1.3e-3)
        monkeypatch.setitem(SLICE_STEPS, method, 37)  # many slices, some splitting nothing
        sliced = run_kernel(kernel, y0, nodes, method, 1.3e-3)
        monkeypatch.undo()
        assert whole is not None and sliced is not None
        assert sliced[1] == whole[1]
        np.testing.assert_array_equal(sliced[0], whole[0])


def test_step_slices_cover_every_interval_once() -> None:
    nodes = np.array([0.0, 1.0, 1.5, 4.0, 4.1, 9.0])
    slices = step_slices(nodes, 0.1, 20)
    assert slices[0][0] == 0 and slices[-1][1] == nodes.size - 1
    assert all(a[1] == b[0] for a, b in itertools.pairwise(slices))
