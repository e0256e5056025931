"""Closed-form constant-a pendulum against a 30-digit Taylor integration of θ'' itself.

The reference integrates θ'' = -(g/l) sin θ + (a/l) cos θ (not the reduced φ equation) from the same
double-precision initial state, taken exactly. It runs in 124-bit fixed point (mp_reference, fast) and
is itself checked against the same method in mpmath arithmetic at mp.dps = 30 (mp_taylor_reference).
Near the separatrix the allowance is 10x the reference's own spread under a one-ulp change of the start.
"""

from __future__ import annotations

import math
from operator import mul

import mpmath as mp
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp
from scipy.special import ellipk

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics.exact import (
    OrbitStart,
    complete_k,
    exact_period,
    exact_solution,
    jacobi_reduced,
    libration_amplitude,
    libration_motion,
    rotation_motion,
)
from pendulum_accel.physics.params import STANDARD_GRAVITY as G
from pendulum_accel.physics.params import Pendulum

HORIZON = 20.0  # s, the accuracy horizon
CHECK_TIMES = np.linspace(2.0, HORIZON, 10)
TOLERANCE = 1e-10  # rad, the bound for θ against the reference
TAYLOR_ORDER = 36
TAYLOR_STEP = 0.22  # × 1/Ω; the nearest complex singularity is ≥ (π/2)/Ω away, so terms shrink ≥ 7× each
FIXED_BITS = 124  # fixed-point fraction bits, ≈ 37 digits


def _taylor_step_bound(gravity: float, accel: float, length: float, theta_dot0: float) -> float:
    """h_max = 0.22/Ω, Ω² = g_eff/l + θ0'²/4 ≥ the fastest phase rate the orbit can reach."""
    return TAYLOR_STEP / math.sqrt(math.hypot(gravity, accel) / length + theta_dot0**2 / 4.0)


def mp_taylor_reference(
    gravity: float, accel: float, length: float, theta0: float, theta_dot0: float, times: np.ndarray
) -> list[tuple[mp.mpf, mp.mpf]]:
    """(θ, θ') at ``times``: 36th-order Taylor method in mpmath arithmetic at mp.dps = 30.

    Taylor coefficients of θ'' = -(g/l) S + (a/l) C with S = sin θ, C = cos θ, from S' = C θ', C' = -S θ'
    (Cauchy products). Used to validate the faster fixed-point twin below.
    """
    with mp.workdps(30):
        g_l, a_l = mp.mpf(gravity) / length, mp.mpf(accel) / length
        theta, rate = mp.mpf(theta0), mp.mpf(theta_dot0)
        h_max = mp.mpf(_taylor_step_bound(gravity, accel, length, theta_dot0))
        inv = [mp.mpf(1) / k for k in range(1, TAYLOR_ORDER + 3)]
        now = mp.mpf(0)
        out = []
        for target in map(mp.mpf, times):
            while now < target:
                h = min(h_max, target - now)
                x, d = [theta, rate], [rate]
                sin_s, cos_s = [mp.sin(theta)], [mp.cos(theta)]
                for k in range(TAYLOR_ORDER):
                    x.append((a_l * cos_s[k] - g_l * sin_s[k]) * inv[k] * inv[k + 1])
                    d.append((k + 2) * x[k + 2])
                    rev = d[k::-1]
                    sin_s.append(mp.fdot(cos_s, rev) * inv[k])
                    cos_s.append(-mp.fdot(sin_s[: k + 1], rev) * inv[k])
                theta, rate = mp.polyval(x, h, asc=True), mp.polyval(d, h, asc=True)
                now += h
            out.append((theta, rate))
        return out


