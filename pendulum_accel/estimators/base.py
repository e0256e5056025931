"""What every estimator shares: configuration, the Estimate record, angle conditioning and input checks.

The accelerometer relation is a = g tan θ, so an angle error dθ becomes an acceleration error
da = g sec²θ dθ. The teaching estimators (``Estimator.teaching``: instant, period_mean, lowpass, dynamic)
publish their linearised noise gain times σ² plus the sensor bias (:func:`bias_variance`), nothing else;
kalman and smoother publish their own covariance plus the same bias.
"""

from __future__ import annotations

import itertools
import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics.params import STANDARD_GRAVITY, require_finite, require_positive

# A sensor is never perfect; a floor keeps variances and the Kalman gain finite when a scene says σ = 0.
MIN_NOISE_STD = 1e-6  # rad
# The sensor bias fields an estimator is told about (EstimatorConfig, recording.settings).
BIAS_FIELDS = (
    "bias",
    "bias_mean",
    "bias_stddev",
    "bias_random_walk",
    "dynamic_bias_stddev",
    "dynamic_bias_correlation_time",
)
# What a teaching estimator's σ leaves out, said wherever the user meets it (run summary, node start-up).
TEACHING_NOTE = "teaching: its σ counts sensor noise and bias only, not the swing or lag"
# tan θ is undefined at 90°; beyond this the angle is clamped and the estimate flagged.
DEFAULT_CLAMP_ANGLE = math.radians(89.0)


@dataclass(frozen=True, slots=True)
class Estimate:
    """â (m/s²) and its variance ((m/s²)²); ``clamped`` when |θ| hit the clamp; ``time``: the sample it
    describes (s), when that is not the latest input (a fixed-lag smoother's estimate describes the past)."""

    a: float
    variance: float
    clamped: bool = False
    time: float | None = None


