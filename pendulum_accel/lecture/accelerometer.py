"""Result 6: the accelerometer a = g tan θ, read off a bob that is still swinging.

The car pulls away at t = T_STEP with constant a; the bob, hanging at rest until then, swings
about θ_eq = atan(a/g) with amplitude θ_eq and (undamped) never settles. The raw reading
g tan θ then swings between about 0 and 2a, and even its average over whole periods is biased
high: tan is convex, so ⟨g tan θ⟩ > g tan ⟨θ⟩ = a (Jensen). Each estimator in
:mod:`pendulum_accel.estimators` removes the swing its own way.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from pendulum_accel.estimators import ESTIMATORS, estimate_batch
from pendulum_accel.lecture import formulas
from pendulum_accel.lecture.report import SIGN_NOTE, Comparison, LectureReport
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Step
from pendulum_accel.physics.simulate import simulate
from pendulum_accel.sensor import SensorModel

NAME = "accelerometer"
SUMMARY = "a = g tan θ off a swinging bob: the raw reading's bias, and how each estimator removes it"

LENGTH = 0.5  # m
ACCEL = 3.0  # m/s²
T_STEP = 1.0  # s
RATE_HZ = 200.0
NOISE_STD = 1e-3  # rad, white angle noise of the sensor (and the σ each estimator is told)
SEED = 6
DURATION = 24.0  # s: the low-pass filter's own step transient (cut-off f_osc/8) needs ~13 s to die out
SETTLED = 6.0  # s: checks use the last SETTLED seconds, after every estimator's start-up
RAW = "instant"  # a = g tan θ per sample: the raw reading
TOL_ESTIMATE = 0.03  # m/s², 1 % of a, a fifth of the raw reading's bias
TOL_MEAN_ANGLE = 1e-4  # rad
TOL_RAW_BIAS = 0.02  # m/s²: the 4th-order terms of the expansion, ≈ 5 % of the bias at A = 0.3 rad
RTOL, ATOL = 1e-11, 1e-13


def run(quick: bool = False) -> LectureReport:
    """Simulate the swing after a step in a, run every estimator on θ(t), compare with the true a."""
    p = Pendulum(length=LENGTH)
    del quick  # one run of the chain takes well under a second; there is nothing to coarsen
    duration = DURATION
    sensor = SensorModel(rate_hz=RATE_HZ, noise_std=NOISE_STD, seed=SEED)
    t = sensor.sample_times(duration)
    traj = simulate(p, Step(T_STEP, 0.0, ACCEL), t, theta0=0.0, model="rigid", rtol=RTOL, atol=ATOL)
    theta = traj.theta
    measured = sensor.measure(t, theta)
    cfg = {"length": LENGTH, "gravity": p.gravity, "noise_std": NOISE_STD, "rate_hz": RATE_HZ}
    estimates = {name: estimate_batch(name, t, measured, **cfg)[0] for name in ESTIMATORS}

    theta_eq = float(formulas.equilibrium_angle(p, ACCEL))
    amplitude = theta_eq  # released hanging at rest: the swing reaches from 0 to 2 θ_eq
    period = float(formulas.exact_period(p, ACCEL, amplitude))
    n_periods = int(SETTLED // period)
    window = t >= t[-1] - SETTLED
    # Means are taken over a whole number of periods so that no partial swing is left over.
    whole = t >= t[-1] - n_periods * period

    def period_mean(values: np.ndarray) -> float:
        """(1/nT) ∫ values dt over the last n whole periods (trapezoid rule)."""
        span = t[whole][-1] - t[whole][0]
        return float(np.trapezoid(values[whole], t[whole]) / span)

    raw = estimates[RAW]
    raw_mean = period_mean(raw)
    # g tan(θ_eq + η) = a + g sec²θ_eq η + g sec²θ_eq tan θ_eq η² + …, ⟨η⟩ = 0, ⟨η²⟩ ≈ A²/2.
    bias_predicted = ACCEL * (1.0 + (ACCEL / p.gravity) ** 2) * amplitude**2 / 2.0
    whole_note = f"mean over the last {n_periods} whole periods of {period:.3f} s"
    comparisons = [
        Comparison("⟨θ⟩ = atan(a/g)", "rad", theta_eq, period_mean(theta), TOL_MEAN_ANGLE, whole_note),
        Comparison(
            "raw bias ⟨g tan θ⟩ − a ≈ a (1 + a²/g²) A²/2",
            "m/s²",
            bias_predicted,
            raw_mean - ACCEL,
            TOL_RAW_BIAS,
            f"A = {amplitude:.3f} rad, {whole_note}",
        ),
    ]
    ripple = {}
    for name, est in estimates.items():
        ripple[name] = float(np.max(np.abs(est[window] - ACCEL)))
        if name != RAW:
            comparisons.append(
                Comparison(f"{name}: ⟨â⟩ = a", "m/s²", ACCEL, period_mean(est), TOL_ESTIMATE, whole_note)
            )
    notes = (
        f"raw g tan θ ({RAW}) swings between {raw[window].min():.2f} and {raw[window].max():.2f} m/s²; its "
        f"mean {raw_mean:.3f} m/s² is biased by {raw_mean - ACCEL:+.3f} m/s² "
        f"({(raw_mean - ACCEL) / ACCEL:+.1%}) "
        "because tan is convex: ⟨g tan θ⟩ > g tan⟨θ⟩ = a",
        "worst |â − a| over the last "
        f"{SETTLED:g} s: " + ", ".join(f"{name} {value:.3g}" for name, value in ripple.items()) + " m/s²",
        "period_mean averages θ over a period before taking g tan; lowpass filters the swing out of θ "
        "(with delay, some ripple left); dynamic inverts the equation of motion a = (l θ'' + g sin θ)/cos θ; "
        "kalman fits the pendulum model to θ(t)",
        SIGN_NOTE,
    )

    def draw(fig: Figure) -> None:
        """θ(t); the raw reading and each estimate against the true a; the settled error per estimator."""
        ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True, height_ratios=(1, 2, 1.3))
        ax1.plot(t, np.degrees(theta), lw=1, label="θ(t), released hanging at rest")
        ax1.axhline(np.degrees(theta_eq), color="k", ls="--", lw=1, label="atan(a/g)")
        ax1.set(ylabel="θ [deg]")
        ax1.set_title(
            f"car pulls away at t = {T_STEP:g} s with a = {ACCEL:g} m/s², l = {LENGTH:g} m", fontsize=10
        )
        ax2.plot(t, raw, color="0.7", lw=0.8, label="raw g tan θ")
        ax2.axhline(
            raw_mean, color="0.4", ls="-.", lw=1, label=f"raw mean over whole periods ({raw_mean:.3f})"
        )
        for name, est in estimates.items():
            if name != RAW:
                ax2.plot(t, est, lw=1.3, label=name)
        ax2.plot(t, traj.accel, "k--", lw=1, label="true a(t)")
        ax2.set(ylabel="acceleration [m/s²]", ylim=(-1.0, 2.5 * ACCEL))
        tiny = 1e-12  # keeps exact zeros visible on the log axis
        for name, est in estimates.items():
            style = {"color": "0.7", "lw": 0.8} if name == RAW else {"lw": 1.2}
            ax3.semilogy(t[t > T_STEP], np.abs(est - traj.accel)[t > T_STEP] + tiny, label=name, **style)
        ax3.axvspan(t[-1] - SETTLED, t[-1], color="g", alpha=0.08, label="checked window")
        ax3.set(xlabel="time t [s]", ylabel="|â − a| [m/s²]", ylim=(1e-5, 20.0))
        for ax in (ax1, ax2, ax3):
            ax.grid(True, alpha=0.3)
            # Beside the axes, not on them: inside, the legends covered the swing and the estimates.
            ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))

    return LectureReport(
        name=NAME,
        title="the accelerometer a = g tan θ on a swinging bob",
        formulas=(
            "a = g tan θ at rest  (lecture: tan θ' = −a/g)",
            "⟨θ⟩ over a period = θ_eq, but ⟨g tan θ⟩ > a",
        ),
        setup=(
            f"l = {LENGTH:g} m, undamped, step 0 → {ACCEL:g} m/s² at t = {T_STEP:g} s, θ sampled at "
            f"{RATE_HZ:g} Hz for {duration:g} s with noise σ = {NOISE_STD:g} rad (seed {SEED}); "
            f"checked over the last {SETTLED:g} s"
        ),
        comparisons=tuple(comparisons),
        notes=notes,
        draw=draw,
    )
