"""The planner's lean compiled path (physics.simulate.SteppedRuns) and the variational runs behind S(t).

SteppedRuns.theta must be simulate()'s θ bit for bit (the planner's pilot run is the plan's run), the
variational run's θ too, and its ∂θ/∂x the derivative of that very run: it agrees with the nudged-run
S(t) of conditioning.input_sensitivity to a few %, and the Sensitivity built from it
(conditioning.tangent_sensitivity) with the one built from nudged runs.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from pendulum_accel import planner
from pendulum_accel.conditioning import input_sensitivity, input_units, tangent_sensitivity
from pendulum_accel.physics import kernels
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import AccelProfile, Sinusoid, Step, Table
from pendulum_accel.physics.simulate import SteppedRuns, simulate, stepped_runs
from pendulum_accel.scene import load_scene

T = np.linspace(0.0, 8.0, 81)
CASES: dict[str, tuple[str, Pendulum, AccelProfile, float, float, float]] = {
    # model, pendulum, a(t), θ0, θ'0, largest step (elastic: inside the radial mode's stability)
    "rigid table, damped": ("rigid", Pendulum(1.0, damping=0.05), Table((0, 2, 4, 6), (0, 2, -1, 0.5)),
                            0.3, 0.1, 0.04),
    "rigid sinusoid": ("rigid", Pendulum(0.7), Sinusoid(2.0, 0.5, offset=1.0), 1.2, -0.4, 0.03),
    "elastic step": ("elastic", Pendulum(1.0, stiffness=1e4, damping=0.1), Step(1.0, 0.0, 3.0),
                     0.3, 0.2, 0.004),
}  # fmt: skip


def _runs(name: str, method: str) -> SteppedRuns:
    model, p, profile, *_ = CASES[name]
    runs = stepped_runs(p, profile, T, model, method)
    assert runs is not None
    return runs


@pytest.mark.parametrize("method", ["rk4", "rk8", "verlet"])
@pytest.mark.parametrize("name", sorted(CASES))
def test_stepped_runs_are_simulate_bit_for_bit(name: str, method: str) -> None:
    """θ of the lean path equals simulate()'s θ exactly, at two steps; so does the variational run's θ."""
    model, p, profile, th0, w0, dt = CASES[name]
    runs = _runs(name, method)
    for h in (dt, 0.37 * dt):
        full = simulate(p, profile, T, theta0=th0, theta_dot0=w0, model=model, method=method, dt=h)
        assert runs.theta(th0, w0, h).tobytes() == full.theta.tobytes()
        if runs.variational:
            theta, _ = runs.tangent(th0, w0, h)
            assert theta.tobytes() == full.theta.tobytes()
    assert runs.variational == (method in ("rk4", "rk8"))


def test_no_lean_path_where_simulate_has_no_kernel() -> None:
    """Adaptive methods and the multiplier model have no compiled path: None, the caller uses simulate()."""
    p, profile = Pendulum(1.0), Step(1.0, 0.0, 3.0)
    assert stepped_runs(p, profile, T, "rigid", "DOP853") is None
    assert stepped_runs(p, profile, T, "multiplier", "rk4") is None


@pytest.mark.parametrize("method", ["rk4", "rk8"])
@pytest.mark.parametrize("name", sorted(CASES))
def test_variational_derivative_matches_nudged_runs(name: str, method: str) -> None:
    """∂θ/∂x from the variational run against central differences of the same scheme (nudge 1e-6,
    truncation ~1e-12 relative) to 1e-6, and against the conditioning's 64-ulp nudged runs to 3 %."""
    _, _, _, th0, w0, dt = CASES[name]
    runs = _runs(name, method)
    _, derivative = runs.tangent(th0, w0, dt)
    scale = np.max(np.abs(derivative), axis=1)
    nudge = 1e-6
    for which in (0, 1):
        e = np.zeros(2)
        e[which] = nudge
        up, down = runs.theta(th0 + e[0], w0 + e[1], dt), runs.theta(th0 - e[0], w0 - e[1], dt)
        central = (up - down) / (2 * nudge)
        assert np.max(np.abs(central - derivative[which])) <= 1e-6 * scale[which]
    sensitivity = input_sensitivity(lambda a, b: runs.theta(a, b, dt), th0, w0, 3.0, T, 1e-9, noise=False)
    units = input_units(th0, w0, 3.0)
    for which in (0, 1):
        assert float(np.max(np.abs(derivative[which]))) * units[which] == pytest.approx(
            sensitivity.peaks[which], rel=0.03
        )


@pytest.mark.parametrize("name", sorted(CASES))
def test_tangent_sensitivity_agrees_with_the_nudged_one(name: str) -> None:
    """Each input's peak S within 3 %, the lost time and λ the same from both; the round-off within 4×."""
    _, _, _, th0, w0, dt = CASES[name]
    runs = _runs(name, "rk8")
    base, derivative = runs.tangent(th0, w0, dt)

    def run(a: float, b: float) -> np.ndarray:
        return runs.theta(a, b, dt)

    for target in (1e-15, 1e-9):
        nudged = input_sensitivity(run, th0, w0, 3.0, T, target, base=base)
        tangent = tangent_sensitivity(run, th0, w0, 3.0, T, target, base, derivative)
        assert tangent is not None and tangent.linear
        assert tangent.peaks == pytest.approx(nudged.peaks, rel=0.03)
        assert tangent.lost_at == nudged.lost_at
        assert tangent.lyapunov == pytest.approx(nudged.lyapunov, abs=0.02)
        assert 0.25 <= tangent.noise / nudged.noise <= 4.0


def test_past_the_linear_regime_the_tangent_defers_to_nudged_runs() -> None:
    """A derivative so large that 64 ulps would move θ by over 0.01 rad: None (the caller nudges)."""
    t = np.linspace(0.0, 1.0, 11)
    derivative = np.vstack((np.full(11, 1e14), np.zeros(11)))
    assert tangent_sensitivity(lambda a, b: t * 0.0, 1.0, 0.0, 1.0, t, 1e-6, t * 0.0, derivative) is None


def test_the_planner_uses_the_variational_run_and_stays_honest() -> None:
    """The stop-and-go plan (rk4/rk8, pilot run reused) carries the tangent S: it equals the nudged S."""
    scene = load_scene("stop_and_go")
    for target in (1e-3, 1e-9):
        plan = planner.plan_scene(dataclasses.replace(scene, accuracy=target))
        assert plan.sensitivity is not None and plan.sensitivity.linear
        nudged = planner.measure_sensitivity(scene.on_level(), plan, noise=False)
        assert plan.sensitivity.floor == pytest.approx(nudged.floor, rel=0.03)
        assert plan.meets_target and not plan.ill_conditioned


def test_single_slice_shortcut_gives_the_counted_slices() -> None:
    """step_slices' one-slice shortcut answers as the per-interval count does."""
    nodes = np.sort(np.concatenate((np.linspace(0.0, 3.0, 31), [0.123, 2.001])))
    for dt in (1e-3, 0.05, 1.0):
        for per_slice in (10, 100, 3000, 10**6):
            counts = np.maximum(1.0, np.ceil(np.diff(nodes) / dt * (1.0 - 1e-12)))
            expected = kernels.step_slices(nodes, dt, per_slice)
            if counts.sum() <= per_slice:
                assert expected == [(0, nodes.size - 1)]
            assert expected[0][0] == 0 and expected[-1][1] == nodes.size - 1
