"""Sweep throughput: trajectory-steps per CPU second for the rigid model with vectorised RK4.

``python -m benchmarks.sweep_bench [--variants 1000] [--steps 10000] [--out DIR]`` integrates
a length sweep (l from 0.5 to 2 m, the lecture's a = 2 m/s²) of ``variants`` pendulums for ``steps``
RK4 steps, best of ``--repeats`` runs, and prints the rate against the target of 10 M
trajectory-steps/s. For context it also times: the same batch under a 0 → 3 m/s² step profile (a(t)
looked up per stage), an accel sweep, the right-hand side alone (its share of the time), and the
single-trajectory path (simulate() per variant) the sweep replaces. Writes sweep_bench.md and
sweep_bench.png.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

from benchmarks import report
from benchmarks.work_precision import cpu_time
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import AccelProfile, Constant, Step
from pendulum_accel.physics.simulate import simulate
from pendulum_accel.sweep import SweepSetup, batch_rigid_rhs, run_batch

TARGET_RATE = 10e6  # trajectory-steps per second
DT = 1e-3
SAMPLE_EVERY = 10  # steps per output sample (100 Hz samples at dt = 1 ms)


def _setup(profile: AccelProfile, steps: int) -> SweepSetup:
    """Lecture pendulum, θ0 = 0.1 rad, samples every SAMPLE_EVERY steps of DT over ``steps`` steps."""
    n_samples = steps // SAMPLE_EVERY
    t = np.linspace(0.0, n_samples * SAMPLE_EVERY * DT, n_samples + 1)
    return SweepSetup(Pendulum(1.0), profile, 0.1, 0.0, t, None, 0.0, 1.0 / (SAMPLE_EVERY * DT))


def _rate(
    fn: Callable[[], tuple[np.ndarray, np.ndarray, float | None, int]], variants: int, repeats: int
) -> float:
    """Best trajectory-steps per CPU second of a run_batch call over ``repeats`` runs."""
    seconds, result = cpu_time(fn, budget=0.0, rounds=repeats)
    steps = result[3]
    return variants * steps / seconds


def main(argv: list[str] | None = None) -> int:
    """Run the throughput benchmark and print the target check."""
    parser = argparse.ArgumentParser(prog="python -m benchmarks.sweep_bench", description=__doc__)
    parser.add_argument(
        "--variants", type=report.count, default=1000, help="trajectories in the batch (1000)"
    )
    parser.add_argument("--steps", type=report.count, default=10_000, help="RK4 steps per trajectory (10000)")
    parser.add_argument("--repeats", type=report.count, default=3, help="best of this many runs (3)")
    parser.add_argument("--out", type=Path, default=Path("out/bench"), help="output directory (out/bench)")
    report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    if args.variants < 1 or args.steps < SAMPLE_EVERY or args.repeats < 1:
        print(
            f"sweep_bench: error: need --variants ≥ 1, --steps ≥ {SAMPLE_EVERY}, --repeats ≥ 1",
            file=sys.stderr,
        )
        return 2
    n, steps = args.variants, args.steps
    lengths = np.linspace(0.5, 2.0, n)
    const = _setup(Constant(2.0), steps)
    step_profile = _setup(Step(1.0, 0.0, 3.0), steps)

    results: list[tuple[str, float]] = []
    rate = _rate(lambda: run_batch(const, lengths, None, dt=DT), n, args.repeats)
    results.append((f"length sweep, constant a, {n} × {steps} RK4 steps", rate))
    results.append(
        (
            "length sweep, 0 → 3 m/s² step profile",
            _rate(lambda: run_batch(step_profile, lengths, None, dt=DT), n, args.repeats),
        )
    )
    accels = np.linspace(-5.0, 5.0, n)
    results.append(
        (
            "accel sweep (per-variant constant a)",
            _rate(lambda: run_batch(const, np.full(n, 1.0), accels, dt=DT), n, args.repeats),
        )
    )

    rhs = batch_rigid_rhs(lengths, 9.80665, 0.0, lambda t: 2.0)
    y = np.vstack((np.full(n, 0.1), np.zeros(n)))
    calls = 2000
    rhs_seconds, _ = cpu_time(lambda: [rhs(0.0, y) for _ in range(calls)], budget=0.0, rounds=args.repeats)
    rhs_share = 4 * steps * rhs_seconds / calls / (n * steps / results[0][1])

    single_n = max(1, min(n, 5))

    def one_at_a_time() -> list[object]:
        """simulate() per variant: RK4 in the compiled kernel, one trajectory per call."""
        return [
            simulate(Pendulum(float(length)), Constant(2.0), const.t, theta0=0.1, model="rigid",
                     method="rk4", dt=DT)
            for length in lengths[:single_n]
        ]  # fmt: skip

    one_at_a_time()  # the first call loads the compiled kernel from numba's cache (~0.3 s): not a step cost
    single_seconds, _ = cpu_time(one_at_a_time, budget=0.0, rounds=args.repeats)
    single_rate = single_n * steps / single_seconds
    results.append(
        (f"simulate() one trajectory at a time (compiled RK4 kernel, {single_n} runs)", single_rate)
    )

    met = rate >= TARGET_RATE
    lines = [
        f"# Sweep throughput (`python -m benchmarks.sweep_bench --variants {n} --steps {steps}`)",
        "",
        "Trajectory-steps per CPU second (`time.process_time`, best of "
        f"{args.repeats}); RK4, dt = {DT:g} s, samples every {SAMPLE_EVERY} steps.",
        "",
        "| run | M trajectory-steps/s |",
        "|---|---|",
        *(f"| {name} | {value / 1e6:.2f} |" for name, value in results),
        "",
        f"Right-hand side share of the batch time: {rhs_share:.0%} (one sine per evaluation, in place); "
        "the rest is the registry's RK4 stage arithmetic and per-step Python overhead.",
        "",
        f"Target ≥ {TARGET_RATE / 1e6:.0f} M trajectory-steps/s: {'MET' if met else 'MISSED'} "
        f"({rate / 1e6:.2f} M/s; {rate / single_rate:.0f}× the one-at-a-time path).",
    ]
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "sweep_bench.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))
    png = report.bar_plot(
        args.out / "sweep_bench.png",
        "Sweep throughput (best of the runs, CPU time)",
        [(name, value / 1e6) for name, value in results],
        "M trajectory-steps per CPU second",
        bound=(TARGET_RATE / 1e6, f"target {TARGET_RATE / 1e6:g} M/s"),
    )
    page = report.write_page(
        "sweep_bench", "Sweep throughput", ["\n".join(lines[2:])],
        [(png, "Trajectory-steps per CPU second of each run, beside the 10 M/s target")],
        intro=__doc__ or "", docs=args.docs, argv=argv,
    )  # fmt: skip
    print(f"wrote {page}")
    return 0 if math.isfinite(rate) else 1


if __name__ == "__main__":
    sys.exit(main())
