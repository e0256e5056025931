"""Result 3: the Lagrange multiplier of the constraint ½(x² + z² − l²) = 0 is μ = −T/l.

Two independent simulations of the same swing: the Cartesian multiplier model, which knows
nothing about tension and only enforces the constraint, and the reduced-coordinate rigid model,
whose tension is Newton's T = m (l θ'² + g cos θ + a sin θ). Along the whole swing μ = −T/l.
"""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from pendulum_accel.lecture import formulas
from pendulum_accel.lecture.report import Comparison, LectureReport
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Constant
from pendulum_accel.physics.simulate import simulate

NAME = "multiplier"
SUMMARY = "Lagrange multiplier μ of the Cartesian model against −T/l from Newton's tension, along a swing"

LENGTH = 1.0  # m
MASS = 1.0  # kg
ACCEL = 2.0  # m/s²
THETA0 = 1.2  # rad: a wide swing, so T and μ change by a large factor over each period
PERIODS = 4
TOL_MULTIPLIER = 1e-6  # N/m
TOL_ANGLE = 1e-6  # rad
RTOL, ATOL = 1e-11, 1e-13


def run(quick: bool = False) -> LectureReport:
    """Simulate one swing with the multiplier and rigid models; compare μ(t) with −T(t)/l and θ(t)."""
    p = Pendulum(length=LENGTH, mass=MASS)
    duration = PERIODS * float(formulas.exact_period(p, ACCEL, THETA0 - formulas.equilibrium_angle(p, ACCEL)))
    t = np.linspace(0.0, duration, 401 if quick else 2001)
    profile = Constant(ACCEL)
    cart = simulate(p, profile, t, theta0=THETA0, model="multiplier", rtol=RTOL, atol=ATOL)
    rigid = simulate(p, profile, t, theta0=THETA0, model="rigid", rtol=RTOL, atol=ATOL)
    if cart.multiplier is None or rigid.tension is None:
        raise RuntimeError("the multiplier model must return μ and the rigid model T")
    mu = cart.multiplier
    mu_newton = formulas.multiplier_from_tension(p, rigid.tension)
    i_mu = int(np.argmax(np.abs(mu - mu_newton)))
    i_th = int(np.argmax(np.abs(cart.theta - rigid.theta)))
    comparisons = (
        Comparison(
            "μ = −T/l",
            "N/m",
            float(mu_newton[i_mu]),
            float(mu[i_mu]),
            TOL_MULTIPLIER,
            f"worst of {t.size} samples, at t = {t[i_mu]:.3f} s",
        ),
        Comparison(
            "θ multiplier model = θ rigid model",
            "rad",
            float(rigid.theta[i_th]),
            float(cart.theta[i_th]),
            TOL_ANGLE,
            f"worst of {t.size} samples, at t = {t[i_th]:.3f} s",
        ),
    )
    notes = (
        f"over the swing T ranges from {rigid.tension.min():.3f} to {rigid.tension.max():.3f} N; "
        "μ < 0 throughout: the constraint force μ·(x, z) points from the bob to the pivot",
        "the lecture (a = 0) writes Newton's tension T = m l θ'² + m g cos θ; in the car frame the "
        "fictitious force adds m a sin θ",
        "by construction, not a test of the physics: μ is solved in closed form from f'' = 0, which on "
        "the circle *is* −T/l; the check compares two independent integrations of the same swing "
        "(Cartesian with Baumgarte stabilisation, and reduced θ), so it tests the solvers and the index "
        "reduction, and the θ row is the informative one",
    )

    def draw(fig: Figure) -> None:
        """θ(t) from both models, −μ l against T, and their differences."""
        ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True)
        ax1.plot(t, np.degrees(rigid.theta), label="rigid model θ(t)")
        ax1.plot(t, np.degrees(cart.theta), "--", label="multiplier model θ = atan2(−x, −z)")
        ax1.set(ylabel="θ [deg]")
        ax1.set_title(f"swing released at θ = {THETA0:g} rad, a = {ACCEL:g} m/s²", fontsize=10)
        ax2.plot(t, rigid.tension, label="Newton: T = m (l θ'² + g cos θ + a sin θ)")
        ax2.plot(t, -mu * p.length, "--", label="Lagrange: −μ l")
        ax2.set(ylabel="force [N]")
        tiny = 1e-18  # keeps exact zeros visible on the log axis
        ax3.semilogy(t, np.abs(mu - mu_newton) + tiny, label="|μ + T/l| [N/m]")
        ax3.semilogy(t, np.abs(cart.theta - rigid.theta) + tiny, label="|Δθ| [rad]")
        ax3.axhline(TOL_MULTIPLIER, color="k", ls=":", lw=1, label="tolerance")
        ax3.set(xlabel="time t [s]", ylabel="difference")
        for ax in (ax1, ax2, ax3):
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=8, loc="upper right")

    return LectureReport(
        name=NAME,
        title="tension from Newton's laws against the Lagrange multiplier",
        formulas=(
            "L = ½ m (ẋ² + ż²) − m g z − m a x + (μ/2)(x² + z² − l²)  ⇒  m ẍ = −m a + μ x,  m z̈ = −m g + μ z",
            "compare with Newton m ẍ = −m a − T x/l  ⇒  μ = −T/l  (car frame, x forward, z up)",
        ),
        setup=(
            f"l = {LENGTH:g} m, m = {MASS:g} kg, a = {ACCEL:g} m/s², "
            f"released at rest from θ = {THETA0:g} rad, "
            f"{PERIODS} periods ({duration:.2f} s), {t.size} samples; multiplier model vs rigid model"
        ),
        comparisons=comparisons,
        notes=notes,
        draw=draw,
    )
