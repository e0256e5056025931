"""Integrated-walk bound: what a model that knows a(t) is smooth would gain over the random walk.

    python -m benchmarks.integrated_walk [--full] [--seeds N] [--workers N] [--out DIR]

A random walk (a' = white noise of density q_a), the model of every other filter in the package, cannot
predict a trend, and a real car's a(t) has one: such a filter lags behind it. An integrated walk (a' = j,
j' = white noise of density q_j) predicts the trend. This page measures what that model would buy, as a
bound: the extended Kalman filter on the state (θ, ω, a, j) at the q_j that minimises its RMS against the
truth (``iw_hindsight``), beside the random-walk EKF at its own hindsight q_a (``ekf_hindsight``,
real_motion's bound), the live default (``kalman``, preset auto) and g·tanθ (``instant``).

The live default runs such a model: auto pairs four of its random-walk modes with integrated-walk
modes (kalman.AUTO_TRENDS, ekf_kernels.with_trends). The page's second table sets it beside auto's
random-walk modes alone (``walks only``, the default before the trend modes), with the figures the
real-motion page judges (RMS, shares beyond 2σ steady and after a change, with n_eff).

Profiles: the validation split of ``benchmarks.corpus`` (motion_designs.PROFILES, role validate); designs: the
two every fit uses and motion_designs.REPORTED_HELDOUT; the first 60 s of each profile unless ``--full``;
seeds 0 … N−1 pooled; t ≥ 2 s scored. Nothing here is fitted for use: both hindsight filters see the truth,
which no estimator may, so they bound what a model of their class can do on the recording.

The integrated-walk EKF is this page's alone (no estimator uses it): predict in sub-steps h ≤
ekf_kernels.MAX_STEP, the state by RK4 with a(s) = a + j s, P ← F P Fᵀ + Q with F the third-order series
of e^{Jh} and Q = q_j ∫₀ʰ v(s) v(s)ᵀ ds (v(s) = e^{Js} e₄ to the same order, 4-point Gauss–Legendre,
exact for its degree-6 integrand); the update is the scalar one of ``ekf_kernels.correct`` over four states.
"""

from __future__ import annotations

import argparse
import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit

from benchmarks import report
from benchmarks.motion_designs import (
    PROFILES,
    REPORTED_HELDOUT,
    Design,
    Profile,
    Run,
    designs,
    simulate_runs,
)
from benchmarks.motion_scores import Q_GRID, WARMUP, Score, kalman_q, pooled_rms, q_scan, share_cell
from pendulum_accel.cluster import map_tasks
from pendulum_accel.estimators import ekf_kernels as kern
from pendulum_accel.estimators import make_estimator
from pendulum_accel.estimators.ekf_kernels import MAX_STEP
from pendulum_accel.estimators.kalman import PRESETS, KalmanEstimator

QJ_GRID = tuple(float(q) for q in np.logspace(-4, 4, 17))  # (m/s³)²/s, 2 per decade
"""q_j of the integrated walk scanned for its hindsight optimum."""

_GAUSS_X = np.array([-0.8611363115940526, -0.3399810435848563, 0.3399810435848563, 0.8611363115940526])
_GAUSS_W = np.array([0.3478548451374538, 0.6521451548625461, 0.6521451548625461, 0.3478548451374538])
# 4-point Gauss–Legendre nodes and weights on [−1, 1]: exact for polynomials of degree ≤ 7.


@njit(cache=True, inline="always")
def _swing(th: float, om: float, a: float, g: float, length: float, c: float) -> float:
    """θ'' = (a cos θ − g sin θ)/l − c θ'."""
    return (a * math.cos(th) - g * math.sin(th)) / length - c * om


@njit(cache=True)
def _flow(jac: np.ndarray, s: float) -> np.ndarray:
    """Φ(s) = I + Js + (Js)²/2 + (Js)³/6: e^{Js} to third order."""
    js = jac * s
    js2 = js @ js
    return np.eye(4) + js + js2 / 2.0 + js2 @ js / 6.0


