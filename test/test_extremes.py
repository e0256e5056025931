"""The extremes: inverted starts, the separatrix, rotation, huge a, tiny and huge l, 1e6-step runs, bad
input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pendulum_accel.errors import ParameterError, StabilityError
from pendulum_accel.physics.integrators import integrate, stability_limit
from pendulum_accel.physics.kernels import Kernel
from pendulum_accel.physics.params import STANDARD_GRAVITY, Pendulum
from pendulum_accel.physics.profiles import Constant, Step
from pendulum_accel.physics.rigid import energy, rigid_rhs
from pendulum_accel.physics.simulate import simulate
from test.figures import assert_figure
from test.swing import omega_of_swing

G = STANDARD_GRAVITY


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_inverted_start(sign):
    """θ0 = π ± 1e-9, a = 0: the bob falls to the side of the offset, and DOP853 stays within 10× the exact
    solution's sensitivity to a one-ulp change of θ0 over 8 s (by then it has swung through the bottom)."""
    p = Pendulum(1.0)
    t = np.linspace(0.0, 8.0, 801)
    theta0 = math.pi + sign * 1e-9
    rigid = simulate(p, Constant(0.0), t, theta0=theta0)
    exact = simulate(p, Constant(0.0), t, theta0=theta0, model="exact")
    nudged = simulate(p, Constant(0.0), t, theta0=math.nextafter(theta0, 10.0), model="exact")
    sensitivity = np.maximum.accumulate(np.abs(nudged.theta - exact.theta))
    assert np.all(np.abs(rigid.theta - exact.theta) <= 10.0 * sensitivity + 1e-15)
    offset = sign * (rigid.theta - math.pi)
    assert np.all(np.diff(offset[:700]) > 0.0)  # moves steadily away from the top, to its own side
    assert offset[-1] > math.pi  # past the bottom
    e = energy(p, rigid.theta, rigid.theta_dot, 0.0)
    assert np.max(np.abs(e - e[0])) < 1e-9 * G


@pytest.mark.parametrize("eps", [1e-9, -1e-9])
def test_near_separatrix(eps):
    """Start at θ_eq with ½θ'² = 2 g_eff/l·(1 + eps): above the separatrix the bob goes over the top, below it
    turns back short of θ_eq + π. DOP853's error is below the exact solution's response to a 1e-11 relative
    change of θ'0 (its own tolerance applied to the start) over 8 s."""
    p = Pendulum(1.0)
    a = 3.0
    geff = math.hypot(G, a)
    theta_eq = p.equilibrium_angle(a)
    w0 = math.sqrt(4.0 * geff * (1.0 + eps))
    t = np.linspace(0.0, 8.0, 801)
    rigid = simulate(p, Constant(a), t, theta0=theta_eq, theta_dot0=w0)
    exact = simulate(p, Constant(a), t, theta0=theta_eq, theta_dot0=w0, model="exact")
    nudged = simulate(p, Constant(a), t, theta0=theta_eq, theta_dot0=w0 * (1 + 1e-11), model="exact")
    assert np.max(np.abs(rigid.theta - exact.theta)) < np.max(np.abs(nudged.theta - exact.theta))
    reach = float(np.max(rigid.theta)) - theta_eq
    if eps > 0:
        assert reach > math.pi + 1.0
    else:
        assert math.pi - 1e-3 < reach < math.pi


def test_rotating_bob():
    """θ'0 = 10 rad/s (energy ≈ 2.4× the separatrix): θ increases monotonically, tension stays positive, and
    DOP853 matches the exact rotation to 1e-8 rad over 10 s (≈ 9 turns)."""
    p = Pendulum(1.0, mass=0.5)
    t = np.linspace(0.0, 10.0, 2001)
    rigid = simulate(p, Constant(3.0), t, theta0=0.0, theta_dot0=10.0)
    exact = simulate(p, Constant(3.0), t, theta0=0.0, theta_dot0=10.0, model="exact")
    assert np.all(np.diff(rigid.theta) > 0.0)
    assert rigid.theta[-1] > 8 * 2 * math.pi
    assert rigid.tension is not None and np.all(rigid.tension > 0.0)
    assert np.max(np.abs(rigid.theta - exact.theta)) < 1e-8


