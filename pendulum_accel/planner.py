"""Planner: the cheapest model and solver that meets a scene's angle-accuracy target, explained in one line.

Cost order (cheapest first, by the CPU costs CLOSED_FORM_SAMPLE_S and KERNEL_STEP_S): linear closed form
< exact closed form (Jacobi elliptic functions) < rigid, stepped by the compiled kernels of physics.kernels
(RK4 or RK8, whichever needs less CPU for the target) < elastic string, stepped the same way. The
Lagrange-multiplier model is used only when a scene forces it.

Rules, in order:

1. A forced model (scene ``force.model``) is used as is; its method is forced too or chosen by rule 5/6.
2. Stretch requested, or the string's static stretch makes the rigid model miss the target
   (angle error of ignoring it ≈ (δ/l)(1 + A ωT), δ = g_eff m/k, checked against the elastic model):
   the elastic string (rule 5, its step also bounded by the radial mode's stability).
3. a(t) piecewise constant on [0, T] and no damping: closed form, chained over the pieces.
   Linear when its proven bound (``physics.linear.linear_error_bound`` per piece, A the piece's
   libration amplitude; errors carried across pieces in the energy norm, hence ×√2·ω_max/ω_min)
   meets the target; else exact, whose error is round-off, ≈ 1e-13 (1 + ωT) per piece, amplified near
   the separatrix by 1/m₁ (m₁ = cos²(A/2): the period's sensitivity to the amplitude).
4. Otherwise the rigid model, stepped.
5. Fixed steps of order p (RK4: 4, RK8: 8). A first step from err ≈ C (hω)^p (1 + ωT), ω of the swing
   (C: RK4 0.1, RK8 0.01, typical of a swing; near the separatrix C grows by orders of magnitude, which the
   pilot below catches), h ≤ the sample interval, hω ≤ MAX_H_OMEGA, and for the elastic string
   h √(k/m) ≤ 0.8 of the method's stability limit. The cheaper of RK4 and RK8 at that step (steps × the
   measured µs per step) is then checked by a pilot on the scene itself, step halving: the error of θ_h
   is ≈ |θ_h − θ_{h/2}| · 2^p/(2^p − 1), which the plan predicts as PILOT_SAFETY_FIXED × that; while the
   prediction misses the budget the step shrinks, ×(budget/prediction)^(1/p), up to PILOT_ROUNDS times
   (a halving that no longer helps means round-off: the plan then says the target is out of reach).
   Other models (multiplier) keep the a-priori prediction with C = 0.1 (RK4), 0.5 (Verlet), 1 (Euler).
6. Adaptive (DOP853 for the multiplier model, or a forced solve_ivp method; LSODA for an elastic string
   so stiff that fixed steps would exceed MAX_FIXED_STEPS): global error ≈ K rtol (1 + ωT). K is
   measured for the scene by a pilot pair (rtol 1e-6 against 1e-9 on a coarse grid) and multiplied by 20
   for safety (K grew up to 8× from rtol 1e-6 to rtol 6e-13 in those measurements); floor 0.05. The rtol
   is never looser than the pilot's 1e-6: the model is not extrapolated where it was not measured.

Every prediction is an upper estimate; ``test/test_planner.py`` runs a tight reference for every bundled
scene and checks the chosen plan meets the target.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from pendulum_accel.conditioning import Sensitivity, input_sensitivity, tangent_sensitivity
from pendulum_accel.errors import ParameterError, SceneError
from pendulum_accel.physics.exact import (
    FOURIER_MAX_NOME,
    OrbitStart,
    complete_k,
    exact_solution,
    libration_amplitude,
    nome,
)
from pendulum_accel.physics.integrators import FIXED_STEP_METHODS, stability_limit
from pendulum_accel.physics.linear import linear_error_bound
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import AccelProfile, Piece
from pendulum_accel.physics.simulate import (
    CLOSED_FORM_METHOD,
    SteppedRuns,
    closed_form_motion,
    simulate,
    stability_omega,
    stepped_runs,
)
from pendulum_accel.scene import Scene

COST_ORDER: tuple[str, ...] = ("linear", "exact", "rigid", "elastic")  # multiplier: forced only

# Fixed-step error model: order p and constant C in  err ≤ C (hω)^p (1 + ωT).
FIXED_STEP_ORDER: dict[str, tuple[int, float]] = {
    "rk8": (8, 0.01),
    "rk4": (4, 0.1),
    "verlet": (2, 0.5),
    "symplectic_euler": (1, 1.0),
    "euler": (1, 1.0),
}
ROUND_SLACK = 1e-9  # aim a hair inside the budget so the prediction's own rounding stays ≤ target
MAX_H_OMEGA = {"rk8": 1.0}  # beyond this the (hω)^p error model is no longer asymptotic; others 0.5
DEFAULT_MAX_H_OMEGA = 0.5
PILOT_SAFETY_FIXED = 4.0
# Fraction of the stability limit a first step may use on the fastest mode; the pilot would see a
# step past the true limit (the radial mode's ω shifts with θ'²) as a blown-up difference and shrink it.
STABILITY_FRACTION = 0.8
PILOT_ROUNDS = 6
PILOT_NO_CONVERGENCE = 1.0  # rad: a halving that moves θ this much means chaos; no smaller step helps
COMPILED_MODELS = ("rigid", "elastic")
STEPPED_METHODS = ("rk4", "rk8")  # what the planner chooses between for a compiled model
MAX_FIXED_STEPS = 20_000_000
K_FLOOR = 0.05
PILOT_SAFETY = 20.0
PILOT_RTOLS = (1e-6, 1e-9)
PILOT_POINTS = 1000
RTOL_RANGE = (1e-13, 1e-3)
EXACT_ROUNDOFF = 2.0  # × ε (Θ + 2kω span): closed_form_roundoff, calibrated by benchmarks/error_bounds.py
DOUBLING_SHARE = 1.0 / 32.0  # round-off share per argument doubling (docs/benchmarks/constants.md)
START_SAFETY = 2.0  # × the closed form's start rounding carried through S(t) (closed_form_start_error)
START_NEAR_SEPARATRIX = 0.5  # |m1| below which K, K' and the nome depend on m1 enough for its rounding
ROUNDOFF_SAFETY = 2.0  # × the measured round-off of a stepped run (conditioning: max over t of 1 draw)
# A halving difference within this × the run's round-off at h is rounding, not truncation (the h/2 run
# takes twice the steps, so rounds more); set on error_bounds' RK8 cases (docs/benchmarks/constants.md).
HALVING_NOISE = 10.0
# Truncation shrinks 2^p-fold per halving: a doubling difference |θ_{2h} − θ_h| under 2^(p − DOUBLING_SLACK)
# times the halving difference |θ_h − θ_{h/2}| says the latter is rounding (RK8: under 64×, RK4: under 4×).
DOUBLING_SLACK = 2
# Past the linear regime the predicted error is this × the spread of five runs one ulp apart (conditioning):
# the run and the reference are two more such runs; set past linear on docs/benchmarks/constants.md.
SPREAD_SAFETY = 2.0
DOUBLE_EPS = 2.0**-52
LINEAR_CARRY = math.sqrt(2.0)
# CPU a step or a sample costs (docs/benchmarks/constants.md); only their ratio matters for the choice.
KERNEL_STEP_S: dict[tuple[str, str], float] = {  # compiled kernels (physics.kernels), per step
    ("rigid", "rk4"): 0.1e-6,
    ("rigid", "rk8"): 0.4e-6,
    ("elastic", "rk4"): 0.25e-6,
    ("elastic", "rk8"): 0.6e-6,
}
PYTHON_STEP_S = 15e-6  # the numpy loop of physics.integrators (the multiplier model), per RK4 step
ADAPTIVE_CALL_S = 24e-6
ADAPTIVE_CALLS = 3.5  # calls ≈ 3.5 (1 + ωT) rtol^(-1/8) for DOP853 (fit over rtol 1e-4 … 1e-12)
CLOSED_FORM_SAMPLE_S = {"linear": 0.2e-6, "exact": 0.6e-6}
CONDITIONING_POINTS = 20_000  # sample times of the paired runs when no fixed step ties them to the sensor


@dataclass(frozen=True)
class Plan:
    """Model, method, step dt (s) or rtol, predicted max angle error (rad), target, and why (one line)."""

    model: str
    method: str
    dt: float | None
    rtol: float | None
    predicted_error: float
    reason: str
    target: float = math.nan
    estimated_cpu_s: float = math.nan
    sensitivity: Sensitivity | None = None
    method_error: float = math.nan
    driven: bool = False
    halving_difference: float = math.nan
    coarse_difference: float = math.nan

    @property
    def meets_target(self) -> bool:
        """predicted_error ≤ target."""
        return self.predicted_error <= self.target

    @property
    def ill_conditioned(self) -> bool:
        """The inputs' own rounding moves θ by more than the target (conditioning.Sensitivity)."""
        return self.sensitivity is not None and self.sensitivity.ill_conditioned

    def setting(self) -> str:
        """'dt = … s', 'rtol = …' or 'no stepping'."""
        if self.dt is not None:
            return f"dt = {self.dt:.3g} s"
        if self.rtol is not None:
            return f"rtol = {self.rtol:.1e}"
        return "no stepping"

    def explain(self) -> str:
        """'plan: <model> model, <method> (<dt/rtol>), predicted max angle error … rad (target …): <why>'."""
        verdict = "" if self.meets_target or self.ill_conditioned else " — TARGET NOT MET"
        text = (
            f"plan: {self.model} model, {self.method} ({self.setting()}), predicted max angle error "
            f"{self.predicted_error:.1e} rad (target {self.target:.1e} rad){verdict}: {self.reason}"
        )
        if self.sensitivity is not None:
            text += f"; method error {self.method_error:.1e} rad, {self.sensitivity.describe()}"
            if self.driven:
                text += f"; {self.sensitivity.chaos()}"
            if self.sensitivity.verdict():
                text += f" — {self.sensitivity.verdict()}"
        return " ".join(text.split())


