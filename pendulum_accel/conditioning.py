"""The problem's own conditioning: how far θ(t) moves when the inputs θ0, θ'0 move by their own rounding.

No simulation in double precision can be more accurate than the inputs determine the answer: the start
(θ0, θ'0) is known to within an ulp, and the method's own first roundings act like such a change. The
input sensitivity is measured by paired runs with the plan's own model and solver: θ0 (then θ'0) nudged by
NUDGE_ULPS ulps, the difference divided by NUDGE_ULPS: the linearised response S(t) to one ulp (the
variational solution, sampled), free of the rounding noise a one-ulp pair would drown in. Where the nudged
pair separates by more than LINEAR_LIMIT the response is no longer linear (an unstable start, chaos): the
one-ulp pair itself is then run and its difference is the answer.

Where the run can carry its own variational equations (the compiled RK4/RK8 kernels, SteppedRuns.tangent
in physics.simulate), S(t) = |∂θ/∂xᵢ(t)| ulpᵢ comes from that one run instead (``tangent_sensitivity``):
the derivative of the scheme's own map, what the nudged pair measures in the limit of a small nudge,
without the pair's rounding noise. The nudged runs remain past the linear regime, and for the round-off.

From S(t): the floor max S (a statement about the problem, not about a run: the planner announces it
and calls the inputs ill-conditioned when it exceeds the target), the first time S reaches the target
(from then on θ is not determined by the inputs to within the target), and a finite-time Lyapunov
exponent λ, the slope of ln max_{s≤t} S(s) over the growing stretch.

The same runs also measure the solver's own round-off on this trajectory: the nudges are made in both
directions, and the second difference θ(x + δ) + θ(x − δ) − 2 θ(x) cancels the response to δ (to first
and, being symmetric, to second order) and leaves three independent realisations of the rounding,
r₊ + r₋ − 2 r₀, whose spread is √6 times that of one run's rounding error r₀. ``noise`` =
max |second difference| / √6, averaged over the two inputs: the typical max round-off error of one run,
propagated through the problem's own growth (the rounding committed at step s is amplified to t exactly
as an input perturbation is), with nothing modelled. It costs two more runs, so the caller asks for it
only where a prediction uses it (``noise=False`` leaves NaN).

Past the linear regime (the one-ulp pair itself separates by more than LINEAR_LIMIT) no linearised
response exists, and the pair's difference is one draw of how far runs whose inputs differ by their own
rounding drift apart. The one-ulp runs are then made in both directions for both inputs: with the
unnudged run, five equally valid runs, whose ``spread`` = max over t of (max θ − min θ) across them is the
scale of the disagreement, which the planner multiplies by a safety factor (planner.SPREAD_SAFETY). Past
the time the inputs stop determining θ (``lost_at``), that figure is how far apart runs of the same
inputs land, not an accuracy of the method: no run is closer than that to the answer, except by luck.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]
Runner = Callable[[float, float], FloatArray]  # (θ0, θ'0) → θ at the sample times

# Nudges tried in turn (ulps): the first whose pair stays within LINEAR_LIMIT gives S = |Δθ| / nudge;
# 64 rises above the method's rounding noise; 1 is the last resort (an unstable start, chaos).
NUDGE_LADDER = (64.0, 8.0, 1.0)
LINEAR_LIMIT = 1e-2  # rad: a nudged pair further apart than this is past the linear regime
INPUTS = ("θ0", "θ'0")
SECOND_DIFFERENCE_SPREAD = math.sqrt(6.0)  # |r₊ + r₋ − 2 r₀| / |r| for independent equal roundings
FIRST_DIFFERENCE_SPREAD = math.sqrt(2.0)  # |r₊ − r₀| / |r|
# rad: a nudged pair closer than this leaves a second-order remainder far below its rounding
# (tangent_sensitivity)
TANGENT_NOISE_LIMIT = 1e-6


def input_units(theta0: float, theta_dot0: float, omega: float) -> tuple[float, float]:
    """One ulp of θ0 and of θ'0 (rad, rad/s); for an input that is exactly 0, one ulp of its scale
    (|θ'0|/ω, |θ0| ω, else 1 rad or ω rad/s), the rounding a simulation's state meets there."""
    theta_scale = abs(theta0) or abs(theta_dot0) / omega or 1.0
    rate_scale = abs(theta_dot0) or abs(theta0) * omega or omega
    return math.ulp(theta_scale), math.ulp(rate_scale)


@dataclass(frozen=True)
class Sensitivity:
    """S(t) = |Δθ(t)| per ulp of the input that moves θ most, and what follows from it (module docstring).

    ``input`` names that input, ``ulp`` its size; ``floor`` = max S (rad) at ``at`` (s); ``lost_at`` the
    first sample time where S ≥ ``target`` (None if never); ``lyapunov`` λ (1/s); ``linear`` False when
    the one-ulp pair itself had to be run (S then is that pair's difference, not a linearised response);
    ``noise`` the run's own round-off (rad, module docstring; NaN when not linear or not asked for);
    ``spread`` max over t of max θ − min θ across the five one-ulp runs (NaN when linear); ``peaks`` max S
    per input (θ0, θ'0) and ``units`` their ulps.
    """

    input: str
    ulp: float
    floor: float
    at: float
    target: float
    lost_at: float | None
    lyapunov: float
    linear: bool
    noise: float
    spread: float
    peaks: tuple[float, float]
    units: tuple[float, float]
    times: FloatArray = field(repr=False, compare=False)
    curve: FloatArray = field(repr=False, compare=False)

    @property
    def ill_conditioned(self) -> bool:
        """The inputs' own rounding moves θ by more than the target: floor > target."""
        return self.floor > self.target

    def describe(self) -> str:
        """'input sensitivity: 1 ulp of θ'0 → 1.1e-03 rad at t = 18.3 s' (+ the Lyapunov exponent if > 0)."""
        text = f"input sensitivity: 1 ulp of {self.input} → {self.floor:.1e} rad at t = {self.at:.3g} s"
        if not self.linear:
            text += (
                f" (past the linear regime: runs one ulp apart spread over {self.spread:.1e} rad, "
                f"how far equally valid runs land apart, not an accuracy of the method)"
            )
        return text

    def verdict(self) -> str:
        """The one-line statement when the floor exceeds the target, else ''."""
        if self.lost_at is None or not self.ill_conditioned:
            return ""
        return (
            f"ILL-CONDITIONED: the inputs do not determine θ to within the target from "
            f"t = {self.lost_at:.3g} s on (one ulp of {self.input} moves θ by more; a run may still land "
            f"within it, nothing assures it)"
        )

    def chaos(self) -> str:
        """'finite-time Lyapunov exponent λ ≈ … 1/s; θ determined by the inputs to within the target until
        t = … s' (or '… for the whole run')."""
        until = (
            f"until t = {self.lost_at:.3g} s"
            if self.lost_at is not None
            else f"for the whole {self.times[-1]:.3g} s"
        )
        return (
            f"finite-time Lyapunov exponent λ ≈ {self.lyapunov:.2g} 1/s: θ is determined by the inputs "
            f"to within the target {until}"
        )


def lyapunov_exponent(times: FloatArray, curve: FloatArray, saturation: float) -> float:
    """λ = least-squares slope of ln max_{s≤t} S(s) (1/s, ≥ 0) over the growing stretch: from a quarter of
    the way to where S first reaches ``saturation`` (past it the nudged pair is no longer linear)."""
    running = np.maximum.accumulate(np.maximum(curve, 1e-300))
    over = running >= saturation
    first = int(over.argmax())
    end = float(times[first]) if over[first] else float(times[-1])
    lo = int(np.searchsorted(times, 0.25 * end))  # the window 0.25 end ≤ t ≤ end (times ascending)
    hi = int(np.searchsorted(times, end, side="right"))
    if hi - lo < 2 or end <= 0.0:
        return 0.0
    x = times[lo:hi] - times[lo:hi].mean()
    y = np.log(running[lo:hi])
    denominator = float(np.dot(x, x))
    if denominator == 0.0:
        return 0.0
    slope = float(np.dot(x, y - y.mean())) / denominator  # Σ(x − x̄)(y − ȳ) / Σ(x − x̄)²
    # a growth by less than e^(1e-9) over the window is rounding in the fit, not growth
    return slope if slope * end > 1e-9 else 0.0


def _nudged(theta0: float, theta_dot0: float, which: int, size: float) -> tuple[float, float]:
    """(θ0 + size, θ'0) for which = 0, (θ0, θ'0 + size) for which = 1."""
    return (theta0 + size, theta_dot0) if which == 0 else (theta0, theta_dot0 + size)


def _rounding_noise(
    run: Runner,
    theta0: float,
    theta_dot0: float,
    sizes: list[float],
    plus: list[FloatArray],
    reference: FloatArray,
) -> float:
    """mean over the inputs of max |θ(x + δ) + θ(x − δ) − 2 θ(x)| / √6: one run's round-off (docstring);
    ``plus`` holds θ(x + δ), already run."""
    spreads = [
        float(np.max(np.abs(up + run(*_nudged(theta0, theta_dot0, which, -size)) - 2.0 * reference)))
        for which, (size, up) in enumerate(zip(sizes, plus, strict=True))
    ]
    return float(np.mean(spreads)) / SECOND_DIFFERENCE_SPREAD


def _spread(run: Runner, theta0: float, theta_dot0: float, units: tuple[float, float],
            members: list[FloatArray]) -> float:  # fmt: skip
    """max_t (max_i θ_i(t) − min_i θ_i(t)) over ``members`` (the run and its +1-ulp runs) and the −1-ulp
    runs of both inputs."""
    down = [run(*_nudged(theta0, theta_dot0, i, -u)) for i, u in enumerate(units)]
    stack = np.vstack([*members, *down])
    return float(np.max(np.max(stack, axis=0) - np.min(stack, axis=0)))


def input_sensitivity(
    run: Runner,
    theta0: float,
    theta_dot0: float,
    omega: float,
    times: FloatArray,
    target: float,
    base: FloatArray | None = None,
    noise: bool = True,
) -> Sensitivity:
    """S(t) from paired runs of ``run`` (module docstring); ``base`` = run(θ0, θ'0) when already at hand;
    the round-off (two more runs) only with ``noise``."""
    units = input_units(theta0, theta_dot0, omega)
    reference = run(theta0, theta_dot0) if base is None else base
    linear = False
    roundoff = math.nan
    spread = math.nan
    curves: list[FloatArray] = []
    plus: list[FloatArray] = []
    for size in NUDGE_LADDER:  # the largest nudge that keeps the pair in the linear regime
        plus = [run(*_nudged(theta0, theta_dot0, i, size * u)) for i, u in enumerate(units)]
        deltas = [np.abs(p - reference) for p in plus]
        # a one-ulp pair can round to the same start (the nudge lost): the 8-ulp response per ulp stays
        curves = [
            d / size if not curves else np.maximum(d / size, c)
            for d, c in zip(deltas, curves or deltas, strict=True)
        ]
        if max(float(np.max(d)) for d in deltas) <= LINEAR_LIMIT:
            linear = True
            if noise:
                sizes = [size * u for u in units]
                roundoff = _rounding_noise(run, theta0, theta_dot0, sizes, plus, reference)
            break
    if not linear:  # the one-ulp runs are what is left: five equally valid runs, and their spread
        spread = _spread(run, theta0, theta_dot0, units, [reference, *plus])
    return _from_curves(curves, units, times, target, linear, roundoff, spread)


def _from_curves(
    curves: list[FloatArray],
    units: tuple[float, float],
    times: FloatArray,
    target: float,
    linear: bool,
    roundoff: float,
    spread: float,
) -> Sensitivity:
    """The Sensitivity of the per-input curves Sᵢ(t) (rad per ulp of input i)."""
    where = [int(c.argmax()) for c in curves]
    peaks = [float(c[i]) for c, i in zip(curves, where, strict=True)]
    worst = int(np.argmax(peaks))
    curve = np.maximum(curves[0], curves[1])
    index = where[worst]
    over = curve >= target
    first = int(over.argmax())
    lost_at = float(times[first]) if over[first] else None
    return Sensitivity(
        input=INPUTS[worst],
        ulp=units[worst],
        floor=peaks[worst],
        at=float(times[index]),
        target=target,
        lost_at=lost_at,
        lyapunov=lyapunov_exponent(times, curve, LINEAR_LIMIT / NUDGE_LADDER[1]),
        linear=linear,
        noise=roundoff,
        spread=spread,
        peaks=(peaks[0], peaks[1]),
        units=units,
        times=times,
        curve=curve,
    )


def tangent_sensitivity(
    run: Runner,
    theta0: float,
    theta_dot0: float,
    omega: float,
    times: FloatArray,
    target: float,
    base: FloatArray,
    derivative: FloatArray,
    noise: bool = True,
) -> Sensitivity | None:
    """S(t) from the variational solution: Sᵢ(t) = |∂θ/∂xᵢ(t)| ulpᵢ, ``derivative`` = [∂θ/∂θ0, ∂θ/∂θ'0] at
    ``times`` along ``base`` = run(θ0, θ'0) (the run's own variational equations, no nudged runs); None
    past the linear regime (NUDGE_LADDER[0] ulps would move θ by more than LINEAR_LIMIT: the caller then
    measures S with input_sensitivity's nudged runs, as the linearisation no longer holds).

    With ``noise``, the round-off from one run with both inputs nudged (by δᵢ = NUDGE_LADDER[0] ulpᵢ)
    instead of four: θ(x + δ) − θ(x) − Σᵢ δᵢ ∂θ/∂xᵢ removes the response to first order and leaves r₊ − r₀,
    two independent realisations of the rounding (spread √2 × one run's), so noise = max |that| / √2.
    Its second-order remainder ½ δᵀ (∂²θ/∂x²) δ is not cancelled (the second difference cancels it), so
    where a nudge moves θ by more than TANGENT_NOISE_LIMIT the second differences
    θ(x + δᵢ) + θ(x − δᵢ) − 2 θ(x) of input_sensitivity are taken instead.
    """
    units = input_units(theta0, theta_dot0, omega)
    size = NUDGE_LADDER[0]
    curves = [np.abs(d) * u for d, u in zip(derivative, units, strict=True)]
    largest = size * max(float(c.max()) for c in curves)
    if not largest <= LINEAR_LIMIT:  # NaN included
        return None
    roundoff = math.nan
    if noise and largest <= TANGENT_NOISE_LIMIT:
        nudged = (theta0 + size * units[0], theta_dot0 + size * units[1])
        steps = (nudged[0] - theta0, nudged[1] - theta_dot0)  # the nudges as rounded, taken exactly
        residual = run(*nudged) - base - steps[0] * derivative[0] - steps[1] * derivative[1]
        roundoff = float(np.abs(residual).max()) / FIRST_DIFFERENCE_SPREAD
    elif noise:
        plus = [run(*_nudged(theta0, theta_dot0, i, size * u)) for i, u in enumerate(units)]
        roundoff = _rounding_noise(run, theta0, theta_dot0, [size * u for u in units], plus, base)
    return _from_curves(curves, units, times, target, True, roundoff, math.nan)
