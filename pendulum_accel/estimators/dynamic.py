"""``dynamic``: invert the equation of motion, a = (l (θ'' + c θ') + g sin θ)/cos θ.

θ, θ' and θ'' come from one Savitzky-Golay least-squares polynomial fit over the last W samples
(scipy.signal.savgol_coeffs), evaluated at the window centre: causal (only past samples), with a
fixed delay of (W − 1)/2 samples and no phase distortion. A second derivative amplifies noise by
~1/(W dt)²; the window length is the noise/bandwidth knob. Linearised, the estimate is a weighted
sum of the W angles, so its variance is σ² Σ w_k² with w = (l/cos θ)(c₂ + c c₁) + g sec²θ c₀.
"""

from __future__ import annotations

import math
from typing import ClassVar

import numpy as np
from scipy import signal

from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators.base import (
    Estimate,
    Estimator,
    EstimatorConfig,
    accel_gain,
    accel_gain_array,
    check_batch_input,
    segments,
    wrap_clamp,
    wrap_clamp_array,
)
from pendulum_accel.physics.params import require_positive


class DynamicEstimator(Estimator):
    """a = (l(θ'' + c θ') + g sin θ)/cos θ from a centred Savitzky-Golay fit of W samples."""

    name: ClassVar[str] = "dynamic"
    summary: ClassVar[str] = "(l θ'' + g sin θ)/cos θ with Savitzky-Golay derivatives"

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
        dt = 1.0 / config.rate_hz
        pos = width // 2
        self._c0 = signal.savgol_coeffs(width, self.polyorder, deriv=0, pos=pos, use="dot")
        self._c1 = signal.savgol_coeffs(width, self.polyorder, deriv=1, delta=dt, pos=pos, use="dot")
        self._c2 = signal.savgol_coeffs(width, self.polyorder, deriv=2, delta=dt, pos=pos, use="dot")
        coeffs = np.stack([self._c0, self._c1, self._c2])
        self._gram = coeffs @ coeffs.T
        self._coeffs = coeffs.T.copy()  # (W, 3) for one matrix-vector product per sample
        self._buffer = np.zeros(2 * width)
        self.reset()

    def reset(self) -> None:
        """Empty the window."""
        self._filled = 0
        self._head = 0
        self._last_t: float | None = None

    def _accel(self, th: float, th_d: float, th_dd: float) -> tuple[float, float, bool]:
        """(a, var_a, clamped) from the fitted θ, θ', θ''."""
        cfg = self.config
        thc, clamped = wrap_clamp(th, cfg.clamp_angle)
        cos_th = math.cos(thc)
        lever = cfg.length / cos_th
        a = (cfg.length * (th_dd + cfg.damping * th_d) + cfg.gravity * math.sin(thc)) / cos_th
        v0, v1, v2 = accel_gain(thc, cfg.gravity), lever * cfg.damping, lever
        g = self._gram
        quad = (
            v0 * v0 * g[0, 0]
            + v1 * v1 * g[1, 1]
            + v2 * v2 * g[2, 2]
            + 2.0 * (v0 * v1 * g[0, 1] + v0 * v2 * g[0, 2] + v1 * v2 * g[1, 2])
        )
        return a, cfg.sigma**2 * quad, clamped

    def update(self, t: float, theta: float) -> Estimate | None:
        """Push θ into the window; once full, fit and invert the equation of motion."""
        if not self._accepts(t, theta, self._last_t):
            return None
        if self._last_t is not None and t - self._last_t > self.config.gap:
            self.reset()
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
            return Estimate(cfg.gravity * math.tan(th), (gain * cfg.sigma) ** 2, clamped)
        th, th_d, th_dd = (float(x) for x in self._buffer[self._head : self._head + width] @ self._coeffs)
        a, var, clamped = self._accel(th, th_d, th_dd)
        return Estimate(a, var, clamped)

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Sliding-window products per gap-free segment; the same formulas as ``update``."""
        t, theta = check_batch_input(t, theta)
        cfg = self.config
        th_c, _ = wrap_clamp_array(theta, cfg.clamp_angle)
        accel = cfg.gravity * np.tan(th_c)
        gain = accel_gain_array(th_c, cfg.gravity)
        var = (gain * cfg.sigma) ** 2
        width = self.width
        for seg in segments(t, cfg.gap):
            x = theta[seg]
            if x.size < width:
                continue
            fits = np.lib.stride_tricks.sliding_window_view(x, width) @ self._coeffs
            th, _ = wrap_clamp_array(fits[:, 0], cfg.clamp_angle)
            cos_th = np.cos(th)
            lever = cfg.length / cos_th
            a = (cfg.length * (fits[:, 2] + cfg.damping * fits[:, 1]) + cfg.gravity * np.sin(th)) / cos_th
            v0, v1, v2 = accel_gain_array(th, cfg.gravity), lever * cfg.damping, lever
            g = self._gram
            quad = (
                v0 * v0 * g[0, 0]
                + v1 * v1 * g[1, 1]
                + v2 * v2 * g[2, 2]
                + 2.0 * (v0 * v1 * g[0, 1] + v0 * v2 * g[0, 2] + v1 * v2 * g[1, 2])
            )
            start = seg.start + width - 1
            accel[start : seg.stop] = a
            var[start : seg.stop] = cfg.sigma**2 * quad
        return accel, var

    def noise_equivalent_samples(self, accel: float) -> float:
        """N = (g sec²θ_eq)²/Σw²: the weights' white-noise gain relative to one sample at θ_eq."""
        theta = math.atan2(accel, self.config.gravity)
        _, var, _ = self._accel(theta, 0.0, 0.0)
        return (accel_gain(theta, self.config.gravity) * self.config.sigma) ** 2 / var

    def nominal_delay(self, accel: float) -> float:
        """(W − 1)/2 samples: the fit is evaluated at the window centre."""
        return (self.width // 2) / self.config.rate_hz