@dataclass(frozen=True)
class _Setup:
    """What every rule needs: pendulum, profile, span, ω of the swing, the model's fastest ω, sample count."""

    scene: Scene
    pendulum: Pendulum
    profile: AccelProfile
    duration: float
    omega: float
    omega_fast: float
    samples: int
    prepared: dict[tuple[str, str, int], SteppedRuns | None] = field(default_factory=dict, compare=False)

    def runs(self, model: str, method: str, stride: int = 1) -> SteppedRuns | None:
        """simulate()'s compiled path prepared once (physics.simulate.SteppedRuns) for ``model`` and
        ``method`` at every ``stride``-th sample time; None where simulate() has no compiled path."""
        key = (model, method, stride)
        if key not in self.prepared:
            t = self.scene.sensor.sample_times(self.duration)[::stride]
            self.prepared[key] = stepped_runs(self.pendulum, self.profile, t, model, method)
        return self.prepared[key]

    def theta(self, model: str, method: str, dt: float, stride: int = 1) -> np.ndarray:
        """θ at every ``stride``-th sample time from the scene's start, stepped with dt: simulate()'s θ,
        by its compiled path without its overheads where there is one."""
        scene = self.scene
        runs = self.runs(model, method, stride)
        if runs is not None:
            return runs.theta(scene.theta0, scene.theta_dot0, dt)
        t = scene.sensor.sample_times(self.duration)[::stride]
        return simulate(self.pendulum, self.profile, t, theta0=scene.theta0, theta_dot0=scene.theta_dot0,
                        model=model, method=method, dt=dt).theta  # fmt: skip

    @property
    def omega_t(self) -> float:
        """1 + ωT, the secular growth factor of the angle error (ω of the swing)."""
        return 1.0 + self.omega * self.duration

    @property
    def omega_fast_t(self) -> float:
        """1 + ω_fast T, the same with the fastest mode (the elastic string's √(k/m)), for fixed steps."""
        return 1.0 + self.omega_fast * self.duration


def _setup(scene: Scene, model: str = "rigid") -> _Setup:
    """_Setup of ``scene``: ω and ω_fast from physics.simulate.stability_omega (rigid and ``model``)."""
    a_max = scene.profile.max_abs(0.0, scene.duration)
    omega = stability_omega(scene.pendulum, scene.profile, 0.0, scene.duration, "rigid", a_max)
    fast = stability_omega(scene.pendulum, scene.profile, 0.0, scene.duration, model, a_max)
    samples = scene.sensor.sample_count(scene.duration)
    return _Setup(scene, scene.pendulum, scene.profile, scene.duration, omega, fast, samples)


