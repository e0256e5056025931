"""Why the constants: the figures each tuned constant of the package was chosen on, computed afresh.

    python -m benchmarks.constants            # every section (under five minutes of CPU)
    python -m benchmarks.constants --quick    # shorter timings, fewer Allan records, no cold compile

A constant's comment in the code says what it is and names this page; the measurements that set it live
here, each row with the constant, its value, what was compared, the figures and the data:

- costs: planner.KERNEL_STEP_S and CLOSED_FORM_SAMPLE_S against the CPU a step or a sample takes here
  (best of ``--repeats``, ``time.process_time``), physics.kernels.SLICE_STEPS as seconds a compiled call,
  and sweep.MAX_SWEEP_STEPS / MAX_SWEEP_WORK as minutes of a sweep (the Python step and the batch rate);
- the smoothing spline (motion_input.trace): MAX_SMOOTHING_STEPS from a sinusoid's derivative at f_c/4
  against the continuous-limit gain H as 1/(f_c h) grows, SPLINE_MARGIN_WIDTHS from a unit impulse's
  fitted curve and slope against the kernel's envelope e^(−t/(b√2));
- allan.MISFIT_LIMIT: χ²/dof of the white-noise-and-walk fit on records it describes (white noise and
  walks), on Gauss-Markov biases it lacks, and on the bundled scenes' swings, without and with the
  Gauss-Markov term;
- the planner's safety factors: SPREAD_SAFETY from the measured error against the one-ulp spread past the
  linear regime, DOUBLING_SHARE from the measured closed-form error near the separatrix against the
  prediction with no share, 1/32 and 1/8 per argument doubling (37-digit reference,
  benchmarks/reference.py, as benchmarks/error_bounds.py), and HALVING_NOISE from the halving difference
  of error_bounds' RK8 plans against the run's measured round-off;
- kernel_cache.WARM_PARTS: each part's cold compile, alone in a fresh process into an empty numba cache
  (not with --quick);
- kalman.AUTO_CROSS_TIME: auto's RMS with its trend partners (AUTO_TRENDS) swapping every 1, 3 or 10 s,
  over its random walks alone, on benchmarks.corpus's training entries (the first 60 s, seed 0) through
  the teaching and short_damped designs of benchmarks.real_motion.

Machine-dependent rows (the costs) hold for the machine named below only; the rest are deterministic
(seeded) up to the last digits.
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar
from unittest import mock

import numpy as np

from benchmarks import report
from benchmarks.allan_recovery import Sensor
from benchmarks.corpus import CORPUS
from benchmarks.error_bounds import ILL_CONDITIONED, SEPARATRIX_RATE, Case, battery, run_case
from pendulum_accel import plan_scene, planner, sweep
from pendulum_accel.allan import MISFIT_LIMIT, allan_deviation
from pendulum_accel.conditioning import input_sensitivity
from pendulum_accel.estimators import ekf_kernels as kern
from pendulum_accel.estimators.kalman import AUTO_CROSS_TIME, PRESETS
from pendulum_accel.kernel_cache import WARM_PARTS
from pendulum_accel.motion_input import trace
from pendulum_accel.physics import kernels
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Constant
from pendulum_accel.physics.simulate import simulate
from pendulum_accel.scene import Scene

if TYPE_CHECKING:
    from benchmarks.motion_designs import Run

T = TypeVar("T")


@dataclass(frozen=True)
class Row:
    """One line of the page: the constant, its value, what was compared, the figures, the data."""

    constant: str
    value: str
    compared: str
    figures: str
    data: str


def best_cpu(work: Callable[[], T], repeats: int) -> tuple[float, T]:
    """(least CPU seconds of ``repeats`` calls of ``work``, its last result): process time, best of."""
    best, result = math.inf, None
    for _ in range(repeats):
        start = time.process_time()
        result = work()
        best = min(best, time.process_time() - start)
    assert result is not None
    return best, result


# --- costs ---------------------------------------------------------------------------------------------

STIFFNESS = 900.0  # N/m on 1 kg, 1 m: a radial ω of 30 rad/s, ~10× the swing's, stepped without stiffness
STEP = 1e-4  # s: short enough that explicit Euler's growth over a million steps stays within its check


def _step_cost(model: str, method: str, steps: int, repeats: int) -> float:
    """CPU s per step of a compiled ``model``/``method`` run of ``steps`` steps of STEP (samples every 10):
    the whole run is one compiled call per slice."""
    pendulum = Pendulum(1.0, stiffness=STIFFNESS if model == "elastic" else None)
    t = np.linspace(0.0, steps * STEP, steps // 10 + 1)

    def run() -> object:
        """One simulate() call."""
        return simulate(pendulum, Constant(2.0), t, theta0=0.3, model=model, method=method, dt=STEP)

    run()  # the first call loads the kernel from numba's cache: not a step cost
    seconds, _ = best_cpu(run, repeats)
    return seconds / steps


def _sample_cost(model: str, samples: int, repeats: int) -> float:
    """CPU s per sample of the ``model`` closed form (linear or exact) over ``samples`` sample times."""
    t = np.linspace(0.0, 100.0, samples)
    pendulum = Pendulum(1.0)
    seconds, _ = best_cpu(lambda: simulate(pendulum, Constant(2.0), t, theta0=0.3, model=model), repeats)
    return seconds / samples


def _sweep_costs(steps: int, variants: int, repeats: int) -> tuple[float, float]:
    """(CPU s per Python step of a sweep of one variant, trajectory-steps per CPU s of ``variants``):
    the rigid RK4 batch of benchmarks.sweep_bench, a = 2 m/s², dt = 1 ms."""
    t = np.linspace(0.0, steps * 1e-3, steps // 10 + 1)
    setup = sweep.SweepSetup(Pendulum(1.0), Constant(2.0), 0.1, 0.0, t, None, 0.0, 100.0)
    one, _ = best_cpu(lambda: sweep.run_batch(setup, np.array([1.0]), None, dt=1e-3), repeats)
    lengths = np.linspace(0.5, 2.0, variants)
    many, result = best_cpu(lambda: sweep.run_batch(setup, lengths, None, dt=1e-3), repeats)
    return one / steps, variants * result[3] / many


def cost_rows(quick: bool, repeats: int) -> list[Row]:
    """KERNEL_STEP_S, CLOSED_FORM_SAMPLE_S, SLICE_STEPS, MAX_SWEEP_STEPS and MAX_SWEEP_WORK against the CPU
    measured here."""
    steps = 200_000 if quick else 1_000_000
    rows = []
    per_step: dict[tuple[str, str], float] = {}
    for key, assumed in planner.KERNEL_STEP_S.items():
        per_step[key] = _step_cost(*key, steps, repeats)
        rows.append(
            Row(
                f"planner.KERNEL_STEP_S[{key[0]}, {key[1]}]",
                f"{assumed * 1e6:g} µs",
                f"CPU a compiled step takes ({STEP:g} s steps, a = 2 m/s², θ0 0.3 rad)",
                f"{per_step[key] * 1e6:.3g} µs a step ({per_step[key] / assumed:.2g}× the value)",
                f"{steps:,} steps, best of {repeats}",
            )
        )
    samples = 100_000 if quick else 1_000_000
    for model, assumed in planner.CLOSED_FORM_SAMPLE_S.items():
        cost = _sample_cost(model, samples, repeats)
        rows.append(
            Row(
                f"planner.CLOSED_FORM_SAMPLE_S[{model}]",
                f"{assumed * 1e6:g} µs",
                "CPU a closed-form sample takes (a = 2 m/s², θ0 0.3 rad)",
                f"{cost * 1e6:.3g} µs a sample ({cost / assumed:.2g}× the value)",
                f"{samples:,} samples over 100 s, best of {repeats}",
            )
        )
    for method, per_call in kernels.SLICE_STEPS.items():
        for model in ("rigid", "elastic"):
            if (model, method) not in per_step and model == "rigid":
                per_step[(model, method)] = _step_cost(model, method, steps, repeats)
        rigid, elastic = per_step[("rigid", method)], per_step.get(("elastic", method))
        rows.append(
            Row(
                f"physics.kernels.SLICE_STEPS[{method}]",
                f"{per_call:,}",
                "CPU seconds of one compiled call (a slice), rigid / elastic",
                f"{per_call * rigid:.2g} s" + ("" if elastic is None else f" / {per_call * elastic:.2g} s"),
                "the step costs above"
                if elastic is not None
                else f"rigid, {steps:,} steps, best of {repeats}",
            )
        )
    sweep_steps = 20_000 if quick else 50_000
    python_step, rate = _sweep_costs(sweep_steps, 1000, repeats)
    rows.append(
        Row(
            "sweep.MAX_SWEEP_STEPS",
            f"{sweep.MAX_SWEEP_STEPS:,}",
            "minutes of a sweep that long (its Python step: one variant, RK4)",
            f"{python_step * 1e6:.3g} µs a step → {sweep.MAX_SWEEP_STEPS * python_step / 60:.2g} min",
            f"{sweep_steps:,} steps, best of {repeats}",
        )
    )
    rows.append(
        Row(
            "sweep.MAX_SWEEP_WORK",
            f"{sweep.MAX_SWEEP_WORK:,}",
            "minutes of that many trajectory-steps (1000 variants, RK4)",
            f"{rate / 1e6:.3g} M trajectory-steps/s → {sweep.MAX_SWEEP_WORK / rate / 60:.2g} min",
            f"1000 × {sweep_steps:,} steps, best of {repeats}",
        )
    )
    return rows


# --- the smoothing spline --------------------------------------------------------------------------------


def kernel_width(cutoff_hz: float) -> float:
    """b = (√2 − 1)^¼ / (2π f_c): the smoothing spline's kernel width (trace.SPLINE_MARGIN_WIDTHS)."""
    return (math.sqrt(2.0) - 1.0) ** 0.25 / (2.0 * math.pi * cutoff_hz)


