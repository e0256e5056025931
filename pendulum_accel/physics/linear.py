"""Small-angle (linearised) model about the tilted equilibrium, in closed form.

φ = θ - θ_eq, θ_eq = atan2(a, g), φ'' = -ω² φ with ω² = √(g² + a²)/l (sin φ ≈ φ):
φ(t) = φ0 cos ωt + (φ0'/ω) sin ωt.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics.exact import times_array
from pendulum_accel.physics.params import Pendulum, require_finite

FloatArray = NDArray[np.float64]


def linear_solution(
    pendulum: Pendulum, accel: float, theta0: float, theta_dot0: float, t: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """θ = θ_eq + φ0 cos ωt + (θ0'/ω) sin ωt, θ' = θ0' cos ωt - φ0 ω sin ωt; φ0 = θ0 - θ_eq, t from the start.

    Linearised about the equilibrium copy θ_eq + 2πn nearest θ0; undamped (``pendulum.damping`` ignored).
    Returns (θ, θ') with the shape of t.
    """
    a = require_finite("acceleration", accel)
    theta_start = require_finite("theta0", theta0)
    rate = require_finite("theta_dot0", theta_dot0)
    times = times_array(t)
    omega = pendulum.omega(a)
    phi0 = math.remainder(theta_start - pendulum.equilibrium_angle(a), 2.0 * math.pi)
    phase = omega * times
    cos_phase, sin_phase = np.cos(phase), np.sin(phase)
    phi = phi0 * cos_phase + (rate / omega) * sin_phase
    # θ0 + (φ - φ0) returns θ(0) = θ0 exactly, whichever 2π copy θ0 was given in.
    return theta_start + (phi - phi0), rate * cos_phase - phi0 * omega * sin_phase


def abs_sine_integral(x: float) -> float:
    """G(x) = ∫₀ˣ |sin u| du = 2⌊x/π⌋ + 1 - cos(x mod π), for x ≥ 0."""
    half_turns, rest = divmod(x, math.pi)
    return 2.0 * half_turns + 1.0 - math.cos(rest)


def linear_error_bound(pendulum: Pendulum, accel: float, amplitude: float, duration: float) -> float:
    """max |θ_linear - θ_exact| over [0, T] ≤ min(2A, (A - sin A) G(ωT)), G(x) = ∫₀ˣ |sin u| du.

    For any start on the exact orbit of amplitude A (max |φ|) with the linear model started from the same
    state: the error e obeys e'' + ω² e = ω² (φ - sin φ), |φ - sin φ| ≤ A - sin A, so by variation of
    constants |e(t)| ≤ (A - sin A) ∫₀ᵗ ω |sin ωs| ds. Both solutions stay within A of θ_eq, hence 2A.
    The bound grows like (A³/3π) ωT, about 1.7× the true secular phase drift A (A²/16) ωT of the
    amplitude-dependent frequency ω(A) ≈ ω(1 - A²/16). Amplitude A ≥ π (rotation) gives inf.
    """
    a = require_finite("acceleration", accel)
    amp = require_finite("amplitude", amplitude)
    span = require_finite("duration", duration)
    if amp < 0.0:
        raise ParameterError(f"amplitude must be >= 0 rad, got {amp!r}")
    if span < 0.0:
        raise ParameterError(f"duration must be >= 0 s, got {span!r}")
    if amp >= math.pi:
        return math.inf
    # A - sin A by its series for small A, where the subtraction would cancel.
    a2 = amp * amp
    excess = amp * a2 / 6.0 * (1.0 - a2 / 20.0 * (1.0 - a2 / 42.0)) if amp < 1e-2 else amp - math.sin(amp)
    return min(2.0 * amp, excess * abs_sine_integral(pendulum.omega(a) * span))