def plan_scene(scene: Scene) -> Plan:
    """The cheapest (model, method, dt | rtol) whose predicted max angle error meets scene.accuracy.

    The prediction: the run's own error, its method error with its round-off, or past the linear regime
    the spread of one-ulp runs; the input-sensitivity floor is announced beside it (with_conditioning).
    """
    return with_conditioning(scene, _plan_method(scene))


def _plan_method(scene: Scene) -> Plan:
    """Rules 1-6 (method error only); a ParameterError becomes a SceneError naming the scene."""
    try:
        return _plan(scene.on_level())  # a road grade is planned as its level equivalent
    except ParameterError as err:
        raise SceneError(f"scene {scene.name}: cannot plan: {err}") from None


def _sensitivity_times(scene: Scene, plan: Plan) -> np.ndarray:
    """The sample times (a fixed step depends on them), or ≤ CONDITIONING_POINTS evenly spread ones."""
    t = scene.sensor.sample_times(scene.duration)
    if plan.dt is not None or t.size <= CONDITIONING_POINTS:
        return t
    return np.linspace(0.0, float(t[-1]), CONDITIONING_POINTS)


def measure_sensitivity(
    scene: Scene,
    plan: Plan,
    base: np.ndarray | None = None,
    noise: bool = True,
    derivative: np.ndarray | None = None,
    runs: SteppedRuns | None = None,
) -> Sensitivity:
    """S(t) of ``scene`` by paired runs of ``plan``'s own model and solver (pendulum_accel.conditioning);
    ``base`` = the plan's run at the conditioning times when at hand; the round-off only with ``noise``.

    With ``derivative`` = [∂θ/∂θ0, ∂θ/∂θ'0] along ``base`` (the run's variational equations), S(t) comes
    from it (conditioning.tangent_sensitivity) and the nudged runs are made only for the round-off or
    past the linear regime; ``runs`` = the plan's compiled path prepared for those runs.
    """
    from pendulum_accel.physics.simulate import AUTO_METHOD

    times = _sensitivity_times(scene, plan)
    method = AUTO_METHOD if plan.method == CLOSED_FORM_METHOD else plan.method
    if runs is None and plan.dt is not None:
        runs = stepped_runs(scene.pendulum, scene.profile, times, plan.model, plan.method)

    def run(theta0: float, theta_dot0: float) -> np.ndarray:
        """θ at ``times`` with the plan's model and solver from (θ0, θ'0)."""
        if plan.method == CLOSED_FORM_METHOD:  # θ alone: the closed form without simulate()'s extras
            return closed_form_motion(scene.pendulum, scene.profile, times, theta0, theta_dot0, plan.model)[0]
        if runs is not None and plan.dt is not None:  # the compiled path, bit for bit simulate()'s θ
            return runs.theta(theta0, theta_dot0, plan.dt)
        return simulate(scene.pendulum, scene.profile, times, theta0=theta0, theta_dot0=theta_dot0,
                        model=plan.model, method=method, dt=plan.dt, rtol=plan.rtol).theta  # fmt: skip

    omega = scene.pendulum.omega(scene.profile.max_abs(0.0, scene.duration))
    if base is not None and base.shape != times.shape:
        base = derivative = None
    try:
        if base is not None and derivative is not None:
            measured = tangent_sensitivity(
                run, scene.theta0, scene.theta_dot0, omega, times, scene.accuracy, base, derivative, noise
            )
            if measured is not None:
                return measured
        return input_sensitivity(
            run, scene.theta0, scene.theta_dot0, omega, times, scene.accuracy, base=base, noise=noise
        )
    except ParameterError as err:
        raise SceneError(f"scene {scene.name}: cannot measure the input sensitivity: {err}") from None


def with_conditioning(scene: Scene, plan: Plan) -> Plan:
    """``plan`` with its input sensitivity (measured unless the plan carries it) and its method error
    including the method's own round-off carried through that sensitivity (_with_roundoff).

    The input-sensitivity floor is a statement about the problem, not a term of this run's error (the
    run starts from the same floats as any reference): it is announced, and when it exceeds the target
    the plan says the inputs are ill-conditioned, but while the response stays linear the run's own error
    is still its method error (its rounding carried through the same growth). Past the linear regime the
    run's error is decided by how its rounding falls and no tight bound exists: the prediction becomes
    max(method error, floor, SPREAD_SAFETY × the spread of five runs one ulp apart). A θ0 the scene
    wrapped into (-π, π] is said first in the reason, and the wrap's rounding, an input error this run has
    and an unwrapped reference has not, is added to the prediction through the run's response to θ0
    (wrap_effect)."""
    if plan.sensitivity is None:
        # only a fixed step without a pilot adds the measured round-off (_with_roundoff): a closed form's
        # bound is a priori, an adaptive plan's K holds its rounding
        noise = plan.method != CLOSED_FORM_METHOD and plan.rtol is None
        plan = _with_roundoff(scene, plan, measure_sensitivity(scene, plan, noise=noise))
    sensitivity = plan.sensitivity
    assert sensitivity is not None  # set by _with_roundoff
    predicted = plan.method_error
    # A step-halving pilot whose two runs come out identical (a table denser than half a step: the runs
    # stop at every breakpoint whatever h) reads 0 and sees neither truncation nor rounding: the
    # prediction is then the worst-case rounding of every step, never 0.
    if plan.dt is not None and plan.halving_difference == 0.0:
        predicted = max(predicted, stepping_roundoff(scene, plan.dt))
    if sensitivity.ill_conditioned and not sensitivity.linear:
        predicted = max(predicted, sensitivity.floor, SPREAD_SAFETY * sensitivity.spread)
    driven = scene.profile.constant_pieces(0.0, scene.duration) is None
    note = scene.wrap_note()
    wrap = wrap_effect(scene, sensitivity)
    if note:  # the run starts from the wrapped θ0: its rounding is an input error of this run
        predicted += wrap
        note = f"{note}, its rounding moves θ by ≤ {wrap:.1e} rad"
    predicted += level_effect(scene, sensitivity)  # a grade's level problem, rounded (0 on a level road)
    reason = f"{note}; {plan.reason}" if note and not plan.reason.startswith(note) else plan.reason
    return replace(plan, predicted_error=predicted, driven=driven, reason=reason)