def derivative_error(per_cutoff: int) -> float:
    """max |s' − H v'| / (H max |v'|) in the middle of 32 cut-off periods of v = sin 2π (f_c/4) t, h = 1,
    f_c = 1/per_cutoff: the spline's derivative against the continuous-limit gain H(f) = 1/(1 + (2πfb)⁴)
    (12 cut-off periods, over 90 kernel widths, kept from either end)."""
    cutoff = 1.0 / per_cutoff
    f = cutoff / 4.0
    t = np.arange(32 * per_cutoff, dtype=float)
    spline = trace.interpolate.make_smoothing_spline(
        t, np.sin(2.0 * math.pi * f * t), lam=trace.spline_lambda(cutoff, 1.0)
    )
    gain = 1.0 / (1.0 + (2.0 * math.pi * f * kernel_width(cutoff)) ** 4)
    middle = t[12 * per_cutoff : 20 * per_cutoff]
    slope = spline.derivative(1)(middle)
    expected = gain * 2.0 * math.pi * f * np.cos(2.0 * math.pi * f * middle)
    return float(np.max(np.abs(slope - expected)) / (gain * 2.0 * math.pi * f))


SMOOTHING_STEPS = (1000, 3000, 10_000, 30_000)
IMPULSE_WIDTH = 20.0  # samples per kernel width b: the continuous limit, as a 1 Hz cut-off on 100 Hz data