@dataclass(frozen=True)
class EstimatorConfig:
    """Pendulum and sensor description shared by all methods: l, g, c, angle noise σ and nominal rate f.

    ``max_gap`` (s): a forward gap in the input longer than this restarts the window-based methods,
    whose filters assume the nominal rate (default: 10 nominal sample periods).
    The sensor's bias fields (rad, rad/√s, s; as in ``sensor.SensorModel``) are not corrected for:
    they only enter the published variance through :meth:`bias_second_moment`.
    """

    length: float
    gravity: float = STANDARD_GRAVITY
    noise_std: float = 1e-3
    rate_hz: float = 200.0
    damping: float = 0.0
    clamp_angle: float = DEFAULT_CLAMP_ANGLE
    max_gap: float | None = None
    bias: float = 0.0
    bias_mean: float = 0.0
    bias_stddev: float = 0.0
    bias_random_walk: float = 0.0
    dynamic_bias_stddev: float = 0.0
    dynamic_bias_correlation_time: float = 0.0

    def __post_init__(self) -> None:
        """Validate every field once; raise ParameterError naming the bad one."""
        object.__setattr__(self, "length", require_positive("length", self.length))
        object.__setattr__(self, "gravity", require_positive("gravity", self.gravity))
        object.__setattr__(self, "rate_hz", require_positive("rate_hz", self.rate_hz))
        noise = require_finite("noise_std", self.noise_std)
        if noise < 0.0:
            raise ParameterError(f"noise_std must be >= 0, got {noise!r}")
        object.__setattr__(self, "noise_std", noise)
        damping = require_finite("damping", self.damping)
        if damping < 0.0:
            raise ParameterError(f"damping must be >= 0, got {damping!r}")
        object.__setattr__(self, "damping", damping)
        clamp = require_positive("clamp_angle", self.clamp_angle)
        if clamp >= math.pi / 2:
            raise ParameterError(f"clamp_angle must be < π/2 rad, got {clamp!r}")
        object.__setattr__(self, "clamp_angle", clamp)
        gap = 10.0 / self.rate_hz if self.max_gap is None else require_positive("max_gap", self.max_gap)
        object.__setattr__(self, "max_gap", gap)
        for name in BIAS_FIELDS:
            value = require_finite(name, getattr(self, name))
            if value < 0.0 and name not in ("bias", "bias_mean"):
                raise ParameterError(f"{name} must be >= 0, got {value!r}")
            object.__setattr__(self, name, value)

    def bias_second_moment(self, elapsed: float) -> float:
        """E[b(t)²] (rad²) of the sensor's total bias t = ``elapsed`` s after turn-on.

        b² + σ_rw² t + e^{−2t/τ}(μ² + s²) + σ_b² τ/2 (1 − e^{−2t/τ}): the offset, the random walk, the
        turn-on bias ±N(μ, s) decaying through the Gauss-Markov process and that process's own spread
        (τ = 0: no Gauss-Markov process, the turn-on bias stays).
        """
        t = max(elapsed, 0.0)
        turn_on = self.bias_mean**2 + self.bias_stddev**2
        total = self.bias**2 + self.bias_random_walk**2 * t
        tau = self.dynamic_bias_correlation_time
        if tau <= 0.0:
            return total + turn_on
        decay = math.exp(-2.0 * t / tau)
        return total + decay * turn_on + 0.5 * tau * self.dynamic_bias_stddev**2 * (1.0 - decay)

    def bias_second_moment_array(self, elapsed: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`bias_second_moment`: E[b(t)²] (rad²) at each of ``elapsed`` (s)."""
        t = np.maximum(elapsed, 0.0)
        turn_on = self.bias_mean**2 + self.bias_stddev**2
        total = self.bias**2 + self.bias_random_walk**2 * t
        tau = self.dynamic_bias_correlation_time
        result: np.ndarray
        if tau <= 0.0:
            result = total + turn_on
            return result
        decay = np.exp(-2.0 * t / tau)
        result = total + decay * turn_on + 0.5 * tau * self.dynamic_bias_stddev**2 * (1.0 - decay)
        return result

    @property
    def sigma(self) -> float:
        """σ used in variances: max(noise_std, MIN_NOISE_STD) rad."""
        return max(self.noise_std, MIN_NOISE_STD)

    @property
    def gap(self) -> float:
        """The resolved max_gap in seconds."""
        assert self.max_gap is not None
        return self.max_gap

    def omega(self, accel: float) -> float:
        """ω = (√(g² + a²)/l)^½, small-oscillation angular frequency about θ_eq."""
        return math.sqrt(math.hypot(self.gravity, accel) / self.length)

    def period(self, accel: float) -> float:
        """T = 2π/ω(a), the small-oscillation period."""
        return 2.0 * math.pi / self.omega(accel)


def wrap_clamp(theta: float, limit: float) -> tuple[float, bool]:
    """θ wrapped into [−π, π) then clamped to [−limit, limit]; returns (θ_c, clamped)."""
    if -limit <= theta <= limit:
        return theta, False
    wrapped = (theta + math.pi) % (2.0 * math.pi) - math.pi
    if abs(wrapped) <= limit:
        return wrapped, False
    return math.copysign(limit, wrapped), True


def wrap_clamp_array(theta: np.ndarray, limit: float) -> tuple[np.ndarray, np.ndarray]:
    """Vectorised :func:`wrap_clamp`: (θ_c, clamped) arrays."""
    inside = np.abs(theta) <= limit
    if inside.all():
        return theta.astype(float, copy=True), np.zeros(theta.shape, dtype=bool)
    wrapped = np.where(inside, theta, np.remainder(theta + np.pi, 2.0 * np.pi) - np.pi)
    clamped = np.abs(wrapped) > limit
    return np.where(clamped, np.copysign(limit, wrapped), wrapped), clamped


def accel_gain(theta: float, gravity: float) -> float:
    """da/dθ = g sec²θ."""
    c = math.cos(theta)
    return gravity / (c * c)


def accel_gain_array(theta: np.ndarray, gravity: float) -> np.ndarray:
    """Vectorised da/dθ = g sec²θ."""
    c = np.cos(theta)
    result: np.ndarray = gravity / (c * c)
    return result


def bias_variance(config: EstimatorConfig, theta: float, elapsed: float) -> float:
    """(g sec²θ)² E[b²](elapsed): the sensor bias, which no estimator can tell from a tilt, in (m/s²)²."""
    return accel_gain(theta, config.gravity) ** 2 * config.bias_second_moment(elapsed)


def bias_variance_array(config: EstimatorConfig, theta: np.ndarray, elapsed: np.ndarray) -> np.ndarray:
    """Vectorised :func:`bias_variance`: (g sec²θ)² E[b²](elapsed)."""
    result: np.ndarray = accel_gain_array(theta, config.gravity) ** 2 * config.bias_second_moment_array(
        elapsed
    )
    return result


def cramer_rao_std(accel: float, sigma: float, samples: float, gravity: float = STANDARD_GRAVITY) -> float:
    """σ_a ≥ σ (g² + a²)/(g √N): the bound for a static a from N independent angle samples of noise σ."""
    return sigma * (gravity * gravity + accel * accel) / (gravity * math.sqrt(samples))


def check_batch_input(t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return (t, θ) as contiguous 1-D float arrays; raise ParameterError unless finite, equal length, t
    increasing. Contiguous: a strided column (a field of np.genfromtxt's table, as the lab notebook reads
    a CSV) would otherwise make numba compile each kernel once more, for its layout."""
    t = np.asarray(t, dtype=float)
    theta = np.asarray(theta, dtype=float)
    if t.ndim != 1 or theta.ndim != 1 or t.shape != theta.shape:
        raise ParameterError(
            f"t and theta must be 1-D arrays of equal length, got {t.shape} and {theta.shape}"
        )
    t, theta = np.ascontiguousarray(t), np.ascontiguousarray(theta)
    if not np.isfinite(t).all():
        raise ParameterError(f"t must be finite, sample {int(np.argmin(np.isfinite(t)))} is not")
    if not np.isfinite(theta).all():
        raise ParameterError(f"theta must be finite, sample {int(np.argmin(np.isfinite(theta)))} is not")
    if t.size > 1 and not (np.diff(t) > 0.0).all():
        bad = int(np.argmin(np.diff(t) > 0.0)) + 1
        raise ParameterError(f"t must be strictly increasing, t[{bad}] = {t[bad]!r} <= t[{bad - 1}]")
    return t, theta


def segments(t: np.ndarray, max_gap: float) -> list[slice]:
    """Slices of t between forward gaps longer than max_gap (where streaming methods restart)."""
    if t.size == 0:
        return []
    cuts = (np.flatnonzero(np.diff(t) > max_gap) + 1).tolist()
    edges = [0, *cuts, t.size]
    return [slice(a, b) for a, b in itertools.pairwise(edges)]


class Estimator(ABC):
    """One acceleration estimator: streaming ``update`` (O(1) per sample) and a batch path with equal numbers.

    ``update(t, θ)`` expects finite θ and increasing t (the InputGuard ensures both); a sample that
    violates this is ignored and gives None, so the output is never NaN or inf.
    """

    name: ClassVar[str]
    summary: ClassVar[str]
    # A teaching estimator publishes noise gain × σ² + sensor bias only: it does not count the swing or its
    # lag, so in motion it is over-confident (docs/estimators.md, "Teaching estimators").
    teaching: ClassVar[bool] = False

    def __init__(self, config: EstimatorConfig) -> None:
        """Keep the shared configuration; subclasses build their filters from it."""
        self.config = config

    @abstractmethod
    def update(self, t: float, theta: float) -> Estimate | None:
        """Consume one sample (t s, θ rad); return â and its variance, or None when the sample is ignored."""

    @abstractmethod
    def reset(self) -> None:
        """Forget every past sample (a looping bag, a restart)."""

    @abstractmethod
    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(â, var_a) for a whole recording, equal to streaming ``update`` from a fresh state (to ~1e-12)."""

    @abstractmethod
    def noise_equivalent_samples(self, accel: float) -> float:
        """N such that the steady-state variance at constant a is (g sec²θ_eq)² σ²/N."""

    @abstractmethod
    def nominal_delay(self, accel: float) -> float:
        """Group delay at zero frequency (s) of the linearised method about θ_eq(a)."""

    def warm(self) -> None:
        """Load the compiled code ``update`` runs now, so a live chain's first angles do not wait behind
        numba's loader (the estimator node calls it before it subscribes); nothing to load here."""
        return None

    def motion_model(self) -> str | None:
        """The motion model the estimate assumes (kalman: its preset), as reports name it; None when the
        method has none."""
        return None

    def describe(self) -> str:
        """One line: method name, its settings, N and the steady-state group delay at a = 0."""
        # "steady-state": for the IMM this is its modes' mix at the chain's stationary probabilities, which
        # its describe() follows with the per-mode range (its delay moves with the mode probabilities).
        line = (
            f"{self.name}: {self.summary}; N_eff={self.noise_equivalent_samples(0.0):.1f}, "
            f"steady-state group delay {self.nominal_delay(0.0):.3f} s"
        )
        return f"{line}; {TEACHING_NOTE}" if self.teaching else line

    def _accepts(self, t: float, theta: float, last_t: float | None) -> bool:
        """True when θ is finite and t finite and later than last_t."""
        return math.isfinite(theta) and math.isfinite(t) and (last_t is None or t > last_t)