def wrap_effect(scene: Scene, sensitivity: Sensitivity) -> float:
    """max_t |∂θ/∂θ0| |δθ0| = S_θ0 · |δθ0| / ulp(θ0): the wrap's rounding δθ0 (Scene.wrap_error, ≤ ½ ulp)
    carried through the run's measured response to θ0 (peaks[0] per units[0]); 0 when θ0 was not wrapped.
    Past the linear regime S is the one-ulp runs' own difference, still the response to a shift ≤ 1 ulp."""
    shift = scene.wrap_error()
    if shift == 0.0:
        return 0.0
    return sensitivity.peaks[0] * shift / sensitivity.units[0]


def level_effect(scene: Scene, sensitivity: Sensitivity) -> float:
    """What the rounding of a grade's level problem (Scene.on_level: g cos β, a(t) + g sin β) moves θ by:
    r (1 + S_θ0/ulp(θ0) + ω sin(A/2) T), 0 on a level road.

    g_l = fl(g fl(cos β)) is within 2ε g_l of g cos β (libm's cos ≤ 1 ulp, one product); c = g sin β
    likewise within 2ε|c|, and a + c rounds by ε/2 (|a| + |c|) more. r = (δg + δa)/g_l bounds the relative
    change of √(g_l² + a_l²) and the shift of θ_eq = atan2(a_l, g_l). For a constant a_l: φ'' = −ω² sin φ
    only rescales time when ω² does, so θ moves by the θ_eq shift itself, by the start's φ0 = θ0 − θ_eq
    moving as much (the run's measured response to θ0, S per ulp) and by max|φ'| T δω/ω ≤ 2ω sin(A/2) T r/2
    (A the libration amplitude). A varying a(t) or damping: the same with sin(A/2) ≤ 1 and ω at max |a|.
    """
    if scene.grade == 0.0:
        return 0.0
    level = scene.on_level()
    g_level = level.pendulum.gravity
    offset = abs(scene.pendulum.gravity * math.sin(scene.grade))
    a_max = scene.profile.max_abs(0.0, scene.duration)
    r = DOUBLE_EPS * (2.0 * g_level + 2.0 * offset + 0.5 * (a_max + offset)) / g_level
    pieces = level.profile.constant_pieces(0.0, scene.duration)
    half_swing, omega = 1.0, level.pendulum.omega(level.profile.max_abs(0.0, scene.duration))
    if pieces is not None and len(pieces) == 1 and level.pendulum.damping == 0.0:
        accel = pieces[0][2]
        amplitude = libration_amplitude(level.pendulum, accel, scene.theta0, scene.theta_dot0)
        half_swing, omega = math.sin(min(amplitude, math.pi) / 2.0), level.pendulum.omega(accel)
    response = sensitivity.peaks[0] / sensitivity.units[0]
    return r * (1.0 + response + omega * half_swing * scene.duration)


def stepping_roundoff(scene: Scene, dt: float) -> float:
    """N ε Θ: each of the N steps (T/dt, plus one per a(t) breakpoint, where the kernels restart a step)
    rounds θ by up to ε|θ|, Θ = max(π, |θ0| + |θ'0| T) (|θ| ≤ π while the bob librates), and in the worst
    case these add up. The pilot-blind case's floor (with_conditioning): a table of 10⁵ points measured
    2.0e-11 rad, under this 7e-11."""
    breaks = sum(1 for b in scene.profile.breakpoints() if 0.0 < b < scene.duration)
    steps = math.ceil(scene.duration / dt) + breaks
    return steps * DOUBLE_EPS * max(math.pi, abs(scene.theta0) + abs(scene.theta_dot0) * scene.duration)


def _with_roundoff(scene: Scene, plan: Plan, sensitivity: Sensitivity) -> Plan:
    """``plan`` with ``sensitivity`` and method_error = its error estimate with its own round-off.

    Closed form: the evaluation-path bound plus START_SAFETY × the start's rounding carried through S(t)
    (closed_form_start_error). Stepped with a halving pilot: the Richardson estimate of truncation,
    PILOT_SAFETY_FIXED |θ_h − θ_{h/2}| 2^p/(2^p − 1), which holds the run's rounding too while truncation
    dominates. When the halving difference is rounding (_rounding_dominated) the truncation at h is taken
    from the doubling above instead, PILOT_SAFETY_FIXED |θ_{2h} − θ_h| / (2^p − 1), plus ROUNDOFF_SAFETY ×
    the round-off: the larger of the measured one (input-nudged runs, conditioning) and |θ_h − θ_{h/2}|/√2,
    two realisations of the rounding on different step grids (which also holds the rounding of t and a(t)
    that input nudges leave alike). Other fixed steps: their a-priori error plus the round-off term;
    adaptive plans as they are (their pilot pair's K holds their rounding).
    """
    noise = sensitivity.noise if math.isfinite(sensitivity.noise) else 0.0
    error = plan.predicted_error
    if plan.method == CLOSED_FORM_METHOD:
        error += START_SAFETY * _start_rounding_effect(scene, sensitivity)
    elif math.isfinite(plan.halving_difference):
        order = FIXED_STEP_ORDER[plan.method][0]
        richardson = PILOT_SAFETY_FIXED * 2.0**order / (2.0**order - 1.0)
        if _rounding_dominated(plan, sensitivity.noise):
            # rounding hides the truncation at h: take it from the doubling above, 2^p-fold larger there
            coarse = plan.coarse_difference if math.isfinite(plan.coarse_difference) else 0.0
            error += PILOT_SAFETY_FIXED * coarse / (2.0**order - 1.0) - richardson * plan.halving_difference
            error += ROUNDOFF_SAFETY * max(noise, plan.halving_difference / math.sqrt(2.0))
    elif plan.rtol is None:  # adaptive plans: the pilot pair's K was measured with their rounding in it
        error += ROUNDOFF_SAFETY * noise
    return replace(plan, method_error=error, predicted_error=error, sensitivity=sensitivity)


def _start_rounding_effect(scene: Scene, sensitivity: Sensitivity) -> float:
    """max |Δθ| from the closed form's rounding of m1 at the start: S_i |δm1| / (|∂m1/∂x_i| ulp_i), x_i the
    input through which an ulp moves m1 most (0 away from the separatrix, |m1| ≥ START_NEAR_SEPARATRIX)."""
    pieces = _closed_form_pieces(scene)
    if pieces is None:
        return 0.0
    p, accel = scene.pendulum, pieces[0][2]
    start = OrbitStart.from_state(p, accel, scene.theta0, scene.theta_dot0)
    if abs(start.m1) >= START_NEAR_SEPARATRIX:
        return 0.0
    per_ulp = (
        abs(start.c * start.s) * sensitivity.units[0],  # ∂m1/∂θ0 = -c s   (m1 = c² − h², c = cos(φ0/2))
        abs(start.h) / start.omega * sensitivity.units[1],  # ∂m1/∂θ'0 = -h/ω  (h = θ'0/2ω)
    )
    which = int(np.argmax(per_ulp))
    if per_ulp[which] == 0.0:
        return 0.0
    delta = closed_form_start_error(p, accel, scene.theta0, scene.theta_dot0)
    return sensitivity.peaks[which] * delta / per_ulp[which]


