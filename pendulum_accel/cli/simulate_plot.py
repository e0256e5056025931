"""``simulate --plot``: θ(t) above, the input sensitivity (θ moved by 1 ulp of the inputs) below.

The time from which the inputs no longer determine θ to within the target (conditioning.Sensitivity
``lost_at``) is marked on both panels as a vertical line.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from pendulum_accel.lecture.plotting import check_plot_path
from pendulum_accel.physics.trajectory import Trajectory
from pendulum_accel.planner import Plan


def plot_simulation(traj: Trajectory, plan: Plan, path: Path) -> Path:
    """Write the two-panel PNG at ``path`` (must end in .png, its directory must exist); returns it."""
    out = check_plot_path(path)
    fig = Figure(figsize=(9, 6), dpi=100, layout="constrained")
    FigureCanvasAgg(fig)
    top, bottom = fig.subplots(2, 1, sharex=True)
    top.plot(traj.t, traj.theta, lw=1.0)
    top.set_ylabel("θ (rad)")
    top.set_title(f"{plan.model} model, {plan.method}: predicted max error {plan.predicted_error:.1e} rad")
    sensitivity = plan.sensitivity
    if sensitivity is not None:
        bottom.semilogy(sensitivity.times, np.maximum(sensitivity.curve, 1e-300), lw=1.0,
                        label=f"|Δθ| per ulp of the inputs (max: {sensitivity.input})")  # fmt: skip
        bottom.axhline(sensitivity.target, color="k", ls=":", lw=1.0, label="target")
        bottom.set_ylim(
            bottom=max(1e-18, float(np.min(sensitivity.curve[sensitivity.curve > 0], initial=1e-18)))
        )
        if sensitivity.lost_at is not None:
            for axis in (top, bottom):
                axis.axvline(sensitivity.lost_at, color="r", lw=1.2)
            top.annotate(f"not determined by the inputs past t = {sensitivity.lost_at:.3g} s",
                         (sensitivity.lost_at, 0.95), xycoords=("data", "axes fraction"), color="r",
                         ha="right", va="top")  # fmt: skip
        bottom.legend(loc="lower right")
    bottom.set_xlabel("t (s)")
    bottom.set_ylabel("rad per ulp")
    fig.savefig(out, format="png")
    return out
