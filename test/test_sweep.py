"""The vectorised sweep engine agrees with single-trajectory simulate(), and its CLI writes one table."""

from __future__ import annotations

import csv
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Constant, Sinusoid, Step
from pendulum_accel.physics.simulate import simulate
from pendulum_accel.sweep import SweepSetup, batch_rigid_rhs, parse_values, run_batch

# The batch right-hand side is the amplitude-phase form of the same equation, so the batch and the
# single-trajectory RK4 runs differ only by rounding: a few ulps per step, ~1e-13 rad over the run.
SAME_STEP_TOL = 1e-12
# Against a tight DOP853 reference, the default RK4 step (hω ≤ 0.02) is accurate to this over 10 s.
DEFAULT_STEP_TOL = 1e-7


def _setup(
    profile: object, damping: float = 0.0, theta0: float = 0.3, duration: float = 10.0, theta_dot0: float = 0.1
) -> SweepSetup:
    """A SweepSetup without a sensor (run_batch does not measure)."""
    t = np.linspace(0.0, duration, int(duration * 100) + 1)
    return SweepSetup(
        pendulum=Pendulum(1.0, damping=damping),
        profile=profile,  # type: ignore[arg-type]
        theta0=theta0,
        theta_dot0=theta_dot0,
        t=t,
        sensor=None,
        noise_std=0.0,
        rate_hz=100.0,
    )


@pytest.mark.parametrize(
    "profile",
    [Constant(2.0), Step(1.0, 0.0, 3.0), Sinusoid(1.5, 0.4, offset=0.5)],
    ids=["constant", "step", "sinusoid"],
)
@pytest.mark.parametrize("damping", [0.0, 0.4])
def test_length_sweep_matches_simulate(profile: object, damping: float) -> None:
    """Each variant of a length sweep equals simulate(model='rigid', method='rk4') with the same dt."""
    setup = _setup(profile, damping)
    lengths = np.array([0.3, 1.0, 2.5])
    theta, theta_dot, dt, steps = run_batch(setup, lengths, None)
    assert dt is not None and steps > 0
    for i, length in enumerate(lengths):
        single = simulate(
            Pendulum(float(length), damping=damping), setup.profile, setup.t,
            theta0=setup.theta0, theta_dot0=setup.theta_dot0, model="rigid", method="rk4", dt=dt,
        )
        assert np.max(np.abs(theta[i] - single.theta)) < SAME_STEP_TOL
        assert np.max(np.abs(theta_dot[i] - single.theta_dot)) < SAME_STEP_TOL * 10
        reference = simulate(
            Pendulum(float(length), damping=damping), setup.profile, setup.t,
            theta0=setup.theta0, theta_dot0=setup.theta_dot0, model="rigid", method="DOP853", rtol=1e-12,
            atol=1e-12,
        )
        assert np.max(np.abs(theta[i] - reference.theta)) < DEFAULT_STEP_TOL


def test_accel_sweep_matches_simulate_with_constant_profiles() -> None:
    """An accel sweep is a constant-a run per variant, starting from the scene's state."""
    setup = _setup(Step(1.0, 0.0, 3.0))
    accels = np.array([-4.0, 0.0, 2.0, 9.0])
    theta, _, dt, _ = run_batch(setup, np.full(accels.size, 1.0), accels)
    for i, a in enumerate(accels):
        single = simulate(
            setup.pendulum, Constant(float(a)), setup.t, theta0=setup.theta0, theta_dot0=setup.theta_dot0,
            model="rigid", method="rk4", dt=dt,
        )
        assert np.max(np.abs(theta[i] - single.theta)) < SAME_STEP_TOL


def test_batch_rhs_is_the_equation_of_motion() -> None:
    """(g_eff/l) sin(θ_eq − θ) − c θ' equals −(g/l) sin θ + (a/l) cos θ − c θ' to rounding."""
    rng = np.random.default_rng(7)
    lengths = rng.uniform(0.1, 5.0, 50)
    y = np.vstack((rng.uniform(-7, 7, 50), rng.uniform(-3, 3, 50)))
    g, c, a = 9.80665, 0.3, rng.uniform(-20, 20, 50)
    f = batch_rigid_rhs(lengths, g, c, a)(0.0, y)
    expected = (-g * np.sin(y[0]) + a * np.cos(y[0])) / lengths - c * y[1]
    np.testing.assert_array_equal(f[0], y[1])
    np.testing.assert_allclose(f[1], expected, rtol=0, atol=1e-12 * np.max(np.abs(expected)))


@pytest.mark.parametrize(
    ("field", "text", "expected"),
    [
        ("length", "0.5,1,2", (0.5, 1.0, 2.0)),
        ("accel", "-3, 0 ,3", (-3.0, 0.0, 3.0)),
        ("noise", "0:0.01:3", (0.0, 0.005, 0.01)),
    ],
)
def test_parse_values(field: str, text: str, expected: tuple[float, ...]) -> None:
    """Comma lists and start:stop:count ranges parse to floats."""
    assert parse_values(field, text) == pytest.approx(expected)


@pytest.mark.parametrize(
    ("field", "text", "fragment"),
    [
        ("length", "1,abc", "'abc' is not a number"),
        ("length", "1,-2", "must be > 0"),
        ("length", "", "needs a comma-separated list"),
        ("noise", "-0.1", "must be >= 0"),
        ("accel", "1,nan", "finite"),
        ("accel", "0:1", "start:stop:count"),
        ("accel", "0:1:x", "integer"),
        ("accel", "0:1:0", "count must be in"),
        ("mass", "1", "unknown sweep field"),
    ],
)
def test_bad_values_raise_one_line(field: str, text: str, fragment: str) -> None:
    """A bad sweep list is a ParameterError whose one-line message names the problem."""
    with pytest.raises(ParameterError, match=fragment) as info:
        parse_values(field, text)
    assert "\n" not in str(info.value)


def test_period_of_a_length_sweep_matches_small_angle_theory() -> None:
    """Small swings (0.02 rad) have the period 2π/√(g_eff/l) within 0.01 % (amplitude effect: 2.5e-5)."""
    from pendulum_accel.sweep import _periods

    setup = _setup(Constant(2.0), theta0=math.atan2(2.0, 9.80665) + 0.02, duration=20.0, theta_dot0=0.0)
    lengths = np.array([0.5, 1.0, 2.0])
    theta, _, _, _ = run_batch(setup, lengths, None)
    measured = _periods(setup.t, theta)
    expected = 2 * math.pi / np.sqrt(math.hypot(9.80665, 2.0) / lengths)
    np.testing.assert_allclose(measured, expected, rtol=1e-4)
