"""One interface over fixed-step and adaptive integrators for y' = f(t, y).

Fixed-step methods (written here, vectorised: a state may be ``(n_state,)`` or a batch
``(n_state, n_batch)`` stepped together):

- ``euler``: y₁ = y₀ + h f(t₀, y₀).
- ``symplectic_euler``: v₁ = v₀ + h a(t₀, q₀, v₀); q₁ = q₀ + h v₁.
- ``verlet`` (velocity Verlet, kick-drift-kick): v½ = v₀ + ½h a₀; q₁ = q₀ + h v½;
  v₁ = v½ + ½h a₁ with a₁ = a(t₁, q₁, v*), v* = v½ + ½h a(t₁, q₁, v½), and a₁ reused as the next
  step's a₀. The explicit correction v* keeps second order when the force depends on velocity
  (damping); without such a force it is the textbook scheme (at two evaluations per step).
- ``rk4``: classic 4-stage Runge-Kutta.
- ``rk8``: the 8th-order solution of Dormand-Prince 8(5,3) (DOP853's 12-stage tableau) with a fixed step:
  for tight targets, where RK4 would need ~10× more steps.

A single rigid or elastic-string state (``kernel`` given) is stepped by the compiled kernels of
physics.kernels, the same schemes at a fraction of the cost (planner.KERNEL_STEP_S); batches, projected
states (the multiplier model) and other right-hand sides run the numpy loop here.

The two symplectic methods need a second-order system: the state is ``[q, v]`` split in equal
halves with q' = v, and f returns ``[v, a]``.

Adaptive methods are scipy's ``solve_ivp`` (RK45, DOP853, Radau, LSODA), not re-implemented.

Every method lands exactly on the requested sample times (fixed steps are shortened so that a
whole number of them fills each sample interval) and stops at every breakpoint, where f is
evaluated from the inside of each interval so a jump in a(t) never leaks across it.

Linear stability (test equation y'' = -ω² y): a fixed step h with hω past ``stability_limit``
is refused with StabilityError. Explicit Euler grows the amplitude by √(1+(hω)²) per step for
any h, so it is refused when that growth over the whole run would exceed ``EULER_MAX_GROWTH``.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from pendulum_accel.errors import ParameterError, StabilityError
from pendulum_accel.physics.kernels import RK8_A, RK8_B, RK8_C, Kernel, run_kernel

Rhs = Callable[[float, np.ndarray], np.ndarray]
Projection = Callable[[np.ndarray], np.ndarray]
Jacobian = Callable[[float, np.ndarray], np.ndarray]

FIXED_STEP_METHODS: tuple[str, ...] = ("euler", "symplectic_euler", "verlet", "rk4", "rk8")
ADAPTIVE_METHODS: tuple[str, ...] = ("RK45", "DOP853", "Radau", "LSODA")
METHODS: tuple[str, ...] = FIXED_STEP_METHODS + ADAPTIVE_METHODS
STIFF_METHODS: tuple[str, ...] = ("Radau", "LSODA")

# Max hω on the imaginary axis: RK4's stability region reaches 2√2, DOP853's 8th-order solution 5.96
# (|R(iy)| ≤ 1 below it, checked in test_integrators); leapfrog-type schemes reach 2.
_STABILITY_LIMITS: dict[str, float | None] = {
    "euler": 0.0,
    "symplectic_euler": 2.0,
    "verlet": 2.0,
    "rk4": 2.0 * math.sqrt(2.0),
    "rk8": 5.96,
    "RK45": None,
    "DOP853": None,
    "Radau": None,
    "LSODA": None,
}
EULER_MAX_GROWTH = 2.0
# The implicit methods are for stiff problems (the elastic string), where tighter tolerances would
# force them to resolve the fast radial ringing they are meant to step over.
DEFAULT_RTOL: dict[str, float] = {"RK45": 1e-9, "DOP853": 1e-11, "Radau": 1e-7, "LSODA": 1e-8}
DEFAULT_ATOL_FACTOR = 1e-3  # atol = factor · rtol unless given
# Default fixed step h = 1/(20 ω): hω = 0.05, far inside every fixed-step method's stability limit.
DEFAULT_STEPS_PER_RADIAN = 20.0


@dataclass(frozen=True)
class IntegrationResult:
    """States at the sample times: ``y`` has shape y0.shape + (len(t),); ``nfev`` counts f calls."""

    t: np.ndarray
    y: np.ndarray
    nfev: int
    method: str


def check_method(method: str) -> str:
    """Return ``method`` when it is in METHODS, else raise ParameterError listing them."""
    if method not in METHODS:
        raise ParameterError(f"unknown integration method {method!r}; choose one of {', '.join(METHODS)}")
    return method


def stability_limit(method: str) -> float | None:
    """Max stable hω for ``method`` on an undamped oscillator (None: adaptive, no fixed step)."""
    return _STABILITY_LIMITS[check_method(method)]


def default_step(omega: float, steps_per_radian: float = DEFAULT_STEPS_PER_RADIAN) -> float:
    """h = 1/(steps_per_radian · ω): the fixed step that turns the fastest mode by 1/steps_per_radian rad."""
    return 1.0 / (steps_per_radian * omega)


def check_stability(method: str, dt: float, omega: float, n_steps: int = 1) -> None:
    """Raise StabilityError when h·ω exceeds the method's limit (Euler: when √(1+(hω)²)^n > 2)."""
    limit = stability_limit(method)
    if limit is None or omega <= 0.0:
        return
    h_omega = dt * omega
    if method == "euler":
        log_growth = 0.5 * n_steps * math.log1p(h_omega * h_omega)
        if log_growth > math.log(EULER_MAX_GROWTH):
            raise StabilityError(
                f"explicit Euler with h={dt:.6g} s, ω={omega:.6g} rad/s grows the amplitude by "
                f"e^{log_growth:.3g} over {n_steps} steps (limit {EULER_MAX_GROWTH}×); "
                f"use a smaller dt or another method"
            )
        return
    if h_omega > limit:
        raise StabilityError(
            f"step h={dt:.6g} s with ω={omega:.6g} rad/s gives hω={h_omega:.4g}, past the {method} "
            f"stability limit {limit:.4g}; use dt ≤ {limit / omega:.6g} s"
        )


