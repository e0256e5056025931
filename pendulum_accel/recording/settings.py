"""The Scene → estimator settings mapping: what an estimator is told about the pendulum and sensor."""

from __future__ import annotations

from pendulum_accel.scene import Scene


def estimator_settings(scene: Scene) -> dict[str, float]:
    """length, gravity, damping, noise_std, rate_hz of a scene's pendulum and sensor (estimator config)."""
    pendulum = scene.pendulum
    sensor = scene.sensor
    return {
        "length": float(pendulum.length),
        "gravity": float(pendulum.gravity),
        "damping": float(pendulum.damping),
        "noise_std": float(sensor.noise_std),
        "rate_hz": float(sensor.rate_hz),
    }
