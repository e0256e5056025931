"""The Scene → estimator settings mapping: what an estimator is told about the pendulum and sensor."""

from __future__ import annotations

from pendulum_accel.estimators import method_options
from pendulum_accel.estimators.base import BIAS_FIELDS
from pendulum_accel.estimators.motion import MotionChoice, motion_of, stated_motion
from pendulum_accel.scene import Scene


def estimator_settings(scene: Scene) -> dict[str, float]:
    """length, gravity, damping, noise_std, rate_hz and the bias fields of a scene's pendulum and sensor.

    The bias fields only widen the published variance (EstimatorConfig.bias_second_moment).
    """
    pendulum = scene.pendulum
    sensor = scene.sensor
    return {
        "length": float(pendulum.length),
        "gravity": float(pendulum.gravity),
        "damping": float(pendulum.damping),
        "noise_std": float(sensor.noise_std),
        "rate_hz": float(sensor.rate_hz),
        **sensor_bias_settings(scene),
    }


def sensor_bias_settings(scene: Scene) -> dict[str, float]:
    """The sensor's bias fields (bias, bias_mean, bias_stddev, bias_random_walk, dynamic_bias_*)."""
    return {name: float(getattr(scene.sensor, name)) for name in BIAS_FIELDS}


def motion_choice(scene: Scene) -> MotionChoice:
    """kalman's preset for the scene: its ``motion`` key, else auto (estimators.motion)."""
    return stated_motion(scene.motion) if scene.motion is not None else motion_of(scene.profile)


def uses_preset(method: str) -> bool:
    """True when ``method`` takes a motion preset (kalman, smoother)."""
    return "preset" in method_options(method)


def estimator_options(scene: Scene, method: str) -> dict[str, object]:
    """estimator_settings(scene), plus the scene's motion preset for a method that takes one."""
    extra: dict[str, object] = {"preset": motion_choice(scene).preset} if uses_preset(method) else {}
    return {**estimator_settings(scene), **extra}
