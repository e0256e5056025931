"""Result: the butterfly effect in the lecture's own pendulum — two runs one ulp apart, resonantly driven.

The pendulum of the lecture (l = 1 m, θ0 = 0.3 rad) in a car whose acceleration oscillates,
a = 1 + 3 sin(πt) m/s² (the bundled ``resonant_drive`` scene), is chaotic: two runs whose θ0 differ by
one unit in the last place (5.6e-17 rad) separate as e^{λt} until they disagree completely. The
planner's finite-time Lyapunov estimate (pendulum_accel.conditioning) predicts when the separation passes
the 1e-6 rad target; the check compares that with the time the one-ulp pair actually passes it.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from matplotlib.figure import Figure

from pendulum_accel.lecture.report import Comparison, LectureReport
from pendulum_accel.physics.simulate import simulate
from pendulum_accel.planner import plan_scene
from pendulum_accel.scene import load_scene

NAME = "butterfly"
SUMMARY = "two runs one ulp apart diverge in the driven pendulum: when the inputs stop counting"

SCENE = "resonant_drive"
RTOL = 1e-13  # the pair is run with DOP853 this tight: its own error stays far below the separation
TOL_FACTOR = 3.0  # the predicted and the observed crossing times agree within ± ln(3)/λ


def run(quick: bool = False) -> LectureReport:
    """Plan the resonant_drive scene (sensitivity, λ, lost-at time), then run the one-ulp pair."""
    scene = load_scene(SCENE)
    if quick:
        scene = replace(scene, duration=80.0)
    plan = plan_scene(scene)
    sensitivity = plan.sensitivity
    assert sensitivity is not None  # plan_scene always measures it
    t = scene.sensor.sample_times(scene.duration)
    theta0 = scene.theta0
    nudged = math.nextafter(theta0, math.inf)
    runs = [
        simulate(scene.pendulum, scene.profile, t, theta0=start, model="rigid", method="DOP853", rtol=RTOL,
                 atol=1e-15).theta
        for start in (theta0, nudged)
    ]  # fmt: skip
    gap = np.abs(runs[1] - runs[0])
    over = np.flatnonzero(gap >= scene.accuracy)
    observed = float(t[over[0]]) if over.size else math.inf
    predicted = sensitivity.lost_at if sensitivity.lost_at is not None else math.inf
    lam = sensitivity.lyapunov
    tolerance = math.log(TOL_FACTOR) / lam if lam > 0.0 else math.inf
    comparisons = (
        Comparison(
            "time the one-ulp pair separates by the target", "s", predicted, observed, tolerance,
            f"(target {scene.accuracy:g} rad)",
        ),
    )  # fmt: skip
    notes = (
        plan.explain(),
        f"θ0 = {theta0!r} and {nudged!r} (one ulp, {nudged - theta0:.1e} rad apart); "
        f"max separation {gap.max():.2g} rad by t = {t[-1]:g} s",
    )

    def draw(fig: Figure) -> None:
        """θ of both runs above; their separation (log scale) against e^{λt} and the target below."""
        ax1, ax2 = fig.subplots(2, 1, sharex=True)
        ax1.plot(t, runs[0], lw=1.0, label=f"θ0 = {theta0!r}")
        ax1.plot(t, runs[1], "--", lw=1.0, label="θ0 + 1 ulp")
        ax1.set(ylabel="θ [rad]")
        ax1.legend(fontsize=8, loc="upper left")
        ax2.semilogy(t, gap + 1e-18, lw=1.0, label="|Δθ| of the one-ulp pair")
        ax2.semilogy(sensitivity.times, sensitivity.curve + 1e-18, lw=1.0, label="planner: |Δθ| per ulp")
        ax2.axhline(scene.accuracy, color="k", ls=":", lw=1.0, label="target")
        for ax in (ax1, ax2):
            if math.isfinite(predicted):
                ax.axvline(predicted, color="r", lw=1.0)
            ax.grid(True, alpha=0.3)
        ax2.set(xlabel="time t [s]", ylabel="separation [rad]")
        ax2.legend(fontsize=8, loc="lower right")

    return LectureReport(
        name=NAME,
        title="one ulp of θ0 decides the swing after a minute: chaos in the driven pendulum",
        formulas=(
            "δθ(t) ≈ δθ0 e^{λt}: a perturbation grows at the finite-time Lyapunov exponent λ",
            "θ is determined by the inputs to within ε only until t* with ulp(θ0)·S(t*) = ε",
        ),
        setup=(
            f"scene {SCENE}: l = {scene.pendulum.length:g} m, a = 1 + 3 sin(πt) m/s², θ0 = {theta0:g} rad, "
            f"{t[-1]:g} s at {scene.sensor.rate_hz:g} Hz; pair run with DOP853 rtol {RTOL:g}; "
            f"λ ≈ {lam:.2g} 1/s"
        ),
        comparisons=comparisons,
        notes=notes,
        draw=draw,
    )
