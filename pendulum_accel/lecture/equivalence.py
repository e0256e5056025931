"""Result 7: a pendulum cannot tell acceleration from tilt (the equivalence principle, in a car).

On a road of grade β the car frame sees gravity tilted by β: θ'' = −(g cos β/l) sin θ + ((a + g sin β)/l)
cos θ (physics.rigid), so at rest tan θ = (a + g sin β)/(g cos β). A car at constant speed on the grade
(a = 0) and a level car accelerating at a = g tan β both settle at θ = β: the angle alone cannot tell
them apart, and a = g tan θ reads g tan β on the hill. What does tell them apart is the size of the
specific force, g on the hill against g sec β on the level: it sets the swing's period (ω² = g/l against
g sec β/l) and the string's tension at rest (m g against m g sec β), a second sensor. Rolling freely
downhill (a = −g sin β, speeding up) the specific force is perpendicular to the road, and the reading
is zero.
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure

from pendulum_accel.estimators import estimate_batch
from pendulum_accel.lecture import formulas
from pendulum_accel.lecture.measure import period
from pendulum_accel.lecture.progress import progress
from pendulum_accel.lecture.report import SIGN_NOTE, Comparison, LectureReport
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Constant
from pendulum_accel.physics.rigid import level_equivalent
from pendulum_accel.physics.simulate import simulate
from pendulum_accel.physics.trajectory import Trajectory
from pendulum_accel.recording.settings import estimator_options
from pendulum_accel.scene import load_scene
from pendulum_accel.scene_run import run_scene

NAME = "equivalence"
SUMMARY = "grade β and acceleration g tan β give one angle; the period and the tension tell them apart"

LENGTH = 1.0  # m
MASS = 1.0  # kg
GRADE = math.atan(0.1)  # rad: a 10 % grade, the bundled hill scene's
DAMPING = 4.0  # 1/s: settles the swing as e^(−2t), e^(−30) after SETTLE
SETTLE = 15.0  # s
SWING = 0.05  # rad: amplitude of the undamped swings whose periods are timed
SWING_TIME = 20.0  # s
ESTIMATOR = "kalman"
SETTLED = 10.0  # s: the estimator's reading is averaged over the scene's last SETTLED seconds
TOL_ANGLE = 1e-8  # rad
TOL_TENSION = 1e-8  # N
TOL_PERIOD = 1e-6  # s: zero crossings timed with the simulated rate are good to ~1e-9 s
TOL_READING = 0.01  # m/s²: the sensor noise (σ = 1e-3 rad) averaged over 1000 samples, with margin
RTOL, ATOL = 1e-11, 1e-13


def _run(p: Pendulum, accel: float, grade: float, t: np.ndarray, theta0: float) -> Trajectory:
    """Rigid-model run of a car at constant ``accel`` on ``grade`` (via physics.rigid.level_equivalent)."""
    level_p, profile = level_equivalent(p, Constant(accel), grade)
    return simulate(level_p, profile, t, theta0=theta0, model="rigid", rtol=RTOL, atol=ATOL)


def run(quick: bool = False) -> LectureReport:
    """Settle and swing the bob on the hill and on the level at g tan β; estimate on the hill scene."""
    del quick  # a handful of runs, each well under a second
    g = Pendulum(LENGTH).gravity
    beta = GRADE
    cases = {  # label: (a, β)
        "hill, constant speed": (0.0, beta),
        "level, a = g tan β": (g * math.tan(beta), 0.0),
        "downhill, rolling freely": (g * math.sin(beta), -beta),
    }
    settle_t = np.linspace(0.0, SETTLE, 1501)
    swing_t = np.linspace(0.0, SWING_TIME, 4001)
    damped = Pendulum(LENGTH, mass=MASS, damping=DAMPING)
    free = Pendulum(LENGTH, mass=MASS)
    settled: dict[str, Trajectory] = {}
    swings: dict[str, Trajectory] = {}
    for label in progress(cases, desc=NAME):
        a, b = cases[label]
        settled[label] = _run(damped, a, b, settle_t, 0.0)
        # released SWING rad beyond the steady angle β (or 0 downhill) and timed undamped
        swings[label] = _run(free, a, b, swing_t, float(settled[label].theta[-1]) + SWING)
    hill, level, down = cases
    tension = {k: float(v.tension[-1]) for k, v in settled.items() if v.tension is not None}

    scene = load_scene("hill")
    scene_run = run_scene(scene)
    settings = estimator_options(scene, ESTIMATOR)
    estimate, _ = estimate_batch(ESTIMATOR, scene_run.t, scene_run.theta_measured, **settings)
    tail = scene_run.t >= scene_run.t[-1] - SETTLED
    reading = float(np.mean(estimate[tail]))
    raw = g * np.tan(scene_run.theta_measured)

    def exact_period(label: str) -> float:
        """The lecture's period 4 K(sin²(A/2))/ω with ω² = |f|/l, |f| = √((a + g sin β)² + g² cos² β)."""
        a, b = cases[label]
        level_p, profile = level_equivalent(free, Constant(a), b)
        return float(formulas.exact_period(level_p, profile.scalar(0.0), SWING))

    def t_swing(label: str) -> float:
        """Period of the undamped swing of case ``label`` (lecture.measure.period)."""
        s = swings[label]
        return period(s.t, s.theta, s.theta_dot)

    comparisons = (
        Comparison("θ = β", "rad", beta, float(settled[hill].theta[-1]), TOL_ANGLE, f"on the {hill}"),
        Comparison("θ = atan(a/g) = β", "rad", beta, float(settled[level].theta[-1]), TOL_ANGLE, level),
        Comparison("θ = 0", "rad", 0.0, float(settled[down].theta[-1]), TOL_ANGLE, down),
        Comparison("T = m g", "N", MASS * g, tension[hill], TOL_TENSION, hill),
        Comparison("T = m g sec β", "N", MASS * g / math.cos(beta), tension[level], TOL_TENSION, level),
        Comparison("P = 4 K/ω, ω² = g/l", "s", exact_period(hill), t_swing(hill), TOL_PERIOD, hill),
        Comparison("P = 4 K/ω, ω² = g sec β/l", "s", exact_period(level), t_swing(level), TOL_PERIOD, level),
        Comparison(
            "â = g tan β",
            "m/s²",
            g * math.tan(beta),
            reading,
            TOL_READING,
            f"{ESTIMATOR} on the hill scene (true a = 0), mean of the last {SETTLED:g} s",
        ),
    )

    def draw(fig: Figure) -> None:
        """Settling on hill and level; the swings' periods; the hill scene's readings; the two sensors."""
        ax1, ax2, ax3, ax4 = fig.subplots(2, 2).ravel()
        for label, traj in settled.items():
            ax1.plot(traj.t, np.degrees(traj.theta), label=label)
        ax1.axhline(math.degrees(beta), color="k", ls=":", lw=1, label="β")
        ax1.set(xlabel="time t [s]", ylabel="θ [deg]")
        ax1.set_title(f"settling (damping c = {DAMPING:g}/s): hill and level agree", fontsize=10)
        for label in (hill, level):
            s = swings[label]
            ax2.plot(s.t, np.degrees(s.theta), label=f"{label}: P = {t_swing(label):.4f} s")
        ax2.set(xlabel="time t [s]", ylabel="θ [deg]", xlim=(SWING_TIME - 4.0, SWING_TIME))
        ax2.set_title("free swings, last 4 s: the periods differ", fontsize=10)
        ax3.plot(scene_run.t, raw, lw=0.6, alpha=0.6, label="raw g tan θ")
        ax3.plot(scene_run.t, estimate, label=f"{ESTIMATOR} estimate")
        ax3.plot(scene_run.t, scene_run.accel_true, "k", label="true a = 0")
        ax3.axhline(g * math.tan(beta), color="r", ls=":", lw=1, label="g tan β")
        ax3.set(xlabel="time t [s]", ylabel="acceleration [m/s²]")
        ax3.set_title("hill scene at constant speed: the estimators read g tan β", fontsize=10)
        names = list(tension)
        ax4.bar(names, [tension[k] for k in names], color=["C0", "C1", "C2"])
        ax4.axhline(MASS * g, color="k", ls=":", lw=1, label="m g")
        ax4.set(ylabel="tension at rest T [N]", ylim=(0.9 * MASS * g, 1.02 * MASS * g / math.cos(beta)))
        ax4.set_title("a second sensor: the string's tension", fontsize=10)
        ax4.tick_params(axis="x", labelsize=7)
        for ax in (ax1, ax2, ax3, ax4):
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=8)

    return LectureReport(
        name=NAME,
        title="acceleration or tilt? the equivalence principle in a car",
        formulas=(
            "θ'' = −(g cos β/l) sin θ + ((a + g sin β)/l) cos θ on a grade β (nose-up > 0)",
            "at rest tan θ = (a + g sin β)/(g cos β): a = 0 on grade β, a = g tan β on the level: θ = β",
            "specific force |f| = √((a + g sin β)² + g² cos² β): g on the hill, g sec β on the level",
            "so the period 2π √(l/|f|) and the rest tension m |f| tell them apart",
        ),
        setup=(
            f"l = {LENGTH:g} m, m = {MASS:g} kg, β = atan 0.1 = {beta:.6f} rad (10 % grade); settled with "
            f"c = {DAMPING:g}/s for {SETTLE:g} s, swings of {SWING:g} rad timed over {SWING_TIME:g} s "
            "undamped; "
            f"estimator {ESTIMATOR} on the bundled hill scene"
        ),
        comparisons=comparisons,
        notes=(
            f"the periods differ by the factor √cos β = {math.sqrt(math.cos(beta)):.5f} "
            f"({1e3 * (t_swing(hill) - t_swing(level)):.2f} ms per swing), the tensions by sec β = "
            f"{1 / math.cos(beta):.5f}: small, but either tells the hill from the acceleration",
            "what the estimators report on a hill is the specific force along the car's x axis, "
            "a + g sin β, divided by g cos β; braking uphill at a = −g sin β, or rolling freely downhill, "
            "reads zero",
            SIGN_NOTE,
        ),
        draw=draw,
    )
