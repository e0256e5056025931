"""``dynamic``: invert the equation of motion, a = (l (θ'' + c θ') + g sin θ)/cos θ.

θ, θ' and θ'' come from one Savitzky-Golay least-squares polynomial fit over the last W samples
(scipy.signal.savgol_coeffs), evaluated at the window centre: causal (only past samples), with a
fixed delay of (W − 1)/2 samples and no phase distortion. A second derivative amplifies noise by
~1/(W dt)²; the window length is the noise/bandwidth knob. Linearised, the estimate is a weighted
sum of the W angles, so its noise variance is σ² Σ w_k² with w = (l/cos θ)(c₂ + c c₁) + g sec²θ c₀.

The published variance adds to that the sensor bias, (g sec²θ)² E[b²], and the errors the fit
makes, each estimated from the method's own data:
* the swing the polynomial does not follow: for θ = A cos ωt the fit's θ, θ', θ'' are off by
  R₀ = Σc₀ cos ωτ − 1, R₁ = Σc₁ sin ωτ − ω, R₂ = Σc₂ cos ωτ + ω² (τ the samples' times from the
  centre; each a power series in ω² from the order the polynomial no longer fits exactly), so â is
  off by a sinusoid of mean square ((l/cos θ) R₂ + g sec²θ R₀)² + ((l/cos θ) c R₁)² times A²/2 =
  (var θ − σ²)⁺, var θ and ω = 2π/T over the last swing period (``swing.SwingWindow``). A large
  swing is not a sinusoid: its third harmonic, −(A³/192) cos 3ωt (Lindstedt), meets a fit error
  ~3⁵ times larger, so the same gain at 3ω times (A₃)²/2, A₃ = min(A, 1 rad)³/192, is added
  (at l = 0.5 m: 1 % of the fundamental's at A = 0.2 rad, 16 % at braking's 0.39 rad, 90 % at
  0.6 rad; past 1 rad the series is not used);
* the lag while a changes: â is a at the window centre, D = (W − 1)/2 samples ago, so it trails a
  ramp by D × its rate, which is â − mean(â over the last 2D) for a ramp. Its square counts beyond
  9 × the noise variance (3σ, as kalman's motion term: â − mean(â) carries about â's own noise) and
  beyond 8 × the swing term's mean square m (the residual swing moves â − mean(â) by up to 2√(2m)).
* a change of a inside the window, which the centre does not see for D: the same polynomial
  evaluated at the newest sample gives â_end, a from the window's end, and δ = â_end − â shows a
  step of a ~0.05 s after the bob starts to move (the fit's end bends with the newest samples).
  |δ| counts beyond 3σ_δ of its noise, σ_δ² = σ² Σ(w_end − w)² (the two linearised weight sets),
  and beyond what a swing of amplitude A = √(2 (var θ − σ²)⁺) can make of it through the two fits'
  errors, A (|H_end(ω)| + |H(ω)|) + A₃ (|H_end(3ω)| + |H(3ω)|), H = (l/cos θ)(E₂ + c E₁) + g sec²θ E₀ and
  E_k = Σ c_k e^{iωτ} − (iω)^k each fit's error on e^{iωt} (τ from its own evaluation point).
  The square of that excess enters as the lag does (the larger of the two).
* a ramp begun inside the window, which δ sees late (it grows with the ramp and stays within its
  noise ~0.4 s): a likelihood-ratio test of the raw window against a steady swing
  (``estimators.fit_onset``) finds it 0.15–0.3 s in and gives its rate ĵ, hence the fit's error
  ê = ĵ h; 2 (ê² + var ê) enters with the others (the largest counts), held with a 50 ms decay.
Before the window has filled the estimate is g tan θ, and the swing term is ``instant``'s.
The first ~0.1 s after a step of a (braking) and ~0.2 s after a ramp starts (stop_and_go: the angle
departs as j t³/(6 l)) remain beyond 2σ.
"""

from __future__ import annotations

