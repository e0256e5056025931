"""Result 4: a string with V(r) = ½ k (r − l)² stretches by T/k and tends to the rigid pendulum as k → ∞.

"Not imposing the constraint too soon": the lecture keeps r free, derives the r equation
m r̈ = m r θ'² + m g cos θ + … − ∂V/∂r, and only then sets r = l. The stretch r − l → 0 as the
string stiffens while the force k (r − l) it carries tends to the rigid model's tension T,
and the swing converges to the rigid one with error ∝ 1/k.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from pendulum_accel.lecture import formulas
from pendulum_accel.lecture.progress import progress
from pendulum_accel.lecture.report import Comparison, LectureReport
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Constant
from pendulum_accel.physics.simulate import simulate

NAME = "elastic"
SUMMARY = "elastic string V(r) = ½ k (r − l)²: stretch ≈ T/k; converges to the rigid pendulum as k → ∞"

LENGTH = 1.0  # m
MASS = 1.0  # kg
ACCEL = 2.0  # m/s²
SWING = 0.3  # rad about θ_eq
DURATION = 3.0  # s, about five periods
DURATION_QUICK = 1.5  # s
K_MIN, K_MAX = 1e2, 1e6  # N/m: a soft rubber band up to a steel wire's order of magnitude
K_MAX_QUICK = 1e5
# The radial mode (√(k/m) up to 1000 rad/s) is oscillatory, not dissipative: DOP853 follows it
# several times faster than the implicit Radau that method "auto" picks for a stiff string.
METHOD = "DOP853"
SAMPLES = 1501
TOL_SLOPE = 0.25  # the convergence order 1/k: fitted log-log slope within ±0.25 of −1
TOL_ANGLE = 5e-4  # rad, at the stiffest string (≈ 1e-4 at 1e5 N/m, 1e-5 at 1e6 N/m)
TOL_STRETCH_REL = 1e-2  # stretch against T/k, relative, at the stiffest string
RTOL, ATOL = 1e-10, 1e-13


def run(quick: bool = False) -> LectureReport:
    """Simulate the elastic string for a sweep of k and the rigid model once; compare θ, stretch, tension."""
    stiffnesses = np.geomspace(K_MIN, K_MAX_QUICK, 3) if quick else np.geomspace(K_MIN, K_MAX, 9)
    rigid_p = Pendulum(length=LENGTH, mass=MASS)
    profile = Constant(ACCEL)
    duration = DURATION_QUICK if quick else DURATION
    t = np.linspace(0.0, duration, SAMPLES)
    theta0 = float(formulas.equilibrium_angle(rigid_p, ACCEL)) + SWING
    rigid = simulate(rigid_p, profile, t, theta0=theta0, model="rigid", rtol=RTOL, atol=ATOL)
    if rigid.tension is None:
        raise RuntimeError("the rigid model must return its tension")
    err_theta = np.empty_like(stiffnesses)
    err_tension = np.empty_like(stiffnesses)
    err_stretch = np.empty_like(stiffnesses)
    runs = []
    for i, k in enumerate(progress(stiffnesses, f"{NAME}: k sweep")):
        p = Pendulum(length=LENGTH, mass=MASS, stiffness=float(k))
        el = simulate(p, profile, t, theta0=theta0, model="elastic", method=METHOD, rtol=RTOL, atol=ATOL)
        if el.stretch is None or el.tension is None:
            raise RuntimeError("the elastic model must return stretch and tension")
        err_theta[i] = np.max(np.abs(el.theta - rigid.theta))
        err_tension[i] = np.max(np.abs(el.tension - rigid.tension))
        err_stretch[i] = np.max(np.abs(el.stretch - rigid.tension / k))
        runs.append(el)
    slope = float(np.polyfit(np.log(stiffnesses), np.log(err_theta), 1)[0])
    stiff = runs[-1]
    assert stiff.stretch is not None and stiff.tension is not None
    predicted = rigid.tension / stiffnesses[-1]
    i_s = int(np.argmax(np.abs(stiff.stretch - predicted)))
    comparisons = (
        Comparison(
            "convergence θ_elastic → θ_rigid ∝ 1/k (log-log slope)",
            "1",
            -1.0,
            slope,
            TOL_SLOPE,
            f"fit over k = {stiffnesses[0]:g} … {stiffnesses[-1]:g} N/m ({stiffnesses.size} values)",
        ),
        Comparison(
            "θ_elastic = θ_rigid",
            "rad",
            float(rigid.theta[int(np.argmax(np.abs(stiff.theta - rigid.theta)))]),
            float(stiff.theta[int(np.argmax(np.abs(stiff.theta - rigid.theta)))]),
            TOL_ANGLE,
            f"worst sample, k = {stiffnesses[-1]:g} N/m",
        ),
        Comparison(
            "stretch r − l = T/k",
            "m",
            float(predicted[i_s]),
            float(stiff.stretch[i_s]),
            TOL_STRETCH_REL * float(np.max(predicted)),
            f"worst sample, k = {stiffnesses[-1]:g} N/m",
        ),
    )
    notes = (
        f"at k = {stiffnesses[-1]:g} N/m the string stretches only {np.max(stiff.stretch) * 1e6:.1f} µm yet "
        f"carries k (r − l) up to {np.max(stiff.tension):.3f} N "
        f"(rigid T up to {np.max(rigid.tension):.3f} N)",
        f"max |Δθ| falls from {err_theta[0]:.2e} rad at k = {stiffnesses[0]:g} N/m "
        f"to {err_theta[-1]:.2e} rad at k = {stiffnesses[-1]:g} N/m",
    )

    def draw(fig: Figure) -> None:
        """Stretch and tension against time for a soft and a stiff string, errors against k."""
        ax1, ax2, ax3, ax4 = fig.subplots(2, 2).ravel()
        soft, k_soft = runs[0], stiffnesses[0]
        assert soft.stretch is not None and soft.tension is not None
        ax1.plot(t, soft.stretch * 1e3, label=f"elastic, k = {k_soft:g} N/m")
        ax1.plot(t, rigid.tension / k_soft * 1e3, "--", label="T_rigid / k")
        ax1.set(xlabel="time t [s]", ylabel="stretch r − l [mm]")
        ax1.set_title("stretch of a soft string", fontsize=10)
        ax2.plot(t, rigid.tension, label="rigid model T")
        ax2.plot(t, soft.tension, alpha=0.8, label=f"k (r − l), k = {k_soft:g} N/m")
        ax2.plot(t, stiff.tension, "--", label=f"k (r − l), k = {stiffnesses[-1]:g} N/m")
        ax2.set(xlabel="time t [s]", ylabel="tension [N]")
        ax2.set_title("tension: ∂V/∂r stays finite as r − l → 0", fontsize=10)
        ax3.loglog(stiffnesses, err_theta, "o-", label="max |θ_elastic − θ_rigid| [rad]")
        ax3.loglog(stiffnesses, err_tension, "s-", label="max |k (r − l) − T_rigid| [N]")
        ax3.loglog(stiffnesses, err_stretch, "^-", label="max |(r − l) − T_rigid/k| [m]")
        ax3.loglog(stiffnesses, err_theta[0] * stiffnesses[0] / stiffnesses, "k:", label="∝ 1/k")
        ax3.set(xlabel="string stiffness k [N/m]", ylabel="difference from rigid")
        ax3.set_title("convergence to the rigid pendulum", fontsize=10)
        ax4.plot(t, np.degrees(rigid.theta), label="rigid")
        ax4.plot(t, np.degrees(soft.theta), "--", label=f"elastic, k = {k_soft:g} N/m")
        ax4.set(xlabel="time t [s]", ylabel="θ [deg]")
        ax4.set_title("the swing", fontsize=10)
        for ax in (ax1, ax2, ax3, ax4):
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=8)

    return LectureReport(
        name=NAME,
        title="the elastic string and the rigid limit",
        formulas=(
            "L = ½ m (ṙ² + r² θ'²) + m g r cos θ + m a r sin θ − V(r),  V(r) = ½ k (r − l)²",
            "r: m r̈ = m r θ'² + m g cos θ + m a sin θ − ∂V/∂r;  r = l, ṙ = r̈ = 0 ⇒ T = ∂V/∂r = k (r − l)",
        ),
        setup=(
            f"l = {LENGTH:g} m, m = {MASS:g} kg, a = {ACCEL:g} m/s², "
            f"released at rest from θ_eq + {SWING:g} rad, "
            f"{duration:g} s; elastic model ({METHOD}) for k = {stiffnesses[0]:g} … {stiffnesses[-1]:g} N/m "
            f"({stiffnesses.size} values) "
            "against the rigid model"
        ),
        comparisons=comparisons,
        notes=notes,
        draw=draw,
    )
