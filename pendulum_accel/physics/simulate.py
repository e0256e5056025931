"""The one entry point: simulate a pendulum in an accelerating car with any model and integrator.

Models (equations in each module's docstring):

- ``exact``: closed form for constant a, undamped (physics.exact), chained over the constant pieces;
- ``linear``: small oscillations about θ_eq with ω² = √(g²+a²)/l (physics.linear), chained likewise;
- ``rigid``: θ'' = −(g/l) sin θ + (a/l) cos θ − c θ' (physics.rigid);
- ``multiplier``: Cartesian (x, z) with the constraint ½(x² + z² − l²) = 0 (physics.multiplier);
- ``elastic``: radial spring V(r) = ½ k (r − l)², state (r, θ, r', θ') (physics.elastic).

Integration always stops at the profile's breakpoints. ``method="auto"`` picks DOP853, or LSODA for
the elastic string when √(k/m) ≥ ``STIFF_RATIO``·ω (stiff). ``atol`` is per unit of each state
component's natural scale (rad, rad·ω, l, l·ω). Fixed-step methods refuse a dt past their stability
limit, computed from ω = max(√(√(g² + a_max²)/l), c) (and √(k/m) for the elastic string).

Each model is one runner in ``MODEL_RUNNERS`` (name → function of a checked ``Problem`` returning the
model's ``ModelRun``), and simulate() wraps whichever ran in one Trajectory.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics import elastic as elastic_model
from pendulum_accel.physics import multiplier as multiplier_model
from pendulum_accel.physics.exact import FloatArray, exact_solution
from pendulum_accel.physics.integrators import (
    FIXED_STEP_METHODS,
    METHODS,
    IntegrationResult,
    Jacobian,
    Projection,
    Rhs,
    check_method,
    check_samples,
    check_stability,
    default_step,
    integrate,
    stop_times,
)
from pendulum_accel.physics.kernels import TANGENT_METHODS, Kernel, PreparedKernel
from pendulum_accel.physics.linear import linear_solution
from pendulum_accel.physics.params import Pendulum, require_finite
from pendulum_accel.physics.profiles import AccelProfile, Piece, scalar_accel
from pendulum_accel.physics.rigid import rigid_rhs, tension
from pendulum_accel.physics.trajectory import Trajectory

AUTO_METHOD = "auto"
CLOSED_FORM_METHOD = "closed-form"
STIFF_RATIO = 30.0

ClosedForm = Callable[[Pendulum, float, float, float, np.ndarray], tuple[FloatArray, FloatArray]]
CLOSED_FORMS: dict[str, ClosedForm] = {"exact": exact_solution, "linear": linear_solution}
CLOSED_FORM_MODELS: tuple[str, ...] = tuple(CLOSED_FORMS)


def stability_omega(
    pendulum: Pendulum, profile: AccelProfile, t0: float, t1: float, model: str, a_max: float | None = None
) -> float:
    """ω = max(√(√(g² + a_max²)/l), c), and also √(k/m) for the elastic string (rad/s).

    ``a_max`` = max |a| on [t0, t1] when the caller already has it.
    """
    if a_max is None:
        a_max = profile.max_abs(t0, t1)
    omega = max(pendulum.omega(a_max), pendulum.damping)
    if model == "elastic":
        omega = max(omega, elastic_model.radial_omega(pendulum))
    return omega


def choose_method(pendulum: Pendulum, model: str, method: str) -> str:
    """``method`` unless 'auto': closed-form for exact/linear, LSODA for a stiff string, else DOP853."""
    if model in CLOSED_FORM_MODELS:
        return CLOSED_FORM_METHOD
    if method != AUTO_METHOD:
        return check_method(method)
    if model == "elastic" and elastic_model.radial_omega(pendulum) >= STIFF_RATIO * pendulum.omega(0.0):
        # LSODA switches between Adams and BDF by itself: BDF steps over a quiet radial mode, and
        # Adams is cheaper than an implicit method when a jump in a(t) sets the string ringing.
        return "LSODA"
    return "DOP853"


@dataclass(frozen=True)
class Problem:
    """One checked simulate() call: pendulum, a(t) and its samples, initial state, model and solver settings.

    ``method`` is the chosen one (never 'auto'); ``dt`` the caller's (None: the default step rule).
    """

    pendulum: Pendulum
    profile: AccelProfile
    times: np.ndarray
    accel: np.ndarray
    theta0: float
    theta_dot0: float
    model: str
    method: str
    dt: float | None
    rtol: float | None
    atol: float | None


@dataclass(frozen=True)
class ModelRun:
    """What a model computed at the sample times; simulate() wraps it in a Trajectory."""

    theta: np.ndarray
    theta_dot: np.ndarray
    tension: np.ndarray
    stretch: np.ndarray | None = None
    stretch_rate: np.ndarray | None = None
    multiplier: np.ndarray | None = None
    nfev: int = 0


@dataclass(frozen=True)
class _Stepping:
    """What the integrated models share: scalar a(t), stability ω, rate scale ω(|a|max), step, breaks."""

    a_of_t: Callable[[float], float]
    omega: float
    w_scale: float
    dt: float | None
    breaks: Sequence[float]


def _stepping(problem: Problem) -> _Stepping:
    """_Stepping of ``problem``: dt defaults to integrators.default_step(ω) for a fixed-step method."""
    pendulum, profile, times = problem.pendulum, problem.profile, problem.times
    t0, t1 = float(times[0]), float(times[-1])
    a_max = profile.max_abs(t0, t1)
    omega = stability_omega(pendulum, profile, t0, t1, problem.model, a_max)
    dt = problem.dt
    if problem.method in FIXED_STEP_METHODS and dt is None:
        dt = default_step(omega)
    breaks = profile.breakpoints()
    a_of_t: Callable[[float], float] = scalar_accel(profile, t0, t1)
    return _Stepping(a_of_t, omega, pendulum.omega(a_max), dt, breaks)


def _integrate(
    problem: Problem,
    stepping: _Stepping,
    rhs: Rhs,
    y0: np.ndarray,
    scales: np.ndarray,
    *,
    project: Projection | None = None,
    kernel: Kernel | None = None,
    jac: Jacobian | None = None,
) -> IntegrationResult:
    """integrate() over the sample times with ``stepping``; atol per unit of each component's ``scales``."""
    return integrate(
        rhs,
        y0,
        problem.times,
        problem.method,
        stepping.dt,
        problem.rtol,
        None if problem.atol is None else problem.atol * scales,
        breakpoints=stepping.breaks,
        omega=stepping.omega,
        project=project,
        kernel=kernel,
        jac=jac,
    )


