"""Calibration benchmark: does each estimator's published variance tell the truth?

    python -m benchmarks.calibration [--seeds N] [--out DIR] [--plot PNG]

For every estimator × bundled scene (except large_swing and hill, where no estimate is meaningful), the
scene is simulated with N sensor seeds (0 … N−1, default 10), the estimator run in batch on each, and
NEES = e²/var (e = â − a) summarised for t ≥ 2 s, split into steady state and the 2 s after any change
of a(t) (recording.coverage.calibration): mean, median and the share beyond 2σ, pooled over the seeds,
with in brackets its independent trials (recording.coverage, summed over the seeds) and 95 % interval,
the pooled share beyond 3σ, and the 10th–90th percentile of the per-seed share beyond 2σ. One
recording shows only one draw of a sensor's errors, which a long-memory estimator correlates over
seconds: the pooled figures are what the variance promises, the percentile range how far one bag may
stray from it. A calibrated Gaussian σ gives mean 1, median 0.455, 4.55 % beyond 2σ and 0.27 % beyond
3σ (recording.coverage.GAUSSIAN_NOTE); the tolerance the docs use is mean NEES in [0.5, 2] and 3–8 %
beyond 2σ.
Writes calibration.md into the output directory (default out/bench), prints it, and draws the
consistency plot (kalman error with its ±2σ band on stop_and_go, the scene's own seed) to ``--plot``.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from benchmarks import report
from pendulum_accel import estimate_batch, load_scene, run_scene
from pendulum_accel.estimators import DEFAULT_ESTIMATOR, ESTIMATORS
from pendulum_accel.recording.coverage import GAUSS_3SIGMA
from pendulum_accel.recording.seed_spread import WindowSpread, spread_over_runs, with_seed
from pendulum_accel.recording.settings import estimator_options
from pendulum_accel.scene import SCENE_NAMES
from pendulum_accel.scene_run import SceneRun

SKIP = 2.0  # s of start-up left out
# large_swing: no estimate is meaningful past 90°; hill: the grade reads as 0.98 m/s² by design (the
# pendulum cannot tell a tilt from an acceleration), an error no variance of a sensor can describe.
EXCLUDED = ("large_swing", "hill")
PLOT_SCENE = "stop_and_go"
SEEDS = 10


def _cells(spread: WindowSpread | None) -> list[str]:
    """Pooled mean, median, share beyond 2σ with its independent trials and 95 % interval (the seeds' trials
    add: WindowSpread.of), pooled share beyond 3σ, per-seed share p10–p90, n — or dashes without samples."""
    if spread is None:
        return ["—", "—", "—", "—", "—", "0"]
    s = spread.pooled
    between = f"{100 * spread.share_low:.1f}–{100 * spread.share_high:.1f} %"
    share = f"{100 * s.share_2sigma:.1f} %"
    span = s.interval()
    if span is not None:
        share += f" ({s.trials:.0f}: {100 * span[0]:.1f}–{100 * span[1]:.1f} %)"
    beyond3 = f"{100 * s.share_3sigma:.2f} %"
    return [f"{s.mean:.3g}", f"{s.median:.3g}", share, beyond3, between, str(s.n)]


def table(seeds: int = SEEDS) -> tuple[list[str], dict[str, tuple[SceneRun, np.ndarray, np.ndarray]]]:
    """Markdown rows per estimator × scene, pooled over ``seeds``; the default estimator's (run, â, var)
    per scene at the scene's own seed."""
    tail = f">3σ (Gaussian {100 * GAUSS_3SIGMA:.2f} %)"  # the reference once, in the header
    cols = ["estimator", "scene", "steady NEES mean", "median", ">2σ", tail, "per seed p10–p90", "n"]
    cols += ["after-change NEES mean", "median", ">2σ", tail, "per seed p10–p90", "n"]
    rows = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    runs: dict[str, tuple[SceneRun, np.ndarray, np.ndarray]] = {}
    scenes = {name: load_scene(name) for name in SCENE_NAMES if name not in EXCLUDED}
    sims = {name: [run_scene(with_seed(scene, k)) for k in range(seeds)] for name, scene in scenes.items()}
    for method in ESTIMATORS:
        for name, scene in scenes.items():
            spread = spread_over_runs(sims[name], method, estimator_options(scene, method), SKIP)
            cells = [*_cells(spread.steady), *_cells(spread.after_change)]
            rows.append("| " + " | ".join([method, name, *cells]) + " |")
            if method == DEFAULT_ESTIMATOR:
                own = run_scene(scene)
                a, var = estimate_batch(method, own.t, own.theta_measured, **estimator_options(scene, method))
                runs[name] = (own, a, var)
    return rows, runs


def plot(path: Path, run: SceneRun, accel: np.ndarray, var: np.ndarray) -> None:
    """Error â − a against t with the published ±2σ band (log-free, two panels: whole run and a zoom)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    err = accel - run.accel_true
    band = 2.0 * np.sqrt(var)
    fig, axes = plt.subplots(2, 1, figsize=(9, 6), constrained_layout=True)
    for ax, (lo, hi) in zip(axes, ((SKIP, run.t[-1]), (7.5, 9.5)), strict=True):
        m = (run.t >= lo) & (run.t <= hi)
        ax.fill_between(run.t[m], -band[m], band[m], color="tab:blue", alpha=0.25, label="±2σ published")
        ax.plot(run.t[m], err[m], color="k", lw=0.7, label="error â − a")
        ax.set_xlabel("t (s)")
        ax.set_ylabel("m/s²")
        ax.grid(alpha=0.3)
    axes[0].set_title(f"{DEFAULT_ESTIMATOR} on {PLOT_SCENE}: error and published ±2σ")
    axes[0].set_yscale("symlog", linthresh=0.01)
    axes[1].set_title("zoom: the brake starting at t = 9 s (the band widens once the angle reveals it)")
    axes[0].legend(loc="upper right")
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> None:
    """Print the table, write calibration.md, the consistency plot and the docs page."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/bench"), help="output directory")
    parser.add_argument(
        "--plot", type=Path, default=Path("out/bench/calibration_stop_and_go.png"), help="consistency plot"
    )
    parser.add_argument("--seeds", type=report.count, default=SEEDS, help="sensor seeds per scene (0 … N−1)")
    report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    rows, runs = table(args.seeds)
    text = "\n".join(rows) + "\n"
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "calibration.md").write_text(text)
    plot(args.plot, *runs[PLOT_SCENE])
    caption = f"{DEFAULT_ESTIMATOR} error with its published ±2σ band on {PLOT_SCENE}"
    page = report.write_page(
        "calibration", "Calibration: does each published variance tell the truth?", [text],
        [(args.plot, caption)], intro=__doc__ or "", docs=args.docs, argv=argv,
    )  # fmt: skip
    print(f"wrote {page}")


if __name__ == "__main__":
    main()
