"""Linearised model about θ_eq and its predicted error against the exact closed form."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics.exact import exact_period, exact_solution
from pendulum_accel.physics.linear import abs_sine_integral, linear_error_bound, linear_solution
from pendulum_accel.physics.params import STANDARD_GRAVITY as G
from pendulum_accel.physics.params import Pendulum


def test_harmonic_solution_and_start_state() -> None:
    """θ = θ_eq + φ0 cos ωt + (θ0'/ω) sin ωt with ω² = √(g²+a²)/l, to 1e-15; θ(0), θ'(0) are the start."""
    pendulum, accel = Pendulum(1.0), 2.0
    omega = math.sqrt(math.hypot(G, accel))
    theta_eq = math.atan2(accel, G)
    times = np.linspace(0.0, 7.0, 50)
    theta, rate = linear_solution(pendulum, accel, theta_eq + 0.05, -0.2, times)
    want = theta_eq + 0.05 * np.cos(omega * times) - (0.2 / omega) * np.sin(omega * times)
    # the same cos/sin of the same products, summed alike: |θ| ≤ 0.2, so 1e-15 is ≥ 4 ulp of every term
    np.testing.assert_allclose(theta, want, rtol=0, atol=1e-15)
    want_rate = -0.2 * np.cos(omega * times) - 0.05 * omega * np.sin(omega * times)
    np.testing.assert_allclose(rate, want_rate, rtol=0, atol=1e-14)
    assert theta[0] == theta_eq + 0.05 and rate[0] == -0.2


def test_no_acceleration_recovers_sqrt_g_over_l() -> None:
    """a = 0: period 2π√(l/g) to 1e-12 s; started at rest at θ_eq it stays exactly there."""
    pendulum = Pendulum(2.5)
    period = 2 * math.pi * math.sqrt(2.5 / G)
    theta, _ = linear_solution(pendulum, 0.0, 0.1, 0.0, [period, 3 * period])
    np.testing.assert_allclose(theta, 0.1, atol=1e-12)
    rest, rest_rate = linear_solution(pendulum, 4.0, math.atan2(4.0, G), 0.0, np.linspace(0, 10, 5))
    assert np.all(rest == math.atan2(4.0, G)) and np.all(rest_rate == 0.0)


def test_linearises_about_nearest_equilibrium_copy() -> None:
    """θ0 = θ_eq + 2π + 0.01 oscillates about θ_eq + 2π (amplitude 0.01, to 1e-12), not about θ_eq."""
    pendulum, accel = Pendulum(1.0), 3.0
    theta_eq = math.atan2(accel, G)
    theta, _ = linear_solution(pendulum, accel, theta_eq + 2 * math.pi + 0.01, 0.0, np.linspace(0, 5, 200))
    assert np.max(np.abs(theta - theta_eq - 2 * math.pi)) <= 0.01 + 1e-12


def test_small_amplitude_agrees_with_exact() -> None:
    """A = 1e-4 rad over 20 s: linear and exact agree to 1e-11 rad (error ~ A³ ωT/16 ≈ 4e-12)."""
    pendulum, accel = Pendulum(1.0), 2.0
    theta0 = math.atan2(accel, G) + 1e-4
    times = np.linspace(0.0, 20.0, 400)
    lin, _ = linear_solution(pendulum, accel, theta0, 0.0, times)
    ex, _ = exact_solution(pendulum, accel, theta0, 0.0, times)
    assert np.max(np.abs(lin - ex)) <= 1e-11


def actual_max_error(pendulum: Pendulum, accel: float, amplitude: float, duration: float) -> float:
    """max over 8 starting phases on the amplitude-A orbit of max_t |θ_linear - θ_exact| (4001 samples)."""
    theta_eq = pendulum.equilibrium_angle(accel)
    period = exact_period(pendulum, accel, amplitude)
    phase_times = np.arange(8) * period / 8
    starts_theta, starts_rate = exact_solution(pendulum, accel, theta_eq + amplitude, 0.0, phase_times)
    times = np.linspace(0.0, duration, 4001)
    worst = 0.0
    for theta0, rate0 in zip(starts_theta, starts_rate, strict=True):
        lin, _ = linear_solution(pendulum, accel, float(theta0), float(rate0), times)
        ex, _ = exact_solution(pendulum, accel, float(theta0), float(rate0), times)
        worst = max(worst, float(np.max(np.abs(lin - ex))))
    return worst


@pytest.mark.parametrize("amplitude", [1e-3, 0.03, 0.2, 0.5, 1.0, 2.0, 2.8])
@pytest.mark.parametrize("duration", [0.1, 0.7, 3.0, 20.0])
def test_error_bound_is_honest_and_tight(amplitude: float, duration: float) -> None:
    """actual ≤ bound ≤ 10 actual, amplitudes 1 mrad to 2.8 rad, durations 0.05 to 10 periods."""
    pendulum, accel = Pendulum(1.0), 2.0
    bound = linear_error_bound(pendulum, accel, amplitude, duration)
    actual = actual_max_error(pendulum, accel, amplitude, duration)
    assert actual <= bound
    assert bound <= 10.0 * actual


def test_error_bound_limits() -> None:
    """Zero duration or amplitude → 0; long runs saturate at 2A; a rotation (A ≥ π) → inf; G(x) = ∫|sin|."""
    pendulum = Pendulum(1.0)
    assert linear_error_bound(pendulum, 1.0, 0.5, 0.0) == 0.0
    assert linear_error_bound(pendulum, 1.0, 0.0, 10.0) == 0.0
    assert linear_error_bound(pendulum, 1.0, 1.0, 1e4) == 2.0
    assert linear_error_bound(pendulum, 1.0, math.pi, 1.0) == math.inf
    assert abs_sine_integral(math.pi) == pytest.approx(2.0, abs=1e-15)
    assert abs_sine_integral(2.5 * math.pi) == pytest.approx(5.0, abs=1e-14)
    small = linear_error_bound(pendulum, 1.0, 1e-3, 1.0)  # series branch of A - sin A
    assert small == pytest.approx((1e-3 - math.sin(1e-3)) * abs_sine_integral(pendulum.omega(1.0)), rel=1e-9)


@pytest.mark.parametrize(
    ("call", "field"),
    [
        (lambda: linear_solution(Pendulum(1.0), math.inf, 0.0, 0.0, [1.0]), "acceleration"),
        (lambda: linear_solution(Pendulum(1.0), 0.0, math.nan, 0.0, [1.0]), "theta0"),
        (lambda: linear_solution(Pendulum(1.0), 0.0, 0.0, math.nan, [1.0]), "theta_dot0"),
        (lambda: linear_solution(Pendulum(1.0), 0.0, 0.0, 0.0, [math.inf]), "sample time"),
        (lambda: linear_solution(Pendulum(-1.0), 0.0, 0.0, 0.0, [1.0]), "length"),
        (lambda: linear_error_bound(Pendulum(1.0), 0.0, -0.1, 1.0), "amplitude"),
        (lambda: linear_error_bound(Pendulum(1.0), 0.0, 0.1, math.nan), "duration"),
        (lambda: linear_error_bound(Pendulum(1.0), 0.0, 0.1, -1.0), "duration"),
    ],
)
def test_invalid_input_names_the_value(call: object, field: str) -> None:
    """NaN/inf input, l ≤ 0, negative amplitude or duration: ParameterError naming the field."""
    with pytest.raises(ParameterError, match=field):
        call()  # type: ignore[operator]
