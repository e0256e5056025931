"""Every answer of the lab (docs/lab/), computed: the solution notebook and the teacher key both print these.

``answers(run)`` measures each exercise on the group's own data (``lab_data``) and returns named
:class:`Answer` values. The teacher key (docs/lab/teacher/teacher_key.md) is rendered from them by
``lab_key``; ``python -m pendulum_accel.lecture.lab_answers --seed N --accel A`` prints any group's.

Each answer carries ``tol``: how far a re-computation on another machine may land from the key's printed
value. The data are deterministic for a seed (numpy's PCG64 stream, the simulator to well below its
1e-6 rad accuracy target), so two machines differ only by floating-point rounding in the solver and the
fits, ≲ 1e-9 of each value; ``tol`` is set wider, at a hundredth of the answer's own uncertainty (or a
stated relative margin), and the key prints enough digits that its rounding stays below tol/5.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import curve_fit

from pendulum_accel.errors import ParameterError, SceneError
from pendulum_accel.estimators import estimate_batch
from pendulum_accel.lecture.lab_data import LabRun, drive_data, released_data, swing_data
from pendulum_accel.lecture.measure import period
from pendulum_accel.physics.profiles import Constant
from pendulum_accel.planner import plan_scene, plan_with
from pendulum_accel.scene import load_scene
from pendulum_accel.scene_run import SceneRun, run_scene, simulate_plan

FloatArray = NDArray[np.float64]
KEY_RUN = LabRun()  # the run the teacher key is worked for
DRIVE_ESTIMATORS = ("instant", "period_mean", "kalman", "dynamic")
STIFFNESSES = (1e3, 1e4, 1e5, 1e6)  # N/m, extension A
LSODA_RTOL = 1e-10
# LSODA's step control compares error estimates with rtol 1e-10; rounding (1e-16) flips a step decision
# only when an estimate sits on its threshold, each flip costing a few f-calls: 5 % covers many flips.
LSODA_TOL_REL = 0.05


@dataclass(frozen=True)
class Answer:
    """One number of the key: ``value`` [unit], accepted on re-computation within ±``tol``."""

    name: str
    label: str
    value: float
    unit: str
    tol: float

    @property
    def text(self) -> str:
        """The value as printed in the key and by the solution notebook, its rounding ≤ tol/5.

        A whole count is printed whole; else fixed or scientific notation with the fewest digits whose
        rounding, half a unit of the last digit, stays within tol/5.
        """
        if self.value == round(self.value) and self.tol >= 0.5:
            return f"{self.value:.0f}"
        last = math.floor(math.log10(0.4 * self.tol))  # 0.5·10^last ≤ tol/5
        if abs(self.value) >= 1e-3 or self.value == 0.0:
            return f"{self.value:.{max(0, -last)}f}"
        return f"{self.value:.{max(0, math.floor(math.log10(abs(self.value))) - last)}e}"

    def line(self) -> str:
        """'answer NAME = VALUE UNIT  (label)': the solution notebook's line, parsed by the tests."""
        return f"answer {self.name} = {self.text} {self.unit}  ({self.label})"


@dataclass(frozen=True)
class SwingFit:
    """θ(t) ≈ θ_eq + A cos ωt + B sin ωt fitted by least squares, with 1σ uncertainties from the fit."""

    omega: float
    omega_sigma: float
    theta_eq: float
    theta_eq_sigma: float
    amplitude: float
    residual_std: float


