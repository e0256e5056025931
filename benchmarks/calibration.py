"""Calibration benchmark: does each estimator's published variance tell the truth?

    python -m benchmarks.calibration [--out DIR] [--plot PNG]

For every estimator × bundled scene (except large_swing, where no estimate is meaningful), the
scene is simulated, the estimator run in batch, and NEES = e²/var (e = â − a) summarised for t ≥ 2 s,
split into steady state and the 2 s after any change of a(t) (recording.analyze.calibration):
mean, median and the share beyond 2σ. A calibrated Gaussian σ gives mean ≈ 1 and ≈ 5 % beyond 2σ;
the tolerance used in the README is mean NEES in [0.5, 2] and 3–8 % beyond 2σ.
Writes calibration.md into the output directory (default out/bench), prints it, and draws the
consistency plot (kalman error with its ±2σ band on stop_and_go) to ``--plot``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from pendulum_accel.estimators import DEFAULT_ESTIMATOR, ESTIMATORS, estimate_batch
from pendulum_accel.recording.analyze import NeesStats, calibration
from pendulum_accel.recording.settings import estimator_settings
from pendulum_accel.scene import SCENE_NAMES, load_scene
from pendulum_accel.scene_run import SceneRun, run_scene

SKIP = 2.0  # s of start-up left out
EXCLUDED = ("large_swing",)
PLOT_SCENE = "stop_and_go"


def _cells(s: NeesStats) -> list[str]:
    """Mean, median, share beyond 2σ, n — or dashes without samples."""
    if s.n == 0:
        return ["—", "—", "—", "0"]
    return [f"{s.mean:.3g}", f"{s.median:.3g}", f"{100 * s.share_2sigma:.1f} %", str(s.n)]


def table() -> tuple[list[str], dict[str, tuple[SceneRun, np.ndarray, np.ndarray]]]:
    """Markdown rows per estimator × scene; the default estimator's (run, â, var) per scene."""
    cols = ["estimator", "scene", "steady NEES mean", "median", ">2σ", "n"]
    cols += ["after-change NEES mean", "median", ">2σ", "n"]
    rows = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    runs: dict[str, tuple[SceneRun, np.ndarray, np.ndarray]] = {}
    scenes = {name: load_scene(name) for name in SCENE_NAMES if name not in EXCLUDED}
    sims = {name: run_scene(scene) for name, scene in scenes.items()}
    for method in ESTIMATORS:
        for name, scene in scenes.items():
            run = sims[name]
            a, var = estimate_batch(method, run.t, run.theta_measured, **estimator_settings(scene))
            cal = calibration(run.t, a - run.accel_true, var, run.t, run.accel_true, run.t[0] + SKIP)
            rows.append(
                "| " + " | ".join([method, name, *_cells(cal.steady), *_cells(cal.after_change)]) + " |"
            )
            if method == DEFAULT_ESTIMATOR:
                runs[name] = (run, a, var)
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


def main() -> None:
    """Print the table, write calibration.md and the consistency plot."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("out/bench"), help="output directory")
    parser.add_argument(
        "--plot", type=Path, default=Path("docs/img/calibration_stop_and_go.png"), help="consistency plot"
    )
    args = parser.parse_args()
    rows, runs = table()
    text = "\n".join(rows) + "\n"
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "calibration.md").write_text(text)
    plot(args.plot, *runs[PLOT_SCENE])


if __name__ == "__main__":
    main()
