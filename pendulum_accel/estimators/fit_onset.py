"""A ramp of a begun inside a fit window, found in the raw angles against a steady swing (a GLR test).

``dynamic`` evaluates its fit at the window centre, D = (W − 1)/2 samples back, so a ramp of a begun s ago
is missing from its â by about j·min(s, D), and its lag term sees â move only ~0.4 s into the ramp. The
angles show the ramp sooner. While a is constant the bob swings about θ_eq, θ = c₀ + c₁ cos ωτ + c₂ sin ωτ
over the window (τ the samples' times from the newest); a ramp of rate j begun s_m = m Δt ago adds
(cos θ/l) j r(τ + s_m), r(s) = (ωs − sin ωs)⁺/ω³ (the linearised response: r'' + ω² r = s for s > 0).
With u_m that shape's part orthogonal to the swing's three functions, least squares gives

    ĵ = (l/cos θ) u_mᵀθ/u_mᵀu_m,   λ_m = (u_mᵀθ)²/(σ² u_mᵀu_m + A₃² G_m),

where A₃² G_m allows for what the sinusoid misses of a large swing, the libration's third harmonic
A₃ cos(3ωτ + φ) (A₃ = min(A, 1 rad)³/192, G_m = |u_mᵀ e^{3iωτ}|², the most any phase φ puts into u_m;
without it a 0.6 rad swing passes the test). The likeliest onset, if its λ passes the threshold,
implies the fit's error ê = ĵ h_m with h_m = (c₂ + ω² c₀)·r_m − s_m: the centre fit's response to the ramp
(a = (l/cos θ) θ'' + g sec²θ θ linearised about θ_eq, where g/(l cos θ) = ω²) less the ramp's value now.

``estimators.onset`` is the same idea on a Kalman filter's innovations, where the filter's own model of a
swing makes the null hypothesis; here there is no filter, so the swing is fitted in each window.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.errors import ParameterError

_OMEGA_STEP = 1e-3  # the basis is built for ω rounded to this relative step (and cached)
_CACHE = 64  # bases kept (each ~120 blocks × ~80 ages floats, 80 kB, whatever the rate)
# Above this rate the test runs on means of k = round(rate/200) samples (noise σ²/k each): its cost and
# its shapes stay at ~120 points a window, where 1 kHz would take 601 and 100 kHz 60001.
_BLOCK_RATE = 200.0  # Hz


class FitBasis:
    """One ω's orthogonalised ramp shapes u_m (columns), u_mᵀu_m, G_m and the centre fit's error h_m."""

    def __init__(
        self,
        omega: float,
        tau: NDArray[np.float64],
        ages: NDArray[np.float64],
        c0: NDArray[np.float64],
        c2: NDArray[np.float64],
    ) -> None:
        """u_m = (I − Q Qᵀ) r(τ + s_m), Q an orthonormal basis of {1, cos ωτ, sin ωτ}; h_m: module doc.
        τ are the blocks' centres and c₀, c₂ the fit's weights summed over each block."""
        swing = np.stack([np.ones_like(tau), np.cos(omega * tau), np.sin(omega * tau)], axis=1)
        q, _ = np.linalg.qr(swing)
        since = np.maximum(tau[:, None] + ages[None, :], 0.0)
        shapes = (omega * since - np.sin(omega * since)) / omega**3
        self.u = shapes - q @ (q.T @ shapes)
        self.energy = np.maximum(np.sum(self.u * self.u, axis=0), np.finfo(float).tiny)
        triple = 3.0 * omega * tau
        self.harmonic = (self.u.T @ np.cos(triple)) ** 2 + (self.u.T @ np.sin(triple)) ** 2
        self.response = c2 @ shapes + omega**2 * (c0 @ shapes) - ages


class FitOnsetTest:
    """The GLR test over onsets ``min_age`` … ``max_age`` back in a window of ``c0.size`` samples."""

    def __init__(
        self,
        rate_hz: float,
        c0: NDArray[np.float64],
        c2: NDArray[np.float64],
        *,
        min_age: float,
        max_age: float,
        threshold: float,
    ) -> None:
        """Blocks of k = round(rate/200) samples (at least 1), the newest ⌊W/k⌋ of the window; onset ages
        m k Δt for m from min_age/(k Δt) (at least 1) up to max_age/(k Δt) and the blocks less 4 (the
        swing's three functions need blocks before the onset; a window too short for any age tests
        nothing); c₀, c₂ the fit's weights for θ and θ''."""
        if not (rate_hz > 0.0 and 0.0 <= min_age <= max_age and threshold > 0.0):
            raise ParameterError(
                f"fit onset test needs rate > 0, 0 <= min_age <= max_age and threshold > 0; got rate "
                f"{rate_hz!r}, ages {min_age!r}–{max_age!r} s, threshold {threshold!r}"
            )
        width = c0.size
        stride = max(1, round(rate_hz / _BLOCK_RATE))
        blocks = width // stride
        self._stride, self._skip = stride, width - blocks * stride
        block_dt = stride / rate_hz
        # Each block's centre, from the newest sample.
        offsets = (blocks - 1 - np.arange(blocks)) * stride + 0.5 * (stride - 1)
        self._tau = np.asarray(-offsets / rate_hz, dtype=np.float64)
        low = max(1, round(min_age / block_dt))
        high = min(round(max_age / block_dt), blocks - 4)
        # Empty when the window is too short for any onset age.
        self._ages = np.asarray(np.arange(low, high + 1) * block_dt, dtype=np.float64)
        self._c0, self._c2 = (
            np.asarray(c[self._skip :], dtype=np.float64).reshape(blocks, stride).sum(axis=1)
            for c in (c0, c2)
        )
        self._threshold = threshold
        self._basis = lru_cache(maxsize=_CACHE)(self._build)

    def _build(self, step: int) -> FitBasis:
        """The basis for ω = e^{step·δ}, δ = _OMEGA_STEP."""
        return FitBasis(math.exp(step * _OMEGA_STEP), self._tau, self._ages, self._c0, self._c2)

    def basis(self, omega: float) -> FitBasis:
        """The cached basis for ω rounded to a relative step of 1e-3."""
        return self._basis(round(math.log(omega) / _OMEGA_STEP))

    def error(
        self,
        window: NDArray[np.float64],
        omega: float,
        third: float,
        lever: float,
        sigma: float,
    ) -> tuple[float, float] | None:
        """(ê, var ê) = (ĵ h, var(ĵ) h²) at the likeliest onset if its λ passes the threshold, else None;
        ``window`` the W angles oldest first (taken in block means), A₃ = ``third`` the swing's third
        harmonic (``dynamic``'s), ``lever`` = l/cos θ (ĵ = lever · u_mᵀθ/u_mᵀu_m)."""
        if not self._ages.size:
            return None
        basis = self.basis(omega)
        means = window if self._stride == 1 else window[self._skip :].reshape(-1, self._stride).mean(axis=1)
        noise = sigma * sigma / self._stride
        proj = means @ basis.u
        spread = noise * basis.energy + third * third * basis.harmonic
        with np.errstate(divide="ignore", invalid="ignore"):  # a noiseless sensor: σ = 0 and no swing
            stat = proj * proj / spread
        best = int(np.argmax(stat))
        if not stat[best] > self._threshold:
            return None
        rate = lever * float(proj[best] / basis.energy[best])
        h = float(basis.response[best])
        return rate * h, noise * (lever * h) ** 2 / float(basis.energy[best])
