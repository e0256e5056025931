"""A 37-digit reference for θ'' = -(g/l) sin θ + (a(t)/l) cos θ - c θ': Taylor steps in fixed point.

The same method as test/test_exact.py's ``mp_reference`` (36th-order Taylor on integers scaled by 2^124,
constants from mpmath at 45 digits), generalised to any a(t) of physics.profiles that is a constant, a
ramp or a sinusoid between breakpoints, and to damping: the step restarts at every breakpoint of a(t),
a(t) enters as its own Taylor series over the step, and θ at the sample times inside a step is the step's
Taylor polynomial evaluated there (dense output: one reference step serves every sample it covers).
The start (θ0, θ'0) is taken as the exact value of the given floats, as the simulators do.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from operator import mul

import mpmath as mp
import numpy as np

from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import AccelProfile, Constant, Ramp, Sinusoid, Step

ORDER = 36
STEP = 0.22  # × 1/Ω: the nearest complex singularity of θ(t) is ≥ (π/2)/Ω away
BITS = 124  # fixed-point fraction bits, ≈ 37 digits
ONE = 1 << BITS

AccelSeries = Callable[[mp.mpf, int], list[mp.mpf]]


def _fixed(value: mp.mpf) -> int:
    """round(value · 2^124)."""
    return int(mp.nint(value * ONE))


def accel_series(profile: AccelProfile) -> AccelSeries:
    """(t, n) → the Taylor coefficients a_0 … a_{n-1} of a(t + τ) in τ, inside one smooth piece of a(t)."""
    if isinstance(profile, Constant):
        value = mp.mpf(profile.a)
        return lambda t, n: [value] + [mp.mpf(0)] * (n - 1)
    if isinstance(profile, Step):

        def step(t: mp.mpf, n: int) -> list[mp.mpf]:
            a = profile.a_before if t < profile.t_step else profile.a_after
            return [mp.mpf(a)] + [mp.mpf(0)] * (n - 1)

        return step
    if isinstance(profile, Ramp):
        t0, t1 = mp.mpf(profile.t_start), mp.mpf(profile.t_end)
        a0, a1 = mp.mpf(profile.a_start), mp.mpf(profile.a_end)
        slope = (a1 - a0) / (t1 - t0)

        def ramp(t: mp.mpf, n: int) -> list[mp.mpf]:
            if t < t0:
                return [a0] + [mp.mpf(0)] * (n - 1)
            if t >= t1:
                return [a1] + [mp.mpf(0)] * (n - 1)
            return [a0 + slope * (t - t0), slope] + [mp.mpf(0)] * (n - 2)

        return ramp
    if isinstance(profile, Sinusoid):
        w = 2 * mp.pi * mp.mpf(profile.frequency_hz)
        amp, off, phase = mp.mpf(profile.amplitude), mp.mpf(profile.offset), mp.mpf(profile.phase)

        def sinusoid(t: mp.mpf, n: int) -> list[mp.mpf]:
            # d^k/dτ^k sin(w(t+τ) + φ) = w^k sin(w t + φ + kπ/2)
            s, c = mp.sin(w * t + phase), mp.cos(w * t + phase)
            cycle = (s, c, -s, -c)
            out = [off + amp * s]
            factor = amp
            for k in range(1, n):
                factor = factor * w / k
                out.append(factor * cycle[k % 4])
            return out

        return sinusoid
    raise TypeError(f"no reference series for a {type(profile).__name__} profile")


def reference_theta(
    pendulum: Pendulum, profile: AccelProfile, theta0: float, theta_dot0: float, times: np.ndarray
) -> np.ndarray:
    """θ(t) at ``times`` (ascending, from 0) to ≈ 30 digits, rounded once to double."""
    return reference_state(pendulum, profile, theta0, theta_dot0, times)[0]


def reference_state(
    pendulum: Pendulum, profile: AccelProfile, theta0: float, theta_dot0: float, times: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(θ, θ') at ``times`` (ascending, ≥ 0) from θ(0) = θ0, θ'(0) = θ'0, each rounded once to double."""
    series = accel_series(profile)
    n_terms = ORDER + 2
    with mp.workdps(45):
        g_l = _fixed(mp.mpf(pendulum.gravity) / mp.mpf(pendulum.length))
        inv_l = mp.mpf(1) / mp.mpf(pendulum.length)
        damping = _fixed(mp.mpf(pendulum.damping))
        start = mp.mpf(theta0)
        state = [_fixed(v) for v in (start, mp.mpf(theta_dot0), mp.sin(start), mp.cos(start))]
        breaks = sorted(float(b) for b in profile.breakpoints() if 0.0 < b < float(times[-1]))
        omega2 = math.hypot(pendulum.gravity, profile.max_abs(0.0, float(times[-1]))) / pendulum.length
        drive = 2.0 * math.pi * profile.frequency_hz if isinstance(profile, Sinusoid) else 0.0
        base_rate2 = omega2 + pendulum.damping**2 + drive**2
        now = 0  # fixed-point time
        now_mp = mp.mpf(0)
        fixed_times = [_fixed(mp.mpf(float(t))) for t in times]
        fixed_breaks = [_fixed(mp.mpf(b)) for b in breaks] + [fixed_times[-1] + 1]
        out_theta: list[int] = []
        out_rate: list[int] = []
        index = 0
        next_break = 0
        while index < len(fixed_times):
            rate = state[1] / ONE
            h_max = _fixed(mp.mpf(STEP / math.sqrt(base_rate2 + float(rate) ** 2 / 4.0)))
            while fixed_breaks[next_break] <= now:
                next_break += 1
            end = min(now + h_max, fixed_breaks[next_break], fixed_times[-1])
            h = end - now
            theta, rate_f, sin_t, cos_t = state
            a_fixed = [_fixed(v * inv_l) for v in series(now_mp, n_terms)]
            x, d, sin_s, cos_s = [theta, rate_f], [rate_f], [sin_t], [cos_t]
            for k in range(ORDER):
                drive_k = sum(map(mul, a_fixed[: k + 1], cos_s[k::-1])) >> BITS
                force = drive_k - ((g_l * sin_s[k]) >> BITS) - ((damping * d[k]) >> BITS)
                x.append(force // ((k + 1) * (k + 2)))
                d.append((k + 2) * x[k + 2])
                rev = d[k::-1]
                sin_s.append((sum(map(mul, cos_s, rev)) >> BITS) // (k + 1))
                cos_s.append(-(sum(map(mul, sin_s[: k + 1], rev)) >> BITS) // (k + 1))
            while index < len(fixed_times) and fixed_times[index] <= end:
                tau = fixed_times[index] - now
                out_theta.append(_horner(x, tau))
                out_rate.append(_horner(d, tau))
                index += 1
            state = [_horner(s, h) for s in (x, d, sin_s, cos_s)]
            now = end
            now_mp = mp.mpf(now) / ONE
            if h == 0 and index < len(fixed_times):
                raise RuntimeError("reference made no progress")
    with mp.workdps(30):
        theta_out = np.array([float(mp.mpf(v) / ONE) for v in out_theta])
        rate_out = np.array([float(mp.mpf(v) / ONE) for v in out_rate])
    return theta_out, rate_out


def _horner(series: list[int], tau: int) -> int:
    """Σ series[k] τ^k in fixed point."""
    acc = series[-1]
    for coefficient in reversed(series[:-1]):
        acc = coefficient + ((acc * tau) >> BITS)
    return acc
