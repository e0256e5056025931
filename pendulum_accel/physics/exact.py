"""Closed-form motion of the car-frame pendulum for constant acceleration a, undamped.

In the car frame θ'' = -(g/l) sin θ + (a/l) cos θ = -(g_eff/l) sin(θ - θ_eq), with
g_eff = √(g² + a²) and θ_eq = atan2(a, g): a plain pendulum in the tilted gravity g_eff.
With φ = θ - θ_eq and ω² = g_eff/l, φ'' = -ω² sin φ, whose energy gives the elliptic parameter

    m = k² = sin²(φ0/2) + (φ0'/2ω)²,    m1 = 1 - m = (cos(φ0/2) - |φ0'|/2ω)(cos(φ0/2) + |φ0'|/2ω).

m1 is formed as that product, never as 1 - m, so states within 1e-9 (or 1e-30) of the separatrix keep
their full relative accuracy; every elliptic routine below takes the complementary parameter as input.

Regimes (u, U: elliptic arguments; sn, cn, dn, am: Jacobi functions):
- libration, m1 > 0:  sin(φ/2) = k sn(u | m),  u = ω t + u0,  φ = 2 atan2(k sn u, dn u),  φ' = 2 k ω cn u;
- separatrix, m1 = 0:  φ = 2 gd(U) = 2 atan(sinh U),  U = asinh(tan(φ0/2)) ± ω t,  φ' = ±2 ω sech U;
- rotation, m1 < 0:  φ = 2 am(U | 1/m),  U = F(φ0/2 | 1/m) ± k ω t,  φ' = ±2 k ω dn(U | 1/m);
- tiny amplitude, m < 1e-24: the linear solution, whose relative error O(m) is below double precision.

Evaluation. Away from the separatrix (nome q = exp(-πK'/K) ≤ 0.15) φ and φ' are summed as their Fourier
series in q (at most 21 terms, Clenshaw recurrence, one sin and cos per sample: the fast path). Closer to
it the Jacobi functions are evaluated by halving the argument to |v| ≤ 1e-3 (Maclaurin series of 1 - cn),
then doubling back with the duplication formula for 1 - cn written in sums of positive terms
(Fukushima's approach), after reducing the argument to [-K, K] modulo 2K and reflecting
[K/2, K] onto [0, K/2] with sn(K-w) = cd w, cn(K-w) = k' sd w, dn(K-w) = k'/dn w.
K and F come from Carlson's R_F (scipy.special.elliprf), fed the complementary parameter directly:
scipy's ellipj/ellipkinc take m itself and lose the digits of 1 - m near the separatrix.

The start is taken as the exact value of the given floats: θ0 = math.pi (a = 0) lies 1.2e-16 below the
top, so the bob leaves it after ≈ ln(16/1.2e-16)/ω, as the 30-digit reference does; only the exact top
(not representable in floating point) would stay forever.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics.lazy import lazy_module
from pendulum_accel.physics.params import Pendulum, require_finite

special = lazy_module("scipy.special")  # imported on first use: start-up (docs/portability.md)

FloatArray = NDArray[np.float64]

_TWO_PI = 2.0 * math.pi
_SERIES_LIMIT = 1e-3  # |v| where the cn series through v⁸ is exact to < 1e-19 relative
_LINEAR_LIMIT = 1e-24  # m below which sin φ = φ to double precision over the whole orbit
_CHUNK = 8192
FOURIER_MAX_NOME = 0.15  # beyond (m ≳ 0.91) the > 21 Fourier terms cost more than halving/doubling
EVALUATIONS = ("auto", "fourier", "doubling")


def times_array(t: ArrayLike) -> FloatArray:
    """Return t as a float64 array; ParameterError naming the first NaN/inf sample time."""
    times = np.asarray(t, dtype=np.float64)
    bad = ~np.isfinite(times)
    if np.any(bad):
        raise ParameterError(f"sample time t must be finite, got {times[bad].flat[0]!r}")
    return times


def half_angle_start(phi: float) -> tuple[float, float]:
    """(sin(φ_r/2), cos(φ_r/2)) with φ = φ_r + 2πn, φ_r ∈ [-π, π], so cos(φ_r/2) ≥ 0.

    sin/cos are taken of φ/2 itself and sign-flipped for odd n ((-1)^n), so reducing φ costs no rounding.
    """
    turns = round(phi / _TWO_PI)
    sign = -1.0 if turns % 2 else 1.0
    s = sign * math.sin(0.5 * phi)
    c = sign * math.cos(0.5 * phi)
    if c < 0.0:  # φ sat within an ulp of an odd multiple of π: the neighbouring turn has c ≥ 0
        s, c = -s, -c
    return s, c


@dataclass(frozen=True)
class OrbitStart:
    """φ'' = -ω² sin φ from s = sin(φ0/2), c = cos(φ0/2) ≥ 0, h = φ0'/2ω; m = s²+h², m1 = (c-|h|)(c+|h|)."""

    omega: float
    s: float
    c: float
    h: float
    m: float
    m1: float

    @classmethod
    def from_state(cls, pendulum: Pendulum, accel: float, theta0: float, theta_dot0: float) -> OrbitStart:
        """φ0 = θ0 - θ_eq reduced to [-π, π], ω² = √(g²+a²)/l; m1 as a product, free of cancellation."""
        a = require_finite("acceleration", accel)
        theta_start = require_finite("theta0", theta0)
        rate = require_finite("theta_dot0", theta_dot0)
        omega = pendulum.omega(a)
        s, c = half_angle_start(theta_start - pendulum.equilibrium_angle(a))
        h = 0.5 * rate / omega
        return cls(omega, s, c, h, s * s + h * h, (c - abs(h)) * (c + abs(h)))


