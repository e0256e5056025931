"""simulate(): every model and method through one entry point, chaining, per-model outputs, bad input."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest

from pendulum_accel.errors import ParameterError, StabilityError
from pendulum_accel.physics.integrators import METHODS
from pendulum_accel.physics.linear import linear_error_bound
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Braking, Constant, Ramp, Step, Table
from pendulum_accel.physics.simulate import MODELS, simulate
from test.figures import assert_figure

T = np.linspace(0.0, 6.0, 601)
STEP = Step(2.05, 0.0, 4.0)  # the jump falls between samples


@pytest.fixture(scope="module")
def exact_reference():
    """The closed form chained over the step: the reference every integrator is held to."""
    return simulate(Pendulum(1.0), STEP, T, theta0=0.6, theta_dot0=-0.2, model="exact")


@pytest.mark.parametrize(
    ("method", "dt", "tol"),
    [
        ("DOP853", None, 1e-9),
        ("RK45", None, 1e-6),
        ("Radau", None, 1e-5),
        ("LSODA", None, 1e-5),
        ("rk4", 1e-3, 1e-9),
        ("rk8", 2e-2, 1e-10),
        ("verlet", 1e-3, 1e-5),
        ("symplectic_euler", 1e-4, 1e-3),
        ("euler", 1e-5, 1e-3),
    ],
)
def test_rigid_methods_match_chained_exact(exact_reference, method, dt, tol):
    """Each integrator at its default tolerance/stated dt matches the exact chain across the jump within
    tol rad."""
    tr = simulate(Pendulum(1.0), STEP, T, theta0=0.6, theta_dot0=-0.2, method=method, dt=dt)
    assert tr.method == method
    assert np.max(np.abs(tr.theta - exact_reference.theta)) < tol


def test_all_methods_are_covered():
    """The parametrisation above lists every method in the registry."""
    assert set(METHODS) == {
        "DOP853", "RK45", "Radau", "LSODA", "rk4", "rk8", "verlet", "symplectic_euler", "euler"
    }  # fmt: skip


def test_exact_chain_is_continuous_across_pieces():
    """Chaining over Braking's three pieces equals a DOP853 run to 1e-9 rad and θ' is continuous at t_stop."""
    profile = Braking(v0=12.0, decel=5.0, t_start=0.7)
    t = np.linspace(0.0, 5.0, 501)
    exact = simulate(Pendulum(0.8), profile, t, theta0=0.0, model="exact")
    rigid = simulate(Pendulum(0.8), profile, t, theta0=0.0, model="rigid")
    assert np.max(np.abs(exact.theta - rigid.theta)) < 1e-9
    assert np.max(np.abs(np.diff(exact.theta_dot))) < 0.1


def test_linear_model_within_its_error_bound():
    """For a 0.05 rad swing the linear model stays within linear_error_bound of the exact one (and < 1e-3
    rad)."""
    p = Pendulum(1.0)
    a = 2.0
    theta0 = p.equilibrium_angle(a) + 0.05
    t = np.linspace(0.0, 5.0, 501)
    lin = simulate(p, Constant(a), t, theta0=theta0, model="linear")
    exact = simulate(p, Constant(a), t, theta0=theta0, model="exact")
    err = float(np.max(np.abs(lin.theta - exact.theta)))
    assert err <= linear_error_bound(p, a, 0.05, 5.0) * 1.0000001
    assert err < 1e-3


def test_outputs_per_model():
    """Every model returns θ, θ', a and tension; only elastic has stretch, only multiplier has μ."""
    p = Pendulum(1.0, stiffness=1e4)
    t = np.linspace(0.0, 1.0, 11)
    for model in MODELS:
        tr = simulate(p, Constant(1.0), t, theta0=0.2, model=model)
        assert tr.model == model
        assert tr.theta.shape == tr.theta_dot.shape == tr.accel.shape == t.shape
        assert tr.tension is not None and tr.tension.shape == t.shape
        assert (tr.stretch is not None) == (model == "elastic")
        assert (tr.stretch_rate is not None) == (model == "elastic")
        assert (tr.multiplier is not None) == (model == "multiplier")
        names = list(tr.columns())
        assert names[:3] == ["t", "theta", "theta_dot"]
        assert ("stretch" in names) == (model == "elastic")
        np.testing.assert_array_equal(tr.accel, 1.0)


