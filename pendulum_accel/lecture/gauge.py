"""Result 5: adding a total time derivative such as ½ m a² t² to L leaves the motion unchanged.

The θ equation of motion is derived *numerically* from each Lagrangian, by finite-difference
Euler–Lagrange: θ'' = (∂L/∂θ − θ' ∂²L/∂θ∂θ' − ∂²L/∂t∂θ') / ∂²L/∂θ'², with no algebra done by hand.
Three Lagrangians that differ by total derivatives are integrated from the same start, and the
swings are compared with each other and with the simulator's rigid model.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from matplotlib.figure import Figure

from pendulum_accel.lecture.report import SIGN_NOTE, Comparison, LectureReport
from pendulum_accel.physics.integrators import integrate
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Constant
from pendulum_accel.physics.simulate import simulate

NAME = "gauge"
SUMMARY = "the ½ m a² t² term (a total time derivative) leaves the motion unchanged, shown numerically"

LENGTH = 1.0  # m
MASS = 1.0  # kg
ACCEL = 3.0  # m/s²
THETA0 = 0.6  # rad, released at rest
DURATION = 10.0  # s: by then ½ m a² t² = 450 J, far larger than the swing's energy
TOL_ANGLE = 1e-6  # rad
RTOL, ATOL = 1e-11, 1e-13

# Finite-difference steps. L is a quadratic form in the velocity (kinetic energy), so the
# velocity stencil is exact for any step; a large one keeps cancellation error small.
H_VELOCITY = 0.1  # rad/s
H_ANGLE = 1e-3  # rad
H_TIME = 1e-3  # s

Lagrangian = Callable[[float, float, float], float]


def central_derivative(f: Callable[[float], float], x: float, h: float) -> float:
    """f'(x) ≈ [f(x−2h) − 8 f(x−h) + 8 f(x+h) − f(x+2h)] / 12h (error O(h⁴))."""
    return (f(x - 2 * h) - 8 * f(x - h) + 8 * f(x + h) - f(x + 2 * h)) / (12 * h)


def euler_lagrange_rhs(lagrangian: Lagrangian) -> Callable[[float, np.ndarray], np.ndarray]:
    """(θ, θ')' = (θ', (∂L/∂θ − θ' ∂²L/∂θ∂θ' − ∂²L/∂t∂θ') / ∂²L/∂θ'²), every partial by finite differences."""

    def momentum(q: float, v: float, t: float) -> float:
        """p = ∂L/∂θ'."""
        return central_derivative(lambda w: lagrangian(q, w, t), v, H_VELOCITY)

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        """d/dt (θ, θ') from the Euler–Lagrange equation d/dt ∂L/∂θ' = ∂L/∂θ."""
        q, v = float(y[0]), float(y[1])
        dL_dq = central_derivative(lambda x: lagrangian(x, v, t), q, H_ANGLE)
        d2L_dv2 = central_derivative(lambda w: momentum(q, w, t), v, H_VELOCITY)
        d2L_dqdv = central_derivative(lambda x: momentum(x, v, t), q, H_ANGLE)
        d2L_dtdv = central_derivative(lambda s: momentum(q, v, s), t, H_TIME)
        return np.array([v, (dL_dq - v * d2L_dqdv - d2L_dtdv) / d2L_dv2])

    return rhs


def inertial_lagrangian(p: Pendulum, accel: float) -> Lagrangian:
    """L = ½ m (l² θ'² − 2 a t l θ' cos θ + a² t²) + m g l cos θ: inertial frame, car at X = ½ a t²."""
    m, g, length = p.mass, p.gravity, p.length

    def lagrangian(q: float, v: float, t: float) -> float:
        """L(θ, θ', t) with the ½ m a² t² term."""
        kinetic = 0.5 * m * (length**2 * v * v - 2 * accel * t * length * v * math.cos(q) + accel**2 * t * t)
        return kinetic + m * g * length * math.cos(q)

    return lagrangian


def without_gauge_term(p: Pendulum, accel: float) -> Lagrangian:
    """L − ½ m a² t² = ½ m (l² θ'² − 2 a t l θ' cos θ) + m g l cos θ."""
    full = inertial_lagrangian(p, accel)

    def lagrangian(q: float, v: float, t: float) -> float:
        """L(θ, θ', t) without the ½ m a² t² term."""
        return full(q, v, t) - 0.5 * p.mass * accel * accel * t * t

    return lagrangian


def car_frame_lagrangian(p: Pendulum, accel: float) -> Lagrangian:
    """L_car = ½ m l² θ'² + m g l cos θ + m a l sin θ (fictitious force −m a as a potential)."""
    m, g, length = p.mass, p.gravity, p.length

    def lagrangian(q: float, v: float, t: float) -> float:
        """L_car(θ, θ'): no explicit time dependence at all."""
        return 0.5 * m * length**2 * v * v + m * g * length * math.cos(q) + m * accel * length * math.sin(q)

    return lagrangian


