"""The work-precision benchmark's scenes and the reference θ(t) each run is measured against.

θ_ref: a 30-digit mpmath Taylor integration (``mpmath.odefun``) for the rigid scenes whose a(t) is linear
between breakpoints, independent of every code path measured; DOP853 at rtol 1e-13 for the others,
cross-checked against an independent tight run (the disagreement is the floor the page prints).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from pendulum_accel.errors import PendulumAccelError
from pendulum_accel.physics.integrators import ADAPTIVE_METHODS, FIXED_STEP_METHODS
from pendulum_accel.physics.kernels import ACCEL_LINEAR, accel_coefficients
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import AccelProfile
from pendulum_accel.physics.simulate import simulate, stability_omega
from pendulum_accel.scene import Scene

MPMATH_DIGITS = 30
QUICK_MPMATH_DIGITS = 20  # still 1e-20 below the double-precision answers it checks


@dataclass(frozen=True)
class Case:
    """One benchmark scene: physics, sample times and the (model, method) runs to sweep.

    ``reference`` is 'mpmath' (rigid physics, a linear between breakpoints) or 'tight' (DOP853 at rtol 1e-13).
    """

    name: str
    title: str
    scene: Scene  # for the planner
    pendulum: Pendulum
    profile: AccelProfile
    theta0: float
    theta_dot0: float
    t: np.ndarray
    runs: tuple[tuple[str, str], ...]
    reference: str
    constant_accel: bool
    h_omega: tuple[float, ...]


# Any: mpmath numbers (mpmath has no type information), at whatever precision the caller works in.
def mp_theta_ddot(theta: Any, theta_dot: Any, accel: Any, gravity: Any, length: Any, damping: Any) -> Any:
    """θ'' = −(g/l) sin θ + (a/l) cos θ − c θ' in mpmath numbers (physics.rigid.theta_ddot, any precision)."""
    import mpmath

    return (-gravity * mpmath.sin(theta) + accel * mpmath.cos(theta)) / length - damping * theta_dot


def mpmath_reference(
    pendulum: Pendulum,
    profile: AccelProfile,
    t: np.ndarray,
    theta0: float,
    theta_dot0: float,
    digits: int = MPMATH_DIGITS,
) -> np.ndarray:
    """θ(t) of θ'' = −(g/l) sin θ + (a/l) cos θ − c θ' by mpmath's Taylor integrator at ``digits`` digits.

    a(t) must be linear between its breakpoints (constant, step, ramp, table, braking): the integration
    restarts at each breakpoint from the state there, with a = a(lo⁺) + slope (t − lo) on the piece.
    """
    import mpmath

    t0, t1 = float(t[0]), float(t[-1])
    edges = np.array([t0, *(b for b in profile.breakpoints() if t0 < b < t1), t1])
    linear = accel_coefficients(profile, edges)
    if linear is None or linear[0] != ACCEL_LINEAR:
        raise PendulumAccelError("the mpmath reference needs a(t) linear between its breakpoints")
    coef = linear[1]
    out = np.empty(t.size)
    with mpmath.workdps(digits):
        g, length, c = (mpmath.mpf(v) for v in (pendulum.gravity, pendulum.length, pendulum.damping))
        state = [mpmath.mpf(theta0), mpmath.mpf(theta_dot0)]
        for k in range(edges.size - 1):
            start, end = float(edges[k]), float(edges[k + 1])
            lo, a_lo, slope = mpmath.mpf(start), mpmath.mpf(float(coef[k, 0])), mpmath.mpf(float(coef[k, 1]))

            def rhs(  # Any: mpmath numbers, as mp_theta_ddot's
                x: Any, y: Sequence[Any], lo: Any = lo, a_lo: Any = a_lo, slope: Any = slope
            ) -> list[Any]:
                """[θ', θ''(θ, θ', a(x))], a(x) = a_lo + slope (x − lo)."""
                return [y[1], mp_theta_ddot(y[0], y[1], a_lo + slope * (x - lo), g, length, c)]

            solution = mpmath.odefun(rhs, lo, state)
            last = k == edges.size - 2
            mask = (t >= start) & ((t <= end) if last else (t < end))
            for i in np.flatnonzero(mask):
                out[i] = float(solution(mpmath.mpf(float(t[i])))[0])
            if not last:
                state = list(solution(mpmath.mpf(end)))
    return out


