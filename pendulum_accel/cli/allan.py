"""``pendulum-accel allan BAG|SCENE``: Allan deviation of the angle and the estimate, noise figures."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from pendulum_accel.cli.output import check_output_file, write_output
from pendulum_accel.cli.salvage import add_salvage_flag, read_intact, warn_salvaged
from pendulum_accel.cli.topics import add_topic_flags, choose_topics
from pendulum_accel.errors import ParameterError

if TYPE_CHECKING:
    from pendulum_accel.allan import AllanResult

ESTIMATE_FIT_FROM = 5.0  # s: past the default kalman's quiet-mode memory (3.3 s for the lecture scene)
DEFAULT_DURATION = 3600.0  # s of a generated static run: enough clusters to read the walk out to ~400 s


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``allan`` subcommand."""
    parser = subparsers.add_parser(
        "allan",
        help="Allan deviation of the angle and the estimate: white-noise density, bias random walk",
        description=(
            "Overlapping Allan deviation (NIST SP 1065) of the angle readings and of the acceleration "
            "estimate, from a recorded bag or from a static run generated from a scene (car at rest, "
            "bob hanging still). Prints the fitted white-noise density N (−½ slope, read at τ = 1 s), "
            "bias random walk K (+½ slope, read at τ = 3 s) and bias-instability floor B, and for the "
            "angle a Gauss-Markov bias (σ_b, T_c) where its σ(τ) shows one."
        ),
    )
    parser.add_argument("source", help="bag directory (or .mcap) or a scene name or YAML file")
    parser.add_argument(
        "--duration",
        type=float,
        default=DEFAULT_DURATION,
        metavar="S",
        help=f"length of a scene's generated static run (default {DEFAULT_DURATION:g} s)",
    )
    parser.add_argument(
        "--estimator", "-e", default=None, help="estimator for a scene's run (default: the package default)"
    )
    parser.add_argument(
        "--plot", default=None, metavar="PNG", help="save the log-log plot with the slopes marked"
    )
    add_salvage_flag(parser)
    add_topic_flags(parser)
    parser.set_defaults(func=run)


def _is_bag(source: str) -> bool:
    """True when ``source`` is a bag directory (it holds metadata.yaml or an .mcap) or an .mcap file."""
    path = Path(source)
    return path.suffix == ".mcap" or (
        path.is_dir() and (any(path.glob("*.mcap")) or (path / "metadata.yaml").exists())
    )


def run(args: argparse.Namespace) -> int:
    """Print σ(τ) figures for the angle and the estimate; plot them when asked."""
    from pendulum_accel.allan import (
        MISFIT_LIMIT,
        allan_deviation,
        bag_series,
        interruptible,
        plot_allan,
        scene_series,
    )

    plot = check_output_file(args.plot, (".png",), option="--plot") if args.plot is not None else None
    bag = choose_topics(read_intact(args.source, args.salvage), args) if _is_bag(args.source) else None
    series = bag_series(bag) if bag is not None else scene_series(args.source, args.duration, args.estimator)
    # interruptible: σ(τ) of a long series is seconds of numpy work that Ctrl-C must still stop at once.
    results: list[AllanResult] = [
        interruptible(
            lambda: allan_deviation(
                series.theta, series.rate_hz, label="angle θ", unit="rad", gauss_markov=True
            )
        )
    ]
    note = None
    if series.accel is not None:
        try:
            accel = series.accel
            results.append(
                # The estimator shapes the short τ (it is a filter): fit from τ = ESTIMATE_FIT_FROM on.
                interruptible(
                    lambda: allan_deviation(
                        accel,
                        series.rate_hz,
                        label=f"estimate â ({series.estimator})",
                        unit="m/s²",
                        fit_from=ESTIMATE_FIT_FROM,
                    )
                )
            )
        except ParameterError as err:
            # A bag long enough for the angle's figures but not for the estimate's still has the former.
            note = f"estimate â ({series.estimator}) not fitted: {err}"
    print(f"source: {series.source}, {series.theta.size} samples at {series.rate_hz:g} Hz")
    for res in results:
        print("\n".join(res.lines()))
        if res is results[0] and not res.fits:
            # The angle's only: a filter's output never fits the model closely (the default estimator's
            # static runs: χ²/dof 17–37), so the line would stand under every estimate.
            print(
                f"  model misfit: σ(τ) of the angle misses N²/τ + K²τ/3 by χ²/dof {res.misfit:.3g} (white "
                f"noise and a walk stay under {MISFIT_LIMIT:g}, and no Gauss-Markov bias brings it there): "
                "the record holds motion (a swing, a change of a) or noise the model lacks (bias "
                "instability, a Gauss-Markov bias slower than the record resolves); N and K describe that, "
                "not a white noise and a walk"
            )
    if note is not None:
        print(note)
    if plot is not None:
        print(f"plot: {write_output(plot, lambda target: plot_allan(results, target))}")
    return warn_salvaged("allan", bag) if bag is not None else 0