import math
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
    capped,
    capped_array,
    check_batch_input,
    segments,
    wrap_clamp,
    wrap_clamp_array,
)
from pendulum_accel.estimators.fit_onset import FitOnsetTest
from pendulum_accel.estimators.swing import SwingWindow, Trail, trail_means
from pendulum_accel.physics.lazy import lazy_module, njit
from pendulum_accel.physics.params import require_positive

signal = lazy_module("scipy.signal")  # imported on first use: start-up (docs/portability.md)

_LAG_THRESHOLD = 9.0  # the lag term counts beyond 9 × its noise-only variance (3σ, as kalman's)
# â carries the residual swing the model term already counts (mean square m, amplitude √(2m)); â − mean(â)
# moves with it by at most twice that amplitude, so the lag term counts beyond 4 × 2m as well: without it,
# braking's swinging steady stretch read that residual as lag (mean NEES 0.69, 0.4 % beyond 2σ; now 0.99).
_LAG_SWING = 8.0
_SWING_STAGES = 2  # T₀, then T(a₁, A₁)
_SERIES_TOL = 1e-20  # x^{2j}/(2j)! of the fit-error series' last term at the fastest swing
_JUMP_SIGMAS = 3.0  # δ = â_end − â counts beyond 3 × its noise-only spread (as the lag term)
# The libration's third harmonic, −(A³/192) cos 3ωt (Lindstedt), from this amplitude on not extrapolated.
_HARMONIC_MAX = 1.0  # rad
_TINY = 1e-300  # A below this: no swing, the harmonic's share of the allowance is 0
# The ramp-onset test on the raw window (``estimators.fit_onset``), tuned on the bundled scenes with
# ``python -m benchmarks.calibration``: onsets 0.1–0.5 s back (younger ones fit noise), λ beyond 20 (at 14,
# kalman's, noise alone passes in ~5 % of windows and widens σ at rest), 2 × the implied error's
# variance, held 50 ms.
_ONSET_MIN_AGE, _ONSET_MAX_AGE = 0.1, 0.5  # s
_ONSET_THRESHOLD = 20.0
_ONSET_MARGIN = 2.0
_ONSET_TAU = 0.05  # s
Num = TypeVar("Num", float, np.ndarray)


@njit(cache=True)
def _allowance(
    omega: np.ndarray,
    cos_th: np.ndarray,
    length: float,
    gravity: float,
    damping: float,
    centre: np.ndarray,
    tau_centre: np.ndarray,
    end: np.ndarray,
    tau_end: np.ndarray,
) -> np.ndarray:
    """Σ over the two fits of |(l/cos θ)(E₂ + c E₁) + g sec²θ E₀|, E_k = Σ_j c_kj e^{iωτ_j} − (iω)^k, for
    each sample. A compiled loop: in numpy calls (a W-point complex exponential per fit and frequency) it
    cost ~100 µs a sample, more than the rest of the method together.
    """
    total = np.zeros(omega.size)
    for i in range(omega.size):
        w = omega[i]
        lever = length / cos_th[i]
        gain = gravity / (cos_th[i] * cos_th[i])
        for coeffs, tau in ((centre, tau_centre), (end, tau_end)):
            r0 = i0 = r1 = i1 = r2 = i2 = 0.0
            # τ is evenly spaced: e^{iωτ_j} by repeated rotation through e^{iωΔτ}, not a sine and cosine each.
            c, s = math.cos(w * tau[0]), math.sin(w * tau[0])
            step = tau[1] - tau[0] if tau.size > 1 else 0.0
            dc, ds = math.cos(w * step), math.sin(w * step)
            for j in range(tau.size):
                if j > 0:
                    c, s = c * dc - s * ds, s * dc + c * ds
                r0 += coeffs[0, j] * c
                i0 += coeffs[0, j] * s
                r1 += coeffs[1, j] * c
                i1 += coeffs[1, j] * s
                r2 += coeffs[2, j] * c
                i2 += coeffs[2, j] * s
            re = lever * ((r2 + w * w) + damping * r1) + gain * (r0 - 1.0)
            im = lever * (i2 + damping * (i1 - w)) + gain * i0
            total[i] += math.hypot(re, im)
    return total