def impulse_decay(widths: Sequence[float]) -> list[tuple[float, float]]:
    """(peak |s|, peak b |s'|) over one period 2π√2 b from t0 + d b on, each over s(t0), for each d of
    ``widths``: the smoothing spline s of a unit impulse at t0 (h = 1, b = IMPULSE_WIDTH h, the data
    reaching 100 b either side)."""
    b = IMPULSE_WIDTH
    cutoff = (math.sqrt(2.0) - 1.0) ** 0.25 / (2.0 * math.pi * b)
    half = int(100 * b)
    t = np.arange(-half, half + 1, dtype=float)
    spline = trace.interpolate.make_smoothing_spline(
        t, (t == 0.0).astype(float), lam=trace.spline_lambda(cutoff, 1.0)
    )
    peak = float(spline(0.0))
    out = []
    for d in widths:
        grid = np.linspace(d * b, (d + 2.0 * math.pi * math.sqrt(2.0)) * b, 400)
        out.append(
            (
                float(np.max(np.abs(spline(grid)))) / peak,
                float(np.max(np.abs(spline.derivative(1)(grid)))) * b / peak,
            )
        )
    return out


MARGIN_WIDTHS = (10.0, 20.0, 40.0, 60.0, 80.0)


def spline_rows() -> tuple[list[Row], list[tuple[int, float]], list[tuple[float, float, float]]]:
    """The rows of MAX_SMOOTHING_STEPS and SPLINE_MARGIN_WIDTHS and the figures for the plot."""
    errors = [(n, derivative_error(n)) for n in SMOOTHING_STEPS]
    decays = impulse_decay(MARGIN_WIDTHS)
    envelope = [math.exp(-d / math.sqrt(2.0)) for d in MARGIN_WIDTHS]
    ratio = max(max(curve, slope) / e for (curve, slope), e in zip(decays, envelope, strict=True))
    rows = [
        Row(
            "trace.MAX_SMOOTHING_STEPS",
            f"{trace.MAX_SMOOTHING_STEPS:,}",
            "a sinusoid's derivative at f_c/4 against H, relative to H, by samples per 1/f_c",
            ", ".join(f"{err:.2g} at {n:,}" for n, err in errors),
            "32 cut-off periods of sin 2π (f_c/4) t, h = 1, the middle 8",
        ),
        Row(
            "trace.SPLINE_MARGIN_WIDTHS",
            f"{trace.SPLINE_MARGIN_WIDTHS:g} b",
            "a unit impulse's fitted curve and slope (× b), over s(t0), against e^(−d/√2) at d b",
            ", ".join(
                f"{max(c, s):.2g} (e^(−d/√2) {e:.2g}) at {d:g} b"
                for d, (c, s), e in zip(MARGIN_WIDTHS, decays, envelope, strict=True)
            )
            + f"; at most {ratio:.2g}× the exponential",
            f"impulse on h = 1, b = {IMPULSE_WIDTH:g} h, data 100 b either side",
        ),
    ]
    points = [(d, max(c, s), e) for d, (c, s), e in zip(MARGIN_WIDTHS, decays, envelope, strict=True)]
    return rows, errors, points