@njit(cache=True)
def _predict(
    x: np.ndarray, p: np.ndarray, h: float, g: float, length: float, c: float, q_a: float, q_j: float
) -> None:
    """In place over one sub-step h: x ← RK4 of θ'' = (a(s) cos θ − g sin θ)/l − c θ', a(s) = a + j s,
    a ← a + j h; P ← F P Fᵀ + Q, F = Φ(h), Q = ∫₀ʰ Φ(s) diag(0, 0, q_a, q_j) Φ(s)ᵀ ds, Φ(s) = I + Js + (Js)²/2
    + (Js)³/6 (q_a: a random walk's density on a, q_j: an integrated walk's on j)."""
    th, om, a, j = x[0], x[1], x[2], x[3]
    a_mid = a + 0.5 * h * j
    k1t, k1o = om, _swing(th, om, a, g, length, c)
    k2t, k2o = om + 0.5 * h * k1o, _swing(th + 0.5 * h * k1t, om + 0.5 * h * k1o, a_mid, g, length, c)
    k3t, k3o = om + 0.5 * h * k2o, _swing(th + 0.5 * h * k2t, om + 0.5 * h * k2o, a_mid, g, length, c)
    k4t, k4o = om + h * k3o, _swing(th + h * k3t, om + h * k3o, a + h * j, g, length, c)
    jac = np.zeros((4, 4))
    jac[0, 1] = 1.0
    jac[1, 0] = -(g * math.cos(th) + a * math.sin(th)) / length
    jac[1, 1] = -c
    jac[1, 2] = math.cos(th) / length
    jac[2, 3] = 1.0
    qc = np.zeros((4, 4))
    qc[2, 2], qc[3, 3] = q_a, q_j
    q = np.zeros((4, 4))
    for i in range(4):
        phi = _flow(jac, 0.5 * h * (_GAUSS_X[i] + 1.0))
        q += (0.5 * h * _GAUSS_W[i]) * (phi @ qc @ phi.T)
    f = _flow(jac, h)
    x[0] = th + h / 6.0 * (k1t + 2.0 * k2t + 2.0 * k3t + k4t)
    x[1] = om + h / 6.0 * (k1o + 2.0 * k2o + 2.0 * k3o + k4o)
    x[2] = a + j * h
    p[:, :] = f @ p @ f.T + q


@njit(cache=True)
def _correct(x: np.ndarray, p: np.ndarray, y: float, r: float) -> None:
    """In place: K = P Hᵀ/S, x ← x + K (y − θ), P ← P − K Kᵀ S (H = e₁ᵀ, S = P₀₀ + r): ekf_kernels.correct
    over four states."""
    s = p[0, 0] + r
    k = p[:, 0] / s
    x += k * (y - x[0])
    p -= np.outer(k, k) * s


@njit(cache=True)
def _start(x: np.ndarray, p: np.ndarray, y: float, g: float, length: float, r: float, jerk: bool) -> None:
    """x = [θ, 0, g tan θ, 0]; P = diag(r, (ω₀ 0.1)², (g 0.1)², 10² if ``jerk`` else 0): a 0.1 rad swing,
    a 10 m/s³ jerk (a random-walk mode has none)."""
    x[0], x[1], x[2], x[3] = y, 0.0, g * math.tan(y), 0.0
    p[:, :] = 0.0
    p[0, 0], p[1, 1], p[2, 2] = r, g / length * 0.01, (g * 0.1) ** 2
    p[3, 3] = 100.0 if jerk else 0.0


@njit(cache=True)
def iw_pass(
    t: np.ndarray, theta: np.ndarray, g: float, length: float, c: float, r: float, q_j: float
) -> np.ndarray:
    """â of the integrated-walk EKF over one recording, started by ``_start`` at the first sample (t < WARMUP
    is not scored) and restarted there at any sample where it diverged, as the package's filters are."""
    out = np.empty(t.size)
    x = np.empty(4)
    p = np.empty((4, 4))
    _start(x, p, theta[0], g, length, r, True)
    out[0] = x[2]
    for i in range(1, t.size):
        dt = t[i] - t[i - 1]
        steps = max(1, math.ceil(dt / MAX_STEP))
        for _ in range(steps):
            _predict(x, p, dt / steps, g, length, c, 0.0, q_j)
        _correct(x, p, theta[i], r)
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(p))):
            _start(
                x, p, theta[i], g, length, r, True
            )  # diverged (angles far outside the model): restart here
        out[i] = x[2]
    return out


@dataclass(frozen=True)
class Cell:
    """One validation profile × design: each estimator's figures and the hindsight optima."""

    design: str
    profile: str
    kalman: Score
    """The live default (kalman, preset auto: random-walk modes and their trend partners)."""
    instant: float
    ekf_hindsight: float
    q_a: float
    iw_hindsight: float
    q_j: float
    walks: Score
    """auto's random-walk modes alone (the default before its trend modes), live: no hindsight."""


