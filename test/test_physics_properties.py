"""Property-based checks (hypothesis) of invariants across random pendulums, accelerations and starts."""

from __future__ import annotations

import itertools
import math

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from pendulum_accel.motion_input import profile_from_dict
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Braking, Step, Table
from pendulum_accel.physics.profiles import Constant as ConstantAccel
from pendulum_accel.physics.rigid import energy
from pendulum_accel.physics.simulate import simulate

FAST = settings(max_examples=25, deadline=None)

lengths = st.floats(1e-3, 100.0).map(lambda x: float(x))
log_lengths = st.floats(-3.0, 2.0).map(lambda e: 10.0**e)
gravities = st.floats(0.5, 30.0)
accels = st.floats(-50.0, 50.0)
masses = st.floats(0.01, 100.0)
angles = st.floats(-math.pi, math.pi)


@FAST
@given(log_lengths, gravities, accels, masses)
def test_equilibrium_is_still_with_tension_m_geff(length, g, a, m):
    """At θ_eq = atan2(a, g) the bob stays within 1e-10 rad for 3 periods and T = m√(g²+a²) (rel 1e-10)."""
    p = Pendulum(length, mass=m, gravity=g)
    theta_eq = p.equilibrium_angle(a)
    assert math.isclose(math.tan(theta_eq), a / g, rel_tol=1e-12, abs_tol=1e-15)
    t = np.linspace(0.0, 3 * 2 * math.pi / p.omega(a), 31)
    tr = simulate(p, ConstantAccel(a), t, theta0=theta_eq)
    assert np.max(np.abs(tr.theta - theta_eq)) < 1e-10
    assert tr.tension is not None
    # at θ_eq within 1e-10 rad: T = m(g cos θ + a sin θ + l θ'²) moves by ≤ m √(g² + a²)·1e-10 (rel 1e-10)
    np.testing.assert_allclose(tr.tension, m * math.hypot(g, a), rtol=1e-10)


@FAST
@given(log_lengths, gravities, accels, angles, st.floats(-3.0, 3.0))
def test_energy_invariant(length, g, a, theta0, rate_in_omegas):
    """Constant a, undamped: E = ½l²θ'² − g l cos θ − a l sin θ is conserved to 1e-8 of its scale over 3
    periods."""
    p = Pendulum(length, gravity=g)
    omega = p.omega(a)
    w0 = rate_in_omegas * omega
    t = np.linspace(0.0, 3 * 2 * math.pi / omega, 61)
    tr = simulate(p, ConstantAccel(a), t, theta0=theta0, theta_dot0=w0)
    e = energy(p, tr.theta, tr.theta_dot, a)
    scale = p.effective_gravity(a) * length + 0.5 * (length * w0) ** 2
    assert np.max(np.abs(e - e[0])) < 1e-8 * scale


@FAST
@given(lengths, accels, angles, st.floats(-2.0, 2.0), st.floats(0.0, 2.0))
def test_mirror_symmetry(length, a, theta0, rate, damping):
    """(a, θ0, θ'0) → (−a, −θ0, −θ'0) mirrors θ(t) exactly (to 1e-12), damped or not."""
    p = Pendulum(length, damping=damping)
    t = np.linspace(0.0, 2 * 2 * math.pi / p.omega(a), 41)
    w0 = rate * p.omega(a)
    plus = simulate(p, ConstantAccel(a), t, theta0=theta0, theta_dot0=w0)
    minus = simulate(p, ConstantAccel(-a), t, theta0=-theta0, theta_dot0=-w0)
    # The same code on mirrored inputs: mirrored bit for bit where sin is odd and cos even to the last bit
    # (measured 0 here and under `make test`'s CPU emulation). 1e-12 leaves a libm whose range reduction is
    # not sign-symmetric its 1-ulp differences over the run's ≤ 1e3 evaluations: 1e3 ε π ≈ 7e-13.
    np.testing.assert_allclose(minus.theta, -plus.theta, rtol=0, atol=1e-12)