def closed_form_start_error(pendulum: Pendulum, accel: float, theta0: float, theta_dot0: float) -> float:
    """|m1 − m1*|: physics.exact's rounding of m1 = (c − |h|)(c + |h|) at the start, against m1* formed
    from the same floats in extended precision (numpy longdouble); where longdouble is plain double, the
    worst case ε (c + |h|)(2c + 3|h| + |s| (|φ0| + |θ_eq|)) of the rounding path instead."""
    start = OrbitStart.from_state(pendulum, accel, theta0, theta_dot0)
    if np.finfo(np.longdouble).eps >= DOUBLE_EPS:
        c, h, s = start.c, abs(start.h), abs(start.s)
        tilt = abs(pendulum.equilibrium_angle(accel))
        return 0.5 * DOUBLE_EPS * (c + h) * (2.0 * c + 3.0 * h + s * (abs(theta0 - tilt) + tilt))
    g, a = np.longdouble(pendulum.gravity), np.longdouble(accel)
    omega = np.sqrt(np.sqrt(g * g + a * a) / np.longdouble(pendulum.length))
    half = 0.5 * (np.longdouble(theta0) - np.arctan2(a, g))
    c_exact = abs(np.cos(half))
    h_exact = abs(0.5 * np.longdouble(theta_dot0) / omega)
    m1_exact = (c_exact - h_exact) * (c_exact + h_exact)
    return float(abs(np.longdouble(start.m1) - m1_exact))


def _plan(scene: Scene) -> Plan:
    """Rules 1-6 of the module docstring."""
    target = scene.accuracy
    if scene.model is not None:
        return _forced(scene)
    if scene.wants_stretch:
        return _stepped(_setup(scene, "elastic"), "elastic", target, 0.0, "the outputs ask for the stretch")
    string_error = rigid_string_error(scene)
    if string_error > 0.5 * target:
        why = (
            f"ignoring the stretch δ = g_eff m/k would cost ≈ {string_error:.1e} rad, over half the target, "
            f"so the elastic string"
        )
        return _stepped(_setup(scene, "elastic"), "elastic", target, 0.0, why)
    budget = target - string_error
    setup = _setup(scene)
    pieces = _closed_form_pieces(scene)
    if pieces is not None:
        linear = _closed_form(setup, pieces, "linear", string_error)
        if linear.predicted_error <= target:
            return linear
        exact = _closed_form(setup, pieces, "exact", string_error)
        rejected = f"; linear rejected, its bound {linear.predicted_error:.1e} rad exceeds the target"
        return _replace_reason(exact, exact.reason + rejected)
    why = (
        f"damping c = {scene.pendulum.damping:g} 1/s rules out the closed forms"
        if scene.pendulum.damping != 0.0
        else f"a(t) ({scene.profile.kind}) is not piecewise constant, so no closed form"
    )
    return _stepped(setup, "rigid", budget, string_error, why)


def _replace_reason(plan: Plan, reason: str) -> Plan:
    """``plan`` with a new reason."""
    return replace(plan, reason=reason)


def rigid_string_error(scene: Scene) -> float:
    """Angle error of the rigid model on an elastic string ≈ (δ/l)(1 + A ωT), δ = g_eff m / k (0 if rigid).

    The static stretch δ lengthens the pendulum by δ/l relatively, shifting ω by δ/(2l) and the phase by
    A ωT δ/(2l); measured 2.4e-5 rad for k = 1e5 N/m, a = 2, A = 0.1, ωT = 6.3, within the formula's 1.6e-4.
    """
    p = scene.pendulum
    if p.stiffness is None:
        return 0.0
    a_max = scene.profile.max_abs(0.0, scene.duration)
    stretch = p.effective_gravity(a_max) * p.mass / p.stiffness
    omega = p.omega(a_max)
    amplitude = min(math.pi, abs(scene.theta0 - p.equilibrium_angle(float(scene.profile(0.0)))))
    amplitude += abs(scene.theta_dot0) / omega
    return stretch / p.length * (1.0 + amplitude * omega * scene.duration)


def _closed_form_pieces(scene: Scene) -> list[Piece] | None:
    """The constant pieces of a(t) on [0, T] when undamped, else None."""
    if scene.pendulum.damping != 0.0:
        return None
    return scene.profile.constant_pieces(0.0, scene.duration)


def closed_form_roundoff(
    pendulum: Pendulum, accel: float, theta0: float, theta_dot0: float, span: float
) -> float:
    """Round-off bound of the exact closed form over one piece: EXACT_ROUNDOFF ε (Θ + 2kω span)(1 + n/32).

    From the evaluation path (physics.exact): the elliptic argument u = ωt + u0 (or ζ, its Fourier
    phase) carries a relative error of a few ε, i.e. ε·2kω·span absolutely, and φ moves by at most
    |dφ/du| = 2k per unit of u; θ = θ0 + (φ − φ0) adds ε·Θ, Θ = the largest |θ| on the piece (|θ0| + the
    libration range 2A, or + 2kω·span for a rotation). Near the separatrix the argument is halved n times
    to |v| ≤ 1e-3 and doubled back (n = log2(K/1e-3), K the quarter period), each doubling adding its own
    rounding: the factor (1 + n/32) (measured: far less than one ε per doubling). The start's own
    rounding (m1 from θ0, θ'0) is closed_form_start_error's, carried through the measured sensitivity.
    """
    start = OrbitStart.from_state(pendulum, accel, theta0, theta_dot0)
    k = math.sqrt(start.m)
    rate = 2.0 * k * start.omega  # max |φ'| on the orbit (libration and rotation alike)
    amplitude = libration_amplitude(pendulum, accel, theta0, theta_dot0)
    swing = 2.0 * amplitude if math.isfinite(amplitude) else rate * span + 2.0 * math.pi
    big_theta = abs(theta0) + abs(pendulum.equilibrium_angle(accel)) + swing
    doublings = 0
    if start.m >= 1e-24 and start.m1 != 0.0:
        # libration: K(m) from m1, K' from m; rotation: parameter 1/m, complement -m1/m (physics.exact)
        m1, m = (start.m1, start.m) if start.m1 > 0.0 else (-start.m1 / start.m, 1.0 / start.m)
        quarter = complete_k(m1)
        if nome(quarter, complete_k(m)) > FOURIER_MAX_NOME:
            doublings = max(0, math.ceil(math.log2(0.5 * quarter / 1e-3)))
    return EXACT_ROUNDOFF * DOUBLE_EPS * (big_theta + rate * span) * (1.0 + doublings * DOUBLING_SHARE)


