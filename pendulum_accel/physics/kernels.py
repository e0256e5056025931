"""Compiled fixed-step stepping (numba) for one rigid or elastic-string state: the hot path of simulate().

The equations are those of physics.rigid and physics.elastic, written once more in scalar form because numba
compiles scalar code, not the numpy closures there; ``test/test_kernels.py`` holds whole runs to the numpy
loop's, and ``test/test_equation_of_motion.py`` the rigid rhs to ``rigid.theta_ddot``. A whole run (every
sample interval, every substep) is one compiled call, so a step costs a fraction of a Python-level step
(planner.KERNEL_STEP_S). Each model has its own compiled function: one function branching on the model
keeps numba from optimising its loops.

a(t) reaches the kernel in one of two forms:

- ``ACCEL_LINEAR``: a is linear on every interval between two stop times (true of constant, step,
  ramp, table and braking profiles, whose breakpoints are stop times): row i of ``coef`` holds
  (a at the interval's start, slope), read from the inside of the interval so a jump never leaks;
- ``ACCEL_SINUSOID``: a(t) = offset + A sin(ω t + φ), ``coef`` = [[offset, A, ω, φ]].

Methods: explicit Euler, symplectic Euler, velocity Verlet and RK4 as in physics.integrators, and
``rk8``: the 8th-order solution of Dormand-Prince 8(5,3) (DOP853's 12-stage tableau, physics.dop853_tableau)
taken with a fixed step, for tight targets where RK4 would need too many steps.

RK4 and RK8 add their increment with compensated (Kahan) summation: y += h Σ bᵢkᵢ rounds the small
increment into a large y at every step, an error of ulp(y)/2 that accumulates over N steps to ≈ √N ulp(y)
(≈ N ulp at worst); the compensation c carries each addition's rounding, c = ((y + δ) − y) − δ, into the
next increment, δ ← h Σ bᵢkᵢ − c, which leaves ≈ one ulp however long the run (the stages still read the
rounded y: their error is multiplied by h). c is part of the state: a sliced run carries it from slice to
slice, so it stays bit-identical to one call.

The first call of each model compiles it (≈ 10 s) into numba's on-disk cache beside this file; later
processes load it in ≈ 0.3 s. ``make setup`` warms the cache (``python -m pendulum_accel.physics.kernels``).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from pendulum_accel.physics import dop853_tableau
from pendulum_accel.physics.elastic import stiffness_of
from pendulum_accel.physics.lazy import njit
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import (
    AccelProfile,
    Braking,
    Constant,
    Offset,
    Ramp,
    Sinusoid,
    Step,
    Table,
)

ACCEL_LINEAR = 0
ACCEL_SINUSOID = 1
_EULER, _SYMPLECTIC_EULER, _VERLET, _RK4, _RK8 = range(5)
METHOD_CODES: dict[str, int] = {
    "euler": _EULER,
    "symplectic_euler": _SYMPLECTIC_EULER,
    "verlet": _VERLET,
    "rk4": _RK4,
    "rk8": _RK8,
}

_RK8_STAGES = dop853_tableau.STAGES
RK8_A = np.ascontiguousarray(dop853_tableau.A, dtype=float)
RK8_B = np.ascontiguousarray(dop853_tableau.B, dtype=float)
RK8_C = np.ascontiguousarray(dop853_tableau.C, dtype=float)


@njit(cache=True, inline="always")
def _accel(t: float, seg: int, lo: float, kind: int, coef: np.ndarray) -> float:
    """a(t) = coef[seg, 0] + coef[seg, 1] (t − lo), or offset + A sin(ω t + φ)."""
    result: float
    if kind == ACCEL_LINEAR:
        result = coef[seg, 0] + coef[seg, 1] * (t - lo)
        return result
    result = coef[0, 0] + coef[0, 1] * math.sin(coef[0, 2] * t + coef[0, 3])
    return result


@njit(cache=True, inline="always")
def _rigid_rhs(par: np.ndarray, a: float, y: np.ndarray, out: np.ndarray, row: int) -> None:
    """out[row] = [θ', −(g/l) sin θ + (a/l) cos θ − c θ'], par = (g/l, 1/l, c)."""
    th = y[0]
    w = y[1]
    out[row, 0] = w
    out[row, 1] = -par[0] * math.sin(th) + a * par[1] * math.cos(th) - par[2] * w


@njit(cache=True, inline="always")
def _elastic_rhs(par: np.ndarray, a: float, y: np.ndarray, out: np.ndarray, row: int) -> None:
    """out[row] = [r', θ', r'', θ''] with r'' = r θ'² + g cos θ + a sin θ − (k/m)(r−l) − c r',
    θ'' = (a cos θ − g sin θ − 2r'θ')/r − cθ'.

    par = (k/m, g, c, l).
    """
    r = y[0]
    th = y[1]
    rd = y[2]
    w = y[3]
    s = math.sin(th)
    co = math.cos(th)
    out[row, 0] = rd
    out[row, 1] = w
    out[row, 2] = r * w * w + par[1] * co + a * s - par[0] * (r - par[3]) - par[2] * rd
    out[row, 3] = (-par[1] * s + a * co - 2.0 * rd * w) / r - par[2] * w


@njit(cache=True, inline="always")
def _rigid_tangent_rhs(par: np.ndarray, a: float, y: np.ndarray, out: np.ndarray, row: int) -> None:
    """The rigid rhs and its variational equations: y = [θ, θ', v₁, v₁', v₂, v₂'], (vᵢ, vᵢ') = ∂(θ, θ')/∂xᵢ,
    x = (θ0, θ'0); vᵢ'' = J₁₀ vᵢ + J₁₁ vᵢ' with J₁₀ = −(g/l) cos θ − (a/l) sin θ, J₁₁ = −c."""
    th = y[0]
    w = y[1]
    s = math.sin(th)
    co = math.cos(th)
    out[row, 0] = w
    out[row, 1] = -par[0] * s + a * par[1] * co - par[2] * w
    j10 = -par[0] * co - a * par[1] * s
    j11 = -par[2]
    for col in range(2):
        v = y[2 + 2 * col]
        vd = y[3 + 2 * col]
        out[row, 2 + 2 * col] = vd
        out[row, 3 + 2 * col] = j10 * v + j11 * vd


@njit(cache=True, inline="always")
def _elastic_tangent_rhs(par: np.ndarray, a: float, y: np.ndarray, out: np.ndarray, row: int) -> None:
    """The elastic rhs (``_elastic_rhs``, y[0:4] = [r, θ, r', θ']) and its variational equations: y[4 + 4i :
    8 + 4i] = ∂[r, θ, r', θ']/∂xᵢ, x = (θ0, θ'0), whose derivative is J · that column, J = ∂f/∂y (rows of
    physics.elastic.elastic_jacobian: r'' row [θ'² − k/m, −g sin θ + a cos θ, −c, 2rθ'], θ'' row
    [−τ/r², (−g cos θ − a sin θ)/r, −2θ'/r, −2r'/r − c], τ = a cos θ − g sin θ − 2r'θ')."""
    r = y[0]
    th = y[1]
    rd = y[2]
    w = y[3]
    s = math.sin(th)
    co = math.cos(th)
    out[row, 0] = rd
    out[row, 1] = w
    out[row, 2] = r * w * w + par[1] * co + a * s - par[0] * (r - par[3]) - par[2] * rd
    out[row, 3] = (-par[1] * s + a * co - 2.0 * rd * w) / r - par[2] * w
    tangential = -par[1] * s + a * co - 2.0 * rd * w
    j20 = w * w - par[0]
    j21 = -par[1] * s + a * co
    j22 = -par[2]
    j23 = 2.0 * r * w
    j30 = -tangential / (r * r)
    j31 = (-par[1] * co - a * s) / r
    j32 = -2.0 * w / r
    j33 = -2.0 * rd / r - par[2]
    for col in range(2):
        b = 4 + 4 * col
        out[row, b] = y[b + 2]
        out[row, b + 1] = y[b + 3]
        out[row, b + 2] = j20 * y[b] + j21 * y[b + 1] + j22 * y[b + 2] + j23 * y[b + 3]
        out[row, b + 3] = j30 * y[b] + j31 * y[b + 1] + j32 * y[b + 2] + j33 * y[b + 3]


@njit(inline="always")
def _steps(
    # Any: a numba dispatcher (the model's right-hand side), which numba does not type.
    rhs: Any,
    par: np.ndarray,
    y0: np.ndarray,
    comp: np.ndarray,
    nodes: np.ndarray,
    method: int,
    dt: float,
    kind: int,
    coef: np.ndarray,
) -> tuple[np.ndarray, int]:
    """(y at every node, f calls): each node interval split into ⌈Δ/dt⌉ equal steps of ``method``.

    RK4/RK8: y ← y + (δ − c), c ← ((y + (δ − c)) − y) − (δ − c), δ = h Σ bᵢkᵢ (Kahan); ``comp`` holds c on
    entry and is updated in place.
    """
    n = y0.size
    half = n // 2
    out = np.empty((n, nodes.size))
    out[:, 0] = y0
    y = y0.copy()
    tmp = np.empty(n)
    k = np.empty((_RK8_STAGES, n))
    ha = np.empty_like(RK8_A)  # h a_sq of the interval's step: h a_sq k_q rounds as (h a_sq) k_q
    nfev = 0
    for i in range(nodes.size - 1):
        lo = nodes[i]
        hi = nodes[i + 1]
        n_sub = max(1, math.ceil((hi - lo) / dt * (1.0 - 1e-12)))
        h = (hi - lo) / n_sub
        if method == _RK8:
            for s in range(_RK8_STAGES):
                for q in range(s):
                    ha[s, q] = h * RK8_A[s, q]
        carried = False  # verlet's a(t₁, q₁, v*) is reused as the next step's a₀ within a segment
        for step in range(n_sub):
            t = lo + step * h
            if method == _RK4:
                rhs(par, _accel(t, i, lo, kind, coef), y, k, 0)
                tm = t + 0.5 * h
                am = _accel(tm, i, lo, kind, coef)
                for j in range(n):
                    tmp[j] = y[j] + 0.5 * h * k[0, j]
                rhs(par, am, tmp, k, 1)
                for j in range(n):
                    tmp[j] = y[j] + 0.5 * h * k[1, j]
                rhs(par, am, tmp, k, 2)
                for j in range(n):
                    tmp[j] = y[j] + h * k[2, j]
                rhs(par, _accel(t + h, i, lo, kind, coef), tmp, k, 3)
                for j in range(n):
                    inc = h / 6.0 * (k[0, j] + 2.0 * (k[1, j] + k[2, j]) + k[3, j]) - comp[j]
                    new = y[j] + inc
                    comp[j] = (new - y[j]) - inc
                    y[j] = new
                nfev += 4
            elif method == _RK8:
                for s in range(_RK8_STAGES):
                    for j in range(n):
                        acc = y[j]
                        for q in range(s):
                            acc += ha[s, q] * k[q, j]
                        tmp[j] = acc
                    rhs(par, _accel(t + RK8_C[s] * h, i, lo, kind, coef), tmp, k, s)
                for j in range(n):
                    acc = 0.0
                    for s in range(_RK8_STAGES):
                        acc += RK8_B[s] * k[s, j]
                    inc = h * acc - comp[j]
                    new = y[j] + inc
                    comp[j] = (new - y[j]) - inc
                    y[j] = new
                nfev += _RK8_STAGES
            elif method == _EULER:
                rhs(par, _accel(t, i, lo, kind, coef), y, k, 0)
                for j in range(n):
                    y[j] += h * k[0, j]
                nfev += 1
            elif method == _SYMPLECTIC_EULER:  # v₁ = v₀ + h a(t₀, q₀, v₀); q₁ = q₀ + h v₁
                rhs(par, _accel(t, i, lo, kind, coef), y, k, 0)
                for j in range(half):
                    y[half + j] += h * k[0, half + j]
                    y[j] += h * y[half + j]
                nfev += 1
            else:  # verlet, kick-drift-kick with the velocity correction of physics.integrators
                if not carried:
                    rhs(par, _accel(t, i, lo, kind, coef), y, k, 0)
                    nfev += 1
                    carried = True
                a1 = _accel(t + h, i, lo, kind, coef)
                for j in range(half):
                    tmp[half + j] = y[half + j] + 0.5 * h * k[0, half + j]
                    tmp[j] = y[j] + h * tmp[half + j]
                rhs(par, a1, tmp, k, 1)
                for j in range(half):
                    y[j] = tmp[j]
                    y[half + j] = tmp[half + j] + 0.5 * h * k[1, half + j]
                rhs(par, a1, y, k, 0)
                for j in range(half):
                    y[half + j] = tmp[half + j] + 0.5 * h * k[0, half + j]
                nfev += 2
        out[:, i + 1] = y
    return out, nfev


@njit(cache=True)
def rigid_steps(
    par: np.ndarray,
    y0: np.ndarray,
    comp: np.ndarray,
    nodes: np.ndarray,
    method: int,
    dt: float,
    kind: int,
    coef: np.ndarray,
) -> tuple[np.ndarray, int]:
    """``_steps`` of the rigid pendulum, state [θ, θ'], par = (g/l, 1/l, c)."""
    result: tuple[np.ndarray, int] = _steps(_rigid_rhs, par, y0, comp, nodes, method, dt, kind, coef)
    return result


@njit(cache=True)
def elastic_steps(
    par: np.ndarray,
    y0: np.ndarray,
    comp: np.ndarray,
    nodes: np.ndarray,
    method: int,
    dt: float,
    kind: int,
    coef: np.ndarray,
) -> tuple[np.ndarray, int]:
    """``_steps`` of the elastic string, state [r, θ, r', θ'], par = (k/m, g, c, l)."""
    result: tuple[np.ndarray, int] = _steps(_elastic_rhs, par, y0, comp, nodes, method, dt, kind, coef)
    return result


@njit(cache=True)
def rigid_tangent_steps(
    par: np.ndarray,
    y0: np.ndarray,
    comp: np.ndarray,
    nodes: np.ndarray,
    method: int,
    dt: float,
    kind: int,
    coef: np.ndarray,
) -> tuple[np.ndarray, int]:
    """``_steps`` of the rigid pendulum and its variational equations (``_rigid_tangent_rhs``), 6 states."""
    result: tuple[np.ndarray, int] = _steps(_rigid_tangent_rhs, par, y0, comp, nodes, method, dt, kind, coef)
    return result


@njit(cache=True)
def elastic_tangent_steps(
    par: np.ndarray,
    y0: np.ndarray,
    comp: np.ndarray,
    nodes: np.ndarray,
    method: int,
    dt: float,
    kind: int,
    coef: np.ndarray,
) -> tuple[np.ndarray, int]:
    """``_steps`` of the elastic string and its variational equations (_elastic_tangent_rhs): 12 states."""
    result: tuple[np.ndarray, int] = _steps(
        _elastic_tangent_rhs, par, y0, comp, nodes, method, dt, kind, coef
    )
    return result


_LINEAR_PROFILES = (Constant, Step, Ramp, Table, Braking)
_STEPPERS = {"rigid": rigid_steps, "elastic": elastic_steps}
_TANGENT_STEPPERS = {"rigid": rigid_tangent_steps, "elastic": elastic_tangent_steps}
TANGENT_METHODS = ("rk4", "rk8")  # the schemes whose variational run is the derivative of their own map


@dataclass(frozen=True)
class Kernel:
    """A model the kernels can step: 'rigid' or 'elastic', its compiled parameters, and a(t)."""

    model: str
    par: np.ndarray
    profile: AccelProfile

    @classmethod
    def rigid(cls, p: Pendulum, profile: AccelProfile) -> Kernel:
        """par = (g/l, 1/l, c)."""
        return cls("rigid", np.array([p.gravity / p.length, 1.0 / p.length, p.damping]), profile)

    @classmethod
    def elastic(cls, p: Pendulum, profile: AccelProfile) -> Kernel:
        """par = (k/m, g, c, l), k from the pendulum (ParameterError when it has none)."""
        k_m = stiffness_of(p) / p.mass
        return cls("elastic", np.array([k_m, p.gravity, p.damping, p.length]), profile)


def accel_coefficients(profile: AccelProfile, nodes: np.ndarray) -> tuple[int, np.ndarray] | None:
    """(kind, coef) describing a(t) between the stop times ``nodes``; None for a profile not known here.

    Linear kinds: coef[i] = (a(lo⁺), (a(hi⁻) − a(lo⁺)) / (hi⁻ − lo⁺)) for node interval i = [lo, hi], with
    lo⁺, hi⁻ one ulp inside it, so each interval reads a from its own side of a jump at a breakpoint.
    """
    # Exact types: a subclass may bend a(t) between the breakpoints, which only its __call__ knows.
    if type(profile) is Offset:  # a road grade: column 0 is the constant term of both kinds
        inner = accel_coefficients(profile.base, nodes)
        if inner is not None:
            inner[1][:, 0] += profile.offset
        return inner
    if type(profile) is Sinusoid:
        omega = 2.0 * math.pi * profile.frequency_hz
        return ACCEL_SINUSOID, np.array([[profile.offset, profile.amplitude, omega, profile.phase]])
    if type(profile) not in _LINEAR_PROFILES:
        return None
    lo = np.nextafter(nodes[:-1], np.inf)
    hi = np.nextafter(nodes[1:], -np.inf)
    coef = np.zeros((lo.size, 2))
    coef[:, 0] = profile(lo)
    # An interval of one or two ulps has no inside to read a slope from: a is constant there (slope 0).
    np.divide(profile(hi) - coef[:, 0], hi - lo, out=coef[:, 1], where=hi > lo)
    return ACCEL_LINEAR, coef


def run_kernel(
    kernel: Kernel, y0: np.ndarray, nodes: np.ndarray, method: str, dt: float
) -> tuple[np.ndarray, int] | None:
    """(y at every node, f calls) of a compiled fixed-step run; None when a(t) has no compiled form."""
    prepared = PreparedKernel.of(kernel, nodes)
    return None if prepared is None else prepared.run(y0, method, dt)


@dataclass(frozen=True)
class PreparedKernel:
    """A kernel with its stop times and a(t) coefficients (``accel_coefficients``), computed once for runs
    that differ only in their start and step (the planner's pilot and conditioning runs)."""

    kernel: Kernel
    nodes: np.ndarray
    kind: int
    coef: np.ndarray

    @classmethod
    def of(cls, kernel: Kernel, nodes: np.ndarray) -> PreparedKernel | None:
        """``kernel`` prepared for ``nodes``; None when a(t) has no compiled form."""
        nodes = np.ascontiguousarray(nodes, dtype=float)
        accel = accel_coefficients(kernel.profile, nodes)
        if accel is None:
            return None
        return cls(kernel, nodes, accel[0], accel[1])

    def run(self, y0: np.ndarray, method: str, dt: float, tangent: bool = False) -> tuple[np.ndarray, int]:
        """(y at every node, f calls) from ``y0`` with steps ≤ ``dt`` of ``method``.

        With ``tangent`` (rk4, rk8) y0 also holds the variational columns (``_rigid_tangent_rhs``,
        ``_elastic_tangent_rhs``) and the run steps them with the same scheme: the state rows are
        bit-identical to a plain run's, the columns the exact derivative of the scheme's own map.
        """
        if tangent and method not in TANGENT_METHODS:
            raise ValueError(f"variational runs are compiled for {', '.join(TANGENT_METHODS)}, not {method}")
        kind, coef, nodes = self.kind, self.coef, self.nodes
        steps = (_TANGENT_STEPPERS if tangent else _STEPPERS)[self.kernel.model]
        y = np.ascontiguousarray(y0, dtype=float)
        out = np.empty((y.size, nodes.size))
        out[:, 0] = y
        comp = np.zeros(y.size)  # the compensated sum's carried rounding, updated in place by each slice
        nfev = 0
        # Slices of whole node intervals: each interval restarts its substeps (and verlet's carried force)
        # from y (and the compensation) at its start, so the sliced run is bit-identical to one call, and a
        # Ctrl-C, which Python only sees between compiled calls, lands within one slice's work.
        for lo, hi in step_slices(nodes, float(dt), SLICE_STEPS[method]):
            whole = lo == 0 and hi == nodes.size - 1
            part = coef if kind == ACCEL_SINUSOID or whole else np.ascontiguousarray(coef[lo:hi])
            y_part, calls = steps(
                self.kernel.par,
                y,
                comp,
                nodes if whole else np.ascontiguousarray(nodes[lo : hi + 1]),
                METHOD_CODES[method],
                float(dt),
                kind,
                part,
            )
            out[:, lo + 1 : hi + 1] = y_part[:, 1:]
            y = np.ascontiguousarray(y_part[:, -1])
            nfev += int(calls)
        return out, nfev


SLICE_STEPS: dict[str, int] = {
    "euler": 4_000_000,
    "symplectic_euler": 4_000_000,
    "verlet": 2_000_000,
    "rk4": 1_000_000,
    "rk8": 250_000,
}
"""Steps per compiled call: a fraction of a second of work (docs/benchmarks/constants.md), so Ctrl-C and
progress are seen between calls; fewer for a method of more stages per step."""


def step_slices(nodes: np.ndarray, dt: float, per_slice: int) -> list[tuple[int, int]]:
    """[(lo, hi)] node index ranges covering every interval, each ≤ per_slice substeps (or one interval).

    Interval i takes max(1, ⌈(nodes[i+1] − nodes[i]) / dt (1 − 1e-12)⌉) substeps, as ``_steps`` counts them.
    """
    if nodes.size < 2:
        return []
    # max(1, ⌈x⌉) ≤ x + 1: a run surely within one slice is one slice (what the count below also gives)
    if (float(nodes[-1]) - float(nodes[0])) / dt + nodes.size <= per_slice:
        return [(0, nodes.size - 1)]
    counts = np.maximum(1.0, np.ceil(np.diff(nodes) / dt * (1.0 - 1e-12)))
    total = np.cumsum(counts)
    bounds = [0]
    while bounds[-1] < counts.size:
        done = total[bounds[-1] - 1] if bounds[-1] else 0.0
        # The last interval whose cumulative count stays within this slice's budget (at least one).
        end = int(np.searchsorted(total, done + per_slice, side="right"))
        bounds.append(max(end, bounds[-1] + 1))
    return list(itertools.pairwise(bounds))


def warm() -> None:
    """Compile (or load from the cache) both models' kernels, plain and variational: a one-step run each."""
    p = Pendulum(1.0, stiffness=1e3)
    nodes = np.array([0.0, 0.01])
    for kernel, y0 in (
        (Kernel.rigid(p, Constant(0.0)), np.zeros(2)),
        (Kernel.elastic(p, Constant(0.0)), np.array([1.0, 0.0, 0.0, 0.0])),
    ):
        run_kernel(kernel, y0, nodes, "rk4", 0.01)
        prepared = PreparedKernel.of(kernel, nodes)
        assert prepared is not None
        prepared.run(np.concatenate((y0, np.zeros(2 * y0.size))), "rk4", 0.01, tangent=True)


if __name__ == "__main__":
    warm()
