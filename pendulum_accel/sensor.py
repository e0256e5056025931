"""Angle sensor model with the knobs of Gazebo's IMU noise model (gz-sensors), deterministic for a seed.

A sample k taken at t_k of the true angle θ_k reads

    y_k = S( Q( θ_k + b + β_k + d_k + σ n_k ) ),

* σ n_k: white noise, n_k standard normal. σ is the per-sample standard deviation (Gazebo ``stddev``,
  our ``noise_std``); a datasheet or Kalibr gives it as a density N (rad/√Hz), and σ = N · √f at the
  sample rate f (the scene's ``noise_density`` is converted this way when it is loaded);
* b: the constant offset (Gazebo ``mean``, our ``bias``);
* β: a bias random walk, β_0 = 0, β_k = β_{k−1} + σ_rw √(t_k − t_{k−1}) w_k (σ_rw in rad/√s, Kalibr's
  ``random_walk``, our ``bias_random_walk``);
* d: Gazebo's dynamic bias, started at the turn-on bias d_0 = ±N(bias_mean, bias_stddev) (sign drawn
  with probability ½ each, as gz-sensors' SampleBias) and driven as a first-order Gauss-Markov process
  exactly as gz-sensors' GaussianNoiseModel::ApplyImpl:

      d_{k+1} = φ d_k + σ_b √(τ/2 · (1 − φ²)) v_k,   φ = e^{−Δt/τ},

  with σ_b = ``dynamic_bias_stddev`` and τ = ``dynamic_bias_correlation_time``. σ_b is a driving
  density (rad/√s): the stationary standard deviation is σ_b √(τ/2), and τ → ∞ gives a random walk of
  density σ_b (the same process as β). σ_b > 0 needs τ > 0 (gz-sensors ignores σ_b without τ);
* Q(x) = q · round(x/q): quantisation to the step q (Gazebo ``precision``, our ``quantization``; 0 = none);
* S(x) = clip(x, −R, R): the measurement range R (``range``; 0 = unlimited). A saturated sample reads
  exactly ±R, which ``saturated`` flags.

All draws come from one ``numpy.random.Generator(PCG64(seed))`` in a fixed order (the walk increments,
the white noise, then the turn-on bias and its sign, then the Gauss-Markov increments), so the same
seed and sample times give the same readings bit for bit, and a sensor without the later knobs reads
exactly as it did before they existed.
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

_NON_NEGATIVE = (
    "noise_std",
    "bias_random_walk",
    "quantization",
    "bias_stddev",
    "dynamic_bias_stddev",
    "dynamic_bias_correlation_time",
    "range",
)

SENSOR_LIMITS: dict[str, tuple[float, float, str]] = {
    "noise_std": (0.0, 1.0, "rad"),
    "noise_density": (0.0, 1.0, "rad/√Hz"),
    "bias": (-math.pi, math.pi, "rad"),
    "bias_mean": (-math.pi, math.pi, "rad"),
    "bias_stddev": (0.0, math.pi, "rad"),
    "bias_random_walk": (0.0, 1.0, "rad/√s"),
    "dynamic_bias_stddev": (0.0, 1.0, "rad/√s"),
    "quantization": (0.0, math.pi, "rad"),
    "range": (0.0, math.pi, "rad"),
}
"""(low, high, unit) of the sensor fields that are angles or angle spreads. An angle sensor whose noise,
bias or step exceeds a full turn (1 rad of noise per sample or per √s) measures nothing; values past
these (1e300) would only overflow the noise draws into inf and NaN. noise_density's bound also keeps
σ = N·√f within noise_std's (checked on σ once the rate is known)."""


def check_sensor_field(name: str, value: float) -> float:
    """``value`` when finite and within SENSOR_LIMITS[name], else ParameterError stating the range."""
    low, high, unit = SENSOR_LIMITS[name]
    number = require_finite(f"sensor {name}", value)
    if not low <= number <= high:
        raise ParameterError(f"sensor {name} must be in [{low:.6g}, {high:.6g}] {unit}, got {value!r}")
    return number


def noise_std_from_density(density: float, rate_hz: float) -> float:
    """σ = N · √f: per-sample white-noise std (rad) of a density N (rad/√Hz) sampled at f (Hz)."""
    return density * math.sqrt(rate_hz)