# --- allan.MISFIT_LIMIT -----------------------------------------------------------------------------------

WALKS = (0.0, 1e-5, 1e-4, 3e-4, 1e-3)  # rad/√s: the walks K of the white-noise records
SWING_SCENES = ("braking", "step_start", "hwfet")
BIASES = (Sensor("T_c 0.3 s", drive=1e-3, time=0.3), Sensor("T_c 1 s", drive=3e-3, time=1.0),
          Sensor("T_c 3 s", drive=1e-3, time=3.0), Sensor("T_c 10 s", drive=1e-3, time=10.0))  # fmt: skip


def white_walk_misfits(records: int) -> np.ndarray:
    """χ²/dof of allan_deviation (Gauss-Markov term on) over ``records`` records of 200 s at 100 Hz:
    white noise σ 2e-3 rad plus a walk K, the records spread over WALKS, seeds 0 …"""
    out = []
    for seed in range(records):
        rng = np.random.default_rng(seed)
        walk = WALKS[seed % len(WALKS)]
        y = 2e-3 * rng.standard_normal(20_000) + walk * np.cumsum(rng.standard_normal(20_000)) / 10.0
        out.append(allan_deviation(y, 100.0, gauss_markov=True).misfit)
    return np.array(out)


def bias_misfits(seeds: int) -> tuple[np.ndarray, np.ndarray]:
    """(χ²/dof without, with the Gauss-Markov term) of static records, 2000 s at 50 Hz, of each sensor of
    BIASES (white σ 1 mrad; benchmarks.allan_recovery's sensor model), ``seeds`` seeds each."""
    plain, fitted = [], []
    for sensor in BIASES:
        for seed in range(seeds):
            model = sensor.model(50.0, seed)
            t = model.sample_times(2000.0)
            theta = model.measure(t, np.zeros_like(t))
            plain.append(allan_deviation(theta, 50.0).misfit)
            fitted.append(allan_deviation(theta, 50.0, gauss_markov=True).misfit)
    return np.array(plain), np.array(fitted)


def swing_misfits() -> tuple[np.ndarray, np.ndarray]:
    """(χ²/dof without, with the Gauss-Markov term) of the measured angle of each SWING_SCENES run."""
    from pendulum_accel.scene import load_scene
    from pendulum_accel.scene_run import run_scene

    plain, fitted = [], []
    for name in SWING_SCENES:
        run = run_scene(load_scene(name))
        rate = 1.0 / float(np.median(np.diff(run.t)))
        plain.append(allan_deviation(run.theta_measured, rate).misfit)
        fitted.append(allan_deviation(run.theta_measured, rate, gauss_markov=True).misfit)
    return np.array(plain), np.array(fitted)


