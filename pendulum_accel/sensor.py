"""Angle sensor model with the knobs of Gazebo's IMU noise model, deterministic for a seed.

A sample k taken at t_k of the true angle θ_k reads

    y_k = Q( θ_k + b + β_k + σ n_k ),   β_0 = 0,  β_k = β_{k-1} + σ_b √(t_k − t_{k−1}) w_k,

with n_k, w_k independent standard normals, ``b`` the constant (turn-on) bias, β the bias random walk
(σ_b in rad/√s, Gazebo's ``dynamic_bias_stddev`` as a Wiener process), σ the white noise (Gazebo's
``stddev``) and Q(x) = q · round(x/q) the quantisation to the step q (Gazebo's ``precision``; q = 0
means none). All draws come from one ``numpy.random.Generator(PCG64(seed))`` in a fixed order (the
walk increments, then the white noise), so the same seed and sample times give the same readings bit
for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics.params import require_finite, require_positive

FloatArray = NDArray[np.float64]

MAX_SAMPLES = 50_000_000  # a duration × rate past this is a typo, not a run (400 MB per array)


@dataclass(frozen=True)
class SensorModel:
    """Angle sensor: rate f (Hz), white noise σ (rad), bias b (rad), bias walk σ_b (rad/√s), step q, seed."""

    rate_hz: float
    noise_std: float = 0.0
    bias: float = 0.0
    bias_random_walk: float = 0.0
    quantization: float = 0.0
    seed: int = 0

    def __post_init__(self) -> None:
        """Validate: f > 0, σ, σ_b, q ≥ 0, b finite, seed an integer ≥ 0 (ParameterError naming the field)."""
        object.__setattr__(self, "rate_hz", require_positive("sensor rate_hz", self.rate_hz))
        for name in ("noise_std", "bias_random_walk", "quantization"):
            value = require_finite(f"sensor {name}", getattr(self, name))
            if value < 0.0:
                raise ParameterError(f"sensor {name} must be >= 0, got {value!r}")
            object.__setattr__(self, name, value)
        object.__setattr__(self, "bias", require_finite("sensor bias", self.bias))
        seed = self.seed
        if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
            raise ParameterError(f"sensor seed must be an integer >= 0, got {seed!r}")
        object.__setattr__(self, "seed", int(seed))

    @property
    def period(self) -> float:
        """Sample period 1/f (s)."""
        return 1.0 / self.rate_hz

    def sample_count(self, duration: float) -> int:
        """n = ⌊duration · f⌋ + 1 samples cover [0, duration] (a hair of slack for round-off)."""
        span = require_finite("duration", duration)
        if span < 0.0:
            raise ParameterError(f"duration must be >= 0 s, got {span!r}")
        product = span * self.rate_hz * (1.0 + 1e-12) + 1e-9
        # Compared as a float first: a huge duration (1e308 s) makes it inf, which floor cannot take.
        count = math.floor(product) + 1 if product < MAX_SAMPLES else MAX_SAMPLES + 1
        if count > MAX_SAMPLES:
            raise ParameterError(
                f"duration {span:g} s at {self.rate_hz:g} Hz gives more than {MAX_SAMPLES} samples"
            )
        return count

    def sample_times(self, duration: float) -> FloatArray:
        """t_k = k / f for k = 0 … ⌊duration · f⌋ (s): every sample in [0, duration]."""
        return np.arange(self.sample_count(duration), dtype=np.float64) / self.rate_hz

    def measure(self, t: ArrayLike, theta: ArrayLike) -> FloatArray:
        """y_k = Q(θ_k + b + β_k + σ n_k) at the times t (module docstring); same seed → same output."""
        times = np.asarray(t, dtype=np.float64)
        angles = np.asarray(theta, dtype=np.float64)
        if times.ndim != 1 or angles.shape != times.shape:
            raise ParameterError(
                f"sensor needs 1-D times and angles of equal shape, got {times.shape} and {angles.shape}"
            )
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(angles))):
            raise ParameterError("sensor input must be finite, got NaN or inf in the times or angles")
        if times.size > 1 and np.any(np.diff(times) < 0.0):
            raise ParameterError("sensor sample times must be non-decreasing")
        rng = np.random.Generator(np.random.PCG64(self.seed))
        # Both streams are always drawn, so a knob set to 0 leaves the other's draws unchanged.
        walk = rng.standard_normal(max(times.size - 1, 0))
        white = rng.standard_normal(times.size)
        out = angles + self.bias
        if self.bias_random_walk > 0.0 and times.size > 1:
            out[1:] += np.cumsum(self.bias_random_walk * np.sqrt(np.diff(times)) * walk)
        if self.noise_std > 0.0:
            out += self.noise_std * white
        if self.quantization > 0.0:
            out = self.quantization * np.round(out / self.quantization)
        return out
