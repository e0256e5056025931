"""Result 2: small oscillations about θ_eq have ω² = √(g² + a²)/l, → g/l as a → 0.

Periods are timed from the simulated swing's zero crossings about θ_eq. A second sweep grows the
amplitude at fixed a to show where the small-angle period stops holding, beside the exact
libration period 4 K(m)/ω, m = sin²(A/2).
"""

from __future__ import annotations

import math

import numpy as np
from matplotlib.figure import Figure
from scipy.optimize import brentq

from pendulum_accel.lecture import formulas
from pendulum_accel.lecture.measure import mean_period
from pendulum_accel.lecture.progress import progress
from pendulum_accel.lecture.report import SIGN_NOTE, Comparison, LectureReport
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Constant
from pendulum_accel.physics.simulate import simulate

NAME = "frequency"
SUMMARY = "small-oscillation ω² = √(g² + a²)/l over a sweep of a (extension: the exact, elliptic period)"

LENGTH = 1.0  # m
A_MAX = 15.0  # m/s²
SMALL_AMPLITUDE = 0.01  # rad: the small-angle error in ω² is ≈ A²/8 ≈ 1.3e-5 relative
AMPLITUDE_ACCEL = 3.0  # m/s², fixed a for the amplitude sweep
AMPLITUDE_MAX = 3.0  # rad, just short of the separatrix at π
PERIODS = 8
PERIODS_QUICK = 2
SAMPLES_PER_PERIOD = 200
BREAKDOWN = 0.01  # "stops holding": the small-angle period is off by more than 1 %
TOL_OMEGA2 = 1e-3  # s⁻², ≈ 1e-4 of ω²: well above the O(A²) and timing errors, far below a wrong law
TOL_OMEGA = 1e-4  # rad/s
TOL_PERIOD = 1e-6  # s
RTOL, ATOL = 1e-11, 1e-13


def timed_period(p: Pendulum, accel: float, amplitude: float, periods: int = PERIODS) -> float:
    """Period of the simulated swing released at rest from θ_eq + A, timed from zero crossings of θ − θ_eq."""
    theta_eq = float(formulas.equilibrium_angle(p, accel))
    period = float(formulas.exact_period(p, accel, amplitude))
    t = np.linspace(0.0, periods * period, periods * SAMPLES_PER_PERIOD + 1)
    traj = simulate(p, Constant(accel), t, theta0=theta_eq + amplitude, model="rigid", rtol=RTOL, atol=ATOL)
    return mean_period(traj.t, traj.theta - theta_eq, traj.theta_dot)


def breakdown_amplitude(p: Pendulum, accel: float) -> float:
    """Amplitude A where 4 K(sin²(A/2))/ω = (1 + BREAKDOWN) · 2π/ω (≈ 0.4 rad for 1 %)."""
    small = float(formulas.small_angle_period(p, accel))
    return float(
        brentq(lambda amp: float(formulas.exact_period(p, accel, amp)) / small - 1.0 - BREAKDOWN, 1e-6, 3.0)
    )