def warm_cache() -> None:
    """Compile the loop into numba's on-disk cache, or load it from there: ``make setup`` calls this once,
    and the constructor each time, so that a live node pays the load before it says it is estimating."""
    one = np.ones(1)
    _allowance(one, one, 1.0, 9.8, 0.0, np.ones((3, 2)), np.zeros(2), np.ones((3, 2)), np.zeros(2))


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
        warm_cache()
        dt = 1.0 / config.rate_hz
        pos = width // 2
        self._c0 = signal.savgol_coeffs(width, self.polyorder, deriv=0, pos=pos, use="dot")
        self._c1 = signal.savgol_coeffs(width, self.polyorder, deriv=1, delta=dt, pos=pos, use="dot")
        self._c2 = signal.savgol_coeffs(width, self.polyorder, deriv=2, delta=dt, pos=pos, use="dot")
        coeffs = np.stack([self._c0, self._c1, self._c2])
        self._gram = coeffs @ coeffs.T
        self._coeffs = coeffs.T.copy()  # (W, 3) for one matrix-vector product per sample
        # The same fit evaluated at the newest sample: θ, θ', θ'' there, for δ = â_end − â.
        end = np.stack(
            [
                signal.savgol_coeffs(width, self.polyorder, deriv=k, delta=dt, pos=width - 1, use="dot")
                for k in range(3)
            ]
        )
        self._coeffs_end = end.T.copy()
        self._gram_jump = (end - coeffs) @ (end - coeffs).T
        self._fits = (
            np.ascontiguousarray(coeffs),
            (np.arange(width) - pos) * dt,
            np.ascontiguousarray(end),
            (np.arange(width) - width + 1) * dt,
        )
        self._buffer = np.zeros(2 * width)
        r0, r1, r2 = self._fit_error_series(config)
        # Highest power first, for Horner's rule.
        self._series_even = list(zip(reversed(r0), reversed(r2), strict=True))
        self._series_odd = list(reversed(r1))
        self._delay = (width // 2) * dt
        self._onset = FitOnsetTest(
            config.rate_hz,
            self._c0,
            self._c2,
            min_age=_ONSET_MIN_AGE,
            max_age=_ONSET_MAX_AGE,
            threshold=_ONSET_THRESHOLD,
        )
        self._swing = SwingWindow(config, stages=_SWING_STAGES)
        self._outputs = Trail(2.0 * self._delay)
        self.reset()

    def _fit_error_series(self, config: EstimatorConfig) -> tuple[list[float], list[float], list[float]]:
        """Coefficients of R₀, R₁/ω, R₂ as power series in ω², zero up to the order the fit is exact.

        R = Σ_j (−1)^j ω^{2j} P_j/(2j)! with P_j = Σ c τ^{2j} (c₀, c₂);
        R₁/ω = Σ_j (−1)^j ω^{2j} Σ c₁ τ^{2j+1}/(2j+1)!; enough terms for the fastest swing the clamp
        allows, ω² = g/(l cos θ_max).
        """
        tau = (np.arange(self.width) - self.width // 2) / config.rate_hz
        x_max = math.sqrt(config.gravity / (config.length * math.cos(config.clamp_angle))) * float(tau[-1])
        terms = 2
        while x_max ** (2 * terms) / math.factorial(2 * terms) > _SERIES_TOL:
            terms += 1
        r0, r1, r2 = [], [], []
        for j in range(terms + 1):
            sign = -1.0 if j % 2 else 1.0
            exact = 2 * j <= self.polyorder
            r0.append(0.0 if exact else sign * float(self._c0 @ tau ** (2 * j)) / math.factorial(2 * j))
            r2.append(0.0 if exact else sign * float(self._c2 @ tau ** (2 * j)) / math.factorial(2 * j))
            odd = 2 * j + 1 <= self.polyorder
            r1.append(0.0 if odd else sign * float(self._c1 @ tau ** (2 * j + 1)) / math.factorial(2 * j + 1))
        return r0, r1, r2

    def fit_error_gain(self, theta: float, omega: float) -> float:
        """((l/cos θ) R₂ + g sec²θ R₀)² + ((l/cos θ) c R₁)²: â's mean-square error per A²/2 of swing at ω."""
        cfg = self.config
        y = omega * omega
        r0 = r2 = 0.0
        for c0, c2 in self._series_even:
            r0, r2 = r0 * y + c0, r2 * y + c2
        lever = cfg.length / math.cos(theta)
        real = lever * r2 + accel_gain(theta, cfg.gravity) * r0
        if not cfg.damping:
            return real * real
        r1 = 0.0
        for c1 in self._series_odd:
            r1 = r1 * y + c1
        imag = lever * cfg.damping * r1 * omega
        return real * real + imag * imag

    def _fit_error_gain_array(self, theta: np.ndarray, omega: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`fit_error_gain`, the same operations."""
        cfg = self.config
        y = omega * omega
        r0 = np.zeros_like(y)
        r2 = np.zeros_like(y)
        for c0, c2 in self._series_even:
            r0, r2 = r0 * y + c0, r2 * y + c2
        lever = cfg.length / np.cos(theta)
        real = lever * r2 + accel_gain_array(theta, cfg.gravity) * r0
        if not cfg.damping:
            return real * real
        r1 = np.zeros_like(y)
        for c1 in self._series_odd:
            r1 = r1 * y + c1
        imag = lever * cfg.damping * r1 * omega
        return real * real + imag * imag

    def reset(self) -> None:
        """Empty the window and forget the sensor's turn-on."""
        self._restart()
        self._last_t: float | None = None
        self._first_t = 0.0
        self._swing.reset()

    def _restart(self) -> None:
        """Empty the fit window and the output history (after a hole); the turn-on stays."""
        self._filled = 0
        self._head = 0
        self._outputs.reset()
        self._hint = 0
        self._onset_var = 0.0  # the onset test's variance, held with a 50 ms decay

    @staticmethod
    def _quad(v0: Num, v1: Num, v2: Num, g: np.ndarray) -> Num:
        """vᵀGv, v = (v0, v1, v2): Σ w² of the linearised weights w = v0 c₀ + v1 c₁ + v2 c₂, G their Gram."""
        return (
            v0 * v0 * g[0, 0]
            + v1 * v1 * g[1, 1]
            + v2 * v2 * g[2, 2]
            + 2.0 * (v0 * v1 * g[0, 1] + v0 * v2 * g[0, 2] + v1 * v2 * g[1, 2])
        )

    def swing_allowance(self, theta: Num, omega: Num) -> Num:
        """|H_end(ω)| + |H(ω)|: what a unit swing at ω can make of δ = â_end − â through the fits' errors.

        H = (l/cos θ)(E₂ + c E₁) + g sec²θ E₀, E_k = Σ c_k e^{iωτ} − (iω)^k, τ from each fit's own point.
        """
        cfg = self.config
        w = np.atleast_1d(np.asarray(omega, dtype=float))
        cos_th = np.ascontiguousarray(np.broadcast_to(np.cos(theta), w.shape), dtype=float)
        total = _allowance(w, cos_th, cfg.length, cfg.gravity, cfg.damping, *self._fits)
        return total if isinstance(omega, np.ndarray) else float(total[0])

    def jump_excess(self, jump: Num, quad_jump: Num, amplitude: Num, allowance: Num) -> Num:
        """(|δ| − 3σ_δ − A·allowance)⁺, σ_δ² = σ² Σ(w_end − w)² (= σ² ``quad_jump``)."""
        return np.maximum(
            np.abs(jump) - _JUMP_SIGMAS * self.config.sigma * np.sqrt(quad_jump) - amplitude * allowance, 0.0
        )

    def onset_variance(self, window: np.ndarray, omega: float, third: float, lever: float) -> float:
        """M (ê² + var ê), M = 2, for a ramp the fit-window test finds (``estimators.fit_onset``); else 0."""
        found = self._onset.error(window, omega, third, lever, self.config.sigma)
        if found is None:
            return 0.0
        error, spread = found
        return _ONSET_MARGIN * (error * error + spread)

    def _accel(self, th: float, th_d: float, th_dd: float) -> tuple[float, float, bool]:
        """(a, var_a, clamped) from the fitted θ, θ', θ''."""
        cfg = self.config
        thc, clamped = wrap_clamp(th, cfg.clamp_angle)
        cos_th = math.cos(thc)
        lever = cfg.length / cos_th
        a = (cfg.length * (th_dd + cfg.damping * th_d) + cfg.gravity * math.sin(thc)) / cos_th
        v0, v1, v2 = accel_gain(thc, cfg.gravity), lever * cfg.damping, lever
        return a, cfg.sigma**2 * self._quad(v0, v1, v2, self._gram), clamped

    def update(self, t: float, theta: float) -> Estimate | None:
        """Push θ; once full, fit and invert; var = σ²Σw² + (g sec²θ)²E[b²] + fit error
        + max((lag² − 9σ²Σw² − 8 m)⁺, jump², onset), m the fit-error (swing) term."""
        if not self._accepts(t, theta, self._last_t):
            return None
        if self._last_t is None:
            self._first_t = t
        elif t - self._last_t > self.config.gap:
            self._restart()
        else:
            self._onset_var *= math.exp(-(t - self._last_t) / _ONSET_TAU)
        self._last_t = t
        width = self.width
        # Each sample is written twice so the last W samples are always one contiguous slice.
        self._buffer[self._head] = theta
        self._buffer[self._head + width] = theta
        self._head = (self._head + 1) % width
        self._filled += 1
        cfg = self.config
        means, _ = self._swing.push(t, theta)
        swing = max(means.variance - cfg.sigma**2, 0.0)
        if self._filled < width:
            th, clamped = wrap_clamp(theta, cfg.clamp_angle)
            gain = accel_gain(th, cfg.gravity)
            a, var = cfg.gravity * math.tan(th), (gain * cfg.sigma) ** 2
            th_bar, _ = wrap_clamp(means.mean, cfg.clamp_angle)
            model = accel_gain(th_bar, cfg.gravity) ** 2 * swing
            jump = 0.0
        else:
            recent = self._buffer[self._head : self._head + width]
            fit = recent @ self._coeffs
            th_fit, th_d, th_dd = (float(x) for x in fit)
            a, var, clamped = self._accel(th_fit, th_d, th_dd)
            th, _ = wrap_clamp(th_fit, cfg.clamp_angle)
            omega = 2.0 * math.pi / means.window
            amplitude = math.sqrt(2.0 * swing)
            third = min(amplitude, _HARMONIC_MAX) ** 3 / 192.0
            model = (
                self.fit_error_gain(th, omega) * swing
                + self.fit_error_gain(th, 3.0 * omega) * 0.5 * third * third
            )
            a_end, _, _ = self._accel(*(float(x) for x in recent @ self._coeffs_end))
            lever = cfg.length / math.cos(th)
            quad = self._quad(accel_gain(th, cfg.gravity), lever * cfg.damping, lever, self._gram_jump)
            allowance = self.swing_allowance(th, omega) + third / max(
                amplitude, _TINY
            ) * self.swing_allowance(th, 3.0 * omega)
            jump = float(self.jump_excess(a_end - a, quad, amplitude, allowance))
            found = self.onset_variance(recent, omega, third, lever)
            self._onset_var = max(self._onset_var, found)
        k = self._outputs.append(t, a)
        mean, _, _, self._hint = self._outputs.means(k, 2.0 * self._delay, self._hint)
        self._outputs.prune(k)
        lag = a - mean
        excess = max(lag * lag - _LAG_THRESHOLD * var - _LAG_SWING * model, jump * jump, self._onset_var, 0.0)
        var += capped(model + excess, cfg.error_cap) + bias_variance(cfg, th, t - self._first_t)
        return Estimate(a, var, clamped)

    def batch(self, t: np.ndarray, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Sliding-window products per gap-free segment; the same formulas as ``update``."""
        t, theta = check_batch_input(t, theta)
        cfg = self.config
        th_c, _ = wrap_clamp_array(theta, cfg.clamp_angle)
        accel = cfg.gravity * np.tan(th_c)
        gain = accel_gain_array(th_c, cfg.gravity)
        var = (gain * cfg.sigma) ** 2
        if not t.size:
            return accel, var
        mean, mean_sq, _, window = self._swing.batch(t, theta)
        swing = np.maximum(np.maximum(mean_sq - mean * mean, 0.0) - cfg.sigma**2, 0.0)
        th_bar, _ = wrap_clamp_array(mean, cfg.clamp_angle)
        model = accel_gain_array(th_bar, cfg.gravity) ** 2 * swing
        width = self.width
        jump = np.zeros(t.size)
        onset = np.zeros(t.size)
        for seg in segments(t, cfg.gap):
            x = theta[seg]
            if x.size < width:
                continue
            windows = np.lib.stride_tricks.sliding_window_view(x, width)
            fits = windows @ self._coeffs
            ends = windows @ self._coeffs_end
            th, _ = wrap_clamp_array(fits[:, 0], cfg.clamp_angle)
            cos_th = np.cos(th)
            lever = cfg.length / cos_th
            a = (cfg.length * (fits[:, 2] + cfg.damping * fits[:, 1]) + cfg.gravity * np.sin(th)) / cos_th
            v0, v1, v2 = accel_gain_array(th, cfg.gravity), lever * cfg.damping, lever
            quad = self._quad(v0, v1, v2, self._gram)
            th_end, _ = wrap_clamp_array(ends[:, 0], cfg.clamp_angle)
            a_end = (
                cfg.length * (ends[:, 2] + cfg.damping * ends[:, 1]) + cfg.gravity * np.sin(th_end)
            ) / np.cos(th_end)
            start = seg.start + width - 1
            accel[start : seg.stop] = a
            var[start : seg.stop] = cfg.sigma**2 * quad
            th_c[start : seg.stop] = th
            omega = 2.0 * math.pi / window[start : seg.stop]
            amplitude = np.sqrt(2.0 * swing[start : seg.stop])
            third = np.minimum(amplitude, _HARMONIC_MAX) ** 3 / 192.0
            model[start : seg.stop] = (
                self._fit_error_gain_array(th, omega) * swing[start : seg.stop]
                + self._fit_error_gain_array(th, 3.0 * omega) * 0.5 * third * third
            )
            allowance = self.swing_allowance(th, omega) + third / np.maximum(
                amplitude, _TINY
            ) * self.swing_allowance(th, 3.0 * omega)
            quad_jump = self._quad(v0, v1, v2, self._gram_jump)
            jump[start : seg.stop] = self.jump_excess(a_end - a, quad_jump, amplitude, allowance)
            held = 0.0
            for i, k in enumerate(range(start, seg.stop)):
                if k > start:
                    held *= math.exp(-(t[k] - t[k - 1]) / _ONSET_TAU)
                found = self.onset_variance(windows[i], float(omega[i]), float(third[i]), float(lever[i]))
                held = max(held, found)
                onset[k] = held
        lag = accel - trail_means(t, accel, 2.0 * self._delay, cfg.gap)
        lag_excess = lag * lag - _LAG_THRESHOLD * var - _LAG_SWING * model
        excess = np.maximum(np.maximum(np.maximum(lag_excess, jump * jump), onset), 0.0)
        var = var + capped_array(model + excess, cfg.error_cap)
        return accel, var + bias_variance_array(cfg, th_c, t - t[0])

    def noise_equivalent_samples(self, accel: float) -> float:
        """N = (g sec²θ_eq)²/Σw²: the weights' white-noise gain relative to one sample at θ_eq."""
        theta = math.atan2(accel, self.config.gravity)
        _, var, _ = self._accel(theta, 0.0, 0.0)
        return (accel_gain(theta, self.config.gravity) * self.config.sigma) ** 2 / var

    def nominal_delay(self, accel: float) -> float:
        """(W − 1)/2 samples: the fit is evaluated at the window centre."""
        return (self.width // 2) / self.config.rate_hz
