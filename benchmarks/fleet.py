"""Fleet: ``analyze`` over many bags, serial against Dask LocalClusters of 1 and W workers, in one run.

    python -m benchmarks.fleet [--bags N] [--workers W] [--docs DIR]

Generates a few short bags of the bundled real-motion scenes and copies them to N bags (the work per bag
is what matters, not its content), then analyses all N with the default estimator: once in this process
(the serial path), then on a LocalCluster of 1 and of W single-threaded worker processes (the engine
``analyze`` uses for many bags). Throughput = bags per second of wall time; each cluster's time is given
with and without its start-up, beside the peak RSS of its workers. The tables must be identical
(checked). From the measured figures it writes what they predict for a 10-node cluster, and why. Writes
docs/benchmarks/fleet.md and docs/img/bench_fleet.png.
"""

from __future__ import annotations

import argparse
import functools
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from benchmarks import report as bench_report
from pendulum_accel.cluster import dask_client, map_tasks
from pendulum_accel.recording.fleet import FleetRow, Job, analyze_many, bag_rows, find_bags

SCENES = ("udds", "hwfet", "husky_odom", "ftp75", "bus_gps_speed")  # real motion, as a fleet records it
DURATION = 120.0  # s of each scene: a two-minute recording per bag
NODES = 10  # the cluster the prediction is for: NODES machines like this one
LINK_MB_S = 125.0  # MB/s each node reads its bags at from shared storage: one 1 Gbit/s link


@dataclass(frozen=True)
class ClusterRun:
    """One LocalCluster's figures: workers, start-up and run wall times (s), its workers' peak RSS (MiB)."""

    workers: int
    startup: float
    run: float
    peak_rss_mib: tuple[float, ...]


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


def peak_rss_mib() -> float:
    """This process's peak resident set (MiB): getrusage's ru_maxrss, which Linux gives in KiB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def on_cluster(paths: Sequence[Path], workers: int, serial: list[FleetRow]) -> ClusterRun:
    """Start a LocalCluster of ``workers``, analyse ``paths`` on it (the table compared with ``serial``)."""
    job = Job()
    start = time.perf_counter()
    with dask_client(None, workers) as client:
        client.wait_for_workers(workers)
        startup = time.perf_counter() - start
        # Each worker imports the package and loads the compiled estimator once, as the serial path did
        # before its timing; what is timed below is the analysis itself.
        client.run(analyze_many, paths[:1], job, distributed=False)
        start = time.perf_counter()
        task: Callable[[str], list[FleetRow]] = functools.partial(bag_rows, job=job)
        parts = map_tasks(task, [str(p) for p in paths], client=client)
        run = time.perf_counter() - start
        rss = client.run(peak_rss_mib)
    rows = [r for part in parts for r in part]
    if rows != serial:
        raise SystemExit(f"the {workers}-worker cluster's table differs from the serial one")
    return ClusterRun(workers, startup, run, tuple(sorted(rss.values())))


def prediction(n: int, serial: float, one: ClusterRun, many: ClusterRun, bag_mb: float) -> str:
    """What the measured figures predict for NODES machines of ``many.workers`` workers each, and why.

    Per bag: compute c = serial/n; the cluster's own cost o = one.run/n − c (scheduling a task, shipping
    its rows back), an upper bound on the central scheduler's share. Efficiency at W workers
    e = n c /(W · many.run). NODES·W workers then give about NODES·W·e/c bags/s, capped by the scheduler
    (≤ 1/o when o > 0) and by each node's link to the bags (NODES · LINK_MB_S / bag size)."""
    c = serial / n
    o = one.run / n - c
    e = n * c / (many.workers * many.run)
    total = NODES * many.workers
    compute_rate = total * e / c
    caps = [(compute_rate, f"{total} workers at the {e:.0%} efficiency measured with {many.workers}")]
    if o > 0.0:
        caps.append((1.0 / o, f"the scheduler, at most {o * 1e3:.1f} ms a bag (the 1-worker cluster's cost)"))
    caps.append((NODES * LINK_MB_S / bag_mb, f"{NODES} links of {LINK_MB_S:g} MB/s to {bag_mb:.1f} MB bags"))
    rate, limit = min(caps)
    overhead = (
        f"the 1-worker cluster costs {o * 1e3:.1f} ms a bag more than the serial path"
        if o > 0.0
        else "the 1-worker cluster costs no more than the serial path per bag (within this run's scatter)"
    )
    return (
        f"**What this predicts for a {NODES}-node cluster** of machines like this one ({many.workers} "
        f"workers each, {total} in all), bags read from shared storage. Each bag is {c * 1e3:.0f} ms of "
        f"compute here; {overhead}; {many.workers} workers ran at {e:.0%} of {many.workers}× the serial "
        f"rate (the rest is the machine's own: {many.workers} workers share its cores with the scheduler "
        f"and this process). The bags are independent, so the work divides by the workers until something "
        f"shared is saturated: the central scheduler, or the storage every node reads from. The first "
        f"limit is {limit}: about **{rate:.0f} bags/s**, {rate * c:.0f}× the serial path, so "
        f"{n} bags would take {n / rate:.1f} s beside a start-up of several seconds per node. With fewer "
        f"bags than that the start-up dominates, and a single machine is faster."
    )