def run(quick: bool = False) -> LectureReport:
    """Sweep a at small amplitude (ω²), then sweep amplitude at fixed a (period vs 2π/ω and 4K(m)/ω)."""
    p = Pendulum(length=LENGTH)
    periods = PERIODS_QUICK if quick else PERIODS
    accels = np.linspace(-A_MAX, A_MAX, 4 if quick else 31)
    accels = np.union1d(accels, [0.0])  # the a → 0 limit is always measured
    omega2_sim = np.array(
        [
            (2.0 * math.pi / timed_period(p, a, SMALL_AMPLITUDE, periods)) ** 2
            for a in progress(accels, f"{NAME}: ω² against a")
        ]
    )
    omega2_lec = formulas.omega_squared(p, accels)
    i0 = int(np.nonzero(accels == 0.0)[0][0])

    amplitudes = np.linspace(0.05, AMPLITUDE_MAX, 5 if quick else 40)
    period_sim = np.array(
        [
            timed_period(p, AMPLITUDE_ACCEL, amp, periods)
            for amp in progress(amplitudes, f"{NAME}: period against A")
        ]
    )
    period_exact = formulas.exact_period(p, AMPLITUDE_ACCEL, amplitudes)
    period_small = float(formulas.small_angle_period(p, AMPLITUDE_ACCEL))
    amp_break = breakdown_amplitude(p, AMPLITUDE_ACCEL)
    sim_excess = period_sim / period_small - 1.0
    # Where the timed periods cross the 1 % line; the excess grows like A²/16, so √excess is
    # nearly linear in A and interpolates well even on the coarse sweep.
    amp_break_sim = float(np.interp(np.sqrt(BREAKDOWN), np.sqrt(np.maximum(sim_excess, 0.0)), amplitudes))

    i_w = int(np.argmax(np.abs(omega2_sim - omega2_lec)))
    i_p = int(np.argmax(np.abs(period_sim - period_exact)))
    comparisons = (
        Comparison(
            "ω² = √(g² + a²)/l",
            "1/s²",
            float(omega2_lec[i_w]),
            float(omega2_sim[i_w]),
            TOL_OMEGA2,
            f"A = {SMALL_AMPLITUDE:g} rad, worst of {accels.size} values, at a = {accels[i_w]:+.2f} m/s²",
        ),
        Comparison(
            "a → 0 limit ω = √(g/l)",
            "rad/s",
            math.sqrt(p.gravity / p.length),
            math.sqrt(float(omega2_sim[i0])),
            TOL_OMEGA,
            "a = 0",
        ),
        Comparison(
            "exact period 4K(m)/ω",
            "s",
            float(period_exact[i_p]),
            float(period_sim[i_p]),
            TOL_PERIOD,
            f"a = {AMPLITUDE_ACCEL:g} m/s², worst of {amplitudes.size} amplitudes, "
            f"at A = {amplitudes[i_p]:.3f} rad",
        ),
    )
    notes = (
        f"the small-angle period 2π/ω = {period_small:.6f} s is off by more than {BREAKDOWN:.0%} beyond "
        f"A = {amp_break:.3f} rad ({math.degrees(amp_break):.1f}°) from 4K(m)/ω; the timed swings cross "
        f"{BREAKDOWN:.0%} at A = {amp_break_sim:.3f} rad",
        f"at A = {amplitudes[-1]:.2f} rad the swing takes {period_sim[-1] / period_small:.2f}× "
        "the small-angle period",
        SIGN_NOTE,
    )

    def draw(fig: Figure) -> None:
        """ω² against a, its difference, period against amplitude, small-angle error against amplitude."""
        fine_a = np.linspace(-A_MAX, A_MAX, 400)
        fine_amp = np.linspace(1e-3, AMPLITUDE_MAX, 400)
        ax1, ax2, ax3, ax4 = fig.subplots(2, 2).ravel()
        ax1.plot(fine_a, formulas.omega_squared(p, fine_a), label="lecture: ω² = √(g² + a²)/l")
        ax1.plot(accels, omega2_sim, "o", ms=4, label=f"simulated, A = {SMALL_AMPLITUDE:g} rad")
        ax1.axhline(p.gravity / p.length, color="k", ls=":", lw=1, label="a → 0: ω² = g/l")
        ax1.set(xlabel="car acceleration a [m/s²]", ylabel="ω² [1/s²]")
        ax1.set_title("small-oscillation frequency", fontsize=10)
        ax2.plot(accels, omega2_sim - omega2_lec, "o-", ms=3, label="simulated − lecture")
        ax2.axhline(TOL_OMEGA2, color="k", ls=":", lw=1, label="± tolerance")
        ax2.axhline(-TOL_OMEGA2, color="k", ls=":", lw=1)
        ax2.set(xlabel="car acceleration a [m/s²]", ylabel="Δω² [1/s²]")
        ax2.set_title("difference (the rest is the finite amplitude, ≈ −ω² A²/8)", fontsize=10)
        ax3.plot(fine_amp, np.full_like(fine_amp, period_small), label="small angle: 2π/ω")
        ax3.plot(fine_amp, formulas.exact_period(p, AMPLITUDE_ACCEL, fine_amp), label="exact: 4 K(m)/ω")
        ax3.plot(amplitudes, period_sim, "o", ms=4, label="simulated (zero crossings)")
        ax3.axvline(amp_break, color="r", ls="--", lw=1, label=f"small angle off by {BREAKDOWN:.0%}")
        ax3.set(xlabel="amplitude A about θ_eq [rad]", ylabel="period [s]")
        ax3.set_title(f"period against amplitude, a = {AMPLITUDE_ACCEL:g} m/s²", fontsize=10)
        ax4.semilogy(amplitudes, np.abs(sim_excess), "o", ms=4, label="|T_sim/(2π/ω) − 1|")
        exact_excess = formulas.exact_period(p, AMPLITUDE_ACCEL, fine_amp) / period_small - 1.0
        ax4.semilogy(fine_amp, exact_excess, label="4K(m)/ω ÷ 2π/ω − 1")
        ax4.semilogy(fine_amp, fine_amp**2 / 16.0, ":", label="A²/16 (leading term)")
        ax4.axhline(BREAKDOWN, color="r", ls="--", lw=1, label=f"{BREAKDOWN:.0%}")
        ax4.axvline(amp_break, color="r", ls="--", lw=1)
        ax4.set(xlabel="amplitude A about θ_eq [rad]", ylabel="relative error of 2π/ω")
        ax4.set_title("where the small-angle result stops holding", fontsize=10)
        for ax in (ax1, ax2, ax3, ax4):
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=8)

    return LectureReport(
        name=NAME,
        title="small-oscillation frequency and the exact period",
        formulas=("ω² = √(g² + a²)/l,  a → 0: ω → √(g/l)", "exact libration period 4 K(m)/ω, m = sin²(A/2)"),
        setup=(
            f"l = {LENGTH:g} m, undamped rigid model released at rest from θ_eq + A; periods timed from zero "
            f"crossings of θ − θ_eq over {periods} periods, {SAMPLES_PER_PERIOD} samples per period"
        ),
        comparisons=comparisons,
        notes=notes,
        draw=draw,
    )