@pytest.mark.parametrize("a", [0.0, 10.0 * G, -10.0 * G])
def test_zero_and_ten_g(a):
    """a = 0, ±10 g: θ_eq = atan(a/g) holds still (1e-12), and ω from a simulated period matches
    √(√(g²+a²)/l) to 1e-6."""
    p = Pendulum(1.0)
    theta_eq = math.atan(a / G)
    # atan2(a, g) against atan(a/g): two libm calls and one division, ≤ 3 ulp of |θ_eq| < π/2
    assert p.equilibrium_angle(a) == pytest.approx(theta_eq, abs=1e-15)
    still = simulate(p, Constant(a), np.linspace(0.0, 5.0, 51), theta0=theta_eq)
    assert np.max(np.abs(still.theta - theta_eq)) < 1e-12
    omega = (math.hypot(G, a) / p.length) ** 0.5
    t = np.linspace(0.0, 20 * 2 * math.pi / omega, 20001)
    tr = simulate(p, Constant(a), t, theta0=theta_eq + 1e-3)
    assert omega_of_swing(t, tr.theta, tr.theta_dot, theta_eq) == pytest.approx(omega, rel=1e-6)


@pytest.mark.parametrize("length", [1e-3, 1e-2, 1.0, 10.0, 100.0])
def test_lengths_from_1_mm_to_100_m(length):
    """l = 1 mm … 100 m: ω from the simulated period matches √(√(g²+a²)/l) (rel 1e-6) with DOP853 and RK4 at
    hω = 0.05; RK4 at hω = 3 is refused."""
    p = Pendulum(length)
    a = 4.0
    omega = (math.hypot(G, a) / length) ** 0.5
    theta_eq = p.equilibrium_angle(a)
    t = np.linspace(0.0, 10 * 2 * math.pi / omega, 10001)
    for method, dt in (("DOP853", None), ("rk4", 0.05 / omega)):
        tr = simulate(p, Constant(a), t, theta0=theta_eq + 1e-3, method=method, dt=dt)
        assert omega_of_swing(t, tr.theta, tr.theta_dot, theta_eq) == pytest.approx(omega, rel=1e-6)
    with pytest.raises(StabilityError, match="hω=3"):
        simulate(p, Constant(a), t[:3], theta0=0.1, method="rk4", dt=3.0 / omega)


def test_million_step_runs():
    """1e6 steps at hω = 0.1.

    Symplectic Euler and Verlet, 1 rad swing: the energy error stays bounded (max over the last 10% of the run
    within 5% of the max over the first 10%; at most hω and 0.3(hω)² of the swing energy). RK4 drifts: at
    0.01 rad its swing energy decays by |R(ihω)|^(2n), R(z) = 1 + z + z²/2 + z³/6 + z⁴/24, measured to 1%.
    """
    p = Pendulum(1.0, gravity=1.0)  # ω = 1 rad/s, so h = 0.1 s
    h, n = 0.1, 1_000_000
    t = np.linspace(0.0, n * h, 1001)
    rhs = rigid_rhs(p, lambda t: 0.0)
    fast = Kernel.rigid(p, Constant(0.0))  # the compiled kernel: a million numpy steps would take minutes
    swing = lambda th, w: energy(p, th, w, 0.0) + 1.0  # energy above the bottom, per unit mass  # noqa: E731
    for method, bound in (("symplectic_euler", 0.1), ("verlet", 0.003)):
        res = integrate(rhs, np.array([1.0, 0.0]), t, method, h, omega=1.0, kernel=fast)
        e = swing(res.y[0], res.y[1])
        rel = np.abs(e - e[0]) / e[0]
        first, last = rel[1:101].max(), rel[-100:].max()
        assert last <= 1.05 * first, (method, first, last)
        assert rel.max() < bound, (method, rel.max())
    res = integrate(rhs, np.array([0.01, 0.0]), t, "rk4", h, omega=1.0, kernel=fast)
    e = swing(res.y[0], res.y[1])
    z = 0.1j
    predicted = abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24) ** (2 * n)
    assert e[-1] / e[0] == pytest.approx(predicted, rel=0.01)
    assert predicted < 0.99  # a real, measurable drift (≈ 1.4%)


