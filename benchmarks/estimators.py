"""Estimator benchmark: accuracy, settling and delay of every method against the Cramér-Rao bound.

    python -m benchmarks.estimators [--out DIR] [--seeds N] [--duration S] [--quick]

Scenes (l = 0.5 m, undamped, σ = 1e-3 rad white noise at 200 Hz by default; true θ(t) from
pendulum_accel.physics.simulate, noise added with numpy): ``step`` (0 → 3 m/s² at t = 2 s),
``ramp`` (0 → 3 m/s² over 2–6 s) and ``stop_and_go`` (pull away, cruise, brake, stop).

Per scene and method: bias, RMS and max error (t ≥ 1 s), steady-state RMS on the final constant
stretch (from 5 s after the last change), settling time to within 2 % of the last change, time to
50 % of a step, delay (the lag τ minimising RMS(â(t) − a(t − τ))), and streaming cost.
The bound is σ (g² + a²)/(g √N) with N the method's noise-equivalent sample count
(``Estimator.noise_equivalent_samples``: window samples T·f for period_mean, 1/Σh² for lowpass,
(Σw)²/Σw² of the steady-state gain's impulse response for kalman and of the fit weights for dynamic).
``crb_settle`` is the bound for a static estimator allowed the method's settling time, N = t_settle·f:
``ss_over_crb_settle`` (steady RMS over it) measures the accuracy/latency trade, 1 being ideal.
Writes estimators.csv, estimators.md and estimators.png into the output directory.
"""

from __future__ import annotations

import argparse
import csv
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchmarks import report
from pendulum_accel import make_estimator
from pendulum_accel.estimators import DEFAULT_ESTIMATOR, ESTIMATORS, LIVE_ESTIMATORS
from pendulum_accel.estimators.base import cramer_rao_std
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import AccelProfile, Ramp, Step, Table

SETTLE_FRACTION = 0.02
WARMUP = 1.0  # s excluded from bias/RMS/max: every method starts from a single sample
STEADY_AFTER = 5.0  # s after the last change before the steady-state window opens
MAX_LAG = 3.0  # s searched for the delay


@dataclass(frozen=True)
class BenchScene:
    """A benchmark scene: profile, the last change (time, size) and the steady a after it."""

    name: str
    profile: AccelProfile
    change_time: float
    change_size: float
    steady_accel: float
    step_time: float | None = None  # set for a pure step: enables t50


def bench_scenes() -> tuple[BenchScene, ...]:
    """The three benchmark scenes: step, ramp, stop-and-go."""
    stop_go = Table(
        times=(0.0, 2.0, 2.5, 6.0, 6.5, 10.0, 10.5, 13.0, 13.5),
        accels=(0.0, 0.0, 2.5, 2.5, 0.0, 0.0, -3.0, -3.0, 0.0),
    )
    return (
        BenchScene("step", Step(2.0, 0.0, 3.0), 2.0, 3.0, 3.0, step_time=2.0),
        BenchScene("ramp", Ramp(2.0, 6.0, 0.0, 3.0), 6.0, 3.0, 3.0),
        BenchScene("stop_and_go", stop_go, 13.5, 3.0, 0.0),
    )


@dataclass(frozen=True)
class BenchConfig:
    """Pendulum, sensor and run length of the benchmark."""

    length: float = 0.5
    rate_hz: float = 200.0
    noise_std: float = 1e-3
    duration: float = 40.0
    seeds: int = 3
    methods: tuple[str, ...] = LIVE_ESTIMATORS
    # kalman runs as the default does (preset auto); the priors for a lab's steps and a car are rows below.
    method_options: tuple[tuple[str, dict[str, object]], ...] = ()
    # Extra rows (label, method, options) that show what a design choice buys.
    variants: tuple[tuple[str, str, dict[str, object]], ...] = (
        ("kalman_lab_steps", "kalman", {"preset": "lab_steps"}),
        ("kalman_car", "kalman", {"preset": "car"}),
        ("kalman_fixed_q", "kalman", {"preset": "lab_steps", "q_accel": 0.215}),
        ("period_mean_2pi_over_w", "period_mean", {"exact_period": False}),
    )


