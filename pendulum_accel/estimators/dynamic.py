"""``dynamic``: invert the equation of motion, a = (l (θ'' + c θ') + g sin θ)/cos θ.

θ, θ' and θ'' come from one Savitzky-Golay least-squares polynomial fit over the last W samples
(scipy.signal.savgol_coeffs), evaluated at the window centre: causal (only past samples), with a
fixed delay of (W − 1)/2 samples and no phase distortion. A second derivative amplifies noise by
~1/(W dt)²; the window length is the noise/bandwidth knob. Before the window has filled the estimate
is g tan θ. It teaches model inversion: the swing is in the model, so it does not bias the estimate.

Variance: linearised, â is a weighted sum of the W angles, w = (l/cos θ)(c₂ + c c₁) + g sec²θ c₀, so
var = σ² Σw² + (g sec²θ)² E[b²] ((g sec²θ)² (σ² + E[b²]) while filling) — noise and bias only: it does
not count the fit's error on the swing or its lag, so in motion it is over-confident (docs/estimators.md).
"""

from __future__ import annotations

import math
from functools import cache
from typing import ClassVar, TypeVar

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators.base import (
    Estimate,
    Estimator,
    EstimatorConfig,
    accel_gain,
    accel_gain_array,
    bias_variance,
    bias_variance_array,
    check_batch_input,
    segments,
    wrap_clamp,
    wrap_clamp_array,
)
from pendulum_accel.physics.lazy import lazy_module
from pendulum_accel.physics.params import require_positive

signal = lazy_module("scipy.signal")  # imported on first use: start-up (docs/portability.md)

# Output block of the batch fit (``sliding_fits``): each block is one row of a matrix product. 64 keeps
# the block-Toeplitz weights small (K·B × 3B doubles, 1 MB at W = 601) and BLAS efficient.
_BLOCK = 64