def fit_swing(t: FloatArray, theta: FloatArray) -> SwingFit:
    """Least-squares fit of θ_eq + A cos ωt + B sin ωt; σ from the covariance scaled by the residual.

    ω starts at the periodogram's peak (zero-padded 16×), A and B at their linear fit for that ω.
    """
    tt = np.asarray(t, dtype=float)
    yy = np.asarray(theta, dtype=float)
    n_pad = 16 * tt.size
    spectrum = np.abs(np.fft.rfft(yy - yy.mean(), n_pad))
    freqs = np.fft.rfftfreq(n_pad, d=float(tt[1] - tt[0]))
    omega0 = 2.0 * math.pi * float(freqs[1 + int(np.argmax(spectrum[1:]))])
    design = np.column_stack((np.ones_like(tt), np.cos(omega0 * tt), np.sin(omega0 * tt)))
    c0, a0, b0 = np.linalg.lstsq(design, yy, rcond=None)[0]

    def model(x: FloatArray, omega: float, mean: float, a: float, b: float) -> FloatArray:
        """θ_eq + A cos ωt + B sin ωt."""
        return mean + a * np.cos(omega * x) + b * np.sin(omega * x)

    popt, pcov = curve_fit(model, tt, yy, p0=(omega0, c0, a0, b0))
    residual = yy - model(tt, *popt)
    return SwingFit(
        omega=float(popt[0]),
        omega_sigma=float(math.sqrt(pcov[0, 0])),
        theta_eq=float(popt[1]),
        theta_eq_sigma=float(math.sqrt(pcov[1, 1])),
        amplitude=float(math.hypot(popt[2], popt[3])),
        residual_std=float(np.std(residual)),
    )


def recover_a_g(fit: SwingFit, length: float) -> tuple[float, float, float, float]:
    """(a, σ_a, g, σ_g): g_eff = ω² l = √(g² + a²), tan θ_eq = a/g, so a = g_eff sin θ_eq, g = g_eff cos θ_eq.

    σ by first-order propagation, ω and θ_eq taken as independent (the cos/sin fit decorrelates them):
    σ_geff = 2 ω l σ_ω, σ_a² = (sin θ_eq σ_geff)² + (g_eff cos θ_eq σ_θ)², σ_g likewise.
    """
    g_eff = fit.omega**2 * length
    s_geff = 2.0 * fit.omega * length * fit.omega_sigma
    s, c = math.sin(fit.theta_eq), math.cos(fit.theta_eq)
    a, g = g_eff * s, g_eff * c
    s_a = math.hypot(s * s_geff, g_eff * c * fit.theta_eq_sigma)
    s_g = math.hypot(c * s_geff, g_eff * s * fit.theta_eq_sigma)
    return a, s_a, g, s_g