def _run_closed_form(problem: Problem) -> ModelRun:
    """The exact or linear closed form chained over the constant pieces; T from the reduced tension."""
    p = problem.pendulum
    theta, theta_dot = closed_form_motion(
        p, problem.profile, problem.times, problem.theta0, problem.theta_dot0, problem.model
    )
    return ModelRun(theta, theta_dot, tension(p, theta, theta_dot, problem.accel))


def _run_rigid(problem: Problem) -> ModelRun:
    """State [θ, θ'] (atol scales 1, ω), compiled kernel for fixed steps; T from the reduced tension."""
    stepping = _stepping(problem)
    p = problem.pendulum
    result = _integrate(
        problem,
        stepping,
        rigid_rhs(p, stepping.a_of_t),
        np.array([problem.theta0, problem.theta_dot0]),
        np.array([1.0, stepping.w_scale]),
        kernel=Kernel.rigid(p, problem.profile),
    )
    theta, theta_dot = result.y[0], result.y[1]
    return ModelRun(theta, theta_dot, tension(p, theta, theta_dot, problem.accel), nfev=result.nfev)


def _run_multiplier(problem: Problem) -> ModelRun:
    """State [x, z, x', z'] projected onto the circle; θ unwrapped onto θ0's branch, T = −μ l."""
    stepping = _stepping(problem)
    p = problem.pendulum
    length, w_scale = p.length, stepping.w_scale
    result = _integrate(
        problem,
        stepping,
        multiplier_model.multiplier_rhs(p, stepping.a_of_t),
        multiplier_model.cartesian_state(p, problem.theta0, problem.theta_dot0),
        np.array([length, length, length * w_scale, length * w_scale]),
        project=multiplier_model.project_to_circle(p),
    )
    theta, theta_dot = multiplier_model.angle_state(result.y)
    theta = np.unwrap(theta)
    theta = theta + 2.0 * math.pi * round((problem.theta0 - theta[0]) / (2.0 * math.pi))
    mu = multiplier_model.multiplier(p, result.y, problem.accel)
    return ModelRun(theta, theta_dot, -mu * length, multiplier=mu, nfev=result.nfev)