def _span(values: np.ndarray) -> str:
    """'min–max' of χ²/dof values, two significant digits."""
    return f"{values.min():.2g}–{values.max():.2g}"


def misfit_rows(records: int, seeds: int) -> tuple[list[Row], dict[str, np.ndarray]]:
    """The MISFIT_LIMIT row and the χ²/dof groups for the plot."""
    white = white_walk_misfits(records)
    bias_plain, bias_fitted = bias_misfits(seeds)
    swing_plain, swing_fitted = swing_misfits()
    row = Row(
        "allan.MISFIT_LIMIT",
        f"{MISFIT_LIMIT:g}",
        "χ²/dof of the white-noise-and-walk fit: records it describes, biases it lacks, swings",
        f"white noise + walk at most {white.max():.2g}; Gauss-Markov biases {_span(bias_plain)} "
        f"({_span(bias_fitted)} with the term); swings {_span(swing_plain)} ({_span(swing_fitted)} with it)",
        f"{records} records of 200 s at 100 Hz, K {min(WALKS):g} … {max(WALKS):g} rad/√s; "
        f"{seeds} seeds × T_c {', '.join(f'{s.time:g}' for s in BIASES)} s, 2000 s at 50 Hz; "
        f"the scenes {', '.join(SWING_SCENES)}",
    )
    groups = {
        "white + walk": white,
        "Gauss-Markov, no term": bias_plain,
        "Gauss-Markov, with term": bias_fitted,
        "swings, no term": swing_plain,
        "swings, with term": swing_fitted,
    }
    return [row], groups


# --- the planner's safety factors ----------------------------------------------------------------------


def doubling_cases() -> list[Case]:
    """Starts where the exact closed form halves and doubles its argument (nome past FOURIER_MAX_NOME) and
    its round-off, not the start's, carries the prediction (benchmarks.error_bounds's scenes: l = 1 m,
    a = 0, 20 s at 100 Hz; target 1e-6): librations of 3, 3.1 and 3.14 rad, and starts 1e-2 and 1e-3
    below and above the separatrix's rate."""
    base = next(case.scene for case in battery() if case.name == "libration 3 rad")
    cases = [
        Case(f"libration {amp:g} rad", replace(base, name=f"lib_{amp * 100:.0f}", theta0=amp), (1e-6,))
        for amp in (3.0, 3.1, 3.14)
    ]
    for gap in (1e-2, 1e-3):
        for side, sign in (("below", -1.0), ("above", 1.0)):
            rate = SEPARATRIX_RATE * (1.0 + sign * gap)
            scene = replace(base, name=f"{side}_{gap:.0e}", theta0=0.0, theta_dot0=rate)
            cases.append(Case(f"{side} separatrix {gap:g}", scene, (1e-6,)))
    return cases


def _prediction_with_share(case: Case, predicted: float, share: float) -> float:
    """The plan's predicted error with DOUBLING_SHARE replaced by ``share`` (the closed form's round-off
    term recomputed, the rest of the prediction kept)."""
    scene = case.scene
    accel = scene.profile.scalar(0.0)
    args = (scene.pendulum, accel, scene.theta0, scene.theta_dot0, scene.duration)
    kept = planner.closed_form_roundoff(*args)
    with mock.patch.object(planner, "DOUBLING_SHARE", share):
        other = planner.closed_form_roundoff(*args)
    return predicted - kept + other


HALVING_CASES = ("ramp", "sinusoid", "damped large swing", "damped rotation, sinusoid")
"""The cases of benchmarks.error_bounds's full battery the planner steps with RK8 (target 1e-12)."""


def _rk8_runner(scene: Scene, model: str, t: np.ndarray, h: float) -> Callable[[float, float], np.ndarray]:
    """(θ0, θ'0) → θ at the times t of an RK8 run of ``scene``'s ``model`` at step h."""

    def run(theta0: float, theta_dot0: float) -> np.ndarray:
        """θ at the sample times."""
        return simulate(scene.pendulum, scene.profile, t, theta0=theta0, theta_dot0=theta_dot0, model=model,
                        method="rk8", dt=h).theta  # fmt: skip

    return run