def tight_reference(case: Case) -> tuple[np.ndarray, float]:
    """(θ_ref from DOP853 at rtol 1e-13, its max disagreement with an independent tight run).

    The check run is Radau at rtol 1e-12 for the elastic string, RK4 at hω = 5e-4 for the rigid model.
    """
    model = "elastic" if case.pendulum.stiffness is not None else "rigid"

    def run(method: str, **settings: float) -> np.ndarray:
        """θ of one simulate() call of the case."""
        return simulate(
            case.pendulum, case.profile, case.t, theta0=case.theta0, theta_dot0=case.theta_dot0,
            model=model, method=method, **settings,
        ).theta  # fmt: skip

    ref = run("DOP853", rtol=1e-13, atol=1e-13)
    if model == "elastic":
        check = run("Radau", rtol=1e-12, atol=1e-12)
    else:
        check = run("rk4", dt=5e-4 / case_omega(case, model))
    return ref, float(np.max(np.abs(ref - check)))


def reference(case: Case, cache_dir: Path | None, digits: int = MPMATH_DIGITS) -> tuple[np.ndarray, float]:
    """(θ_ref at case.t, an estimate of its own error); mpmath results are cached in ``cache_dir``."""
    if case.reference == "tight":
        return tight_reference(case)
    key = json.dumps(
        [
            asdict_pendulum(case.pendulum),
            case.profile.to_dict(),
            case.theta0,
            case.theta_dot0,
            case.t.tolist(),
            digits,
        ],
        sort_keys=True,
    )
    digest = hashlib.sha256(key.encode()).hexdigest()[:16]
    path = None if cache_dir is None else cache_dir / f"reference_{case.name}_{digest}.npy"
    if path is not None and path.exists():
        return np.load(path), 0.0
    theta = mpmath_reference(case.pendulum, case.profile, case.t, case.theta0, case.theta_dot0, digits)
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.save(path, theta)
    return theta, 0.0


def asdict_pendulum(p: Pendulum) -> dict[str, object]:
    """{'length': l, 'mass': m, 'gravity': g, 'damping': c, 'stiffness': k} of a Pendulum."""
    return asdict(p)


def case_omega(case: Case, model: str) -> float:
    """The fastest natural frequency a fixed step must resolve (rad/s), as simulate() checks it."""
    return stability_omega(case.pendulum, case.profile, float(case.t[0]), float(case.t[-1]), model)


@dataclass(frozen=True)
class CaseSpec:
    """The physics of one benchmark scene, and the bundled scene the planner is asked about."""

    name: str
    title: str
    scene_name: str
    pendulum: Pendulum
    profile: AccelProfile
    theta0: float
    theta_dot0: float
    duration: float
    rate_hz: float
    h_omega: tuple[float, ...]