def complete_k(m1: float) -> float:
    """K(m) = R_F(0, m1, 1), from the complementary parameter m1 = 1 - m > 0."""
    return float(special.elliprf(0.0, m1, 1.0))


def incomplete_f(sin_psi: float, cos_psi: float, m: float, m1: float) -> float:
    """F(ψ | m) = sin ψ · R_F(cos²ψ, cos²ψ + m1 sin²ψ, 1) for |ψ| ≤ π/2 (cos ψ ≥ 0)."""
    c2 = cos_psi * cos_psi
    return sin_psi * float(special.elliprf(c2, c2 + m1 * sin_psi * sin_psi, 1.0))


def _jacobi_half_quarter(v: FloatArray, m: float, m1: float) -> tuple[FloatArray, FloatArray, FloatArray]:
    """(sn, cn, dn)(v | m) for 0 ≤ v ≤ K: halve v, series for y = 1 - cn, then y ← 2 z D/(cn² + z D).

    z = sn² = y(2 - y), D = dn² = m1 + m cn²: every term positive, so no cancellation as m → 1.
    """
    vmax = float(np.max(v)) if v.size else 0.0
    halvings = max(0, math.ceil(math.log2(vmax / _SERIES_LIMIT))) if vmax > _SERIES_LIMIT else 0
    v0 = np.ldexp(v, -halvings)
    x = v0 * v0
    # 1 - cn(v) = v²/2 - (1+4m) v⁴/24 + (1+44m+16m²) v⁶/720 - (1+408m+912m²+64m³) v⁸/40320
    c4 = (1.0 + 4.0 * m) / 24.0
    c6 = (1.0 + m * (44.0 + 16.0 * m)) / 720.0
    c8 = (1.0 + m * (408.0 + m * (912.0 + 64.0 * m))) / 40320.0
    y = x * (0.5 - x * (c4 - x * (c6 - x * c8)))
    for _ in range(halvings):
        z = y * (2.0 - y)
        c = 1.0 - y
        c2 = c * c
        zd = z * (m1 + m * c2)
        y = 2.0 * zd / (c2 + zd)
    cn = 1.0 - y
    sn = np.sqrt(y * (2.0 - y))
    dn = np.sqrt(m1 + m * cn * cn)
    return sn, cn, dn