def _run_elastic(problem: Problem) -> ModelRun:
    """State [r, θ, r', θ'] from the quasi-static radius, with its Jacobian; T = k (r − l)."""
    stepping = _stepping(problem)
    p = problem.pendulum
    length, w_scale = p.length, stepping.w_scale
    th0, w0 = problem.theta0, problem.theta_dot0
    r0 = elastic_model.quasi_static_radius(p, th0, w0, float(problem.accel[0]))
    result = _integrate(
        problem,
        stepping,
        elastic_model.elastic_rhs(p, stepping.a_of_t),
        np.array([r0, th0, 0.0, w0]),
        np.array([length, 1.0, length * w_scale, w_scale]),
        jac=elastic_model.elastic_jacobian(p, stepping.a_of_t),
        kernel=Kernel.elastic(p, problem.profile),
    )
    r, theta, r_dot, theta_dot = result.y
    return ModelRun(
        theta,
        theta_dot,
        elastic_model.string_tension(p, r),
        stretch=r - length,
        stretch_rate=r_dot,
        nfev=result.nfev,
    )


ModelRunner = Callable[[Problem], ModelRun]
MODEL_RUNNERS: dict[str, ModelRunner] = {
    "exact": _run_closed_form,
    "linear": _run_closed_form,
    "rigid": _run_rigid,
    "multiplier": _run_multiplier,
    "elastic": _run_elastic,
}
MODELS: tuple[str, ...] = tuple(MODEL_RUNNERS)


def simulate(
    pendulum: Pendulum,
    profile: AccelProfile,
    t: np.ndarray,
    *,
    theta0: float,
    theta_dot0: float = 0.0,
    model: str = "rigid",
    method: str = AUTO_METHOD,
    dt: float | None = None,
    rtol: float | None = None,
    atol: float | None = None,
) -> Trajectory:
    """θ(t), θ'(t), a(t) (+ tension, stretch, multiplier per model) from θ(t[0]) = θ0, θ'(t[0]) = θ'0."""
    times = check_samples(t)
    th0 = require_finite("theta0", theta0)
    w0 = require_finite("theta_dot0", theta_dot0)
    if model not in MODELS:
        raise ParameterError(f"unknown model {model!r}; choose one of {', '.join(MODELS)}")
    if method != AUTO_METHOD and method not in METHODS:
        raise ParameterError(f"unknown method {method!r}; choose one of auto, {', '.join(METHODS)}")
    if dt is not None:
        dt = require_finite("dt", dt)
        if dt <= 0.0:
            raise ParameterError(f"dt must be > 0, got {dt!r}")
    chosen = choose_method(pendulum, model, method)
    accel = profile(times)
    problem = Problem(pendulum, profile, times, accel, th0, w0, model, chosen, dt, rtol, atol)
    run = MODEL_RUNNERS[model](problem)
    return Trajectory(
        t=times,
        theta=run.theta,
        theta_dot=run.theta_dot,
        accel=accel,
        tension=run.tension,
        stretch=run.stretch,
        stretch_rate=run.stretch_rate,
        multiplier=run.multiplier,
        model=model,
        method=chosen,
        nfev=run.nfev,
    )