def test_single_sample_returns_initial_state():
    """With t = [t0] the trajectory is the initial state (exactly)."""
    tr = simulate(Pendulum(1.0), Constant(1.0), np.array([3.0]), theta0=0.3, theta_dot0=-1.0)
    assert tr.theta.tolist() == [0.3] and tr.theta_dot.tolist() == [-1.0]


def test_start_time_need_not_be_zero():
    """Starting at t0 = 10 s on a table profile equals starting at 0 with the shifted profile (1e-9 rad)."""
    p = Pendulum(1.0)
    late = simulate(p, Table((10.0, 11.0, 12.0), (0.0, 3.0, 1.0)), np.linspace(10.0, 14.0, 41), theta0=0.2)
    early = simulate(p, Table((0.0, 1.0, 2.0), (0.0, 3.0, 1.0)), np.linspace(0.0, 4.0, 41), theta0=0.2)
    assert np.max(np.abs(late.theta - early.theta)) < 1e-9


def test_default_fixed_step_is_stable_and_accurate():
    """A fixed-step method without dt uses dt = 1/(20 ω): RK4 then agrees with DOP853 to 1e-5 rad."""
    p = Pendulum(1.0)
    profile = Ramp(0.5, 1.5, 0.0, 6.0)
    t = np.linspace(0.0, 4.0, 9)
    rk4 = simulate(p, profile, t, theta0=0.5, method="rk4")
    ref = simulate(p, profile, t, theta0=0.5)
    assert np.max(np.abs(rk4.theta - ref.theta)) < 1e-5


def test_stability_refusal_through_simulate():
    """dt past RK4's limit (ω from a_max = 30 m/s²) is refused and the message names h, ω and the limit."""
    p = Pendulum(0.1)
    omega = (math.hypot(p.gravity, 30.0) / 0.1) ** 0.5
    with pytest.raises(StabilityError) as info:
        simulate(p, Step(1.0, 0.0, 30.0), np.linspace(0.0, 2.0, 3), theta0=0.1, method="rk4", dt=3.0 / omega)
    message = str(info.value)
    # ω here is (√(g² + a²)/l)^½ by pow, the refusal's by its own formula: a few ulp apart (rel 1e-14);
    # RK4's limit is √8 (test.figures: each compared to its printed digits).
    assert "h=" in message
    assert_figure(message, "ω=", omega, rel=1e-14)
    assert_figure(message, "stability limit ", math.sqrt(8.0), rel=0.0)


@pytest.mark.parametrize(
    ("kwargs", "needle"),
    [
        ({"model": "rigid_body"}, "unknown model"),
        ({"method": "rk5"}, "unknown method"),
        ({"theta0": float("nan")}, "theta0"),
        ({"theta_dot0": float("inf")}, "theta_dot0"),
        ({"t": np.array([0.0, 2.0, 1.0])}, "strictly increasing"),
        ({"t": np.array([0.0, np.inf])}, "finite"),
        ({"t": np.array([])}, "non-empty"),
        ({"dt": 0.0, "method": "rk4"}, "dt"),
        ({"model": "exact", "profile": Ramp(0.0, 1.0, 0.0, 1.0)}, "piecewise-constant"),
        ({"model": "linear", "pendulum": Pendulum(1.0, damping=0.1)}, "undamped"),
    ],
)
def test_bad_input_is_a_clear_error(kwargs, needle):
    """Bad input raises ParameterError whose message names the problem."""
    args: dict[str, Any] = {
        "pendulum": Pendulum(1.0),
        "profile": Constant(0.0),
        "t": np.linspace(0.0, 1.0, 3),
    }
    args["theta0"] = 0.1
    args.update(kwargs)
    with pytest.raises(ParameterError, match=needle):
        simulate(args.pop("pendulum"), args.pop("profile"), args.pop("t"), **args)
