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
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.physics import elastic as elastic_model
from pendulum_accel.physics import multiplier as multiplier_model
from pendulum_accel.physics.exact import exact_solution
from pendulum_accel.physics.integrators import (
    FIXED_STEP_METHODS,
    METHODS,
    check_method,
    check_samples,
    integrate,
)
from pendulum_accel.physics.kernels import Kernel
from pendulum_accel.physics.linear import linear_solution
from pendulum_accel.physics.params import Pendulum, require_finite
from pendulum_accel.physics.profiles import AccelProfile, Piece, scalar_accel
from pendulum_accel.physics.rigid import rigid_rhs, tension
from pendulum_accel.physics.trajectory import Trajectory

MODELS: tuple[str, ...] = ("exact", "linear", "rigid", "multiplier", "elastic")
CLOSED_FORM_MODELS: tuple[str, ...] = ("exact", "linear")
AUTO_METHOD = "auto"
CLOSED_FORM_METHOD = "closed-form"
STIFF_RATIO = 30.0
DEFAULT_STEPS_PER_RADIAN = 20.0  # default fixed step: dt = 1/(20 ω)


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
    if model in CLOSED_FORM_MODELS:
        theta, theta_dot = _closed_form(pendulum, profile, times, th0, w0, model)
        return Trajectory(
            t=times,
            theta=theta,
            theta_dot=theta_dot,
            accel=accel,
            tension=tension(pendulum, theta, theta_dot, accel),
            stretch=None,
            stretch_rate=None,
            multiplier=None,
            model=model,
            method=chosen,
            nfev=0,
        )
    t0, t1 = float(times[0]), float(times[-1])
    a_max = profile.max_abs(t0, t1)
    omega = stability_omega(pendulum, profile, t0, t1, model, a_max)
    if chosen in FIXED_STEP_METHODS and dt is None:
        dt = 1.0 / (DEFAULT_STEPS_PER_RADIAN * omega)
    breaks = profile.breakpoints()
    a_of_t: Callable[[float], float] = scalar_accel(profile, t0, t1)
    w_scale = pendulum.omega(a_max)

    if model == "rigid":
        scales = np.array([1.0, w_scale])
        result = integrate(
            rigid_rhs(pendulum, a_of_t),
            np.array([th0, w0]),
            times,
            chosen,
            dt,
            rtol,
            None if atol is None else atol * scales,
            breakpoints=breaks,
            omega=omega,
            kernel=Kernel.rigid(pendulum, profile),
        )
        theta, theta_dot = result.y[0], result.y[1]
        return Trajectory(
            t=times,
            theta=theta,
            theta_dot=theta_dot,
            accel=accel,
            tension=tension(pendulum, theta, theta_dot, accel),
            stretch=None,
            stretch_rate=None,
            multiplier=None,
            model=model,
            method=chosen,
            nfev=result.nfev,
        )

    length = pendulum.length
    if model == "multiplier":
        scales = np.array([length, length, length * w_scale, length * w_scale])
        result = integrate(
            multiplier_model.multiplier_rhs(pendulum, a_of_t),
            multiplier_model.cartesian_state(pendulum, th0, w0),
            times,
            chosen,
            dt,
            rtol,
            None if atol is None else atol * scales,
            breakpoints=breaks,
            omega=omega,
            project=multiplier_model.project_to_circle(pendulum),
        )
        theta, theta_dot = multiplier_model.angle_state(result.y)
        theta = np.unwrap(theta)
        theta = theta + 2.0 * math.pi * round((th0 - theta[0]) / (2.0 * math.pi))
        mu = multiplier_model.multiplier(pendulum, result.y, accel)
        return Trajectory(
            t=times,
            theta=theta,
            theta_dot=theta_dot,
            accel=accel,
            tension=-mu * length,
            stretch=None,
            stretch_rate=None,
            multiplier=mu,
            model=model,
            method=chosen,
            nfev=result.nfev,
        )

    r0 = elastic_model.quasi_static_radius(pendulum, th0, w0, float(accel[0]))
    scales = np.array([length, 1.0, length * w_scale, w_scale])
    result = integrate(
        elastic_model.elastic_rhs(pendulum, a_of_t),
        np.array([r0, th0, 0.0, w0]),
        times,
        chosen,
        dt,
        rtol,
        None if atol is None else atol * scales,
        breakpoints=breaks,
        omega=omega,
        jac=elastic_model.elastic_jacobian(pendulum, a_of_t),
        kernel=Kernel.elastic(pendulum, profile),
    )
    r, theta, r_dot, theta_dot = result.y
    return Trajectory(
        t=times,
        theta=theta,
        theta_dot=theta_dot,
        accel=accel,
        tension=elastic_model.string_tension(pendulum, r),
        stretch=r - length,
        stretch_rate=r_dot,
        multiplier=None,
        model=model,
        method=chosen,
        nfev=result.nfev,
    )


def _closed_form(
    pendulum: Pendulum, profile: AccelProfile, times: np.ndarray, theta0: float, theta_dot0: float, model: str
) -> tuple[np.ndarray, np.ndarray]:
    """Chain the exact or linear closed form over the constant pieces of a(t), restarting at each edge."""
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
    solution = exact_solution if model == "exact" else linear_solution
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