@cache
def fit_coefficients(width: int, polyorder: int, rate_hz: float) -> np.ndarray:
    """(3, W) Savitzky-Golay weights of θ, θ', θ'' at the centre of W samples at rate_hz (read-only)."""
    dt = 1.0 / rate_hz
    coeffs = np.stack(
        [
            signal.savgol_coeffs(width, polyorder, deriv=k, delta=dt, pos=width // 2, use="dot")
            for k in range(3)
        ]
    )
    coeffs.flags.writeable = False
    return coeffs


@cache
def shared_block_weights(width: int, polyorder: int, rate_hz: float, damped: bool) -> np.ndarray:
    """:func:`block_weights` of (c₀, c₂), and c₁ after them when ``damped`` (read-only, shared)."""
    coeffs = fit_coefficients(width, polyorder, rate_hz)
    used = coeffs[[0, 2, 1]] if damped else coeffs[[0, 2]]
    weights = block_weights(np.ascontiguousarray(used.T), _BLOCK)
    weights.flags.writeable = False
    return weights


def block_weights(coeffs: np.ndarray, block: int) -> np.ndarray:
    """C (K·B × B·m), K = ⌈(B + W − 1)/B⌉: C[kB + u, r·m + q] = coeffs[kB + u − r, q] where 0 ≤ · < W, else 0.

    Row m of the sliding view x[mB : mB + K·B] times C gives the fits at samples mB … mB + B − 1.
    """
    width, sets = coeffs.shape
    rows = -(-(block + width - 1) // block) * block
    lag = np.arange(rows)[:, None] - np.arange(block)[None, :]
    inside = (lag >= 0) & (lag < width)
    weights = np.where(inside[:, :, None], coeffs[np.clip(lag, 0, width - 1)], 0.0)
    return weights.reshape(rows, block * sets)


def sliding_fits(x: np.ndarray, weights: np.ndarray, width: int, block: int) -> np.ndarray:
    """out[i] = x[i : i + W] @ coeffs for i = 0 … N − W (``weights`` = block_weights(coeffs, block)).

    One matrix product of the overlapping blocks x[mB : mB + K·B] with C: every output is the same
    W-term weighted sum as the streaming dot product, summed in another order (zeros pad the rest).
    """
    outputs = x.size - width + 1
    sets = weights.shape[1] // block
    blocks = -(-outputs // block)
    padded = np.zeros((blocks - 1) * block + weights.shape[0])
    padded[: x.size] = x
    rows = np.lib.stride_tricks.sliding_window_view(padded, weights.shape[0])[::block]
    result: np.ndarray = (rows @ weights).reshape(-1, sets)[:outputs]
    return result


Num = TypeVar("Num", float, np.ndarray)


def _quad_form(v0: Num, v1: Num, v2: Num, g: np.ndarray) -> Num:
    """vᵀGv for v = (v0, v1, v2) and the symmetric 3×3 G: Σw² of w = v0 c₀ + v1 c₁ + v2 c₂, G their Gram
    matrix (for one θ or an array of them: the same operations, so streaming and batch agree)."""
    result: Num = (
        v0 * v0 * g[0, 0]
        + v1 * v1 * g[1, 1]
        + v2 * v2 * g[2, 2]
        + 2.0 * (v0 * v1 * g[0, 1] + v0 * v2 * g[0, 2] + v1 * v2 * g[1, 2])
    )
    return result


class DynamicEstimator(Estimator):
    """a = (l(θ'' + c θ') + g sin θ)/cos θ from a centred Savitzky-Golay fit; var = σ²Σw² + bias."""

    name: ClassVar[str] = "dynamic"
    summary: ClassVar[str] = "(l θ'' + g sin θ)/cos θ with Savitzky-Golay derivatives"
    teaching: ClassVar[bool] = True

    def __init__(self, config: EstimatorConfig, *, window_s: float = 0.6, polyorder: int = 4) -> None:
        """Savitzky-Golay coefficients for θ, θ', θ'' at the centre of a window_s window (nominal rate)."""
        super().__init__(config)
        window_s = require_positive("window_s", window_s)
        width = round(window_s * config.rate_hz) | 1  # odd, so the centre is a sample
        # savgol_coeffs fits raw powers of the sample index: beyond order 6 the fit is ill-conditioned.
        if int(polyorder) != polyorder or not 2 <= polyorder <= min(6, width - 1):
            raise ParameterError(f"polyorder must be an integer in 2..{min(6, width - 1)}, got {polyorder!r}")
        self.width = width
        self.polyorder = int(polyorder)
        coeffs = fit_coefficients(width, self.polyorder, config.rate_hz)
        self._c0, self._c1, self._c2 = coeffs
        self._gram = coeffs @ coeffs.T
        self._coeffs = coeffs.T.copy()  # (W, 3) for one matrix-vector product per sample
        self._buffer = np.zeros(2 * width)
        self.reset()

    def reset(self) -> None:
        """Empty the window and forget the sensor's turn-on."""
        self._restart()
        self._last_t: float | None = None
        self._first_t = 0.0

    def _restart(self) -> None:
        """Empty the fit window (after a hole); the turn-on stays."""
        self._filled = 0
        self._head = 0

    def _noise_gain(self, theta: float) -> float:
        """Σw² = vᵀGv, w = v₀c₀ + v₁c₁ + v₂c₂, v = (g sec²θ, (l/cos θ) c, l/cos θ), G the Gram matrix."""
        cfg = self.config
        lever = cfg.length / math.cos(theta)
        return _quad_form(accel_gain(theta, cfg.gravity), lever * cfg.damping, lever, self._gram)

    def _noise_gain_array(self, theta: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`_noise_gain`, the same operations."""
        cfg = self.config
        lever = cfg.length / np.cos(theta)
        return _quad_form(accel_gain_array(theta, cfg.gravity), lever * cfg.damping, lever, self._gram)

    def update(self, t: float, theta: float) -> Estimate | None:
        """Push θ; once full, fit and invert, var = σ²Σw² + (g sec²θ)²E[b²]; g tan θ and its var before."""
        if not self._accepts(t, theta, self._last_t):
            return None
        if self._last_t is None:
            self._first_t = t
        elif t - self._last_t > self.config.gap:
            self._restart()
        self._last_t = t
        width = self.width
        # Each sample is written twice so the last W samples are always one contiguous slice.
        self._buffer[self._head] = theta
        self._buffer[self._head + width] = theta
        self._head = (self._head + 1) % width
        self._filled += 1
        cfg = self.config
        if self._filled < width:
            th, clamped = wrap_clamp(theta, cfg.clamp_angle)
            gain = accel_gain(th, cfg.gravity)
            a, var = cfg.gravity * math.tan(th), gain * gain * cfg.sigma**2
        else:
            th_fit, th_d, th_dd = (self._buffer[self._head : self._head + width] @ self._coeffs).tolist()
            th, clamped = wrap_clamp(th_fit, cfg.clamp_angle)
            cos_th = math.cos(th)
            a = (cfg.length * (th_dd + cfg.damping * th_d) + cfg.gravity * math.sin(th)) / cos_th
            var = cfg.sigma**2 * self._noise_gain(th)
        return Estimate(a, var + bias_variance(cfg, th, t - self._first_t), clamped)

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Sliding fits per gap-free segment (one matrix product, ``sliding_fits``); ``update``'s formulas."""
        t, theta = check_batch_input(t, theta)
        cfg = self.config
        th, _ = wrap_clamp_array(theta, cfg.clamp_angle)
        accel = cfg.gravity * np.tan(th)
        gain = accel_gain_array(th, cfg.gravity)
        var = gain * gain * cfg.sigma**2
        width = self.width
        for seg in segments(t, cfg.gap):
            if seg.stop - seg.start < width:
                continue
            damped = cfg.damping != 0.0
            weights = shared_block_weights(width, self.polyorder, cfg.rate_hz, damped)
            fits = sliding_fits(theta[seg], weights, width, _BLOCK)  # columns θ, θ'' (, θ')
            fitted, _ = wrap_clamp_array(fits[:, 0], cfg.clamp_angle)
            done = slice(seg.start + width - 1, seg.stop)
            th[done] = fitted
            rates = fits[:, 1] + cfg.damping * fits[:, 2] if damped else fits[:, 1]
            accel[done] = (cfg.length * rates + cfg.gravity * np.sin(fitted)) / np.cos(fitted)
            var[done] = cfg.sigma**2 * self._noise_gain_array(fitted)
        if t.size:
            var = var + bias_variance_array(cfg, th, t - t[0])
        return accel, var

    def noise_equivalent_samples(self, accel: float) -> float:
        """N = (g sec²θ_eq)²/Σw²: the weights' white-noise gain relative to one sample at θ_eq."""
        theta = math.atan2(accel, self.config.gravity)
        return accel_gain(theta, self.config.gravity) ** 2 / self._noise_gain(theta)

    def nominal_delay(self, accel: float) -> float:
        """(W − 1)/2 samples: the fit is evaluated at the window centre."""
        return (self.width // 2) / self.config.rate_hz
