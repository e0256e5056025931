"""The picture of an analysis (``analyze --plot``): θ, the estimates beside the truth, their errors, and
(with a truth) the reliability diagram of every stream's published σ."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pendulum_accel.bag.messages import TOPIC_ACCEL_TRUTH
from pendulum_accel.recording.analyze import Analysis
from pendulum_accel.recording.figures import EstimateFigures
from pendulum_accel.recording.reliability import DECILES, ReliabilityBins, reliability_bins

if TYPE_CHECKING:  # matplotlib is imported when a plot is drawn: analyze without --plot never loads it
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


def plot_analysis(result: Analysis, out: Path | str) -> Path:
    """Three panels, shared time axis: θ (deg); truth, recorded estimate (holes shaded) and re-run; both
    errors with the ±tolerance band (without a truth: each stream's published 2σ instead). With a truth, a
    fourth: the reliability diagram (``_plot_reliability``)."""
    return _save(analysis_figure(result), out)


def analysis_figure(result: Analysis) -> Figure:
    """plot_analysis's figure, unsaved."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = 4 if result.has_truth else 3
    fig = plt.figure(figsize=(9, 8 + 3.5 * (rows - 3)), constrained_layout=True)
    grid = fig.add_gridspec(rows, 1, height_ratios=[1.0, 1.0, 1.0, 1.4][:rows])
    first = fig.add_subplot(grid[0])
    axes = [first, fig.add_subplot(grid[1], sharex=first), fig.add_subplot(grid[2], sharex=first)]
    for ax in axes[:2]:
        ax.tick_params(labelbottom=False)  # the time axis is labelled once, under the error panel
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
        return fig
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
    _plot_reliability(fig.add_subplot(grid[3]), result)
    return fig


def stream_reliability(result: Analysis, f: EstimateFigures) -> ReliabilityBins:
    """reliability_bins of one stream's e = â − a (truth interpolated onto its stamps) and published
    variance, over its estimates after ``skip`` (the samples the figures are computed from)."""
    keep = f.t >= result.t[0] + result.skip
    error = f.accel[keep] - np.interp(f.t[keep], result.t, result.accel_true)
    return reliability_bins(error, f.variance[keep], DECILES)


def stream_label(result: Analysis, f: EstimateFigures) -> str:
    """'recorded (kalman)', 'offline re-run (kalman, lag 0.25 s)': a stream as its diagram names it."""
    lag = result.config.get("lag", 0.0) if f is result.offline_figures else 0.0
    return f"{f.source} ({f.estimator}{f', lag {lag:g} s' if lag > 0 else ''})"


def _plot_reliability(ax: Axes, result: Analysis) -> None:
    """The reliability diagram: each stream's published σ in deciles, √(mean σ²) of a decile against the
    RMS error its samples made (recording.reliability), on log axes, beside the diagonal observed =
    predicted (a calibrated σ). A stream without a positive finite σ is left out."""
    low, high = np.inf, 0.0
    for f, color, marker in (
        (result.recorded_figures, "tab:orange", "s"),
        (result.offline_figures, "tab:blue", "o"),
    ):
        if f is None:
            continue
        bins = stream_reliability(result, f)
        shown = (bins.predicted > 0.0) & (bins.observed > 0.0)  # a log axis holds positive values only
        if not shown.any():
            continue
        ax.plot(bins.predicted[shown], bins.observed[shown], color=color, marker=marker, lw=1.2,
                label=stream_label(result, f))  # fmt: skip
        low = min(low, float(np.min(bins.predicted[shown])), float(np.min(bins.observed[shown])))
        high = max(high, float(np.max(bins.predicted[shown])), float(np.max(bins.observed[shown])))
    if high > 0.0:
        ax.plot([low, high], [low, high], color="black", ls="--", lw=1, label="calibrated: observed = σ")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.legend(loc="best", fontsize=8)
    else:
        ax.text(0.5, 0.5, "no stream publishes a positive σ", ha="center", transform=ax.transAxes)
    ax.set_xlabel(f"published σ, RMS within each of {DECILES} σ-deciles (m/s²)")
    ax.set_ylabel("RMS of â − a (m/s²)")
    ax.set_title("reliability: below the diagonal σ is too wide, above it too narrow", fontsize=9)


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
