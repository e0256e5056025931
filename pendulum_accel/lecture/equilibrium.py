"""Result 1: under constant acceleration the bob settles at tan θ = a/g with tension T = m √(g² + a²).

The simulator is run with damping from the bob hanging straight down (θ = 0) until the swing
has died out; the settled angle and the model's tension are compared with the lecture.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from pendulum_accel.lecture import formulas
from pendulum_accel.lecture.progress import progress
from pendulum_accel.lecture.report import SIGN_NOTE, Comparison, LectureReport
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Constant
from pendulum_accel.physics.simulate import simulate

NAME = "equilibrium"
SUMMARY = "equilibrium angle tan θ = a/g and tension T = m √(g² + a²) against a sweep of constant a"

LENGTH = 1.0  # m
MASS = 1.0  # kg
# c = 4/s decays the swing as e^(−2t): after SETTLE the residual is e^(−30), far below the tolerance.
DAMPING = 4.0  # 1/s
SETTLE = 15.0  # s
A_MAX = 15.0  # m/s², ±1.5 g: beyond any car, still where the lecture's formulas hold
TRACE_ACCELS = (-10.0, 3.0, 12.0)
TOL_ANGLE = 1e-6  # rad
TOL_TENSION = 1e-6  # N
RTOL, ATOL = 1e-10, 1e-12


def settled_state(p: Pendulum, accel: float, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """θ(t) and T(t) from the rigid model started at rest hanging straight down, a = const."""
    traj = simulate(p, Constant(accel), times, theta0=0.0, model="rigid", rtol=RTOL, atol=ATOL)
    if traj.tension is None:
        raise RuntimeError("rigid model returned no tension")
    return traj.theta, traj.tension


def run(quick: bool = False) -> LectureReport:
    """Sweep a, settle the damped pendulum, compare θ with atan(a/g) and T with m √(g² + a²)."""
    p = Pendulum(length=LENGTH, mass=MASS, damping=DAMPING)
    accels = np.linspace(-A_MAX, A_MAX, 5 if quick else 41)
    theta_sim = np.empty_like(accels)
    tension_sim = np.empty_like(accels)
    for i, a in enumerate(progress(accels, f"{NAME}: a sweep")):
        theta, tension = settled_state(p, float(a), np.array([0.0, SETTLE]))
        theta_sim[i], tension_sim[i] = theta[-1], tension[-1]
    theta_lec = formulas.equilibrium_angle(p, accels)
    tension_lec = formulas.rest_tension(p, accels)
    trace_t = np.linspace(0.0, 6.0, 601)
    traces = [(a, settled_state(p, a, trace_t)[0]) for a in TRACE_ACCELS]

    i_th = int(np.argmax(np.abs(theta_sim - theta_lec)))
    i_T = int(np.argmax(np.abs(tension_sim - tension_lec)))
    sweep = f"worst of {accels.size} values, at a = {accels[i_th]:+.2f} m/s²"
    comparisons = (
        Comparison(
            "θ_eq = atan(a/g)", "rad", float(theta_lec[i_th]), float(theta_sim[i_th]), TOL_ANGLE, sweep
        ),
        Comparison(
            "T = m √(g² + a²)",
            "N",
            float(tension_lec[i_T]),
            float(tension_sim[i_T]),
            TOL_TENSION,
            f"worst of {accels.size} values, at a = {accels[i_T]:+.2f} m/s²",
        ),
    )

    def draw(fig: Figure) -> None:
        """θ and T against a (formula line, simulated dots), their differences, settling traces."""
        fine = np.linspace(-A_MAX, A_MAX, 400)
        ax1, ax2, ax3, ax4 = fig.subplots(2, 2).ravel()
        ax1.plot(fine, np.degrees(formulas.equilibrium_angle(p, fine)), label="lecture: tan θ = a/g")
        ax1.plot(accels, np.degrees(theta_sim), "o", ms=4, label="simulated, settled")
        ax1.set(xlabel="car acceleration a [m/s²]", ylabel="θ_eq [deg]  (θ_lecture = −θ)")
        ax1.set_title("equilibrium angle", fontsize=10)
        ax2.plot(fine, formulas.rest_tension(p, fine), label="lecture: T = m √(g² + a²)")
        ax2.plot(accels, tension_sim, "o", ms=4, label="simulated tension")
        ax2.set(xlabel="car acceleration a [m/s²]", ylabel="string tension T [N]")
        ax2.set_title("tension at rest", fontsize=10)
        tiny = 1e-18  # keeps exact zeros visible on the log axis
        ax3.semilogy(accels, np.abs(theta_sim - theta_lec) + tiny, "o-", ms=3, label="|Δθ| [rad]")
        ax3.semilogy(accels, np.abs(tension_sim - tension_lec) + tiny, "s-", ms=3, label="|ΔT| [N]")
        ax3.axhline(TOL_ANGLE, color="k", ls=":", lw=1, label="tolerance")
        ax3.set(xlabel="car acceleration a [m/s²]", ylabel="|simulated − lecture|")
        ax3.set_title("difference", fontsize=10)
        for a, theta in traces:
            line = ax4.plot(trace_t, np.degrees(theta), label=f"a = {a:+.0f} m/s²")[0]
            ax4.axhline(np.degrees(formulas.equilibrium_angle(p, a)), color=line.get_color(), ls="--", lw=1)
        ax4.set(xlabel="time t [s]", ylabel="θ [deg]")
        ax4.set_title(f"settling from θ = 0 with damping c = {DAMPING:g}/s (dashed: atan(a/g))", fontsize=10)
        for ax in (ax1, ax2, ax3, ax4):
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=8)

    return LectureReport(
        name=NAME,
        title="equilibrium angle and tension under constant acceleration",
        formulas=("tan θ = a/g  (lecture: tan θ' = −a/g)", "T = m √(g² + a²)"),
        setup=(
            f"l = {LENGTH:g} m, m = {MASS:g} kg, damping c = {DAMPING:g}/s, "
            f"a from {-A_MAX:g} to {A_MAX:g} m/s² "
            f"({accels.size} values), rigid model from θ = 0 at rest, read at t = {SETTLE:g} s"
        ),
        comparisons=comparisons,
        notes=(SIGN_NOTE,),
        draw=draw,
    )