def mp_reference(
    gravity: float, accel: float, length: float, theta0: float, theta_dot0: float, times: np.ndarray
) -> list[tuple[mp.mpf, mp.mpf]]:
    """The same Taylor method on integers scaled by 2^124 (≈ 37 digits), returned as mp.dps = 30 numbers.

    Constants, sin θ0 and cos θ0 come from mpmath at 45 digits; the step loop carries θ, θ', sin θ, cos θ
    as fixed-point integers (mpmath's own mantissa arithmetic without its per-operation overhead), about
    10x faster than mp_taylor_reference, with which it agrees to 1e-28 (test below).
    """
    one = 1 << FIXED_BITS
    with mp.workdps(45):

        def to_fixed(value: mp.mpf) -> int:
            return int(mp.nint(value * one))

        g_l = to_fixed(mp.mpf(gravity) / length)
        a_l = to_fixed(mp.mpf(accel) / length)
        start = mp.mpf(theta0)
        state = [to_fixed(v) for v in (start, mp.mpf(theta_dot0), mp.sin(start), mp.cos(start))]
        h_max = to_fixed(mp.mpf(_taylor_step_bound(gravity, accel, length, theta_dot0)))
        now = 0
        fixed_out = []
        for target in (to_fixed(mp.mpf(float(t))) for t in times):
            while now < target:
                h = min(h_max, target - now)
                theta, rate, sin_t, cos_t = state
                x, d, sin_s, cos_s = [theta, rate], [rate], [sin_t], [cos_t]
                for k in range(TAYLOR_ORDER):
                    x.append(((a_l * cos_s[k] - g_l * sin_s[k]) >> FIXED_BITS) // ((k + 1) * (k + 2)))
                    d.append((k + 2) * x[k + 2])
                    rev = d[k::-1]
                    sin_s.append((sum(map(mul, cos_s, rev)) >> FIXED_BITS) // (k + 1))
                    cos_s.append(-(sum(map(mul, sin_s[: k + 1], rev)) >> FIXED_BITS) // (k + 1))
                state = []
                for series in (x, d, sin_s, cos_s):
                    acc = series[-1]
                    for coefficient in reversed(series[:-1]):
                        acc = coefficient + ((acc * h) >> FIXED_BITS)
                    state.append(acc)
                now += h
            fixed_out.append((state[0], state[1]))
    with mp.workdps(30):
        return [(mp.mpf(theta) / one, mp.mpf(rate) / one) for theta, rate in fixed_out]


def theta_errors(reference: list[tuple[mp.mpf, mp.mpf]], theta: np.ndarray) -> np.ndarray:
    """|θ_closed - θ_ref| at each check time, exact difference rounded once."""
    return np.array([float(abs(mp.mpf(float(x)) - ref[0])) for x, ref in zip(theta, reference, strict=True)])


EQ2 = math.atan2(2.0, G)
EQ_M5 = math.atan2(-5.0, G)

# (name, length, accel, θ0, θ0', tolerance): states away from the separatrix; tolerance in rad.
ORDINARY = [
    ("lecture a=2, rest", 1.0, 2.0, 0.0, 0.0, 1e-12),  # team target for the lecture case
    ("tiny amplitude 1e-13 (linear branch)", 4.0, 2.0, EQ2 + 1e-13, 0.0, TOLERANCE),
    ("amplitude 1e-5 (Fourier)", 4.0, 2.0, EQ2 - 1e-5, 1e-5, TOLERANCE),
    ("libration 2.5 rad (Fourier)", 4.0, 2.0, EQ2 + 2.5, 0.0, TOLERANCE),
    ("libration 2.9 rad (doubling)", 4.0, 2.0, EQ2 - 2.9, 0.0, TOLERANCE),
    ("rotation just over the top", 4.0, 2.0, EQ2 + 2.5, 1.0, TOLERANCE),
    ("rotation forward", 1.0, 2.0, 0.0, 8.0, TOLERANCE),
    ("rotation backward a=-5, 3 turns start", 4.0, -5.0, 6 * math.pi + 0.3, -6.0, TOLERANCE),
]


def test_fixed_point_reference_matches_mpmath_arithmetic() -> None:
    """Fixed-point Taylor reference = the mp.dps = 30 one to 1e-20 rad, 1e-9 from the separatrix."""
    args = (G, 0.0, G, 0.0, 2.0 - 1e-9)
    fixed = mp_reference(*args, CHECK_TIMES)
    arbitrary = mp_taylor_reference(*args, CHECK_TIMES)
    assert max(abs(x[0] - y[0]) + abs(x[1] - y[1]) for x, y in zip(fixed, arbitrary, strict=True)) <= 1e-20


@pytest.mark.parametrize(("name", "length", "accel", "theta0", "rate0", "tol"), ORDINARY)
def test_matches_30_digit_reference(
    name: str, length: float, accel: float, theta0: float, rate0: float, tol: float
) -> None:
    """|θ - θ_ref| ≤ tol over 20 s, θ' to 10 tol: libration, rotation (both ways, wrapped start), tiny."""
    theta, rate = exact_solution(Pendulum(length), accel, theta0, rate0, CHECK_TIMES)
    reference = mp_reference(G, accel, length, theta0, rate0, CHECK_TIMES)
    assert theta_errors(reference, theta).max() <= tol, name
    rate_err = max(float(abs(mp.mpf(float(w)) - ref[1])) for w, ref in zip(rate, reference, strict=True))
    assert rate_err <= 10 * tol, name


# ω = 1 rad/s for these (g_eff = l), so the 20 s reference stays cheap.
EQ3 = math.atan2(3.0, G)
NEAR_SEPARATRIX = [
    ("separatrix speed - 1e-9", G, 0.0, 0.0, 2.0 - 1e-9, "rate"),
    ("separatrix speed + 1e-9", G, 0.0, 0.0, 2.0 + 1e-9, "rate"),
    ("exactly on the separatrix in double", G, 0.0, 0.0, 2.0, "rate"),
    ("inverted, theta0 = float(pi)", G, 0.0, math.pi, 0.0, "angle"),
    ("inverted, theta0 = pi + 1e-9", G, 0.0, math.pi + 1e-9, 0.0, "angle"),
    ("inverted about tilted eq, a=3", math.hypot(G, 3.0), 3.0, EQ3 - math.pi, 0.0, "angle"),
]


@pytest.mark.parametrize(("name", "length", "accel", "theta0", "rate0", "perturb"), NEAR_SEPARATRIX)
def test_near_separatrix_within_intrinsic_sensitivity(
    name: str, length: float, accel: float, theta0: float, rate0: float, perturb: str
) -> None:
    """|θ - θ_ref| ≤ max(1e-10, 10 S(t)), S = |θ_ref(start + 1 ulp) - θ_ref(start)|, both in mpmath."""
    pendulum = Pendulum(length)
    start = OrbitStart.from_state(pendulum, accel, theta0, rate0)
    assert abs(start.m1) < 1e-8, name  # the case really sits at the separatrix
    theta, _ = exact_solution(pendulum, accel, theta0, rate0, CHECK_TIMES)
    reference = mp_reference(G, accel, length, theta0, rate0, CHECK_TIMES)
    if perturb == "angle":
        nudged = mp_reference(G, accel, length, float(np.nextafter(theta0, np.inf)), rate0, CHECK_TIMES)
    else:
        nudged = mp_reference(G, accel, length, theta0, float(np.nextafter(rate0, np.inf)), CHECK_TIMES)
    sensitivity = np.array([float(abs(x[0] - y[0])) for x, y in zip(nudged, reference, strict=True)])
    allowed = np.maximum(TOLERANCE, 10.0 * sensitivity)
    errors = theta_errors(reference, theta)
    assert np.all(errors <= allowed), (name, errors, sensitivity)


@pytest.mark.parametrize("m1", [0.5, 1e-3, 1e-9, 1e-17, 1e-33])
def test_jacobi_functions_match_mpmath_down_to_tiny_complement(m1: float) -> None:
    """K to 1e-15 relative; sn, cn, dn(u | 1 - m1) to 5e-14 absolute on [-1.3K, 4.3K], m1 down to 1e-33.

    m1 = 1e-33 is the float θ0 = π inverted start.
    """
    m = 1.0 - m1
    K = complete_k(m1)
    u = np.linspace(-1.3 * K, 4.3 * K, 13)
    sn_r, cn_r, dn_r, j = jacobi_reduced(u, m, m1, K)
    parity = 1.0 - 2.0 * np.mod(j, 2.0)
    with mp.workdps(60):
        m_exact = 1 - mp.mpf(m1)
        assert float(abs(K - mp.ellipk(m_exact)) / K) <= 1e-15
        for i, ui in enumerate(u):
            want = [mp.ellipfun(kind, mp.mpf(float(ui)), m=m_exact) for kind in ("sn", "cn", "dn")]
            got = (sn_r[i] * parity[i], cn_r[i] * parity[i], dn_r[i])
            assert max(float(abs(x - y)) for x, y in zip(got, want, strict=True)) <= 5e-14


@pytest.mark.parametrize(("phi0", "rate_scale"), [(0.2, 0.0), (1.5, 0.3), (2.7, -0.1), (2.85, 0.0)])
def test_libration_fourier_and_doubling_agree(phi0: float, rate_scale: float) -> None:
    """Both libration evaluations (Fourier series, halving/doubling) agree to 1e-13 rad over ±20 periods."""
    pendulum = Pendulum(1.0)
    start = OrbitStart.from_state(pendulum, 0.0, phi0, rate_scale * pendulum.omega(0.0))
    assert 0.0 < start.m < 1.0
    times = np.linspace(-40.0, 40.0, 2001)
    phi_f, rate_f = libration_motion(times, start, "fourier")
    phi_d, rate_d = libration_motion(times, start, "doubling")
    assert np.max(np.abs(phi_f - phi_d)) <= 1e-13
    assert np.max(np.abs(rate_f - rate_d)) <= 1e-13 * pendulum.omega(0.0)


@pytest.mark.parametrize("rate_scale", [-2.1, 2.5, 4.0, 30.0])
def test_rotation_fourier_and_doubling_agree(rate_scale: float) -> None:
    """Both rotation evaluations agree to 1e-13 relative to |φ| over ±40 s, for m from 1.1 to 225."""
    pendulum = Pendulum(1.0)
    start = OrbitStart.from_state(pendulum, 0.0, 0.4, rate_scale * pendulum.omega(0.0))
    assert start.m1 < 0.0
    times = np.linspace(-40.0, 40.0, 2001)
    phi_f, rate_f = rotation_motion(times, start, "fourier")
    phi_d, rate_d = rotation_motion(times, start, "doubling")
    assert np.max(np.abs(phi_f - phi_d)) <= 1e-13 * np.max(np.abs(phi_d))
    assert np.max(np.abs(rate_f - rate_d)) <= 1e-13 * np.max(np.abs(rate_d))


@settings(max_examples=40, deadline=None)
@given(
    length=st.floats(1e-3, 100.0),
    accel=st.floats(-10 * G, 10 * G),
    phi0=st.floats(-math.pi, math.pi),
    rate_scale=st.floats(-3.0, 3.0),
)
@example(length=1.0, accel=-1.0, phi0=0.15625, rate_scale=-1.875)  # θ_eq + φ0 cancels (see below)
def test_energy_invariant_and_start_state(
    length: float, accel: float, phi0: float, rate_scale: float
) -> None:
    """E = ½l²θ'² - gl cos θ - al sin θ constant to 1e-11 l g_eff; θ(0), θ'(0) = start to 1e-14 relative."""
    pendulum = Pendulum(length)
    omega = pendulum.omega(accel)
    theta0 = pendulum.equilibrium_angle(accel) + phi0
    rate0 = rate_scale * omega
    times = np.concatenate([[0.0], np.linspace(0.01, 20.0, 50) / omega])
    theta, rate = exact_solution(pendulum, accel, theta0, rate0, times)
    energy = 0.5 * length**2 * rate**2 - G * length * np.cos(theta) - accel * length * np.sin(theta)
    scale = length * pendulum.effective_gravity(accel)
    assert np.ptp(energy) <= 1e-11 * scale
    # θ(0) = θ_eq + φ(0) and θ'(0) come back through the Jacobi functions and their inverses: a few ulp of
    # the terms they are made of, not of the result. θ0 = θ_eq + φ0 may cancel (θ_eq -0.102 + φ0 0.156 gave
    # θ0 0.0546, off by 1.2e-15 = 2.2e-14 of θ0 but 4.7e-15, ~21 ulp, of |θ_eq| + |φ0|, in the generic-CPU
    # pass). So the bound is relative to those terms: 1e-13 is ~450 ulp of them, room for the inverse's
    # conditioning (8 ulp seen at θ0 = -1.75) on any CPU; and to ω(1 + |rate_scale|) for the rate.
    terms = abs(pendulum.equilibrium_angle(accel)) + abs(phi0)
    assert abs(theta[0] - theta0) <= 1e-13 * terms + 1e-15
    assert abs(rate[0] - rate0) <= 1e-13 * omega * (1.0 + abs(rate_scale))


@settings(max_examples=25, deadline=None)
@given(
    accel=st.floats(-20.0, 20.0),
    phi0=st.floats(-3.0, 3.0),
    rate_scale=st.floats(-3.0, 3.0),
)
def test_agrees_with_dop853(accel: float, phi0: float, rate_scale: float) -> None:
    """Away from the separatrix (|m1| > 1e-2), θ matches DOP853 (rtol 1e-12) to 1e-8 rad over 10 s."""
    pendulum = Pendulum(1.0)
    omega = pendulum.omega(accel)
    theta0 = pendulum.equilibrium_angle(accel) + phi0
    rate0 = rate_scale * omega
    if abs(OrbitStart.from_state(pendulum, accel, theta0, rate0).m1) < 1e-2:
        return
    times = np.linspace(0.0, 10.0, 21)
    theta, rate = exact_solution(pendulum, accel, theta0, rate0, times)
    g = pendulum.gravity
    sol = solve_ivp(
        lambda _t, y: [y[1], -g * math.sin(y[0]) + accel * math.cos(y[0])],
        (0.0, 10.0),
        [theta0, rate0],
        method="DOP853",
        t_eval=times,
        rtol=1e-12,
        atol=1e-12,
    )
    assert np.max(np.abs(sol.y[0] - theta)) <= 1e-8
    assert np.max(np.abs(sol.y[1] - rate)) <= 1e-8 * (1.0 + abs(rate0))


@pytest.mark.parametrize(
    ("theta0", "rate0"), [(0.4, 0.0), (2.9, 1.5), (0.0, 7.0), (1.0, -9.0), (math.pi, 1e-8)]
)
def test_restart_and_time_reversal(theta0: float, rate0: float) -> None:
    """Chaining (restart from the state at t1) and θ(-t; θ0, θ0') = θ(t; θ0, -θ0') agree to 1e-11 rad."""
    pendulum, accel = Pendulum(0.8), 1.5
    times = np.linspace(0.0, 6.0, 25)
    theta, rate = exact_solution(pendulum, accel, theta0, rate0, times)
    th1, w1 = exact_solution(pendulum, accel, theta0, rate0, 2.5)
    theta_b, rate_b = exact_solution(pendulum, accel, float(th1), float(w1), times[times >= 2.5] - 2.5)
    assert np.max(np.abs(theta_b - theta[times >= 2.5])) <= 1e-11
    assert np.max(np.abs(rate_b - rate[times >= 2.5])) <= 1e-10
    theta_back, rate_back = exact_solution(pendulum, accel, theta0, -rate0, -times)
    assert np.max(np.abs(theta_back - theta)) <= 1e-11
    assert np.max(np.abs(rate_back + rate)) <= 1e-10


def test_rotation_is_unwrapped_and_periodic() -> None:
    """A rotating bob's θ is monotone, gains exactly 2π per period T = 2K(1/m)/(kω) (to 1e-11), both ways."""
    pendulum, accel = Pendulum(1.0), 2.0
    start = OrbitStart.from_state(pendulum, accel, 0.0, 8.0)
    assert start.m1 < 0.0
    k = math.sqrt(start.m)
    period = 2.0 * float(ellipk(1.0 / start.m)) / (k * start.omega)
    times = np.linspace(0.0, 5 * period, 400)
    for sign in (1.0, -1.0):
        theta, rate = exact_solution(pendulum, accel, 0.0, sign * 8.0, times)
        assert np.all(np.diff(theta) * sign > 0.0)
        assert np.all(rate * sign > 0.0)
        turn, _ = exact_solution(pendulum, accel, 0.0, sign * 8.0, [period, 5 * period])
        # the closed form's round-off, EXACT_ROUNDOFF ε (Θ + 2kω·span), grows with the turns: with Θ = 10π
        # and 2kω·span of the same order, ~1e-13; 1e-11 leaves the elliptic argument reduction 100×
        assert turn == pytest.approx(sign * np.array([2 * math.pi, 10 * math.pi]), abs=1e-11)


def test_vectorised_shape_and_scalar_time() -> None:
    """Output has the shape of t: a 2-D grid and a scalar both work, equal to the 1-D values."""
    pendulum = Pendulum(1.0)
    grid = np.linspace(0.0, 3.0, 12).reshape(3, 4)
    theta, rate = exact_solution(pendulum, 2.0, 0.3, 0.1, grid)
    assert theta.shape == rate.shape == (3, 4)
    flat, _ = exact_solution(pendulum, 2.0, 0.3, 0.1, grid.ravel())
    np.testing.assert_array_equal(theta.ravel(), flat)
    single, _ = exact_solution(pendulum, 2.0, 0.3, 0.1, 3.0)
    assert np.ndim(single) == 0 and float(single) == flat[-1]


def test_exact_period_known_values() -> None:
    """T(0) = 2π/ω; T(π/2) = 4K(½)/ω, K(½) = 1.854074677301372; θ(T) = θ0 and θ(T/2) = θ_eq - A (1e-12)."""
    pendulum, accel = Pendulum(2.0), 3.0
    omega = pendulum.omega(accel)
    # K(m=0) = π/2 from R_F(0, 1, 1) exactly to an ulp, then ≤ 3 roundings: within 4.5 ε relative
    assert exact_period(pendulum, accel, 0.0) == pytest.approx(2 * math.pi / omega, rel=1e-15)
    quarter_turn = exact_period(pendulum, accel, math.pi / 2)
    assert quarter_turn == pytest.approx(4 * 1.854074677301372 / omega, rel=1e-14)
    amp = 2.7
    period = exact_period(pendulum, accel, amp)
    theta0 = pendulum.equilibrium_angle(accel) + amp
    theta, _ = exact_solution(pendulum, accel, theta0, 0.0, [0.5 * period, period])
    # back to θ0 after one period of A = 2.7 rad: the period's few-ulp rounding is amplified by 1/m₁ ≈ 20
    # (m₁ = cos²(A/2) ≈ 0.05, near the separatrix), ~1e-14 rad; 1e-12 leaves it 100×
    assert theta[1] == pytest.approx(theta0, abs=1e-12)
    assert theta[0] == pytest.approx(theta0 - 2 * amp, abs=1e-12)  # turning point on the other side
    assert libration_amplitude(pendulum, accel, theta0, 0.0) == pytest.approx(amp, abs=1e-14)
    assert math.isfinite(exact_period(pendulum, accel, math.pi))  # float π sits just below the top
    assert libration_amplitude(pendulum, accel, 0.0, 50.0) == math.inf


ONE_METRE = Pendulum(1.0)


@pytest.mark.parametrize(
    ("call", "field"),
    [
        (lambda: exact_solution(Pendulum(1.0), math.nan, 0.0, 0.0, [1.0]), "acceleration"),
        (lambda: exact_solution(Pendulum(1.0), 1.0, math.inf, 0.0, [1.0]), "theta0"),
        (lambda: exact_solution(Pendulum(1.0), 1.0, 0.0, -math.inf, [1.0]), "theta_dot0"),
        (lambda: exact_solution(Pendulum(1.0), 1.0, 0.0, 0.0, [0.0, math.nan]), "sample time"),
        (lambda: exact_solution(Pendulum(0.0), 1.0, 0.0, 0.0, [1.0]), "length"),
        (lambda: exact_solution(Pendulum(1.0, gravity=-9.8), 1.0, 0.0, 0.0, [1.0]), "gravity"),
        (lambda: exact_period(Pendulum(1.0), 0.0, 3.5), "amplitude"),
        (lambda: exact_period(Pendulum(1.0), 0.0, math.nan), "amplitude"),
        (lambda: libration_motion(np.zeros(2), OrbitStart.from_state(ONE_METRE, 0, 1, 0), "agm"), "method"),
    ],
)
def test_invalid_input_names_the_value(call: object, field: str) -> None:
    """NaN/inf inputs, l ≤ 0, g ≤ 0, amplitude outside [0, π]: ParameterError naming the field."""
    with pytest.raises(ParameterError, match=field):
        call()  # type: ignore[operator]
