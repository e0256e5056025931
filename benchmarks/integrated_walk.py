"""Integrated-walk bound: what a model that knows a(t) is smooth would gain over the random walk.

    python -m benchmarks.integrated_walk [--full] [--seeds N] [--workers N] [--out DIR]

Every filter in the package, the live default included, models a(t) as a random walk: a' = white noise
of density q_a. A real car's a(t) is smoother than that: it has a trend, which a random walk cannot
predict, so the filter lags behind it. An integrated walk (a' = j, j' = white noise of density q_j) predicts
the trend. This page measures what that model would buy, as a bound: the extended Kalman filter on the
state (θ, ω, a, j) at the q_j that minimises its RMS against the truth (``iw_hindsight``), beside the
random-walk EKF at its own hindsight q_a (``ekf_hindsight``, real_motion's bound), the live default
(``kalman``, preset auto) and g·tanθ (``instant``).

The page's second table runs such a model live, as the next default could: an IMM over both walks
(``both_walks``, ``imm_pass``), auto's random-walk modes beside as many integrated-walk ones, with the
figures the real-motion page judges (RMS, shares beyond 2σ steady and after a change, with n_eff). It is a
prototype for that decision, not an estimator of the package: with the random-walk modes alone it is the
package's IMM (to 0.06 % of the error on a real trace; test/test_bench_integrated_walk.py).

Profiles: the validation split of ``benchmarks.corpus`` (real_motion.PROFILES, role validate); designs: the
two every fit uses and real_motion.REPORTED_HELDOUT; the first 60 s of each profile unless ``--full``;
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
from benchmarks.real_motion import (
    PROFILES,
    Q_GRID,
    REPORTED_HELDOUT,
    WARMUP,
    Design,
    Profile,
    Run,
    Score,
    designs,
    kalman_q,
    pooled_rms,
    q_scan,
    share_cell,
    simulate_runs,
)
from pendulum_accel.cluster import map_tasks
from pendulum_accel.estimators import make_estimator
from pendulum_accel.estimators.ekf_kernels import MAX_STEP, _chain_step, _update_modes, chain_rates
from pendulum_accel.estimators.kalman import PRESETS

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


IW_FACTOR = 10.0
"""q_j of each integrated-walk mode over the q_a of its random-walk partner ((m/s³)²/s per (m/s²)²/s): a
decade above it, chosen before any run and not fitted."""

CROSS_TIME = 10.0
"""s: the mean time before the chain moves from a random-walk mode to its integrated-walk partner or back.
Of 1, 3 and 10 s, the one with the least RMS on the training split (benchmarks.corpus's train entries,
the teaching and short_damped designs, first 60 s, seed 0; geometric mean over the profiles, relative to
auto: 0.904, 0.897 and 0.895 on teaching, 0.732, 0.708 and 0.701 on short_damped)."""


def both_walks() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(q_a, q_j, jerk, R) of the IMM over both walks: auto's random-walk modes (kalman.AUTO_MODES, q_j = 0,
    jerk False) and as many integrated-walk modes (q_a = 0, q_j = IW_FACTOR × the same grid, jerk True),
    each family a birth-death chain at auto's rates (ekf_kernels.chain_rates), mode k of each family linked
    to mode k of the other at 1/CROSS_TIME both ways."""
    auto = PRESETS["auto"]
    m = len(auto.modes)
    rates = np.zeros((2 * m, 2 * m))
    family = chain_rates(m, auto.switch_time, auto.down_time)
    rates[:m, :m] = family
    rates[m:, m:] = family
    for k in range(m):
        rates[k, m + k] = rates[m + k, k] = 1.0 / CROSS_TIME
    q_a = np.array([*auto.modes, *([0.0] * m)])
    q_j = np.array([*([0.0] * m), *(IW_FACTOR * q for q in auto.modes)])
    jerk = np.array([False] * m + [True] * m)
    return q_a, q_j, jerk, rates