def halving_noise_ratios() -> list[tuple[str, float, float]]:
    """(case, the plan's halving difference max |θ_h − θ_{h/2}| over the round-off of the run at h, the
    round-off of the run at h/2 over that at h) for each HALVING_CASES case whose plan at target 1e-12 is
    RK8 with a step h: the round-off as the planner measures it (conditioning.input_sensitivity's
    ``noise``: the second difference of runs nudged both ways)."""
    out = []
    for case in battery():
        if case.name not in HALVING_CASES:
            continue
        scene = replace(case.scene, accuracy=1e-12)
        plan = plan_scene(scene)
        if plan.method != "rk8" or plan.dt is None:
            continue
        t = scene.sensor.sample_times(scene.duration)
        omega = scene.pendulum.omega(scene.profile.max_abs(0.0, scene.duration))
        noises = [
            input_sensitivity(_rk8_runner(scene, plan.model, t, h), scene.theta0, scene.theta_dot0, omega, t,
                              1e-12).noise
            for h in (plan.dt, plan.dt / 2.0)
        ]  # fmt: skip
        out.append((case.name, plan.halving_difference / noises[0], noises[1] / noises[0]))
    return out


def _share(share: float) -> str:
    """'0' or '1/n' of a share a doubling adds."""
    return "0" if share == 0.0 else f"1/{1.0 / share:g}"


def planner_rows() -> list[Row]:
    """SPREAD_SAFETY on the chaotic drive, DOUBLING_SHARE on the separatrix starts."""
    reference: dict[str, np.ndarray] = {}
    past = []  # (case, measured, spread) of the ill-conditioned cases past the linear regime
    for case in ILL_CONDITIONED:
        for row in run_case(case, reference):
            sensitivity = row.plan.sensitivity
            if sensitivity is not None and not sensitivity.linear:
                past.append((case, row.measured, sensitivity.spread))
    rows = [
        Row(
            "planner.SPREAD_SAFETY",
            f"{planner.SPREAD_SAFETY:g}",
            "measured error against the spread of five runs one ulp apart, past the linear regime",
            "; ".join(
                f"{case.name}: {measured:.2g} rad, spread {spread:.2g} rad, {measured / spread:.2g}×"
                for case, measured, spread in past
            ),
            "benchmarks.error_bounds's ill-conditioned cases past the linear regime, target 1e-6",
        )
    ]
    cases = doubling_cases()
    ratios: dict[float, list[float]] = {0.0: [], planner.DOUBLING_SHARE: [], 1.0 / 8.0: []}
    for case in cases:
        (sep,) = run_case(case, reference)
        for share, found in ratios.items():
            found.append(sep.measured / _prediction_with_share(case, sep.plan.predicted_error, share))
    rows.append(
        Row(
            "planner.DOUBLING_SHARE",
            _share(planner.DOUBLING_SHARE),
            "measured / predicted error of the exact closed form where it doubles its argument, by the "
            "share a doubling adds",
            "; ".join(
                f"{_share(share)}: {min(found):.2g}–{max(found):.2g}" for share, found in ratios.items()
            ),
            f"{', '.join(c.name for c in cases)}; 20 s at 100 Hz",
        )
    )
    halving = halving_noise_ratios()
    rows.append(
        Row(
            "planner.HALVING_NOISE",
            f"{planner.HALVING_NOISE:g}",
            "the halving difference max over t of abs(θ_h − θ_h/2) over the run's round-off at h, and the "
            "h/2 run's round-off over the h run's (RK8, the plan's h)",
            "; ".join(f"{name}: {diff:.2g}, {ratio:.2g}" for name, diff, ratio in halving),
            "benchmarks.error_bounds's full battery, its RK8 plans at target 1e-12",
        )
    )
    return rows


# --- kalman.AUTO_CROSS_TIME ----------------------------------------------------------------------------

CROSS_TIMES = (1.0, 3.0, 10.0)  # s: the candidates AUTO_CROSS_TIME was picked from
TRAINING_SPAN = 60.0  # s: the first seconds of each training profile, as auto's other fits take