def jacobi_reduced(
    u: FloatArray, m: float, m1: float, K: float
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """u = 2K j + r, |r| ≤ K; return (sn r, cn r, dn r, j), so sn u = (-1)^j sn r, am u = jπ + am r."""
    j = np.rint(u / (2.0 * K))
    r = u - j * (2.0 * K)
    v = np.abs(r)
    reflect = v > 0.5 * K
    w = np.where(reflect, K - v, v)
    sn_w, cn_w, dn_w = _jacobi_half_quarter(w, m, m1)
    kc = math.sqrt(m1)
    sn = np.where(reflect, cn_w / dn_w, sn_w)
    cn = np.where(reflect, kc * sn_w / dn_w, cn_w)
    dn = np.where(reflect, kc / dn_w, dn_w)
    return np.copysign(sn, r), cn, dn, j


Evaluator = Callable[[FloatArray], tuple[FloatArray, FloatArray]]


def _chunked(times: FloatArray, evaluate: Evaluator) -> tuple[FloatArray, FloatArray]:
    """(φ, φ') = evaluate(t) over flat t in chunks of 8192 samples: temporaries that stay in the CPU cache."""
    flat = times.ravel()
    phi = np.empty_like(flat)
    phi_dot = np.empty_like(flat)
    for first in range(0, flat.size, _CHUNK):
        phi[first : first + _CHUNK], phi_dot[first : first + _CHUNK] = evaluate(flat[first : first + _CHUNK])
    return phi.reshape(times.shape), phi_dot.reshape(times.shape)


def _use_fourier(method: str, q: float) -> bool:
    """Fourier series when asked, or for "auto" when q ≤ 0.15; ParameterError for an unknown method."""
    if method not in EVALUATIONS:
        raise ParameterError(f"evaluation method must be one of {EVALUATIONS}, got {method!r}")
    return method == "fourier" or (method == "auto" and q <= FOURIER_MAX_NOME)


def nome(K: float, K_prime: float) -> float:
    """q = exp(-π K'/K), the nome of the Fourier series of the Jacobi functions."""
    return math.exp(-math.pi * K_prime / K)


def _series_length(q: float) -> int:
    """Number N of Fourier terms with q^N < 1e-17, the first neglected term below double precision."""
    return max(1, math.ceil(math.log(1e-17) / math.log(q))) if q > 0.0 else 1


def _clenshaw(coefficients: list[float], x: FloatArray) -> tuple[FloatArray, FloatArray]:
    """(b_0, b_1) of b_k = c_k + x b_{k+1} - b_{k+2}; then Σ c_k f_k = b_0 f_0 - b_1 f_{-1}.

    Valid for any f obeying f_{k+1} = x f_k - f_{k-1}, e.g. f_k = sin((2k+1)ζ) with x = 2 cos 2ζ.
    """
    b1 = np.zeros_like(x)
    b2 = np.zeros_like(x)
    for coefficient in reversed(coefficients):
        b1, b2 = coefficient + x * b1 - b2, b1
    return b1, b2


def libration_motion(t: FloatArray, start: OrbitStart, method: str = "auto") -> tuple[FloatArray, FloatArray]:
    """φ = 2 atan2(k sn u, dn u), φ' = 2kω cn u, u = ωt + u0, am(u0) = atan2(sin(φ0/2), φ0'/2ω).

    method "fourier" (the default when q ≤ 0.15, i.e. m ≲ 0.91): with ζ = πu/2K (DLMF 22.11.2),
        φ = 8 Σ_{n≥0} q^{n+½} sin((2n+1)ζ) / ((2n+1)(1 + q^{2n+1})),
        φ' = (4πω/K) Σ_{n≥0} q^{n+½} cos((2n+1)ζ) / (1 + q^{2n+1}),
    summed by Clenshaw's recurrence: one sin and one cos per sample and no division, so it is fast.
    method "doubling": Jacobi functions by halving and doubling (accurate up to the separatrix).
    """
    omega, s, h, m, m1 = start.omega, start.s, start.h, start.m, start.m1
    k = math.sqrt(m)
    K = complete_k(m1)
    # F(ψ') for ψ' = asin(s/k) ∈ [-π/2, π/2]; a start moving downhill-backwards (h < 0) is ψ0 = ±π - ψ'.
    f_near = incomplete_f(s / k, abs(h) / k, m, m1)
    u0 = f_near if h >= 0.0 else math.copysign(2.0 * K, s) - f_near
    q = nome(K, complete_k(m))
    if _use_fourier(method, q):
        powers = [q ** (n + 0.5) / (1.0 + q ** (2 * n + 1)) for n in range(_series_length(q))]
        phi_terms = [8.0 * c / (2 * n + 1) for n, c in enumerate(powers)]
        rate_terms = [4.0 * math.pi * omega / K * c for c in powers]
        zeta_rate, zeta0 = 0.5 * math.pi * omega / K, 0.5 * math.pi * u0 / K

        def fourier(times: FloatArray) -> tuple[FloatArray, FloatArray]:
            zeta = zeta_rate * times + zeta0
            sin_z = np.sin(zeta)
            x = 2.0 - 4.0 * sin_z * sin_z  # 2 cos 2ζ
            b0, b1 = _clenshaw(phi_terms, x)
            r0, r1 = _clenshaw(rate_terms, x)
            return sin_z * (b0 + b1), np.cos(zeta) * (r0 - r1)

        return _chunked(t, fourier)

    def doubling(times: FloatArray) -> tuple[FloatArray, FloatArray]:
        sn, cn, dn, j = jacobi_reduced(omega * times + u0, m, m1, K)
        parity = 1.0 - 2.0 * np.mod(j, 2.0)
        return 2.0 * np.arctan2(k * sn * parity, dn), 2.0 * k * omega * cn * parity

    return _chunked(t, doubling)


def rotation_motion(t: FloatArray, start: OrbitStart, method: str = "auto") -> tuple[FloatArray, FloatArray]:
    """φ = 2 am(U | p), φ' = ±2kω dn(U | p), p = 1/m, p1 = -m1/m, U = F(φ0/2 | p) ± kωt.

    method "fourier" (default when q ≤ 0.15): with ζ = πU/2K (DLMF 22.16.9, 22.11.3),
        φ = 2ζ + 4 Σ_{n≥1} q^n sin(2nζ) / (n(1 + q^{2n})),
        φ' = ±kω (π/K + (4π/K) Σ_{n≥1} q^n cos(2nζ) / (1 + q^{2n})), Clenshaw-summed;
    method "doubling": am U = jπ + atan2(sn r, cn r) from the reduced argument r = U - 2jK.
    """
    omega, s, c, h, m, m1 = start.omega, start.s, start.c, start.h, start.m, start.m1
    k = math.sqrt(m)
    p = 1.0 / m
    p1 = -m1 / m
    K = complete_k(p1)
    speed = math.copysign(k * omega, h)  # dU/dt
    u0 = incomplete_f(s, c, p, p1)
    q = nome(K, complete_k(p))
    if _use_fourier(method, q):
        powers = [q**n / (1.0 + q ** (2 * n)) for n in range(1, _series_length(q) + 1)]
        phi_terms = [4.0 * c / (n + 1) for n, c in enumerate(powers)]
        rate_terms = [4.0 * math.pi / K * c for c in powers]

        def fourier(times: FloatArray) -> tuple[FloatArray, FloatArray]:
            two_zeta = (math.pi / K) * (u0 + speed * times)
            cos_2z = np.cos(two_zeta)
            b1, _ = _clenshaw(phi_terms, 2.0 * cos_2z)
            r1, r2 = _clenshaw(rate_terms, 2.0 * cos_2z)
            return two_zeta + b1 * np.sin(two_zeta), speed * (math.pi / K + r1 * cos_2z - r2)

        return _chunked(t, fourier)

    def doubling(times: FloatArray) -> tuple[FloatArray, FloatArray]:
        sn, cn, dn, j = jacobi_reduced(u0 + speed * times, p, p1, K)
        return 2.0 * (j * math.pi + np.arctan2(sn, cn)), 2.0 * speed * dn

    return _chunked(t, doubling)


def _separatrix(t: FloatArray, omega: float, s: float, c: float, h: float) -> tuple[FloatArray, FloatArray]:
    """φ = 2 gd(U) = 2 atan(sinh U), φ' = ±2ω sech U, U = asinh(tan(φ0/2)) ± ωt."""
    direction = 1.0 if h > 0.0 else -1.0
    big_u = math.asinh(s / c) + direction * omega * t
    with np.errstate(over="ignore"):
        return 2.0 * np.arctan(np.sinh(big_u)), direction * 2.0 * omega / np.cosh(big_u)


def libration_amplitude(pendulum: Pendulum, accel: float, theta0: float, theta_dot0: float) -> float:
    """A = max |θ - θ_eq| = 2 atan2(k, k') (sin(A/2) = k) of the orbit through the state; inf if rotating."""
    start = OrbitStart.from_state(pendulum, accel, theta0, theta_dot0)
    if start.m1 <= 0.0:
        return math.inf
    return 2.0 * math.atan2(math.sqrt(start.m), math.sqrt(start.m1))


def exact_solution(
    pendulum: Pendulum, accel: float, theta0: float, theta_dot0: float, t: ArrayLike
) -> tuple[FloatArray, FloatArray]:
    """θ(t) = θ_eq + φ(t), φ'' = -ω² sin φ in closed form (module docstring), t measured from the start.

    Exact for constant a and no damping (``pendulum.damping`` is ignored); every regime, vectorised over t
    (any real times, also negative). θ is continuous in t: a rotating bob's θ keeps growing past ±π.
    Returns (θ, θ') with the shape of t.
    """
    start = OrbitStart.from_state(pendulum, accel, theta0, theta_dot0)
    times = times_array(t)
    omega, s, c, h, m, m1 = start.omega, start.s, start.c, start.h, start.m, start.m1
    # θ = θ0 + (φ - φ0) rather than θ_eq + 2πn + φ: no rounding of 2πn, θ(0) = θ0 exactly.
    phi_start = 2.0 * math.atan2(s, c)
    if m < _LINEAR_LIMIT:
        phase = omega * times
        phi0 = 2.0 * s  # |φ0| < 2e-12 here, so 2 sin(φ0/2) = φ0 to double precision
        rate = 2.0 * omega * h
        phi = phi0 * np.cos(phase) + (rate / omega) * np.sin(phase)
        phi_dot = rate * np.cos(phase) - phi0 * omega * np.sin(phase)
    elif m1 > 0.0:
        phi, phi_dot = libration_motion(times, start)
    elif m1 < 0.0:
        phi, phi_dot = rotation_motion(times, start)
    else:
        phi, phi_dot = _separatrix(times, omega, s, c, h)
    return float(theta0) + (phi - phi_start), phi_dot


def exact_period(pendulum: Pendulum, accel: float, amplitude: float) -> float:
    """T = 4 K(m)/ω, m = sin²(A/2), ω² = √(g²+a²)/l: libration period for amplitude A about θ_eq.

    A must lie in [0, π]; the float nearest π gives a long but finite period.
    """
    a = require_finite("acceleration", accel)
    amp = require_finite("amplitude", amplitude)
    if amp < 0.0 or amp > math.pi:
        raise ParameterError(f"amplitude must be in [0, π] rad, got {amp!r}")
    half_cos = math.cos(0.5 * amp)
    return 4.0 * complete_k(half_cos * half_cos) / pendulum.omega(a)
