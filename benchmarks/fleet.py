"""Fleet: ``analyze`` over many bags, serial against a 2-worker Dask LocalCluster, in one run.

    python -m benchmarks.fleet [--bags N] [--workers W] [--docs DIR]

Generates a few short bags of the bundled lab scenes and copies them to N bags (the work per bag is
what matters, not its content), then analyses all N with the default estimator: once in this process
(the serial path), once on a LocalCluster of W single-threaded worker processes (the engine
``analyze`` uses for many bags). Throughput = bags per second of wall time; the cluster's time is given
with and without its start-up. The tables must be identical (checked). Writes docs/benchmarks/fleet.md
and docs/img/bench_fleet.png.
"""

from __future__ import annotations

import argparse
import functools
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from benchmarks import report as bench_report
from pendulum_accel.cluster import dask_client, map_tasks
from pendulum_accel.recording.fleet import Job, analyze_many, bag_rows, find_bags

SCENES = ("udds", "hwfet", "husky_odom", "ftp75", "bus_gps_speed")  # real motion, as a fleet records it
DURATION = 120.0  # s of each scene: a two-minute recording per bag


def make_corpus(root: Path, n: int) -> list[Path]:
    """n bags under root: the SCENES generated once, then copied round-robin."""
    sources = []
    (root / "src").mkdir()
    (root / "fleet").mkdir()
    for scene in SCENES:
        out = root / "src" / scene
        subprocess.run(
            [sys.executable, "-m", "pendulum_accel.cli.main", "generate", scene, "--out", str(out),
             "--duration", str(DURATION)],
            check=True, capture_output=True,
        )  # fmt: skip
        sources.append(out)
    for i in range(n):
        shutil.copytree(sources[i % len(sources)], root / "fleet" / f"bag_{i:04d}")
    return find_bags([str(root / "fleet")])


def measure(paths: Sequence[Path], workers: int) -> dict[str, float]:
    """Wall times (s): serial; the cluster's start-up; its run (tables compared)."""
    job = Job()
    start = time.perf_counter()
    serial = analyze_many(paths, job, distributed=False)
    t_serial = time.perf_counter() - start
    start = time.perf_counter()
    with dask_client(None, workers) as client:
        client.wait_for_workers(workers)
        t_up = time.perf_counter() - start
        # Each worker imports the package and loads the compiled estimator once, as the serial path did
        # before its timing; what is timed below is the analysis itself.
        client.run(analyze_many, paths[:1], job, distributed=False)
        start = time.perf_counter()
        task: Callable[[str], list[dict[str, Any]]] = functools.partial(bag_rows, job=job)
        parts = map_tasks(task, [str(p) for p in paths], client=client)
        t_run = time.perf_counter() - start
    rows = [r for part in parts for r in part]
    if rows != serial:
        raise SystemExit("the cluster's table differs from the serial one")
    return {"serial": t_serial, "startup": t_up, "cluster": t_run}


def main(argv: Sequence[str] | None = None) -> int:
    """Run, print, write the page."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bags", type=bench_report.count, default=200, help="bags in the fleet (200)")
    parser.add_argument(
        "--workers",
        type=bench_report.count,
        default=2,
        help="local cluster workers (2: this machine's cores)",
    )
    bench_report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        paths = make_corpus(Path(tmp), args.bags)
        analyze_many(paths[:1], Job(), distributed=False)  # compiled code loaded before timing
        t = measure(paths, args.workers)
    n = len(paths)
    serial_rate = n / t["serial"]
    run_rate = n / t["cluster"]
    whole_rate = n / (t["cluster"] + t["startup"])
    table = "\n".join(
        [
            "| path | wall time (s) | bags/s | × serial |",
            "|---|---|---|---|",
            f"| serial (one process) | {t['serial']:.1f} | {serial_rate:.2f} | 1.00 |",
            f"| LocalCluster, {args.workers} workers, run | {t['cluster']:.1f} | {run_rate:.2f} | "
            f"{run_rate / serial_rate:.2f} |",
            f"| the same with its start-up ({t['startup']:.1f} s) | {t['cluster'] + t['startup']:.1f} | "
            f"{whole_rate:.2f} | {whole_rate / serial_rate:.2f} |",
        ]
    )
    summary = (
        f"{n} bags of {DURATION:g} s ({', '.join(SCENES)}, copied round-robin), the default estimator; the "
        f"cluster's table is identical to the serial one."
    )
    print(summary)
    print(table)
    png = Path(tempfile.mkdtemp()) / "fleet.png"
    _plot(png, serial_rate, run_rate, whole_rate, args.workers)
    page = bench_report.write_page(
        "fleet",
        "Fleet: many bags on Dask",
        [summary, table],
        [(png, "bags per second: serial against the local cluster")],
        intro=(__doc__ or "").split("\n\n", 1)[0],
        docs=args.docs,
        argv=argv,
    )
    print(f"wrote {page}")
    return 0


def _plot(png: Path, serial: float, run: float, whole: float, workers: int) -> None:
    """Bars of the three throughputs."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.2))
    labels = ["serial", f"{workers} workers", f"{workers} workers\n+ start-up"]
    ax.bar(labels, [serial, run, whole], color=["0.6", "C0", "C1"])
    ax.set_ylabel("bags / s")
    ax.grid(True, axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(png, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