@dataclass(frozen=True)
class SensorModel:
    """Angle sensor: rate f, white σ, offset b, walk σ_rw, turn-on and Gauss-Markov bias, step q, range R."""

    rate_hz: float
    noise_std: float = 0.0
    bias: float = 0.0
    bias_random_walk: float = 0.0
    quantization: float = 0.0
    seed: int = 0
    bias_mean: float = 0.0
    bias_stddev: float = 0.0
    dynamic_bias_stddev: float = 0.0
    dynamic_bias_correlation_time: float = 0.0
    range: float = 0.0

    def __post_init__(self) -> None:
        """Validate: f > 0, spreads, τ and R ≥ 0, angle fields within SENSOR_LIMITS, seed an integer ≥ 0."""
        object.__setattr__(self, "rate_hz", require_positive("sensor rate_hz", self.rate_hz))
        for name in _NON_NEGATIVE:
            value = require_finite(f"sensor {name}", getattr(self, name))
            if value < 0.0:
                raise ParameterError(f"sensor {name} must be >= 0, got {value!r}")
            object.__setattr__(self, name, value)
        for name in SENSOR_LIMITS.keys() - {"noise_density"}:
            object.__setattr__(self, name, check_sensor_field(name, getattr(self, name)))
        seed = self.seed
        if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
            raise ParameterError(f"sensor seed must be an integer >= 0, got {seed!r}")
        object.__setattr__(self, "seed", int(seed))
        if self.dynamic_bias_stddev > 0.0 and self.dynamic_bias_correlation_time == 0.0:
            raise ParameterError(
                "sensor dynamic_bias_correlation_time must be > 0 s when dynamic_bias_stddev is set "
                "(for τ → ∞ use bias_random_walk)"
            )

    @property
    def period(self) -> float:
        """Sample period 1/f (s)."""
        return 1.0 / self.rate_hz

    @property
    def noise_density(self) -> float:
        """N = σ/√f: the white noise as a density (rad/√Hz), the form datasheets and Kalibr use."""
        return self.noise_std / math.sqrt(self.rate_hz)

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

    def saturated(self, y: ArrayLike) -> NDArray[np.bool_]:
        """|y| ≥ R for a limited range (a clipped reading sits exactly on ±R); all False when R = 0."""
        values = np.asarray(y, dtype=np.float64)
        if self.range <= 0.0:
            return np.zeros(values.shape, dtype=bool)
        return np.abs(values) >= self.range

    def measure(self, t: ArrayLike, theta: ArrayLike) -> FloatArray:
        """y_k = S(Q(θ_k + b + β_k + d_k + σ n_k)) at the times t (module docstring); same seed, same bits."""
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
        if self.bias_stddev > 0.0 or self.bias_mean != 0.0 or self.dynamic_bias_stddev > 0.0:
            # Drawn only when used, after the older streams: scenes without these knobs keep their bits.
            out += self._dynamic_bias(times, rng)
        if self.quantization > 0.0:
            out = self.quantization * np.round(out / self.quantization)
        if self.range > 0.0:
            out = np.clip(out, -self.range, self.range)
        return out

    def _dynamic_bias(self, times: FloatArray, rng: np.random.Generator) -> FloatArray:
        """d_k: turn-on bias ±N(bias_mean, bias_stddev), then the gz-sensors Gauss-Markov recursion."""
        start = rng.normal(self.bias_mean, self.bias_stddev) if self.bias_stddev > 0.0 else self.bias_mean
        if rng.uniform() < 0.5:
            start = -start
        steps = rng.standard_normal(max(times.size - 1, 0))
        bias = np.full(times.size, float(start))
        sigma_b, tau = self.dynamic_bias_stddev, self.dynamic_bias_correlation_time
        if sigma_b <= 0.0 or times.size < 2:
            return bias
        dt = np.diff(times)
        phi = np.exp(-dt / tau)
        drive = sigma_b * np.sqrt(-0.5 * tau * np.expm1(-2.0 * dt / tau)) * steps
        # d_{k+1} = φ_k d_k + u_k as a first-order IIR filter (exact, no Python loop per sample).
        return _first_order_recursion(float(start), phi, drive, bias)


NOISE_DIFFERENCE_ORDER = 3
"""Differences of this order estimate the angle noise (noise_from_angles): white noise's grow as √20 σ,
a smooth swing's as (ω Δt)³ θ, which a sample rate well above the pendulum's frequency makes small."""


def noise_from_angles(theta: ArrayLike) -> float | None:
    """σ ≈ 1.4826 · median |d − median d| / √20, d = Δ³θ: the white noise of equally spaced angles, from
    their third differences (noise_from_differences); an upper bound where the swing is fast beside the
    sample rate. None below 8 angles."""
    values = np.asarray(theta, dtype=np.float64)
    values = values[np.isfinite(values)]
    if values.size < 8:
        return None
    return noise_from_differences(np.diff(values, NOISE_DIFFERENCE_ORDER))


def noise_from_differences(third: ArrayLike) -> float:
    """σ = 1.4826 · median |d − median d| / √20 of third differences d = Δ³θ: white noise's have variance
    20 σ², and the median absolute deviation (1.4826 for a Gaussian's σ) lets the odd jump pass."""
    d = np.asarray(third, dtype=np.float64)
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(20.0))


def measured_rate(t: ArrayLike, measured: ArrayLike) -> FloatArray:
    """θ'_k = (y_k − y_{k−1})/(t_k − t_{k−1}): the rate a sensor's driver publishes from its own samples.

    Backward (causal) differences of the *measured* angles y, so it carries the sensor's noise (white σ
    becomes σ √2 / Δt per sample) and none of the simulator's truth; the first sample repeats the second's
    rate (0 for a single sample).
    """
    times = np.asarray(t, dtype=np.float64)
    y = np.asarray(measured, dtype=np.float64)
    if times.size < 2:
        return np.zeros_like(y)
    rate = np.diff(y) / np.diff(times)
    return np.concatenate((rate[:1], rate))


def _first_order_recursion(start: float, phi: FloatArray, drive: FloatArray, out: FloatArray) -> FloatArray:
    """out_0 = start, out_{k+1} = φ_k out_k + u_k; scipy.signal.lfilter when φ is constant, else a loop."""
    # Uniform sampling (t_k = k/f) differs from a constant Δt only by rounding: one φ serves.
    if phi.size and float(np.ptp(phi)) <= 1e-12:
        from scipy.signal import lfilter

        p = float(np.mean(phi))
        values, _ = lfilter([1.0], [1.0, -p], drive, zi=[p * start])
        out[1:] = values
        return out
    value = start
    for k in range(phi.size):
        value = phi[k] * value + drive[k]
        out[k + 1] = value
    return out