def _squared_error(runs: Sequence[Run], params: np.ndarray, qs: np.ndarray, jerks: np.ndarray | None,
                   rates: np.ndarray, warmup: float) -> float:  # fmt: skip
    """Σ (â − a)² over the runs (t ≥ warmup) of the IMM of modes ``qs`` (trend partners ``jerks``)."""
    total = 0.0
    for r in runs:
        a, _, _ = kern.imm_pass(r.t, r.theta, params, qs, rates, np.zeros(1, np.int64), False, jerks)
        keep = r.t >= warmup
        total += float(np.sum((a[keep, 0] - r.accel[keep]) ** 2))
    return total


def cross_time_rms(seeds: int) -> dict[str, np.ndarray]:
    """Per fitted design, per CROSS_TIMES: the geometric mean over benchmarks.corpus's training profiles
    (their first TRAINING_SPAN s, ``seeds`` seeds) of auto's RMS with its trend partners (AUTO_TRENDS)
    swapping every cross time, over auto's RMS with its random walks alone; and over both designs."""
    from benchmarks.motion_designs import designs, simulate_runs
    from benchmarks.motion_scores import WARMUP, kalman_q

    auto = PRESETS["auto"]
    walks, _, rates = auto.imm(walks_only=True)
    out = {}
    for design in designs():
        params = kalman_q(design, 1.0)._params
        logs, used = np.zeros(len(CROSS_TIMES)), 0
        for entry in CORPUS:
            if entry.split != "train":
                continue
            runs = simulate_runs(entry.build(), design, seeds, min(entry.duration, TRAINING_SPAN))
            base = _squared_error(runs, params, walks, None, rates, WARMUP)
            for i, cross in enumerate(CROSS_TIMES):
                qs, jerks, both = kern.with_trends(walks, rates, np.array(auto.trends), cross)
                logs[i] += 0.5 * math.log(_squared_error(runs, params, qs, jerks, both, WARMUP) / base)
            used += 1
        out[design.name] = np.exp(logs / max(used, 1))
    out["both designs"] = np.exp(np.mean(np.log(np.vstack(list(out.values()))), axis=0))
    return out


def cross_time_rows(seeds: int) -> list[Row]:
    """The AUTO_CROSS_TIME row."""
    found = cross_time_rms(seeds)
    return [
        Row(
            "kalman.AUTO_CROSS_TIME",
            f"{AUTO_CROSS_TIME:g} s",
            "auto's RMS with its trend partners swapping every 1, 3 or 10 s, over its random walks alone "
            "(geometric mean over the profiles)",
            "; ".join(
                f"{label}: "
                + ", ".join(f"{v:.3f} at {c:g} s" for c, v in zip(CROSS_TIMES, values, strict=True))
                for label, values in found.items()
            ),
            f"benchmarks.corpus's training entries, the first {TRAINING_SPAN:g} s, "
            f"seed{'s 0-' + str(seeds - 1) if seeds > 1 else ' 0'}; the teaching and short_damped designs",
        )
    ]


# --- kernel_cache.WARM_PARTS ---------------------------------------------------------------------------


def compile_seconds(module: str, function: str) -> float:
    """CPU s (user + system) of a fresh Python process that runs kernel_cache.warm_part(module, function)
    into an empty numba cache (NUMBA_CACHE_DIR a new temporary folder): the part's cold compile, with the
    interpreter's start and the package's import."""
    code = f"from pendulum_accel.kernel_cache import warm_part; warm_part({module!r}, {function!r})"
    with tempfile.TemporaryDirectory() as cache:
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([sys.executable, "-c", code], env={**os.environ, "NUMBA_CACHE_DIR": cache}, check=True)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime


def warm_rows(quick: bool) -> list[Row]:
    """The WARM_PARTS row: each part's cold compile in CPU s and its share of the three (not in --quick)."""
    if quick:
        figures = "not measured with --quick (the cold compiles are most of the full run)"
    else:
        found = [(function, compile_seconds(module, function)) for module, function in WARM_PARTS]
        total = sum(seconds for _, seconds in found)
        figures = ", ".join(f"{name} {seconds:.0f} s ({seconds / total:.0%})" for name, seconds in found)
    return [
        Row(
            "kernel_cache.WARM_PARTS",
            ", ".join(function for _, function in WARM_PARTS),
            "CPU of each part's cold compile (the order: longest first), and its share of the three",
            figures,
            "each part alone in a fresh process into an empty numba cache",
        )
    ]