def run(quick: bool = False) -> LectureReport:
    """Integrate the finite-difference Euler–Lagrange equations of three equivalent Lagrangians; compare."""
    p = Pendulum(length=LENGTH, mass=MASS)
    t = np.linspace(0.0, DURATION if not quick else DURATION / 2, 501 if quick else 2001)
    y0 = np.array([THETA0, 0.0])
    lagrangians = {
        "inertial, with ½ m a² t²": inertial_lagrangian(p, ACCEL),
        "inertial, without ½ m a² t²": without_gauge_term(p, ACCEL),
        "car frame, m a l sin θ": car_frame_lagrangian(p, ACCEL),
    }
    states = {
        label: integrate(euler_lagrange_rhs(lag), y0, t, "DOP853", rtol=RTOL, atol=ATOL).y
        for label, lag in lagrangians.items()
    }
    swings = {label: y[0] for label, y in states.items()}
    with_term, without_term, car = swings.values()
    rigid = simulate(p, Constant(ACCEL), t, theta0=THETA0, model="rigid", rtol=RTOL, atol=ATOL)

    def worst(label: str, ref: np.ndarray, other: np.ndarray, where: str) -> Comparison:
        """Comparison at the sample where |other − ref| is largest."""
        i = int(np.argmax(np.abs(other - ref)))
        return Comparison(
            label, "rad", float(ref[i]), float(other[i]), TOL_ANGLE, f"{where}, at t = {t[i]:.2f} s"
        )

    comparisons = (
        worst("θ with ½ m a² t² = θ without", without_term, with_term, f"worst of {t.size} samples"),
        worst("θ car-frame L = θ inertial L", without_term, car, f"worst of {t.size} samples"),
        worst(
            "θ from Euler–Lagrange = simulator's θ'' = −(g/l) sin θ + (a/l) cos θ",
            rigid.theta,
            with_term,
            f"worst of {t.size} samples",
        ),
    )
    gauge_size = 0.5 * p.mass * ACCEL**2 * t[-1] ** 2
    notes = (
        f"by t = {t[-1]:g} s the added term is ½ m a² t² = {gauge_size:.0f} J, yet the swings agree to "
        f"{np.max(np.abs(with_term - without_term)):.1e} rad (finite-difference rounding)",
        SIGN_NOTE,
    )

    def draw(fig: Figure) -> None:
        """θ(t) from each Lagrangian, the Lagrangians' values along the swing, the differences."""
        ax1, ax2, ax3 = fig.subplots(3, 1, sharex=True)
        styles = ("-", "--", ":")
        for (label, theta), style in zip(swings.items(), styles, strict=True):
            ax1.plot(t, np.degrees(theta), style, lw=2 if style == "-" else 1.5, label=label)
        span = np.degrees([with_term.min(), with_term.max()])
        ax1.set(ylabel="θ [deg]", ylim=(span[0] - 3.0, span[1] + 0.45 * (span[1] - span[0])))
        ax1.set_title("θ(t) from the finite-difference Euler–Lagrange equation of each L", fontsize=10)
        theta_dot = states[next(iter(states))][1]
        for (label, lag), style in zip(lagrangians.items(), styles, strict=True):
            values = [lag(q, v, s) for q, v, s in zip(with_term, theta_dot, t, strict=True)]
            ax2.plot(t, values, style, label=label)
        ax2.set(ylabel="L along the swing [J]")
        ax2.set_title("the Lagrangians themselves differ by growing amounts", fontsize=10)
        tiny = 1e-18  # keeps exact zeros visible on the log axis
        ax3.semilogy(t, np.abs(with_term - without_term) + tiny, label="|θ_with − θ_without|")
        ax3.semilogy(t, np.abs(car - without_term) + tiny, label="|θ_car − θ_without|")
        ax3.semilogy(t, np.abs(with_term - rigid.theta) + tiny, label="|θ_with − θ_simulator|")
        ax3.axhline(TOL_ANGLE, color="k", ls=":", lw=1, label="tolerance")
        ax3.set(xlabel="time t [s]", ylabel="difference [rad]")
        for ax in (ax1, ax2, ax3):
            ax.grid(True, alpha=0.3)
        ax1.legend(fontsize=8, loc="upper center", ncol=3)
        ax2.legend(fontsize=8, loc="upper left")
        ax3.legend(fontsize=8, loc="lower right", ncol=2)

    return LectureReport(
        name=NAME,
        title="the gauge term ½ m a² t² changes nothing",
        formulas=(
            "L = ½ m (l² θ'² − 2 a t l θ' cos θ + a² t²) + m g l cos θ  (lecture's L, with θ_lecture = −θ)",
            "½ m a² t² = d/dt(m a² t³/6) is a total time derivative: the Euler–Lagrange equation is the same",
        ),
        setup=(
            f"l = {LENGTH:g} m, m = {MASS:g} kg, a = {ACCEL:g} m/s², "
            f"released at rest from θ = {THETA0:g} rad, "
            f"{t[-1]:g} s; finite-difference steps h_θ = {H_ANGLE:g} rad, h_θ' = {H_VELOCITY:g} rad/s, "
            f"h_t = {H_TIME:g} s; DOP853 rtol {RTOL:g}"
        ),
        comparisons=comparisons,
        notes=notes,
        draw=draw,
    )