def _runs(profile: Profile, design: Design, seeds: int, full: bool) -> list[Run]:
    """The profile's simulated runs through the design (its first 60 s unless ``full``)."""
    duration = profile.duration if full else min(profile.duration, 60.0)
    return simulate_runs(profile.build(), design, seeds, duration)


def iw_scan(runs: Sequence[Run], design: Design, grid: Sequence[float] = QJ_GRID) -> np.ndarray:
    """Σ (â − a)² over the runs (t ≥ WARMUP) of the integrated-walk EKF at every q_j of the grid."""
    g, length, c, r = kalman_q(design, 1.0)._params[:4]
    out = np.zeros(len(grid))
    for i, q_j in enumerate(grid):
        for run in runs:
            a = iw_pass(run.t, run.theta, g, length, c, r, q_j)
            out[i] += float(np.sum(((a - run.accel)[run.t >= WARMUP]) ** 2))
    return out


def _cell(seeds: int, full: bool, case: tuple[Design, Profile]) -> Cell:
    """Every estimator and both hindsight bounds on one profile × design."""
    design, profile = case
    runs = _runs(profile, design, seeds, full)
    live = make_estimator("kalman", **design.settings())
    assert isinstance(live, KalmanEstimator)
    qs, _, rates = PRESETS["auto"].imm(walks_only=True)
    walks = [kern.imm_pass(run.t, run.theta, live._params, qs, rates, np.zeros(1, np.int64)) for run in runs]
    gtan = make_estimator("instant", **design.settings())
    rw = q_scan(runs, design)
    iw = iw_scan(runs, design)
    n = sum(int(np.count_nonzero(r.t >= WARMUP)) for r in runs)
    return Cell(
        design.short,
        profile.name,
        Score.of(runs, [live.batch(run.t, run.theta) for run in runs], design.rate_hz),
        pooled_rms(runs, [gtan.batch(run.t, run.theta)[0] for run in runs]),
        math.sqrt(float(rw.min()) / n),
        Q_GRID[int(np.argmin(rw))],
        math.sqrt(float(iw.min()) / n),
        QJ_GRID[int(np.argmin(iw))],
        Score.of(runs, [(a[:, 0], var[:, 0]) for a, var, _ in walks], design.rate_hz),
    )


def evaluate(seeds: int, full: bool, *, workers: int | None = None) -> list[Cell]:
    """A cell per design × validation profile: one task each (cluster.map_tasks)."""
    # By name, not from __main__: under `python -m` the workers would get _cell by value, with the
    # package's lazily compiled kernels it calls (physics.lazy) in a module they never imported.
    from benchmarks import integrated_walk as by_name

    cases = [(d, p) for d in (*designs(), *REPORTED_HELDOUT) for p in PROFILES if p.role == "validate"]
    task: Callable[[tuple[Design, Profile]], Cell] = functools.partial(by_name._cell, seeds, full)
    return map_tasks(task, cases, workers=workers)