# --- the page ---------------------------------------------------------------------------------------------


def table(rows: Sequence[Row]) -> str:
    """The markdown table: constant, value, what was compared, the figures, the data."""
    lines = ["| constant | value | compared | figures | data |", "|---|---|---|---|---|"]
    lines += [f"| {r.constant} | {r.value} | {r.compared} | {r.figures} | {r.data} |" for r in rows]
    return "\n".join(lines)


def plot(
    errors: Sequence[tuple[int, float]],
    decays: Sequence[tuple[float, float, float]],
    groups: dict[str, np.ndarray],
    out: Path,
) -> Path:
    """constants.png: the spline's derivative error by samples per 1/f_c beside MAX_SMOOTHING_STEPS, the
    impulse's decay beside its envelope and SPLINE_MARGIN_WIDTHS, and the χ²/dof groups beside
    MISFIT_LIMIT."""
    fig, _ = report.new_axes(12.0, 4.0)
    fig.clear()
    left, middle, right = fig.subplots(1, 3)
    left.loglog([n for n, _ in errors], [e for _, e in errors], "o-")
    left.axvline(trace.MAX_SMOOTHING_STEPS, ls="--", color="tab:red", label="MAX_SMOOTHING_STEPS")
    left.set_xlabel("samples per 1/f_c")
    left.set_ylabel("derivative error at f_c/4, relative to H")
    left.legend(fontsize=8)
    middle.semilogy([d for d, _, _ in decays], [v for _, v, _ in decays], "o", label="impulse's fit (peak)")
    middle.semilogy([d for d, _, _ in decays], [e for _, _, e in decays], "--", label="e^(−d/√2)")
    middle.axvline(trace.SPLINE_MARGIN_WIDTHS, ls=":", color="tab:red", label="SPLINE_MARGIN_WIDTHS")
    middle.set_xlabel("distance d from the impulse, kernel widths b")
    middle.set_ylabel("peak of the fit's abs(s), abs(b s'), over s(t0)")
    middle.legend(fontsize=8)
    for k, values in enumerate(groups.values()):
        right.semilogx(values, np.full(values.size, k), "|", ms=12)
    right.set_yticks(range(len(groups)), list(groups), fontsize=8)
    right.axvline(MISFIT_LIMIT, ls="--", color="tab:red", label="MISFIT_LIMIT")
    right.set_xlabel("χ²/dof of the white-noise-and-walk fit")
    right.legend(fontsize=8)
    for ax in (left, middle, right):
        ax.grid(True, which="both", alpha=0.3)
    fig.set_layout_engine("constrained")
    return report.save_figure(fig, out)


def main(argv: Sequence[str] | None = None) -> int:
    """Compute every section, print the table, write constants.md, constants.png and the docs page."""
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.constants", description=__doc__.split("\n")[0]
    )
    parser.add_argument(
        "--quick", action="store_true", help="shorter timings, fewer Allan records, no cold compile"
    )
    parser.add_argument("--repeats", type=report.count, default=3, help="best of this many timings (3)")
    parser.add_argument("--out", type=Path, default=Path("out/bench"), help="output directory (out/bench)")
    report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    records, seeds = (100, 2) if args.quick else (1000, 5)
    spline, errors, decays = spline_rows()
    allan, groups = misfit_rows(records, seeds)
    crossing = cross_time_rows(1)
    rows = [
        *cost_rows(args.quick, args.repeats),
        *spline,
        *allan,
        *planner_rows(),
        *crossing,
        *warm_rows(args.quick),
    ]
    text = table(rows)
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "constants.md").write_text(text + "\n", encoding="utf-8")
    png = plot(errors, decays, groups, args.out / "constants.png")
    page = report.write_page(
        "constants", "Why the constants", [text],
        [(png, "The spline's derivative error and impulse decay, and the Allan fit's χ²/dof, beside "
          "the constants set on them")],
        intro=__doc__ or "", docs=args.docs, argv=argv,
    )  # fmt: skip
    print(f"wrote {page}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