@dataclass(frozen=True)
class SteppedRuns:
    """simulate()'s compiled fixed-step path for one (pendulum, a(t), sample times, model, method), prepared
    once for runs that differ only in their start and step (the planner's pilot and conditioning runs):
    θ at the samples bit-identical to ``simulate(...).theta``, without simulate()'s checks, a(t) samples,
    tension and Trajectory; and, for rk4/rk8, the variational run giving ∂θ/∂θ0 and ∂θ/∂θ'0 as well.

    Built by ``stepped_runs`` (None where simulate() would not use a compiled kernel).
    """

    pendulum: Pendulum
    model: str
    method: str
    omega: float
    accel0: float
    prepared: PreparedKernel
    is_sample: np.ndarray

    def start(self, theta0: float, theta_dot0: float) -> np.ndarray:
        """The model's initial state: [θ0, θ'0], or [r0, θ0, 0, θ'0], r0 quasi-static (as in simulate())."""
        if self.model == "rigid":
            return np.array([theta0, theta_dot0])
        r0 = elastic_model.quasi_static_radius(self.pendulum, theta0, theta_dot0, self.accel0)
        return np.array([r0, theta0, 0.0, theta_dot0])

    @property
    def variational(self) -> bool:
        """``tangent`` is available: the method is one whose variational run is compiled (rk4, rk8)."""
        return self.method in TANGENT_METHODS

    def _check(self, dt: float) -> None:
        """integrate()'s stability check (explicit Euler's over the run's step count)."""
        nodes = self.prepared.nodes
        steps = int(np.sum(np.ceil(np.diff(nodes) / dt - 1e-9))) if self.method == "euler" else 1
        check_stability(self.method, dt, self.omega, max(steps, 1))

    def _angle(self, y: np.ndarray) -> np.ndarray:
        """θ rows of the node states ``y``, at the samples."""
        result: np.ndarray = y[0 if self.model == "rigid" else 1, self.is_sample]
        return result

    def theta(self, theta0: float, theta_dot0: float, dt: float) -> np.ndarray:
        """θ at the samples from (θ0, θ'0) with steps ≤ dt: simulate(..., dt=dt).theta, bit for bit."""
        self._check(dt)
        y, _ = self.prepared.run(self.start(theta0, theta_dot0), self.method, dt)
        return self._angle(y)

    def tangent(self, theta0: float, theta_dot0: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """(θ, D): θ at the samples as ``theta`` gives it (bit for bit) and D[i] = ∂θ/∂xᵢ at the samples,
        x = (θ0, θ'0): the variational equations stepped with the state by the same scheme, so D is the
        derivative of the run itself. Elastic: the start's columns carry ∂r0/∂θ0 = m(a cos θ0 − g sin θ0)/d
        and ∂r0/∂θ'0 = 2 m θ'0 r0 / d, d = k − m θ'0² (r0 = (k l + m(g cos θ0 + a sin θ0))/d)."""
        self._check(dt)
        y0 = self.start(theta0, theta_dot0)
        n = y0.size
        columns = np.zeros((2, n))
        angle = 0 if self.model == "rigid" else 1
        columns[0, angle] = 1.0  # ∂/∂θ0 of the state
        columns[1, angle + n // 2] = 1.0  # ∂/∂θ'0 of the state
        if self.model == "elastic":
            p = self.pendulum
            d = elastic_model.stiffness_of(p) - p.mass * theta_dot0 * theta_dot0
            a, g = self.accel0, p.gravity
            columns[0, 0] = p.mass * (a * math.cos(theta0) - g * math.sin(theta0)) / d
            columns[1, 0] = 2.0 * p.mass * theta_dot0 * float(y0[0]) / d
        y, _ = self.prepared.run(np.concatenate((y0, columns.ravel())), self.method, dt, tangent=True)
        rows = y[:, self.is_sample]
        return rows[angle], np.vstack((rows[n + angle], rows[2 * n + angle]))


def stepped_runs(
    pendulum: Pendulum, profile: AccelProfile, t: np.ndarray, model: str, method: str
) -> SteppedRuns | None:
    """SteppedRuns of simulate(pendulum, profile, t, model=model, method=method, dt=…); None when that call
    would not run a compiled kernel (another model or method, or an a(t) with no compiled form)."""
    if model not in ("rigid", "elastic") or method not in FIXED_STEP_METHODS:
        return None
    times = check_samples(t)
    t0, t1 = float(times[0]), float(times[-1])
    omega = stability_omega(pendulum, profile, t0, t1, model)
    nodes, is_sample = stop_times(times, profile.breakpoints())
    kernel = Kernel.rigid(pendulum, profile) if model == "rigid" else Kernel.elastic(pendulum, profile)
    prepared = PreparedKernel.of(kernel, nodes)
    if prepared is None:
        return None
    accel0 = float(profile(times[:1])[0])
    return SteppedRuns(pendulum, model, method, omega, accel0, prepared, is_sample)


def closed_form_motion(
    pendulum: Pendulum, profile: AccelProfile, times: np.ndarray, theta0: float, theta_dot0: float, model: str
) -> tuple[np.ndarray, np.ndarray]:
    """(θ, θ') at ``times``: the exact or linear closed form chained over the constant pieces of a(t),
    restarting at each edge (θ_{k+1}(t) = closed form from the state of piece k at its end)."""
    if pendulum.damping != 0.0:
        raise ParameterError(
            f"model {model!r} is undamped only, got damping={pendulum.damping!r}; use model='rigid'"
        )
    pieces: list[Piece] | None = profile.constant_pieces(float(times[0]), float(times[-1]))
    if pieces is None:
        raise ParameterError(
            f"model {model!r} needs a piecewise-constant acceleration, got a {type(profile).__name__} "
            f"profile that varies continuously; use model='rigid'"
        )
    solution = CLOSED_FORMS[model]
    theta = np.empty_like(times)
    theta_dot = np.empty_like(times)
    th, w = theta0, theta_dot0
    for k, (start, end, a) in enumerate(pieces):
        last = k == len(pieces) - 1
        mask = (times >= start) & ((times <= end) if last else (times < end))
        local = np.append(times[mask], end) - start
        th_piece, w_piece = solution(pendulum, a, th, w, local)
        theta[mask] = np.asarray(th_piece)[:-1]
        theta_dot[mask] = np.asarray(w_piece)[:-1]
        th, w = float(np.asarray(th_piece)[-1]), float(np.asarray(w_piece)[-1])
    return theta, theta_dot
