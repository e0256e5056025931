"""``pendulum-accel sweep SCENE --length 0.5,1,2 | --accel ... | --noise ... [--out table.csv]``."""

from __future__ import annotations

import argparse
import io
import re
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from pendulum_accel.cli.output import check_output_file, write_output, write_text_output
from pendulum_accel.errors import ParameterError

if TYPE_CHECKING:
    from pendulum_accel.sweep import SweepResult


_NEGATIVE_VALUES = re.compile(r"^-(\d|\.\d)[\d.eE+\-,:]*$")
VALUE_OPTIONS = ("--length", "--accel", "--noise")


def attach_negative_values(argv: Sequence[str]) -> list[str]:
    """argv with ``--accel -2,0,2`` written ``--accel=-2,0,2``: argparse reads a token that starts with a
    minus and is not a plain number as an option, and braking accelerations are negative."""
    out: list[str] = []
    for token in argv:
        if out and out[-1] in VALUE_OPTIONS and _NEGATIVE_VALUES.match(token):
            out[-1] = f"{out[-1]}={token}"
        else:
            out.append(token)
    return out


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``sweep`` subcommand: many variants of one scene, vectorised, one CSV row per variant."""
    parser = subparsers.add_parser(
        "sweep",
        help="run many variants of a scene at once (lengths, accelerations or noise levels)",
        description=(
            "Integrate every variant of SCENE together (rigid model, vectorised fixed-step RK4 by default) "
            "and write one table with a row per variant: equilibrium angle, mean and max angle, period, "
            "g·tan(mean θ) and the default estimator's steady-state estimate. Values are a comma list "
            "(0.5,1,2) or start:stop:count. --accel replaces the scene's profile by a constant a."
        ),
    )
    parser.add_argument("scene", help="bundled scene name or path to a scene YAML file")
    which = parser.add_mutually_exclusive_group(required=True)
    which.add_argument("--length", metavar="VALUES", help="string lengths in m")
    which.add_argument("--accel", metavar="VALUES", help="constant car accelerations in m/s²")
    which.add_argument("--noise", metavar="VALUES", help="sensor angle noise σ in rad")
    parser.add_argument("--out", type=Path, help="CSV table to write (default, or '-': standard output)")
    parser.add_argument("--method", default="rk4", help="integration method (default rk4, vectorised)")
    parser.add_argument("--dt", type=float, help="fixed step in s (default: hω = 0.02, at most one sample)")
    parser.add_argument("--duration", type=float, help="override the scene's duration in s")
    parser.add_argument(
        "--estimator", help="estimator for the accel_estimate column (default: the package default; 'none')"
    )
    parser.add_argument(
        "--plot", type=Path, help="also plot the table's columns against the swept value (PNG)"
    )
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar (stderr)")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Parse the sweep list, run the sweep, write the table and print a one-line summary to stderr."""
    from pendulum_accel.scene import load_scene
    from pendulum_accel.sweep import parse_values, run_sweep, setup_from_scene

    to_stdout = args.out is None or str(args.out) == "-"  # '-' is stdout, as for most Unix tools
    out = None if to_stdout else check_output_file(args.out, (".csv",))
    plot = check_output_file(args.plot, (".png",), option="--plot") if args.plot is not None else None
    field = next(name for name in ("length", "accel", "noise") if getattr(args, name) is not None)
    values = parse_values(field, getattr(args, field))
    if args.duration is not None and not args.duration > 0:
        raise ParameterError(f"--duration must be > 0 s, got {args.duration!r}")
    setup = setup_from_scene(load_scene(args.scene), duration=args.duration)
    started = time.perf_counter()
    result = run_sweep(
        setup,
        field,
        values,
        method=args.method,
        dt=args.dt,
        estimator=args.estimator,
        progress=not args.no_progress,
    )
    elapsed = time.perf_counter() - started
    if out is None:
        buffer = io.StringIO()
        result.write_csv_to(buffer)
        sys.stdout.write(buffer.getvalue())
    else:
        write_text_output(out, result.write_csv_to)
    if plot is not None:
        write_output(plot, lambda target: plot_sweep(result, target))
    where = "stdout" if out is None else str(args.out)
    step = "adaptive" if result.dt is None else f"dt={result.dt:.3g} s"
    print(
        f"sweep: {len(values)} variants of {field}, {result.method} {step}, {result.steps} steps each, "
        f"{elapsed:.2f} s -> {where}",
        file=sys.stderr,
    )
    return 0


_UNITS = {"length": "l (m)", "accel": "a (m/s²)", "noise": "σ (rad)"}


def plot_sweep(result: SweepResult, path: Path) -> None:
    """Three panels against the swept value: mean θ vs θ_eq, period vs 2π/ω, estimated vs true a."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = result.values
    cols = result.columns
    order = np.argsort(x)
    fig, axes = plt.subplots(1, 3, figsize=(14, 4))
    axes[0].plot(x[order], cols["theta_eq"][order], "k-", label="θ_eq = atan(a/g)")
    axes[0].plot(x[order], cols["theta_mean"][order], "o", ms=3, label="mean θ (2nd half)")
    axes[0].set_ylabel("angle (rad)")
    axes[1].plot(x[order], cols["period_small_angle"][order], "k-", label="2π/ω, ω² = √(g²+a²)/l")
    axes[1].plot(x[order], cols["period"][order], "o", ms=3, label="measured period")
    axes[1].set_ylabel("period (s)")
    axes[2].plot(x[order], cols["accel"][order], "k-", label="true a")
    axes[2].plot(x[order], cols["accel_g_tan_mean"][order], "s", ms=3, label="g tan(mean measured θ)")
    if np.any(np.isfinite(cols["accel_estimate"])):
        axes[2].plot(x[order], cols["accel_estimate"][order], "o", ms=3, label="default estimator")
    axes[2].set_ylabel("a (m/s²)")
    for ax in axes:
        ax.set_xlabel(_UNITS[result.field])
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"sweep over {result.field}: {x.size} variants, {result.method}", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
