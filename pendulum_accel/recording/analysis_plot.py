"""The picture of an analysis (``analyze --plot``): θ, the estimates beside the truth, and their errors."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pendulum_accel.bag.messages import TOPIC_ACCEL_TRUTH
from pendulum_accel.recording.analyze import Analysis

if TYPE_CHECKING:  # matplotlib is imported when a plot is drawn: analyze without --plot never loads it
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def plot_analysis(result: Analysis, out: Path | str) -> Path:
    """Three panels, shared time axis: θ (deg); truth, recorded estimate (holes shaded) and re-run; both
    errors with the ±tolerance band (without a truth: each stream's published 2σ instead)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True, constrained_layout=True)
    t = result.t
    axes[0].plot(t, np.degrees(result.theta), lw=0.8, color="tab:gray")
    axes[0].set_ylabel("θ (deg)")
    shown = "recorded estimate and " if result.recorded_figures is not None else ""
    title = f"{result.scene or result.path.name}: {shown}{result.estimator} re-run"
    axes[0].set_title(title)
    rec = result.recorded_figures
    if result.has_truth:
        axes[1].plot(t, result.accel_true, lw=1.5, color="black", label="truth a(t)")
    if rec is not None:
        axes[1].plot(rec.t, rec.accel, lw=1.6, color="tab:orange", label=f"recorded ({rec.estimator})")
        for hole in rec.holes:
            axes[1].axvspan(hole.start, hole.end, color="tab:red", alpha=0.12)
    axes[1].plot(t, result.accel_est, lw=0.9, color="tab:blue", label=f"offline re-run ({result.estimator})")
    axes[1].set_ylabel("a (m/s²)")
    axes[1].legend(loc="best")
    if not result.has_truth:
        _plot_sigma(axes[2], result)
        return _save(fig, out)
    if rec is not None:
        rec_error = rec.accel - np.interp(rec.t, t, result.accel_true)
        axes[2].plot(rec.t, rec_error, lw=1.2, color="tab:orange", label="recorded â − a")
    axes[2].plot(t, result.error, lw=0.8, color="tab:blue", label="re-run â − a")
    axes[2].axhspan(-result.tolerance, result.tolerance, color="tab:green", alpha=0.15, label="± tolerance")
    if result.settling_time is not None:
        axes[2].axvline(
            result.settle_from + result.settling_time,
            color="tab:green",
            ls="--",
            lw=1,
            label="re-run settled",
        )
    axes[2].set_ylabel("error (m/s²)")
    axes[2].set_xlabel("t (s)")
    axes[2].legend(loc="best")
    titles = [f"{f.source}: RMS {f.stats.rms:.4f}, max {f.stats.max_abs:.4f} m/s²"
              for f in (rec, result.offline_figures) if f is not None]  # fmt: skip
    axes[2].set_title("; ".join(titles), fontsize=9)
    return _save(fig, out)


def _plot_sigma(ax: Axes, result: Analysis) -> None:
    """The error panel of a bag without a truth: each stream's published 2σ = 2√var over time."""
    for f, lw, color in (
        (result.recorded_figures, 1.2, "tab:orange"),
        (result.offline_figures, 0.8, "tab:blue"),
    ):
        if f is not None:
            sigma = np.sqrt(np.where(f.variance >= 0.0, f.variance, np.nan))
            ax.plot(f.t, 2.0 * sigma, lw=lw, color=color, label=f"{f.source} 2σ")
    ax.set_ylabel("2σ (m/s²)")
    ax.set_xlabel("t (s)")
    ax.set_title(f"no truth in the bag ({TOPIC_ACCEL_TRUTH}): the estimates' published 2σ", fontsize=9)
    ax.legend(loc="best")


def _save(fig: Figure, out: Path | str) -> Path:
    """Grid on every panel, save at 110 dpi (parent directories made), close; the path."""
    import matplotlib.pyplot as plt

    for ax in fig.axes:
        ax.grid(True, alpha=0.3)
    path = Path(out)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