def _closed_form(setup: _Setup, pieces: list[Piece], model: str, extra: float) -> Plan:
    """Closed-form plan with its predicted error: linear bound or exact round-off, per piece (rule 3)."""
    p = setup.pendulum
    th, w = setup.scene.theta0, setup.scene.theta_dot0
    linear_sum = 0.0
    exact_sum = 0.0
    omegas = []
    for index, (start, end, a) in enumerate(pieces):
        span = end - start
        omega = p.omega(a)
        omegas.append(omega)
        amplitude = libration_amplitude(p, a, th, w)
        linear_sum += linear_error_bound(p, a, amplitude, span) if math.isfinite(amplitude) else math.inf
        exact_sum += closed_form_roundoff(p, a, th, w, span)
        if index == len(pieces) - 1:
            break  # the last piece's end state starts nothing
        th_end, w_end = exact_solution(p, a, th, w, np.array([span]))
        th, w = float(th_end[0]), float(w_end[0])
    n = len(pieces)
    shape = "constant" if n == 1 else f"piecewise constant ({n} pieces)"
    cpu = CLOSED_FORM_SAMPLE_S[model] * setup.samples
    if model == "linear":
        carry = 1.0 if n == 1 else LINEAR_CARRY * max(omegas) / min(omegas)
        predicted = min(linear_sum * carry, math.inf) + exact_sum + extra
        why = f"a(t) is {shape} and undamped, and the small-angle bound meets the target: linear closed form"
    else:
        predicted = exact_sum + extra
        chained = "" if n == 1 else " chained over the pieces"
        why = f"a(t) is {shape} and undamped: exact closed form{chained}"
    return Plan(model, CLOSED_FORM_METHOD, None, None, predicted, why, setup.scene.accuracy, cpu)


def _first_step(setup: _Setup, model: str, method: str, budget: float) -> float:
    """A-priori h = (budget / (C (1 + ωT)))^(1/p) / ω, hω ≤ MAX_H_OMEGA, h ω_fast ≤ 0.8 stability limit."""
    order, const = FIXED_STEP_ORDER[method]
    h_omega: float = (budget * (1.0 - ROUND_SLACK) / (const * setup.omega_t)) ** (1.0 / order)
    h = min(h_omega, MAX_H_OMEGA.get(method, DEFAULT_MAX_H_OMEGA)) / setup.omega
    limit = stability_limit(method)
    if limit is not None and limit > 0.0:
        h = min(h, STABILITY_FRACTION * limit / setup.omega_fast)
    return h


def _effective_step(setup: _Setup, dt: float) -> tuple[float, int]:
    """(h, steps): the integrator shortens dt to fill each sample interval with whole steps."""
    interval = setup.duration / max(setup.samples - 1, 1)
    per_interval = max(1, math.ceil(interval / dt * (1.0 - 1e-12)))
    return interval / per_interval, per_interval * max(setup.samples - 1, 1)


def _step_cost(setup: _Setup, model: str, method: str, steps: int) -> float:
    """Estimated CPU seconds: steps × the measured cost of a compiled (or numpy-loop) step."""
    if model in COMPILED_MODELS:
        return KERNEL_STEP_S[(model, "rk8" if method == "rk8" else "rk4")] * steps
    order = FIXED_STEP_ORDER[method][0]
    return PYTHON_STEP_S * steps * (3.0 if order == 8 else 1.0)


def _pilot_fixed(
    setup: _Setup, model: str, method: str, dt: float, budget: float, adjust: bool
) -> tuple[float, float, np.ndarray, np.ndarray | None]:
    """(predicted error, dt, θ_h, D_h): error of θ_h ≈ PILOT_SAFETY_FIXED |θ_h − θ_{h/2}| 2^p/(2^p − 1), on
    the scene; θ_h is the run at the returned dt (the plan's own run, reused by the conditioning runs) and
    D_h = [∂θ_h/∂θ0, ∂θ_h/∂θ'0] its variational solution, from the same run (None where the method has
    none compiled: the conditioning then nudges the inputs).

    With ``adjust`` the step shrinks by (prediction/budget)^(1/p) (at least ½) until the prediction meets
    the budget, at most PILOT_ROUNDS times, or until shrinking stops paying (round-off).
    """
    scene = setup.scene
    order = FIXED_STEP_ORDER[method][0]
    richardson = PILOT_SAFETY_FIXED * 2.0**order / (2.0**order - 1.0)
    runs = setup.runs(model, method)
    variational = runs is not None and runs.variational

    def theta(h: float) -> np.ndarray:
        """θ at the sample times, stepped with h."""
        return setup.theta(model, method, h)

    def with_derivative(h: float) -> tuple[np.ndarray, np.ndarray | None]:
        """(θ, D) at the sample times, stepped with h; D None without a compiled variational run."""
        if runs is None or not variational:
            return theta(h), None
        return runs.tangent(scene.theta0, scene.theta_dot0, h)

    def done(predicted: float, h: float, run: np.ndarray, derivative: np.ndarray | None) -> tuple[
        float, float, np.ndarray, np.ndarray | None
    ]:  # fmt: skip
        """The pilot's answer, the variational run made now if the run at h was a plain one."""
        if derivative is None and variational:
            run, derivative = with_derivative(h)  # θ bit for bit the same: only D is new
        return predicted, h, run, derivative

    dt, _ = _effective_step(setup, dt)  # so that dt/2 really halves the step taken
    coarse, slope = with_derivative(dt)
    best = (math.inf, dt, coarse, slope)
    for _ in range(PILOT_ROUNDS):
        fine = theta(0.5 * dt)
        predicted = richardson * float(np.max(np.abs(coarse - fine)))
        if predicted > 0.5 * best[0]:
            return done(*best)  # round-off: a smaller step no longer buys accuracy
        if predicted > PILOT_NO_CONVERGENCE:
            return done(predicted, dt, coarse, slope)  # θ moves by radians: chaos, no step will converge
        best = (predicted, dt, coarse, slope)
        if not adjust or predicted <= budget:
            return done(*best)
        _, half_steps = _effective_step(setup, 0.5 * dt)
        dt, steps = _effective_step(setup, dt / max(2.0, 1.1 * (predicted / budget) ** (1.0 / order)))
        # a plain halving: that run is done already (without its variational part)
        coarse, slope = (fine, None) if steps == half_steps else with_derivative(dt)
    return done(*best)


