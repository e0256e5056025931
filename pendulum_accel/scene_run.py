"""Run a scene: simulate it with its plan at the sensor's sample times, then measure the angle.

t_k = k / f on [0, T]; θ_true, θ', a(t) from ``physics.simulate.simulate`` with the plan's model and
solver; θ_measured = sensor.measure(t, θ_true). Deterministic bit for bit for a scene (and its seed).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.errors import ParameterError, SceneError
from pendulum_accel.physics.simulate import AUTO_METHOD, CLOSED_FORM_METHOD, simulate
from pendulum_accel.physics.trajectory import Trajectory
from pendulum_accel.planner import Plan, plan_scene
from pendulum_accel.scene import Scene, scene_to_yaml
from pendulum_accel.sensor import measured_rate

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class SceneRun:
    """A simulated scene at the sensor rate: true and measured θ (rad), θ' (rad/s), a (m/s²), string extras.

    ``tension`` (N) is present when the scene asks for it or the model is elastic; ``stretch`` r − l (m) and
    ``stretch_rate`` (m/s) only for the elastic model. ``plan`` is the planner's choice that produced it.
    """

    t: FloatArray
    theta_true: FloatArray
    theta_dot: FloatArray
    theta_measured: FloatArray
    accel_true: FloatArray
    tension: FloatArray | None
    stretch: FloatArray | None
    stretch_rate: FloatArray | None
    plan: Plan
    scene: Scene

    @property
    def theta_dot_measured(self) -> FloatArray:
        """The rate published beside the measured angle: sensor.measured_rate of θ_measured (no truth)."""
        return measured_rate(self.t, self.theta_measured)

    @property
    def explanation(self) -> str:
        """The plan's one-line explanation (stored with every recording)."""
        return self.plan.explain()

    @property
    def scene_yaml(self) -> str:
        """The scene as YAML text (stored with every recording)."""
        return scene_to_yaml(self.scene)


def simulate_plan(scene: Scene, plan: Plan, t: FloatArray) -> Trajectory:
    """θ(t) etc. of ``scene`` with ``plan``'s model and method (dt or rtol) at the times ``t``.

    A graded scene is simulated as its level equivalent (Scene.on_level); ``accel`` is the car's own a(t).
    """
    method = AUTO_METHOD if plan.method == CLOSED_FORM_METHOD else plan.method
    level = scene.on_level()
    try:
        traj = simulate(
            level.pendulum,
            level.profile,
            t,
            theta0=scene.theta0,
            theta_dot0=scene.theta_dot0,
            model=plan.model,
            method=method,
            dt=plan.dt,
            rtol=plan.rtol,
        )
    except ParameterError as err:
        raise SceneError(f"scene {scene.name}: {err}") from None
    return traj if level is scene else replace(traj, accel=np.asarray(scene.profile(t), dtype=float))


def run_scene(scene: Scene, plan: Plan | None = None) -> SceneRun:
    """Simulate ``scene`` (with ``plan``, default plan_scene(scene)) at the sensor rate and measure θ."""
    chosen = plan_scene(scene) if plan is None else plan
    t = scene.sensor.sample_times(scene.duration)
    traj = simulate_plan(scene, chosen, t)
    extras = (traj.tension, traj.stretch, traj.stretch_rate)
    arrays = (traj.theta, traj.theta_dot, traj.accel, *(a for a in extras if a is not None))
    if not all(np.all(np.isfinite(a)) for a in arrays):
        raise SceneError(f"scene {scene.name}: the simulation produced NaN or inf with {chosen.explain()}")
    keep_tension = scene.wants_tension or chosen.model == "elastic"
    return SceneRun(
        t=t,
        theta_true=np.asarray(traj.theta, dtype=np.float64),
        theta_dot=np.asarray(traj.theta_dot, dtype=np.float64),
        theta_measured=scene.sensor.measure(t, traj.theta),
        accel_true=np.asarray(traj.accel, dtype=np.float64),
        tension=None
        if traj.tension is None or not keep_tension
        else np.asarray(traj.tension, dtype=np.float64),
        stretch=None if traj.stretch is None else np.asarray(traj.stretch, dtype=np.float64),
        stretch_rate=None if traj.stretch_rate is None else np.asarray(traj.stretch_rate, dtype=np.float64),
        plan=chosen,
        scene=scene,
    )