@FAST
@given(lengths, accels, st.floats(-1.5, 1.5), st.floats(-1.0, 1.0))
def test_time_reversal(length, a, offset, rate):
    """Undamped: run one period, flip θ', run again: back at (θ0, −θ'0) within 1e-7 (angle) and 1e-7 ω
    (rate)."""
    p = Pendulum(length)
    omega = p.omega(a)
    theta0 = p.equilibrium_angle(a) + offset
    w0 = rate * omega
    t = np.linspace(0.0, 2 * math.pi / omega, 11)
    out = simulate(p, ConstantAccel(a), t, theta0=theta0, theta_dot0=w0)
    back = simulate(p, ConstantAccel(a), t, theta0=float(out.theta[-1]), theta_dot0=-float(out.theta_dot[-1]))
    assert abs(back.theta[-1] - theta0) < 1e-7
    assert abs(back.theta_dot[-1] + w0) < 1e-7 * omega


@settings(max_examples=10, deadline=None)
@given(lengths, st.floats(-20.0, 20.0), angles, st.floats(-2.0, 2.0))
def test_multiplier_agrees_with_reduced(length, a, theta0, rate):
    """The Cartesian multiplier model and the reduced model agree to 1e-7 rad over 2 periods; μ = −T/l.

    Starts within 1 % of the separatrix energy are left out: there any two correct integrators part
    exponentially (the exact-solution tests measure that sensitivity against mpmath instead).
    """
    p = Pendulum(length)
    omega = p.omega(a)
    # Energy above the bottom, in units of g_eff/l: ½(θ'/ω)² + 1 − cos(θ − θ_eq); the separatrix is 2.
    level = 0.5 * rate * rate + 1.0 - math.cos(theta0 - p.equilibrium_angle(a))
    assume(abs(level - 2.0) > 0.02)
    t = np.linspace(0.0, 2 * 2 * math.pi / omega, 41)
    w0 = rate * omega
    rigid = simulate(p, ConstantAccel(a), t, theta0=theta0, theta_dot0=w0)
    cart = simulate(p, ConstantAccel(a), t, theta0=theta0, theta_dot0=w0, model="multiplier")
    assert np.max(np.abs(cart.theta - rigid.theta)) < 1e-7
    assert cart.multiplier is not None and rigid.tension is not None
    scale = p.mass * p.effective_gravity(a) * (1.0 + rate * rate)
    assert np.max(np.abs(cart.multiplier * length + rigid.tension)) < 1e-7 * scale


@FAST
@given(
    st.floats(0.1, 5.0),
    st.floats(-15.0, 15.0),
    st.floats(-15.0, 15.0),
    st.floats(-1.0, 1.0),
)
def test_exact_chain_matches_integration_on_steps(t_step, a_before, a_after, offset):
    """A step in a(t): the chained closed form and DOP853 split at the step agree to 1e-8 rad (libration)."""
    p = Pendulum(1.0)
    t = np.linspace(0.0, 6.0, 61)
    profile = Step(t_step, a_before, a_after)
    theta0 = p.equilibrium_angle(a_before) + offset
    rigid = simulate(p, profile, t, theta0=theta0)
    exact = simulate(p, profile, t, theta0=theta0, model="exact")
    assert np.max(np.abs(rigid.theta - exact.theta)) < 1e-8


@FAST
@given(
    st.lists(st.floats(-20.0, 20.0), min_size=1, max_size=6),
    st.floats(0.01, 3.0),
    st.floats(-5.0, 5.0),
    st.floats(0.0, 10.0),
)
def test_profile_pieces_and_round_trip(levels, spacing, t0, span):
    """Flat tables and braking: constant pieces tile [t0, t0+span] and carry a(midpoint); to_dict
    round-trips."""
    times = tuple(t0 + spacing * i for i in range(2 * len(levels)))
    accels = tuple(v for v in levels for _ in range(2))  # flat segments joined by ramps
    for profile in (Table(times, accels), Braking(v0=spacing * 10, decel=abs(levels[0]) + 0.5, t_start=t0)):
        assert profile_from_dict(profile.to_dict()) == profile
        pieces = profile.constant_pieces(t0, t0 + span)
        if pieces is None:
            assert isinstance(profile, Table) and len(set(levels)) > 1
            continue
        assert pieces[0][0] == t0 and pieces[-1][1] == t0 + span
        for (lo, hi, value), (next_lo, _, _) in itertools.pairwise(pieces):
            assert hi == next_lo and lo <= hi
            assert value == float(profile(0.5 * (lo + hi)))
        assert profile.max_abs(t0, t0 + span) >= max(abs(v) for _, _, v in pieces)
