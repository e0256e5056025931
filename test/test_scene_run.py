"""run_scene: sensor-rate samples, measured = sensor(true), extras per model, bit-for-bit determinism."""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import pytest

from pendulum_accel.errors import SceneError
from pendulum_accel.physics.simulate import simulate
from pendulum_accel.planner import plan_scene
from pendulum_accel.scene import SCENE_NAMES, load_scene, scene_from_yaml
from pendulum_accel.scene_run import SceneRun, run_scene


@functools.cache
def run_of(name: str) -> SceneRun:
    """run_scene of a bundled scene (cached across tests)."""
    return run_scene(load_scene(name))


@pytest.mark.parametrize("name", SCENE_NAMES)
def test_run_samples_at_the_sensor_rate_with_the_requested_outputs(name: str) -> None:
    """t = k/f on [0, T]; every array finite and as long as t; tension/stretch exactly when asked for."""
    run = run_of(name)
    scene = run.scene
    n = int(np.floor(scene.duration * scene.sensor.rate_hz + 1e-9)) + 1
    assert run.t.size == n and run.t[0] == 0.0
    # t_k = k/f rounded once; a difference of two ≤ 20 s is within 2 ulp(20) = 7e-15
    assert np.allclose(np.diff(run.t), 1.0 / scene.sensor.rate_hz, rtol=0.0, atol=1e-12)
    arrays = [run.theta_true, run.theta_dot, run.theta_measured, run.accel_true]
    extras = [a for a in (run.tension, run.stretch, run.stretch_rate) if a is not None]
    for array in arrays + extras:
        assert array.shape == run.t.shape and np.all(np.isfinite(array))
    assert (run.tension is not None) == (scene.wants_tension or run.plan.model == "elastic")
    assert (run.stretch is not None) == (run.plan.model == "elastic") == (run.stretch_rate is not None)
    assert np.array_equal(run.accel_true, scene.profile(run.t))


@pytest.mark.parametrize("name", SCENE_NAMES)
def test_measured_is_the_sensor_applied_to_the_true_angle(name: str) -> None:
    """θ_measured = sensor.measure(t, θ_true) bit for bit; its residual has the sensor's σ within 10%."""
    run = run_of(name)
    sensor = run.scene.sensor
    assert np.array_equal(run.theta_measured, sensor.measure(run.t, run.theta_true))
    if sensor.noise_std > 0.0 and sensor.bias_random_walk == 0.0:
        residual = run.theta_measured - run.theta_true - sensor.bias
        assert np.std(residual) == pytest.approx(sensor.noise_std, rel=0.1)


def test_runs_are_deterministic_bit_for_bit() -> None:
    """Two runs of one scene (fresh loads, fresh plans) are identical; another seed changes only the noise."""
    for name in ("stop_and_go", "lecture_constant"):
        first = run_scene(load_scene(name))
        second = run_scene(load_scene(name))
        for field in ("t", "theta_true", "theta_dot", "theta_measured", "accel_true"):
            assert np.array_equal(getattr(first, field), getattr(second, field)), field
        assert first.plan == second.plan
    scene = load_scene("lecture_constant")
    other = run_scene(dataclasses.replace(scene, sensor=dataclasses.replace(scene.sensor, seed=99)))
    assert np.array_equal(other.theta_true, run_of("lecture_constant").theta_true)
    assert not np.array_equal(other.theta_measured, run_of("lecture_constant").theta_measured)


def test_plan_and_scene_travel_with_the_run() -> None:
    """run.plan is the planner's choice, the explanation is its line, and the scene YAML reloads equal."""
    run = run_of("step_start")
    assert run.plan == plan_scene(run.scene)
    assert run.explanation == run.plan.explain()
    assert scene_from_yaml(run.scene_yaml) == run.scene


def test_lecture_run_swings_about_the_tilted_equilibrium() -> None:
    """Lecture scene from θ = 0 in a = 2: θ oscillates between 0 and 2 θ_eq (to 1e-3 rad at 100 Hz)."""
    run = run_of("lecture_constant")
    theta_eq = float(np.arctan2(2.0, run.scene.pendulum.gravity))
    assert np.min(run.theta_true) == pytest.approx(0.0, abs=1e-3)
    assert np.max(run.theta_true) == pytest.approx(2.0 * theta_eq, abs=1e-3)
    assert np.mean(run.theta_true) == pytest.approx(theta_eq, abs=2e-2)


def test_given_plan_is_used() -> None:
    """run_scene(scene, plan) uses that plan: a forced RK4 plan gives RK4's θ."""
    scene = dataclasses.replace(load_scene("at_rest"), theta0=0.2, duration=2.0, model="rigid", method="rk4")
    plan = plan_scene(scene)
    run = run_scene(scene, plan)
    assert run.plan is plan and plan.method == "rk4"
    direct = simulate(
        scene.pendulum, scene.profile, run.t, theta0=0.2, model="rigid", method="rk4", dt=plan.dt
    )
    assert np.array_equal(run.theta_true, direct.theta)


def test_physics_failure_is_a_scene_error() -> None:
    """A string too soft to hold the bob is a one-line SceneError naming the scene, not a traceback."""
    scene = load_scene("elastic_string")
    soft = dataclasses.replace(
        scene, pendulum=dataclasses.replace(scene.pendulum, stiffness=1e-3), theta_dot0=10.0
    )
    with pytest.raises(SceneError, match="elastic_string") as info:
        run_scene(soft)
    assert "\n" not in str(info.value)