def _fixed_step(
    setup: _Setup, model: str, method: str, budget: float, extra: float, why: str, dt: float | None = None
) -> Plan:
    """Fixed step of ``method``: the first step of rule 5 (or the given dt), piloted for compiled models."""
    given = dt is not None
    if dt is None:
        dt = _first_step(setup, model, method, budget)
    elif not (math.isfinite(dt) and dt > 0.0):
        raise SceneError(f"dt must be a finite step > 0 s, got {dt!r}")
    elif (steps := _effective_step(setup, dt)[1]) > MAX_FIXED_STEPS:
        raise SceneError(
            f"dt = {dt:g} s needs {steps:.2g} steps over {setup.duration:g} s, more than "
            f"{MAX_FIXED_STEPS:.0e}; use a larger dt"
        )
    run: np.ndarray | None = None
    derivative: np.ndarray | None = None
    if model in COMPILED_MODELS:
        error, dt, run, derivative = _pilot_fixed(setup, model, method, dt, budget, adjust=not given)
        h, steps = _effective_step(setup, dt)
        detail = f"{method} with hω = {h * setup.omega:.1e} ({steps} steps), error from a step-halving pilot"
    else:
        order, const = FIXED_STEP_ORDER[method]
        h, steps = _effective_step(setup, dt)
        error = const * (h * setup.omega_fast) ** order * setup.omega_fast_t
        detail = f"{method} with hω = {h * setup.omega_fast:.1e} ({steps} steps)"
    cpu = _step_cost(setup, model, method, steps)
    plan = Plan(model, method, dt, None, error + extra, f"{why}; {detail}", setup.scene.accuracy, cpu)
    if model not in COMPILED_MODELS:
        return plan
    order = FIXED_STEP_ORDER[method][0]
    difference = error / (PILOT_SAFETY_FIXED * 2.0**order / (2.0**order - 1.0))
    assert run is not None  # the pilot's run at the plan's step
    coarse = _coarse_difference(setup, model, method, h, run)
    plan = replace(plan, halving_difference=difference, coarse_difference=coarse)
    # Only a rounding-dominated halving (or one with no doubling to test it against) uses the round-off.
    noise = _rounding_dominated(plan, math.nan) or not math.isfinite(coarse)
    runs = setup.runs(model, method)
    sensitivity = measure_sensitivity(setup.scene, plan, run, noise, derivative, runs)
    return _with_roundoff(setup.scene, plan, sensitivity)


def _coarse_difference(setup: _Setup, model: str, method: str, h: float, run: np.ndarray) -> float:
    """max |θ_{2h} − θ_h| on every other sample time: the truncation one doubling above the plan's step,
    where it stands clear of rounding when the halving below it (h against h/2) does not (NaN if 2h
    would be unstable). θ_h is the pilot's ``run`` at every sample, taken at every other one (a run on
    those times alone differs from it by rounding only)."""
    limit = stability_limit(method)
    if run.size < 3 or (limit is not None and 2.0 * h * setup.omega_fast > STABILITY_FRACTION * limit):
        return math.nan  # 2h would step past the stiff mode's stability: no truncation to read there
    doubled = setup.theta(model, method, 2.0 * h, stride=2)
    return float(np.max(np.abs(doubled - run[::2])))


def _rounding_dominated(plan: Plan, noise: float) -> bool:
    """The halving difference is rounding, not truncation: within HALVING_NOISE × the measured round-off
    ``noise`` (when measured), or the doubling difference is under 2^(p − DOUBLING_SLACK) times it (a
    truncation would have grown 2^p-fold); False without a halving difference."""
    if not math.isfinite(plan.halving_difference):
        return False
    if math.isfinite(noise) and plan.halving_difference <= HALVING_NOISE * noise:
        return True
    order = FIXED_STEP_ORDER[plan.method][0]
    return plan.coarse_difference < 2.0 ** (order - DOUBLING_SLACK) * plan.halving_difference


def _stepped(setup: _Setup, model: str, budget: float, extra: float, why: str) -> Plan:
    """Rule 5: the cheaper of RK4 and RK8 at their first steps, piloted; the other one if it fails the budget.

    An elastic string so stiff that fixed steps would exceed MAX_FIXED_STEPS goes to LSODA (rule 6).
    """
    target = setup.scene.accuracy
    costs = {}
    for method in STEPPED_METHODS:
        _, steps = _effective_step(setup, _first_step(setup, model, method, budget))
        costs[method] = (_step_cost(setup, model, method, steps), steps)
    if model == "elastic" and min(steps for _, steps in costs.values()) > MAX_FIXED_STEPS:
        # ω_r so far above the swing that even RK8 would take millions of steps: BDF steps over it.
        return _adaptive(setup, model, "LSODA", target, f"{why}; too stiff for fixed steps", extra)
    order = sorted(STEPPED_METHODS, key=lambda m: costs[m][0])
    first = _fixed_step(setup, model, order[0], budget, extra, why)
    if first.predicted_error <= target:
        other = f"{order[1]} (est. {costs[order[1]][0]:.2g} s)"
        return _replace_reason(first, f"{first.reason}, cheaper than {other}")
    second = _fixed_step(setup, model, order[1], budget, extra, why)
    if second.predicted_error <= target:
        return _replace_reason(second, f"{second.reason}, {order[0]} cannot promise the target")
    best = min((first, second), key=lambda p: p.predicted_error)
    if extra > 0.5 * target:  # the model's own error, not the method's, is what misses
        return _replace_reason(
            best, f"{best.reason}; the rigid model ignores the string's stretch, ≈ {extra:.1e} rad here"
        )
    if best.ill_conditioned:  # the runs differ by how rounding falls: no step size helps
        return _replace_reason(best, f"{best.reason}; no step meets the target: the inputs do not fix θ")
    noise = best.sensitivity.noise if best.sensitivity is not None else math.nan
    floor = f" (its measured round-off on this trajectory: {noise:.1e} rad)" if math.isfinite(noise) else ""
    return _replace_reason(
        best, f"{best.reason}; the target is below what {best.method} in double precision can promise{floor}"
    )