def case_specs() -> tuple[CaseSpec, ...]:
    """The four lecture scenes plus stop-and-go (where the planner must step); fixed steps span
    hω 0.32 … 3.2e-5 (stiff string: 5.6 … 5.6e-3, up to RK8's stability limit).
    """
    from pendulum_accel.physics.profiles import Constant, Step
    from pendulum_accel.scene import load_scene

    stop_and_go = load_scene("stop_and_go")

    rigid_h = tuple(10.0 ** (-0.5 - 0.5 * k) for k in range(9))
    stiff_h = tuple(10.0 ** (0.75 - 0.5 * k) for k in range(7))  # up to RK8's stability limit (5.96)
    return (
        CaseSpec(
            "lecture",
            "lecture: l=1 m, a=2 m/s², θ0=0 (10 s)",
            "lecture_constant",
            Pendulum(1.0),
            Constant(2.0),
            0.0,
            0.0,
            10.0,
            10.0,
            rigid_h,
        ),
        CaseSpec(
            "large_swing",
            "large swing: θ0=2.5 rad (143°), a=1 m/s² (10 s)",
            "large_swing",
            Pendulum(1.0),
            Constant(1.0),
            2.5,
            0.0,
            10.0,
            10.0,
            rigid_h,
        ),
        CaseSpec(
            "step",
            "step: a 0 → 3 m/s² at t=1 s, from rest (10 s)",
            "step_start",
            Pendulum(1.0),
            Step(1.0, 0.0, 3.0),
            0.0,
            0.0,
            10.0,
            10.0,
            rigid_h,
        ),
        CaseSpec(
            "elastic",
            "stiff string: k=1e5 N/m (√(k/m)=316 rad/s), a=2, θ0=0.3 (2 s)",
            "elastic_string",
            Pendulum(1.0, stiffness=1e5),
            Constant(2.0),
            0.3,
            0.0,
            2.0,
            10.0,
            stiff_h,
        ),
        CaseSpec(
            "stop_and_go",
            "stop-and-go: table a(t), damping 0.05 1/s (10 s): no closed form",
            "stop_and_go",
            stop_and_go.pendulum,
            stop_and_go.profile,
            0.0,
            0.0,
            10.0,
            10.0,
            rigid_h,
        ),
    )


def build_case(spec: CaseSpec, *, quick: bool) -> Case:
    """A Case from its spec: sample times at rate_hz (quick: a fifth of the duration) and its runs."""
    duration = spec.duration / 5.0 if quick else spec.duration
    scene = scene_for(spec, duration)
    t = scene.sensor.sample_times(duration)
    closed = (("exact", "closed-form"), ("linear", "closed-form"))
    pieces = spec.profile.constant_pieces(0.0, duration)
    closed_ok = pieces is not None and spec.pendulum.damping == 0.0
    rigid_runs = tuple(("rigid", m) for m in FIXED_STEP_METHODS + ADAPTIVE_METHODS)
    if spec.pendulum.stiffness is not None:
        elastic_runs = tuple(("elastic", m) for m in FIXED_STEP_METHODS + ADAPTIVE_METHODS)
        runs = (*(closed if closed_ok else ()), ("rigid", "DOP853"), *elastic_runs)
        reference_kind = "tight"
    else:
        runs = (*(closed if closed_ok else ()), *rigid_runs)
        if spec.name == "lecture":
            runs += (("multiplier", "DOP853"),)
        linear = accel_coefficients(spec.profile, np.array([0.0, duration]))
        reference_kind = "mpmath" if linear is not None and linear[0] == ACCEL_LINEAR else "tight"
    constant = closed_ok and pieces is not None and len(pieces) == 1
    return Case(
        name=spec.name,
        title=spec.title,
        scene=scene,
        pendulum=spec.pendulum,
        profile=spec.profile,
        theta0=spec.theta0,
        theta_dot0=spec.theta_dot0,
        t=t,
        runs=runs,
        reference=reference_kind,
        constant_accel=constant,
        h_omega=spec.h_omega,
    )


def scene_for(spec: CaseSpec, duration: float) -> Scene:
    """The bundled scene ``spec.scene_name`` with the spec's physics, duration and sensor rate."""
    from pendulum_accel.scene import load_scene

    scene = load_scene(spec.scene_name)
    return replace(
        scene,
        duration=duration,
        pendulum=spec.pendulum,
        profile=spec.profile,
        theta0=spec.theta0,
        theta_dot0=spec.theta_dot0,
        sensor=replace(scene.sensor, rate_hz=spec.rate_hz),
    )