@pytest.mark.parametrize("method", ["rk4", "verlet", "symplectic_euler"])
def test_dt_past_limit_refused(method):
    """dt = 1.05 × limit/ω (ω from a_max of a step profile) is refused via simulate, naming h, ω and limit."""
    p = Pendulum(0.5)
    profile = Step(1.0, 0.0, 20.0)
    limit = stability_limit(method)
    assert limit is not None
    omega = (math.hypot(G, 20.0) / 0.5) ** 0.5
    with pytest.raises(StabilityError) as info:
        simulate(p, profile, np.linspace(0.0, 2.0, 5), theta0=0.1, method=method, dt=1.05 * limit / omega)
    # ω here is (√(g² + a²)/l)^½ by pow, the refusal's by its own formula: a few ulp apart (rel 1e-14);
    # the limit is the same constant. Each is compared to its printed digits (test.figures).
    assert_figure(str(info.value), "ω=", omega, rel=1e-14)
    assert_figure(str(info.value), "stability limit ", limit, rel=0.0)


def test_stiff_string_refuses_coarse_fixed_step():
    """A fixed step fine for the pendulum but not for the string's ω_r = √(k/m) = 1e4 rad/s is refused."""
    p = Pendulum(1.0, stiffness=1e8)
    with pytest.raises(StabilityError, match="ω=10000"):
        simulate(
            p, Constant(0.0), np.linspace(0.0, 1.0, 3), theta0=0.1, model="elastic", method="rk4", dt=1e-3
        )


@pytest.mark.parametrize(
    ("build", "needle"),
    [
        (lambda: Pendulum(float("nan")), "length"),
        (lambda: Pendulum(float("inf")), "length"),
        (lambda: Pendulum(0.0), "length"),
        (lambda: Pendulum(-1.0), "length"),
        (lambda: Pendulum(1.0, gravity=0.0), "gravity"),
        (lambda: Pendulum(1.0, gravity=-9.8), "gravity"),
        (lambda: Pendulum(1.0, gravity=float("nan")), "gravity"),
        (lambda: Pendulum(1.0, mass=float("inf")), "mass"),
        (lambda: Pendulum(1.0, damping=float("nan")), "damping"),
        (lambda: Constant(float("nan")), "a"),
        (lambda: simulate(Pendulum(1.0), Constant(0.0), np.array([0.0, 1.0]), theta0=float("inf")), "theta0"),
        (lambda: simulate(Pendulum(1.0), Constant(0.0), np.array([0.0, np.nan]), theta0=0.0), "finite"),
        (lambda: simulate(Pendulum(1.0), Constant(0.0), np.array([0.0, 1.0]), theta0=0.0, dt=np.inf), "dt"),
    ],
)
def test_non_finite_and_non_physical_inputs(build, needle):
    """NaN, inf, l ≤ 0, g ≤ 0: a one-line ParameterError naming the bad value."""
    with pytest.raises(ParameterError, match=needle) as info:
        build()
    assert "\n" not in str(info.value)


def test_bob_at_rest_with_a_1e_160_rate_integrates() -> None:
    """Found by hypothesis: from θ ≈ 1.5e-161, θ' ≈ −1e-160 (at rest, for any purpose) scipy's DOP853
    first-step guess made its error norm NaN and the run failed; it must run and stay at rest."""
    p = Pendulum(6.0)
    t = np.linspace(0.0, 2 * math.pi / p.omega(0.0), 11)
    out = simulate(p, Constant(0.0), t, theta0=1.5262158051386013e-161, theta_dot0=-1.0419250829162285e-160)
    assert out.method == "DOP853"
    assert np.all(np.isfinite(out.theta)) and np.max(np.abs(out.theta)) < 1e-159
    assert np.max(np.abs(out.theta_dot)) < 1e-159