def pilot_error_constant(setup: _Setup, model: str, method: str) -> float:
    """K in err ≈ K rtol (1 + ωT): 10 × |θ(rtol 1e-6) − θ(rtol 1e-9)| / (1e-6 (1 + ωT)), at least K_FLOOR."""
    scene = setup.scene
    t = np.linspace(0.0, setup.duration, min(setup.samples, PILOT_POINTS))
    runs = [
        simulate(setup.pendulum, setup.profile, t, theta0=scene.theta0, theta_dot0=scene.theta_dot0,
                 model=model, method=method, rtol=rtol).theta
        for rtol in PILOT_RTOLS
    ]  # fmt: skip
    error = float(np.max(np.abs(runs[0] - runs[1])))
    return max(K_FLOOR, PILOT_SAFETY * error / (PILOT_RTOLS[0] * setup.omega_t))


def _adaptive(
    setup: _Setup,
    model: str,
    method: str,
    target: float,
    why: str,
    extra: float = 0.0,
    rtol: float | None = None,
) -> Plan:
    """rtol = budget / (K (1 + ωT)) or the given rtol; K from the pilot pair; within RTOL_RANGE (rule 6)."""
    budget = target - extra
    k = pilot_error_constant(setup, model, method)
    if rtol is None:
        # Never looser than the pilot's own rtol: K is measured there, and above it the error grew
        # faster than linearly (LSODA on the stiff string: 1.2e-4 rad at rtol 3e-4 against a 1e-4 plan).
        loosest = min(RTOL_RANGE[1], PILOT_RTOLS[0])
        rtol = min(max(budget / (k * setup.omega_t) * (1.0 - ROUND_SLACK), RTOL_RANGE[0]), loosest)
    elif not (math.isfinite(rtol) and rtol > 0.0):
        raise SceneError(f"rtol must be a finite tolerance > 0, got {rtol!r}")
    predicted = k * rtol * setup.omega_t + extra
    calls = ADAPTIVE_CALLS * setup.omega_t * rtol ** (-1.0 / 8.0)
    cpu = ADAPTIVE_CALL_S * calls
    detail = f"{method} with K = {k:.2g} from a pilot pair"
    return Plan(model, method, None, rtol, predicted, f"{why}; {detail}", target, cpu)


def _forced(scene: Scene) -> Plan:
    """Rule 1: the scene's forced model (and method, or the rule's method for it)."""
    model = scene.model or "rigid"
    target = scene.accuracy
    why = f"model {model} forced by the scene"
    if model in ("exact", "linear"):
        pieces = _closed_form_pieces(scene)
        if pieces is None:  # Scene validation rejects this; kept for scenes built by replace()
            raise SceneError(f"force.model: {model} needs an undamped, piecewise-constant scene")
        plan = _closed_form(_setup(scene), pieces, model, rigid_string_error(scene))
        return _replace_reason(plan, why)
    setup = _setup(scene, model)
    extra = rigid_string_error(scene) if model in ("rigid", "multiplier") else 0.0
    # A forced rigid model can ignore more stretch than the target allows: the plan then says TARGET NOT
    # MET, and the method still aims at half the target rather than at a negative budget.
    budget = max(target - extra, 0.5 * target)
    method = scene.method
    if method is None:
        if model == "multiplier":
            return _adaptive(setup, model, "DOP853", target, why, extra)
        return _stepped(setup, model, budget, extra, why)
    why = f"model {model} and method {method} forced by the scene"
    if method in FIXED_STEP_METHODS:
        dt = _first_step(setup, model, method, budget)
        if (steps := _effective_step(setup, dt)[1]) > MAX_FIXED_STEPS:
            # Checked before any stepping: a low-order method at a tight target would run for hours.
            raise SceneError(
                f"method {method} at a {target:g} rad target needs {steps:.2g} steps over "
                f"{setup.duration:g} s, more than {MAX_FIXED_STEPS:.0e}; loosen accuracy or use rk4/rk8"
            )
        return _fixed_step(setup, model, method, budget, extra, why)
    return _adaptive(setup, model, method, target, why, extra)


def plan_with(
    scene: Scene,
    *,
    model: str | None = None,
    method: str | None = None,
    dt: float | None = None,
    rtol: float | None = None,
) -> Plan:
    """The plan for ``scene`` with the user's model/method/dt/rtol; the error prediction follows them.

    A method, dt or rtol without a model forces the rigid model (elastic when the stretch is asked for);
    ``dt`` alone switches to RK4 and ``rtol`` alone to the adaptive default when the plan had the other kind.
    """
    if dt is not None and rtol is not None:
        raise SceneError("give --dt (fixed-step methods) or --rtol (adaptive methods), not both")
    scene = scene.on_level()
    stepping = method is not None or dt is not None or rtol is not None
    if model is not None or stepping:
        if model is None and scene.model is None and method != CLOSED_FORM_METHOD:
            model = "elastic" if scene.wants_stretch else "rigid"
        scene = replace(scene, model=model or scene.model, method=method or scene.method)
    base = _plan_method(scene)
    if dt is None and rtol is None:
        return with_conditioning(scene, base)
    if base.model in ("exact", "linear"):
        raise SceneError(f"model {base.model} is a closed form: it takes no --dt or --rtol")
    setup = _setup(scene, base.model)
    extra = rigid_string_error(scene) if base.model != "elastic" else 0.0
    why = f"{base.model} model, step settings given by the user"
    if dt is not None:
        chosen = base.method if base.method in FIXED_STEP_METHODS else None
        if chosen is None and method is not None:
            raise SceneError(
                f"--dt applies to fixed-step methods ({', '.join(FIXED_STEP_METHODS)}), not {method}"
            )
        given = _fixed_step(setup, base.model, chosen or "rk4", scene.accuracy - extra, extra, why, dt=dt)
        return with_conditioning(scene, given)
    chosen = None if base.method in FIXED_STEP_METHODS else base.method
    if chosen is None and method is not None:
        raise SceneError(f"--rtol applies to adaptive methods, not {method}")
    default = "LSODA" if base.model == "elastic" else "DOP853"
    given = _adaptive(setup, base.model, chosen or default, scene.accuracy, why, extra, rtol=rtol)
    return with_conditioning(scene, given)