def bound_table(cells: Sequence[Cell]) -> str:
    """The bounds' Markdown table, one row per cell, ratios to the integrated-walk bound."""
    lines = [
        "| design | profile | kalman | g·tanθ | ekf_hindsight (q_a) | iw_hindsight (q_j) | kalman / iw "
        "| ekf_hindsight / iw | kalman / g·tanθ |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for c in cells:
        k = c.kalman.rms
        lines.append(
            f"| {c.design} | {c.profile} | {k:.3g} | {c.instant:.3g} | {c.ekf_hindsight:.3g} "
            f"({c.q_a:.2g}) | {c.iw_hindsight:.3g} ({c.q_j:.2g}) | {k / c.iw_hindsight:.2f} "
            f"| {c.ekf_hindsight / c.iw_hindsight:.2f} | {k / c.instant:.2f} |"
        )
    return "\n".join(lines) + "\n"


def live_table(cells: Sequence[Cell]) -> str:
    """The live table: the default and auto's random walks alone, RMS and shares beyond 2σ (with n_eff)."""
    lines = [
        "| design | profile | kalman | walks only | walks / kalman | walks / g·tanθ | kalman >2σ steady "
        "| walks >2σ steady | kalman >2σ after | walks >2σ after |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for c in cells:
        k, b = c.kalman, c.walks
        lines.append(
            f"| {c.design} | {c.profile} | {k.rms:.3g} | {b.rms:.3g} | {b.rms / k.rms:.2f} "
            f"| {b.rms / c.instant:.2f} | {share_cell(k.beyond_steady, k.eff_steady)} "
            f"| {share_cell(b.beyond_steady, b.eff_steady)} | {share_cell(k.beyond_after, k.eff_after)} "
            f"| {share_cell(b.beyond_after, b.eff_after)} |"
        )
    return "\n".join(lines) + "\n"


def _geo(x: np.ndarray) -> str:
    """'geometric mean (min–max)' of positive ratios."""
    return f"{math.exp(float(np.mean(np.log(x)))):.2f} ({x.min():.2f}–{x.max():.2f})"


def _shares(score: Score) -> list[float]:
    """The score's steady and after-change shares beyond 2σ that have samples (NaN: none)."""
    return [x for x in (score.beyond_steady, score.beyond_after) if x == x]


def _outside(score: Score) -> int:
    """How many of the score's shares beyond 2σ lie outside 1–12 %."""
    return sum(1 for x in _shares(score) if not 0.01 <= x <= 0.12)


def _beaten(cells: Sequence[Cell], rms: Callable[[Cell], float]) -> str:
    """The profiles (with the ratio) where g·tanθ's RMS is below ``rms``, or 'none'."""
    lost = [f"{c.profile} ({rms(c) / c.instant:.2f}×)" for c in cells if rms(c) > c.instant]
    return ", ".join(lost) if lost else "none"


def summary(cells: Sequence[Cell]) -> str:
    """Per design: kalman and ekf_hindsight over iw_hindsight, the random walks alone over kalman (geometric
    mean and range), where g·tanθ beats each live filter, and how many shares beyond 2σ lie outside 1–12 %."""
    out = []
    for design in dict.fromkeys(c.design for c in cells):
        mine = [c for c in cells if c.design == design]
        live = np.array([c.kalman.rms / c.iw_hindsight for c in mine])
        rw = np.array([c.ekf_hindsight / c.iw_hindsight for c in mine])
        walks = np.array([c.walks.rms / c.kalman.rms for c in mine])

        out.append(
            f"- {design}: kalman / iw_hindsight {_geo(live)}; ekf_hindsight / iw_hindsight {_geo(rw)}; "
            f"walks only / kalman {_geo(walks)}. "
            f"g·tanθ beats kalman on: {_beaten(mine, lambda c: c.kalman.rms)}; "
            f"beats walks only on: {_beaten(mine, lambda c: c.walks.rms)}. Shares beyond 2σ outside 1–12 % "
            f"(steady and after, of {sum(len(_shares(c.kalman)) for c in mine)}): kalman "
            f"{sum(_outside(c.kalman) for c in mine)}, walks only {sum(_outside(c.walks) for c in mine)}."
        )
    return "\n".join(out) + "\n"


def plot(cells: Sequence[Cell], path: Path) -> None:
    """kalman / iw_hindsight against ekf_hindsight / iw_hindsight, one point per cell, coloured by design."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for design in dict.fromkeys(c.design for c in cells):
        mine = [c for c in cells if c.design == design]
        ax.plot(
            [c.ekf_hindsight / c.iw_hindsight for c in mine],
            [c.kalman.rms / c.iw_hindsight for c in mine],
            "o",
            label=design,
        )
    ax.axhline(1.0, color="0.5", lw=0.8)
    ax.axvline(1.0, color="0.5", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("hindsight random-walk EKF / hindsight integrated-walk EKF (RMS)")
    ax.set_ylabel("live default (kalman) / hindsight integrated-walk EKF (RMS)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> int:
    """Evaluate, print the summary and the table, write integrated_walk.md, its plot and the docs page."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument("--full", action="store_true", help="whole profiles (default: the first 60 s)")
    parser.add_argument("--seeds", type=report.count, default=1, help="sensor noise seeds 0 … N−1")
    parser.add_argument("--workers", type=report.count, default=None, help="local cluster's workers")
    parser.add_argument("--out", type=Path, default=Path("out/bench"), help="output directory")
    report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    cells = evaluate(args.seeds, args.full, workers=args.workers)
    first, second, third = summary(cells), bound_table(cells), live_table(cells)
    print(first)
    print(second)
    print(third)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "integrated_walk.md").write_text(first + "\n" + second + "\n" + third)
    png = args.out / "integrated_walk.png"
    plot(cells, png)
    page = report.write_page(
        "integrated_walk",
        "Integrated-walk bound: what a model of a smooth a(t) would buy",
        [first, second, third],
        [(png, "the live default and the random-walk bound, each over the integrated-walk bound")],
        intro=__doc__ or "",
        docs=args.docs,
        argv=argv,
    )
    print(f"wrote {page}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
