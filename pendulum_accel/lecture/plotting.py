"""Headless PNG output for lecture plots.

matplotlib's object API (Figure + Agg canvas) is used instead of pyplot so no GUI backend
is ever selected, whatever MPLBACKEND says, and figures are freed when they go out of scope.
"""

from __future__ import annotations

from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from pendulum_accel.errors import ParameterError
from pendulum_accel.lecture.report import LectureReport

FIGSIZE = (10.0, 7.0)
DPI = 100


def check_plot_path(path: Path | str) -> Path:
    """Return ``path`` as a Path when it ends in .png and its directory exists, else ParameterError."""
    out = Path(path)
    if out.suffix.lower() != ".png":
        raise ParameterError(f"plot path must end in .png, got {str(out)!r}")
    if not out.parent.is_dir():
        raise ParameterError(f"plot directory does not exist: {str(out.parent)!r}")
    return out


def write_plot(report: LectureReport, path: Path | str) -> Path:
    """Draw ``report`` on a fresh Agg figure and save it as PNG at ``path``; returns the path."""
    if report.draw is None:
        raise ParameterError(f"lecture result {report.name!r} has no plot")
    out = check_plot_path(path)
    fig = Figure(figsize=FIGSIZE, dpi=DPI, layout="constrained")
    FigureCanvasAgg(fig)
    report.draw(fig)
    fig.suptitle(f"{report.name}: {report.title}", fontsize=12)
    fig.savefig(out, format="png")
    return out