def stop_times(t_eval: np.ndarray, breakpoints: Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
    """All stop times (samples ∪ inner breakpoints), ascending, and a mask of which are samples."""
    t0, t1 = float(t_eval[0]), float(t_eval[-1])
    inner = np.array(sorted({float(b) for b in breakpoints if t0 < b < t1}), dtype=float)
    at = np.minimum(np.searchsorted(t_eval, inner), t_eval.size - 1)
    inner = inner[t_eval[at] != inner]  # a breakpoint that is also a sample is stopped at once
    if inner.size == 0:
        return t_eval, np.ones(t_eval.size, dtype=bool)
    merged = np.concatenate((t_eval, inner))
    order = np.argsort(merged, kind="stable")
    return merged[order], order < t_eval.size


def _segment_clamp(lo: float, hi: float) -> Callable[[float], float]:
    """t ↦ t clamped to the open segment (lo, hi), so a(t) is read from the segment's own side."""
    lo_in = math.nextafter(lo, math.inf)
    hi_in = math.nextafter(hi, -math.inf)
    if lo_in > hi_in:
        return lambda t: t
    return lambda t: min(max(t, lo_in), hi_in)


def check_samples(t_eval: np.ndarray) -> np.ndarray:
    """t_eval as a 1-D float array, finite and strictly increasing, else ParameterError."""
    times = np.asarray(t_eval, dtype=float)
    if times.ndim != 1 or times.size == 0:
        raise ParameterError(f"sample times must be a non-empty 1-D array, got shape {times.shape}")
    if not np.isfinite(times).all():
        raise ParameterError("sample times must be finite, got NaN or inf")
    if times.size > 1 and not (times[1:] > times[:-1]).all():
        i = int(np.argmin(np.diff(times) > 0))
        raise ParameterError(
            f"sample times must be strictly increasing: t[{i + 1}]={times[i + 1]!r} <= {times[i]!r}"
        )
    return times


def integrate(
    rhs: Rhs,
    y0: np.ndarray,
    t_eval: np.ndarray,
    method: str,
    dt: float | None = None,
    rtol: float | None = None,
    atol: float | np.ndarray | None = None,
    *,
    breakpoints: Sequence[float] = (),
    omega: float | None = None,
    project: Projection | None = None,
    kernel: Kernel | None = None,
    jac: Jacobian | None = None,
    max_step: float = math.inf,
) -> IntegrationResult:
    """y(t_eval) for y' = rhs(t, y), y(t_eval[0]) = y0, stopping at every breakpoint.

    ``dt`` is the largest fixed step (fixed-step methods only); ``omega`` (rad/s) enables the stability
    check; ``project`` maps a state back onto a constraint manifold after every fixed step and at every
    adaptive stop; ``kernel`` is the compiled form of ``rhs`` (physics.kernels), used by fixed-step runs of a
    single unprojected state;
    ``jac`` is ∂f/∂y for an unbatched state (used by Radau and LSODA); ``rtol``/``atol`` go to solve_ivp.
    """
    check_method(method)
    times = check_samples(t_eval)
    state = np.array(y0, dtype=float)
    if state.ndim not in (1, 2) or not np.all(np.isfinite(state)):
        raise ParameterError(f"initial state must be a finite 1-D or 2-D array, got {state!r}")
    nodes, is_sample = stop_times(times, breakpoints)
    if method in FIXED_STEP_METHODS:
        if dt is None:
            raise ParameterError(f"fixed-step method {method} needs dt")
        step = float(dt)
        if not (math.isfinite(step) and step > 0.0):
            raise ParameterError(f"dt must be finite and > 0, got {dt!r}")
        if omega is not None:
            # Only Euler's limit depends on the number of steps (its growth compounds over the run).
            n_total = int(np.sum(np.ceil(np.diff(nodes) / step - 1e-9))) if method == "euler" else 1
            check_stability(method, step, omega, max(n_total, 1))
        if method in ("symplectic_euler", "verlet") and state.shape[0] % 2:
            raise ParameterError(f"{method} needs a state [q, v] of even size, got {state.shape[0]}")
        compiled = None
        if kernel is not None and state.ndim == 1 and project is None:
            compiled = run_kernel(kernel, state, nodes, method, step)
        if compiled is None:
            compiled = _fixed_array(rhs, state, nodes, method, step, project)
        y_nodes, nfev = compiled
    else:
        jacobian = jac if state.ndim == 1 and method in STIFF_METHODS else None
        y_nodes, nfev = _adaptive(
            rhs, state, nodes, method, rtol, atol, project, max_step, is_sample, jacobian
        )
    return IntegrationResult(t=times, y=y_nodes[..., is_sample], nfev=nfev, method=method)


def _n_substeps(span: float, dt: float) -> int:
    """Smallest n ≥ 1 with span/n ≤ dt (a hair of slack so an exact multiple is not split again)."""
    return max(1, math.ceil(span / dt * (1.0 - 1e-12)))


def _fixed_array(
    rhs: Rhs, y0: np.ndarray, nodes: np.ndarray, method: str, dt: float, project: Projection | None
) -> tuple[np.ndarray, int]:
    """Fixed-step integration of an array (or batch) state through every node."""
    out = np.empty((*y0.shape, nodes.size))
    out[..., 0] = y0
    y = y0.copy()
    half = y0.shape[0] // 2
    nfev = 0
    for i in range(nodes.size - 1):
        lo, hi = float(nodes[i]), float(nodes[i + 1])
        clamp = _segment_clamp(lo, hi)
        acc: np.ndarray | None = None  # a(t) may jump at a node, so the carried value starts afresh
        n = _n_substeps(hi - lo, dt)
        h = (hi - lo) / n

        def f(t: float, state: np.ndarray, clamp: Callable[[float], float] = clamp) -> np.ndarray:
            return np.asarray(rhs(clamp(t), state))

        for k in range(n):
            t = lo + k * h
            if method == "rk4":
                k1 = f(t, y)
                k2 = f(t + 0.5 * h, y + (0.5 * h) * k1)
                k3 = f(t + 0.5 * h, y + (0.5 * h) * k2)
                k4 = f(t + h, y + h * k3)
                y = y + (h / 6.0) * (k1 + 2.0 * (k2 + k3) + k4)
                nfev += 4
            elif method == "rk8":
                stages: list[np.ndarray] = []
                for c_s, a_row in zip(RK8_C, RK8_A, strict=True):
                    y_s = y + h * sum((a * k for a, k in zip(a_row, stages, strict=False)), np.zeros_like(y))
                    stages.append(f(t + c_s * h, y_s))
                y = y + h * sum((b * k for b, k in zip(RK8_B, stages, strict=True)), np.zeros_like(y))
                nfev += len(stages)
            elif method == "euler":
                y = y + h * f(t, y)
                nfev += 1
            elif method == "symplectic_euler":
                v = y[half:] + h * f(t, y)[half:]
                y = np.concatenate((y[:half] + h * v, v))
                nfev += 1
            else:  # verlet; acc is a(t, q, v) carried over from the previous step's closing kick
                if acc is None:
                    acc = f(t, y)[half:]
                    nfev += 1
                v_half = y[half:] + (0.5 * h) * acc
                q1 = y[:half] + h * v_half
                v_star = v_half + (0.5 * h) * f(t + h, np.concatenate((q1, v_half)))[half:]
                acc = f(t + h, np.concatenate((q1, v_star)))[half:]
                y = np.concatenate((q1, v_half + (0.5 * h) * acc))
                nfev += 2
            if project is not None:
                y = project(y)
                acc = None
        out[..., i + 1] = y
    return out, nfev


def _clamped_jac(jac: Jacobian, clamp: Callable[[float], float]) -> Jacobian:
    """jac with its time read from inside the current segment, like the right-hand side."""
    return lambda t, y: jac(clamp(t), y)


def _adaptive(
    rhs: Rhs,
    y0: np.ndarray,
    nodes: np.ndarray,
    method: str,
    rtol: float | None,
    atol: float | np.ndarray | None,
    project: Projection | None,
    max_step: float,
    is_sample: np.ndarray,
    jac: Jacobian | None,
) -> tuple[np.ndarray, int]:
    """scipy solve_ivp, restarted at each breakpoint so it never steps across one."""
    # imported here, not with the module: scipy costs start-up time that --help does not need
    from scipy.integrate import solve_ivp

    shape = y0.shape
    rel = DEFAULT_RTOL[method] if rtol is None else float(rtol)
    if not (math.isfinite(rel) and rel > 0.0):
        raise ParameterError(f"rtol must be finite and > 0, got {rtol!r}")
    abs_tol = np.broadcast_to(
        np.asarray(rel * DEFAULT_ATOL_FACTOR if atol is None else atol, dtype=float).reshape(
            (-1,) + (1,) * (len(shape) - 1)
        ),
        shape,
    ).ravel()
    if not (np.all(np.isfinite(abs_tol)) and np.all(abs_tol > 0.0)):
        raise ParameterError(f"atol must be finite and > 0, got {atol!r}")
    out = np.empty((*shape, nodes.size))
    out[..., 0] = y0
    y = y0.ravel().copy()
    nfev = 0
    # One solve_ivp call per stretch between breakpoints: restarting at every sample would cost a
    # fresh step-size search each time, and the dense output is as accurate as the steps.
    edges = [0, *(int(j) for j in np.flatnonzero(~is_sample)), nodes.size - 1]
    for i_lo, i_hi in itertools.pairwise(sorted(set(edges))):
        lo, hi = float(nodes[i_lo]), float(nodes[i_hi])
        clamp = _segment_clamp(lo, hi)

        def fun(t: float, flat: np.ndarray, clamp: Callable[[float], float] = clamp) -> np.ndarray:
            return np.asarray(rhs(clamp(t), flat.reshape(shape))).ravel()

        options: dict[str, object] = {
            "method": method,
            "t_eval": nodes[i_lo + 1 : i_hi + 1],
            "rtol": rel,
            "atol": abs_tol,
            "max_step": max_step,
            **({} if jac is None else {"jac": _clamped_jac(jac, clamp)}),
        }
        sol = solve_ivp(fun, (lo, hi), y, **options)
        if sol.status != 0 and "step size" in sol.message:
            # scipy's own first-step guess can turn its error norm into NaN on a state of ~1e-160 (a bob
            # at rest at equilibrium, found by hypothesis), reported as a step-size failure: retry the
            # stretch once from an explicit first step. Runs that succeed never get here.
            sol = solve_ivp(fun, (lo, hi), y, first_step=min(max_step, (hi - lo) * 1e-3), **options)
        if sol.status != 0 or not np.all(np.isfinite(sol.y)):
            raise StabilityError(f"{method} failed between t={lo:.6g} s and t={hi:.6g} s: {sol.message}")
        nfev += int(sol.nfev)
        out[..., i_lo + 1 : i_hi + 1] = sol.y.reshape((*shape, i_hi - i_lo))
        y = sol.y[:, -1]
        if project is not None:
            y = project(y.reshape(shape)).ravel()
            out[..., i_hi] = y.reshape(shape)
    return out, nfev