@njit(cache=True)
def imm_pass(
    t: np.ndarray,
    theta: np.ndarray,
    g: float,
    length: float,
    c: float,
    r: float,
    q_a: np.ndarray,
    q_j: np.ndarray,
    jerk: np.ndarray,
    rates: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """(â, P_aa) of the interacting-multiple-model filter over four-state modes (ekf_kernels.imm_step's
    scheme: mix with Π over Δt, predict and update each mode, μ_j ∝ c_j N(ν_j; 0, S_j), combine). A mode
    without ``jerk`` is a random walk: after the mixing its j and j's covariance are set to 0, so it never
    carries a trend its partner handed it. Restarts where the combination is not finite."""
    m, n = q_a.size, t.size
    xs, ps, mu = np.zeros((m, 4)), np.zeros((m, 4, 4)), np.full(m, 1.0 / m)
    x0, p0 = np.zeros((m, 4)), np.zeros((m, 4, 4))
    pi, cj, logl, w = np.empty((m, m)), np.empty(m), np.empty(m), np.empty(m)
    out_a, out_v = np.empty(n), np.empty(n)
    for k in range(m):
        _start(xs[k], ps[k], theta[0], g, length, r, jerk[k])
    out_a[0], out_v[0] = xs[0, 2], ps[0, 2, 2]
    last_dt = -1.0
    for i in range(1, n):
        dt = t[i] - t[i - 1]
        if dt != last_dt:
            _chain_step(rates, dt, pi)
            last_dt = dt
        for j in range(m):
            cj[j] = 0.0
            for k in range(m):
                cj[j] += pi[k, j] * mu[k]
            for k in range(m):
                w[k] = pi[k, j] * mu[k] / cj[j]  # the mixing weight of mode k into mode j
            x0[j] = 0.0
            for k in range(m):
                x0[j] += w[k] * xs[k]
            p0[j] = 0.0
            for k in range(m):
                for a_ in range(4):
                    da = xs[k, a_] - x0[j, a_]
                    for b_ in range(4):
                        p0[j, a_, b_] += w[k] * (ps[k, a_, b_] + da * (xs[k, b_] - x0[j, b_]))
            if not jerk[j]:
                x0[j, 3] = 0.0
                p0[j, 3, :] = 0.0
                p0[j, :, 3] = 0.0
        steps = max(1, math.ceil(dt / MAX_STEP))
        for j in range(m):
            for _ in range(steps):
                _predict(x0[j], p0[j], dt / steps, g, length, c, q_a[j], q_j[j])
            s = p0[j, 0, 0] + r
            nu = theta[i] - x0[j, 0]
            _correct(x0[j], p0[j], theta[i], r)
            logl[j] = -0.5 * (nu * nu / s + math.log(s)) + math.log(cj[j])
        xs[:, :] = x0
        ps[:, :, :] = p0
        _update_modes(logl, mu)
        a = 0.0
        for j in range(m):
            a += mu[j] * xs[j, 2]
        v = 0.0
        for j in range(m):
            v += mu[j] * (ps[j, 2, 2] + (xs[j, 2] - a) ** 2)
        if not (math.isfinite(a) and math.isfinite(v)):
            for k in range(m):
                _start(xs[k], ps[k], theta[i], g, length, r, jerk[k])
            mu[:] = 1.0 / m
            a, v = xs[0, 2], ps[0, 2, 2]
        out_a[i], out_v[i] = a, v
    return out_a, out_v


@dataclass(frozen=True)
class Cell:
    """One validation profile × design: each estimator's figures and the hindsight optima."""

    design: str
    profile: str
    kalman: Score
    """The live default (kalman, preset auto)."""
    instant: float
    ekf_hindsight: float
    q_a: float
    iw_hindsight: float
    q_j: float
    both: Score
    """The IMM over both walks (``both_walks``), live: no hindsight."""


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
    gtan = make_estimator("instant", **design.settings())
    rw = q_scan(runs, design)
    iw = iw_scan(runs, design)
    n = sum(int(np.count_nonzero(r.t >= WARMUP)) for r in runs)
    g, length, c, r = kalman_q(design, 1.0)._params[:4]
    modes = both_walks()
    return Cell(
        design.short,
        profile.name,
        Score.of(runs, [live.batch(run.t, run.theta) for run in runs], design.rate_hz),
        pooled_rms(runs, [gtan.batch(run.t, run.theta)[0] for run in runs]),
        math.sqrt(float(rw.min()) / n),
        Q_GRID[int(np.argmin(rw))],
        math.sqrt(float(iw.min()) / n),
        QJ_GRID[int(np.argmin(iw))],
        Score.of(runs, [imm_pass(run.t, run.theta, g, length, c, r, *modes) for run in runs], design.rate_hz),
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
    """The live table: the default and the IMM over both walks, RMS and shares beyond 2σ (with n_eff)."""
    lines = [
        "| design | profile | kalman | both walks | both / kalman | both / g·tanθ | kalman >2σ steady "
        "| both >2σ steady | kalman >2σ after | both >2σ after |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for c in cells:
        k, b = c.kalman, c.both
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
    """Per design: kalman and ekf_hindsight over iw_hindsight, both walks over kalman (geometric mean and
    range), where g·tanθ beats each live filter, and how many shares beyond 2σ lie outside 1–12 %."""
    out = []
    for design in dict.fromkeys(c.design for c in cells):
        mine = [c for c in cells if c.design == design]
        live = np.array([c.kalman.rms / c.iw_hindsight for c in mine])
        rw = np.array([c.ekf_hindsight / c.iw_hindsight for c in mine])
        both = np.array([c.both.rms / c.kalman.rms for c in mine])

        out.append(
            f"- {design}: kalman / iw_hindsight {_geo(live)}; ekf_hindsight / iw_hindsight {_geo(rw)}; "
            f"both walks / kalman {_geo(both)}. "
            f"g·tanθ beats kalman on: {_beaten(mine, lambda c: c.kalman.rms)}; "
            f"beats both walks on: {_beaten(mine, lambda c: c.both.rms)}. Shares beyond 2σ outside 1–12 % "
            f"(steady and after, of {sum(len(_shares(c.kalman)) for c in mine)}): kalman "
            f"{sum(_outside(c.kalman) for c in mine)}, both walks {sum(_outside(c.both) for c in mine)}."
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