def measure(paths: Sequence[Path], workers: int) -> tuple[float, ClusterRun, ClusterRun]:
    """Serial wall time (s), then the 1-worker and the ``workers``-worker clusters."""
    start = time.perf_counter()
    serial = analyze_many(paths, Job(), distributed=False)
    t_serial = time.perf_counter() - start
    return t_serial, on_cluster(paths, 1, serial), on_cluster(paths, workers, serial)


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
        bag_mb = sum(f.stat().st_size for f in paths[0].rglob("*") if f.is_file()) / 1e6
        analyze_many(paths[:1], Job(), distributed=False)  # compiled code loaded before timing
        t_serial, one, many = measure(paths, args.workers)
    n = len(paths)
    serial_rate = n / t_serial
    rows = [f"| serial (one process) | {t_serial:.1f} | {serial_rate:.2f} | 1.00 | |"]
    bars = [("serial", serial_rate)]
    for run in (one, many):
        rss = " / ".join(f"{r:.0f}" for r in run.peak_rss_mib)
        name = f"LocalCluster, {run.workers} worker{'s' if run.workers > 1 else ''}"
        for label, wall in ((f"{name}, run", run.run), (f"the same with its start-up ({run.startup:.1f} s)",
                                                           run.run + run.startup)):  # fmt: skip
            rate = n / wall
            rows.append(f"| {label} | {wall:.1f} | {rate:.2f} | {rate / serial_rate:.2f} | {rss} |")
        bars += [
            (f"{run.workers} worker(s)", n / run.run),
            (f"{run.workers} + start-up", n / (run.run + run.startup)),
        ]
    table = "\n".join(
        [
            "| path | wall time (s) | bags/s | × serial | peak RSS per worker (MiB) |",
            "|---|---|---|---|---|",
            *rows,
        ]
    )
    summary = (
        f"{n} bags of {DURATION:g} s ({', '.join(SCENES)}, copied round-robin, {bag_mb:.1f} MB each), the "
        f"default estimator; each cluster's table is identical to the serial one."
    )
    predicted = prediction(n, t_serial, one, many, bag_mb)
    print(summary)
    print(table)
    print(predicted)
    png = bench_report.bar_plot(
        Path(tempfile.mkdtemp()) / "fleet.png",
        "analyze over many bags: serial against LocalClusters",
        bars,
        "bags / s",
    )
    page = bench_report.write_page(
        "fleet",
        "Fleet: many bags on Dask",
        [summary, table, predicted],
        [(png, "bags per second: serial against the local clusters")],
        intro=(__doc__ or "").split("\n\n", 1)[0],
        docs=args.docs,
        argv=argv,
    )
    print(f"wrote {page}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