@dataclass
class Row:
    """One line of the results table (scene × method); times in s, accelerations in m/s²."""

    scene: str
    method: str
    bias: float
    rms: float
    max_err: float
    ss_rms: float | None
    n_eff: float
    crb: float
    ss_over_crb: float | None
    settle_s: float | None
    t50_s: float | None
    lag_s: float
    crb_settle: float | None
    ss_over_crb_settle: float | None
    us_per_sample: float

    COLUMNS = (
        "scene",
        "method",
        "bias",
        "rms",
        "max_err",
        "ss_rms",
        "n_eff",
        "crb",
        "ss_over_crb",
        "settle_s",
        "t50_s",
        "lag_s",
        "crb_settle",
        "ss_over_crb_settle",
        "us_per_sample",
    )

    def cells(self) -> list[str]:
        """The row's values formatted for CSV/markdown ('' for not reached)."""
        out: list[str] = []
        for name in self.COLUMNS:
            v = getattr(self, name)
            if v is None:
                out.append("")
            elif isinstance(v, str):
                out.append(v)
            elif name in ("n_eff", "ss_over_crb", "ss_over_crb_settle", "us_per_sample"):
                out.append(f"{v:.3g}")
            else:
                out.append(f"{v:.4g}")
        return out


def true_angles(scene: BenchScene, cfg: BenchConfig) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(t, θ_true, a_true) at the sensor rate from physics.simulate (rigid model, at rest at t = 0)."""
    from pendulum_accel.physics.simulate import simulate

    t = np.arange(round(cfg.duration * cfg.rate_hz)) / cfg.rate_hz
    traj = simulate(Pendulum(length=cfg.length), scene.profile, t, theta0=0.0, rtol=1e-10, atol=1e-12)
    return t, np.asarray(traj.theta, dtype=float), np.asarray(scene.profile(t), dtype=float)


def settling_time(t: np.ndarray, err: np.ndarray, t_change: float, band: float) -> float | None:
    """Time after t_change from which |err| ≤ band until the end; None if never."""
    after = t >= t_change
    outside = np.flatnonzero(after & (np.abs(err) > band))
    if outside.size == 0:
        return 0.0
    last = int(outside[-1])
    if last == t.size - 1:
        return None
    return float(t[last + 1] - t_change)


def time_to_half(t: np.ndarray, est: np.ndarray, t_step: float, size: float) -> float | None:
    """First time after t_step when â has covered half of the step; None if never."""
    crossed = np.flatnonzero((t >= t_step) & (np.sign(size) * est >= 0.5 * abs(size)))
    return float(t[crossed[0]] - t_step) if crossed.size else None


def best_lag(t: np.ndarray, est: np.ndarray, truth: np.ndarray, rate_hz: float) -> float:
    """τ ∈ [0, MAX_LAG] minimising RMS(â(t) − a(t − τ)) over t ≥ WARMUP (a before t₀ held at a(t₀))."""
    start = int(np.searchsorted(t, WARMUP))
    max_k = int(MAX_LAG * rate_hz)
    padded = np.concatenate((np.full(max_k, truth[0]), truth))
    costs = [
        float(np.mean((est[start:] - padded[max_k + start - k : max_k + t.size - k]) ** 2))
        for k in range(max_k + 1)
    ]
    return float(np.argmin(costs) / rate_hz)


def _stream(name: str, opts: dict[str, object], cfg: BenchConfig, t: np.ndarray, y: np.ndarray) -> float:
    """Mean µs per ``update`` call over the recording (streaming cost)."""
    est = make_estimator(name, length=cfg.length, noise_std=cfg.noise_std, rate_hz=cfg.rate_hz, **opts)  # type: ignore[arg-type]
    tl, yl = t.tolist(), y.tolist()
    start = time.perf_counter()
    for ti, yi in zip(tl, yl, strict=True):
        est.update(ti, yi)
    return (time.perf_counter() - start) / max(len(tl), 1) * 1e6


def run_benchmark(
    cfg: BenchConfig, progress: Callable[[str], None] | None = None
) -> tuple[list[Row], dict[str, dict[str, np.ndarray]]]:
    """Rows for every scene × method (seeds pooled), and the seed-0 traces for plotting."""
    rows: list[Row] = []
    traces: dict[str, dict[str, np.ndarray]] = {}
    g = Pendulum(length=cfg.length).gravity
    for scene in bench_scenes():
        t, theta, truth = true_angles(scene, cfg)
        noisy = [
            theta + cfg.noise_std * np.random.default_rng(seed).standard_normal(theta.size)
            for seed in range(cfg.seeds)
        ]
        traces[scene.name] = {"t": t, "truth": truth}
        evaluate = t >= WARMUP
        steady = t >= scene.change_time + STEADY_AFTER
        options = dict(cfg.method_options)
        runs: list[tuple[str, str, dict[str, object]]] = [
            (n, n, dict(options.get(n, {}))) for n in cfg.methods
        ]
        runs += cfg.variants
        for label, name, opts in runs:
            est = make_estimator(
                name,
                length=cfg.length,
                noise_std=cfg.noise_std,
                rate_hz=cfg.rate_hz,
                **opts,  # type: ignore[arg-type]
            )
            errs, settles, halves, lags = [], [], [], []
            ss_sq: list[float] = []
            for y in noisy:
                a_hat, _ = est.batch(t, y)
                err = a_hat - truth
                errs.append(err[evaluate])
                if steady.any():
                    ss_sq.append(float(np.mean(err[steady] ** 2)))
                settles.append(settling_time(t, err, scene.change_time, SETTLE_FRACTION * scene.change_size))
                if scene.step_time is not None:
                    halves.append(time_to_half(t, a_hat, scene.step_time, scene.change_size))
                lags.append(best_lag(t, a_hat, truth, cfg.rate_hz))
                traces[scene.name].setdefault(label, a_hat)
            pooled = np.concatenate(errs)
            n_eff = est.noise_equivalent_samples(scene.steady_accel)
            crb = cramer_rao_std(scene.steady_accel, cfg.noise_std, n_eff, g)
            ss_rms = math.sqrt(float(np.mean(ss_sq))) if ss_sq else None
            settle = None if any(s is None for s in settles) else max(s for s in settles if s is not None)
            t50 = None
            if halves and all(h is not None for h in halves):
                t50 = float(np.mean([h for h in halves if h is not None]))
            crb_settle = None
            if settle is not None and settle > 0.0:
                crb_settle = cramer_rao_std(scene.steady_accel, cfg.noise_std, settle * cfg.rate_hz, g)
            rows.append(
                Row(
                    scene=scene.name,
                    method=label,
                    bias=float(np.mean(pooled)),
                    rms=float(np.sqrt(np.mean(pooled**2))),
                    max_err=float(np.max(np.abs(pooled))),
                    ss_rms=ss_rms,
                    n_eff=n_eff,
                    crb=crb,
                    ss_over_crb=None if ss_rms is None else ss_rms / crb,
                    settle_s=settle,
                    t50_s=t50,
                    lag_s=float(np.median(lags)),
                    crb_settle=crb_settle,
                    ss_over_crb_settle=None if crb_settle is None or ss_rms is None else ss_rms / crb_settle,
                    us_per_sample=_stream(name, opts, cfg, t, noisy[0]),
                )
            )
            if progress is not None:
                progress(f"{scene.name}/{label} done")
    return rows, traces


def markdown_table(rows: Sequence[Row]) -> str:
    """The rows as a GitHub markdown table."""
    lines = ["| " + " | ".join(Row.COLUMNS) + " |", "|" + "---|" * len(Row.COLUMNS)]
    lines += ["| " + " | ".join(c or "—" for c in row.cells()) + " |" for row in rows]
    return "\n".join(lines) + "\n"


def write_outputs(rows: Sequence[Row], traces: dict[str, dict[str, np.ndarray]], out: Path) -> list[Path]:
    """Write estimators.csv, estimators.md and estimators.png (Agg) into ``out``; return the paths."""
    out.mkdir(parents=True, exist_ok=True)
    csv_path, md_path, png_path = out / "estimators.csv", out / "estimators.md", out / "estimators.png"
    with csv_path.open("w", newline="") as fh:
        writer = csv.writer(fh)
        writer.writerow(Row.COLUMNS)
        writer.writerows(row.cells() for row in rows)
    md_path.write_text(markdown_table(rows))
    plot(traces, png_path)
    return [csv_path, md_path, png_path]


def _rolling_rms(err: np.ndarray, width: int) -> np.ndarray:
    """√(mean of err² over a centred box of ``width`` samples)."""
    box = np.ones(max(width, 1)) / max(width, 1)
    return np.sqrt(np.convolve(err * err, box, mode="same"))


def plot(traces: dict[str, dict[str, np.ndarray]], path: Path) -> None:
    """Per scene: true a and each method's â (left), rolling RMS of â − a over 0.25 s, log scale (right)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(traces), 2, figsize=(13, 3.4 * len(traces)), squeeze=False)
    for row, (scene, tr) in enumerate(traces.items()):
        t, truth = tr["t"], tr["truth"]
        width = round(0.25 / (t[1] - t[0])) if t.size > 1 else 1
        ax_a, ax_e = axes[row]
        ax_a.plot(t, truth, "k", lw=2.0, label="truth")
        for name, a_hat in tr.items():
            if name in ("t", "truth"):
                continue
            style = "--" if name not in ESTIMATORS else "-"
            lw = 1.8 if name == DEFAULT_ESTIMATOR else 0.9
            ax_a.plot(t, a_hat, style, lw=lw, label=name)
            ax_e.semilogy(t, _rolling_rms(a_hat - truth, width) + 1e-6, style, lw=lw, label=name)
        lo, hi = float(truth.min()), float(truth.max())
        ax_a.set_ylim(lo - 1.0, hi + 1.0)
        ax_a.set_title(f"{scene}: â vs truth")
        ax_e.set_title(f"{scene}: RMS(â − a) over 0.25 s")
        ax_e.set_ylim(1e-4, 10.0)
        for ax in (ax_a, ax_e):
            ax.set_xlabel("t (s)")
            ax.grid(True, alpha=0.3)
        ax_a.set_ylabel("a (m/s²)")
        ax_e.set_ylabel("m/s²")
        ax_e.legend(fontsize=7, loc="upper right", ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark, print the table and write the files."""
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.estimators", description=__doc__.split("\n")[0]
    )
    parser.add_argument(
        "--out", type=Path, default=Path("out/bench"), help="output directory (default out/bench)"
    )
    parser.add_argument(
        "--seeds", type=report.count, default=3, help="noise realisations per scene (default 3)"
    )
    parser.add_argument(
        "--duration", type=report.positive, default=40.0, help="scene length in s (default 40)"
    )
    parser.add_argument("--rate", type=report.positive, default=200.0, help="sensor rate in Hz (default 200)")
    parser.add_argument(
        "--noise", type=report.positive, default=1e-3, help="angle noise σ in rad (default 1e-3)"
    )
    parser.add_argument("--quick", action="store_true", help="1 seed, 25 s scenes")
    report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    cfg = BenchConfig(
        rate_hz=args.rate,
        noise_std=args.noise,
        duration=25.0 if args.quick else args.duration,
        seeds=1 if args.quick else max(1, args.seeds),
    )
    rows, traces = run_benchmark(cfg)
    paths = write_outputs(rows, traces, args.out)
    setting = (
        f"l={cfg.length} m, σ={cfg.noise_std} rad, {cfg.rate_hz:g} Hz, {cfg.duration:g} s, "
        f"{cfg.seeds} seed(s); default method: {DEFAULT_ESTIMATOR}"
    )
    print(setting)
    print(markdown_table(rows), end="")
    paths.append(
        report.write_page(
            "estimators", "Estimators: accuracy, settling and delay against the Cramér-Rao bound",
            [setting, markdown_table(rows)],
            [(paths[2], "every estimator against the truth, and its RMS error")],
            intro=__doc__ or "", docs=args.docs, argv=argv,
        )
    )  # fmt: skip
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