def whole_period_mean(t: FloatArray, values: FloatArray, period_s: float) -> tuple[float, int]:
    """((1/nT) ∫ values dt over the last n whole periods, n): the trapezoid rule on the samples."""
    n = int((t[-1] - t[0]) // period_s) - 1  # the first period is left out: estimators start up in it
    whole = t >= t[-1] - n * period_s
    span = float(t[whole][-1] - t[whole][0])
    return float(np.trapezoid(values[whole], t[whole]) / span), n


def _cfg(run: SceneRun) -> dict[str, float]:
    """The estimators' configuration for a run: l, g, the sensor's σ and rate."""
    p, s = run.scene.pendulum, run.scene.sensor
    return {"length": p.length, "gravity": p.gravity, "noise_std": s.noise_std, "rate_hz": s.rate_hz}


def exercise1(run: LabRun) -> list[Answer]:
    """Fit the group's swing for ω and θ_eq, recover a and g, measure the frequency shift against a = 0."""
    data = swing_data(run)
    length = data.scene.pendulum.length
    fit = fit_swing(data.t, data.theta_measured)
    a, s_a, g, s_g = recover_a_g(fit, length)
    fit0 = fit_swing(*_t_theta(swing_data(run, accel=0.0)))
    ratio = fit.omega / fit0.omega
    s_ratio = ratio * math.hypot(fit.omega_sigma / fit.omega, fit0.omega_sigma / fit0.omega)
    g_true = data.scene.pendulum.gravity
    predicted = (math.hypot(g_true, run.accel) / g_true) ** 0.5
    return [
        Answer("ex1_omega", "fitted ω", fit.omega, "rad/s", fit.omega_sigma / 100),
        Answer("ex1_omega_sigma", "its 1σ", fit.omega_sigma, "rad/s", fit.omega_sigma / 100),
        Answer("ex1_theta_eq", "fitted θ_eq", fit.theta_eq, "rad", fit.theta_eq_sigma / 100),
        Answer("ex1_theta_eq_sigma", "its 1σ", fit.theta_eq_sigma, "rad", fit.theta_eq_sigma / 100),
        Answer(
            "ex1_residual", "residual RMS (the sensor's σ)", fit.residual_std, "rad", fit.theta_eq_sigma / 100
        ),
        Answer("ex1_a", "recovered a = ω² l sin θ_eq", a, "m/s²", s_a / 100),
        Answer("ex1_a_sigma", "its 1σ", s_a, "m/s²", s_a / 100),
        Answer("ex1_g", "recovered g = ω² l cos θ_eq", g, "m/s²", s_g / 100),
        Answer("ex1_g_sigma", "its 1σ", s_g, "m/s²", s_g / 100),
        Answer("ex1_omega0", "fitted ω at a = 0", fit0.omega, "rad/s", fit0.omega_sigma / 100),
        Answer("ex1_ratio", "ω(a)/ω(0)", ratio, "", s_ratio / 100),
        Answer("ex1_ratio_sigma", "its 1σ", s_ratio, "", s_ratio / 100),
        Answer("ex1_ratio_predicted", "(√(g² + a²)/g)^½", predicted, "", s_ratio / 100),
    ]


def _t_theta(data: SceneRun) -> tuple[FloatArray, FloatArray]:
    """(t, measured θ): what a student is given."""
    return data.t, data.theta_measured


def exercise2(run: LabRun) -> list[Answer]:
    """The raw reading g tan θ of a bob released hanging: its bias over whole periods, over a cut window."""
    data = released_data(run)
    cfg = _cfg(data)
    g, a = cfg["gravity"], run.accel
    period_s = period(data.t, data.theta_true, data.theta_dot)
    raw = estimate_batch("instant", data.t, data.theta_measured, **cfg)[0]
    bias, n = whole_period_mean(data.t, raw, period_s)
    window = float(np.trapezoid(raw, data.t) / (data.t[-1] - data.t[0]))  # the old key's 20 s mean
    amplitude = math.atan2(a, g)  # released hanging: the swing reaches from 0 to 2 θ_eq
    predicted = a * (1.0 + (a / g) ** 2) * amplitude**2 / 2.0
    pm = estimate_batch("period_mean", data.t, data.theta_measured, **cfg)[0]
    pm_bias = whole_period_mean(data.t, pm, period_s)[0]
    # σ of a whole-period mean of white reading noise: g sec²θ σ_θ / √N, N ≈ samples averaged.
    noise = g / math.cos(amplitude) ** 2 * cfg["noise_std"] / math.sqrt(n * period_s * cfg["rate_hz"])
    return [
        Answer("ex2_period", "period of the swing", period_s, "s", 1e-5),
        Answer("ex2_periods", "whole periods averaged", float(n), "", 0.5),
        Answer("ex2_bias_whole", "bias of g tan θ over whole periods", bias - a, "m/s²", noise / 10),
        Answer("ex2_bias_noise", "its 1σ from the sensor noise", noise, "m/s²", noise / 10),
        Answer("ex2_bias_predicted", "a (1 + a²/g²) A²/2, A = θ_eq", predicted, "m/s²", noise / 10),
        Answer("ex2_bias_window", "the same over all 20 s (cuts a swing)", window - a, "m/s²", noise / 10),
        Answer(
            "ex2_bias_period_mean", "period_mean's bias over whole periods", pm_bias - a, "m/s²", noise / 10
        ),
    ]


def exercise3(run: LabRun) -> list[Answer]:
    """The pendulum carried through a window of the real EPA city cycle: each estimator's RMS error."""
    data = drive_data(run)
    cfg = _cfg(data)
    truth = data.accel_true
    out = [
        Answer("ex3_rms_a", "RMS of the recorded a itself", float(np.sqrt(np.mean(truth**2))), "m/s²", 1e-4)
    ]
    for name in DRIVE_ESTIMATORS:
        est = estimate_batch(name, data.t, data.theta_measured, **cfg)[0]
        rms = float(np.sqrt(np.mean((est - truth) ** 2)))
        out.append(Answer(f"ex3_rms_{name}", f"RMS error of {name}", rms, "m/s²", 1e-4))
    return out


def extension_a() -> list[Answer]:
    """The elastic string against the rigid one; what stiffness costs the planner's RK4 and LSODA."""
    elastic = load_scene("elastic_string")
    t = elastic.sensor.sample_times(elastic.duration)
    rigid_scene = dataclasses.replace(
        elastic, outputs=("angle", "tension"), pendulum=dataclasses.replace(elastic.pendulum, stiffness=None)
    )
    rigid = simulate_plan(rigid_scene, plan_scene(rigid_scene), t)
    assert rigid.tension is not None
    out = []
    for k in STIFFNESSES:
        s = dataclasses.replace(elastic, pendulum=dataclasses.replace(elastic.pendulum, stiffness=k))
        el = simulate_plan(s, plan_scene(s), t)
        lsoda = simulate_plan(s, plan_with(s, model="elastic", method="LSODA", rtol=LSODA_RTOL), t)
        assert el.stretch is not None
        tag = f"{k:.0e}".replace("+0", "")
        d_theta = float(np.max(np.abs(el.theta - rigid.theta)))
        d_stretch = float(np.max(np.abs(el.stretch - rigid.tension / k)))
        out += [
            Answer(
                f"extA_{tag}_dtheta", f"max abs(θ_el − θ_rigid), k = {k:.0e}", d_theta, "rad", d_theta * 1e-3
            ),
            Answer(
                f"extA_{tag}_dstretch",
                f"max abs(stretch − T_rigid/k), k = {k:.0e}",
                d_stretch,
                "m",
                d_stretch * 1e-2,
            ),
            Answer(f"extA_{tag}_nfev_plan", f"f-calls, planner, k = {k:.0e}", float(el.nfev), "", 0.5),
            Answer(
                f"extA_{tag}_nfev_lsoda",
                f"f-calls, LSODA, k = {k:.0e}",
                float(lsoda.nfev),
                "",
                LSODA_TOL_REL * lsoda.nfev,
            ),
        ]
    return out


def extension_b() -> list[Answer]:
    """The hill: the reading g tan β at a = 0, and the period and tension that tell it from a level car."""
    hill = load_scene("hill")
    g = hill.pendulum.gravity
    run = run_scene(hill)
    est = estimate_batch("kalman", run.t, run.theta_measured, **_cfg(run))[0]
    late = run.t > run.t[-1] - 10.0
    level = run_scene(dataclasses.replace(hill, grade=0.0, profile=Constant(g * math.tan(hill.grade))))
    assert run.tension is not None and level.tension is not None
    return [
        Answer("extB_prediction", "g tan β", g * math.tan(hill.grade), "m/s²", 1e-5),
        Answer("extB_estimate", "kalman's reading, last 10 s", float(est[late].mean()), "m/s²", 1e-4),
        Answer(
            "extB_period_hill", "period on the hill", period(run.t, run.theta_true, run.theta_dot), "s", 1e-5
        ),
        Answer(
            "extB_period_level",
            "period on the level at g tan β",
            period(level.t, level.theta_true, level.theta_dot),
            "s",
            1e-5,
        ),
        Answer("extB_tension_hill", "mean tension, hill", float(run.tension.mean()), "N", 1e-4),
        Answer("extB_tension_level", "mean tension, level", float(level.tension.mean()), "N", 1e-4),
    ]


def answers(run: LabRun = KEY_RUN, extensions: bool = True) -> dict[str, Answer]:
    """Every answer for ``run``, by name (the extensions do not depend on the run)."""
    found = exercise1(run) + exercise2(run) + exercise3(run)
    if extensions:
        found += extension_a() + extension_b()
    return {a.name: a for a in found}


def main(argv: Sequence[str] | None = None) -> int:
    """Print one group's answers: ``python -m pendulum_accel.lecture.lab_answers --seed N --accel A``."""
    parser = argparse.ArgumentParser(description="The lab's answers for one group's run.")
    parser.add_argument("--seed", type=int, default=KEY_RUN.seed)
    parser.add_argument("--accel", type=float, default=KEY_RUN.accel)
    parser.add_argument("--drive-start", type=float, default=KEY_RUN.drive_start)
    args = parser.parse_args(argv)
    try:
        run = LabRun(seed=args.seed, accel=args.accel, drive_start=args.drive_start)
        found = answers(run, extensions=False)
    except (ParameterError, SceneError) as err:
        print(f"error: {err}", file=sys.stderr)
        return 2
    for answer in found.values():
        print(answer.line())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
