"""Bag command memory benchmark: peak RSS of ``info``, ``analyze`` and ``export`` on a bag over 1 GiB.

    python -m benchmarks.bag_memory [--out DIR] [--scene NAME] [--rate HZ] [--keep] [--bag DIR]

1. Writes the chain bag of a whole drive cycle (default ``ftp75``, 1874 s) with ``generate``, its sensor
   rate raised to ``--rate`` (default 600 Hz: 1.12 million samples) so that the bag passes 1 GiB: every
   topic a live recording holds (the chain's data, diagnostics, the Imu, markers and the URDF). Checks
   the free disk space first; the bag and the tables are deleted at the end unless --keep. ``--bag``
   measures a bag written so before (kept) instead of writing one.
2. Runs each command as a user does (``pendulum-accel …``, a fresh process each, forked from a bare
   Python) and reads its peak resident memory from the kernel (``getrusage``'s ru_maxrss of the
   child: the high-water mark of the whole run), with the wall time. A Python importing the package's
   reader gives the floor every command starts from.

The bound beside each figure is the bag's own size: a command that held the bag would need at least that.
What does grow with the bag is the arrays of samples a command computes with: analyze's re-run of the
estimator, and the smoothed series ``export`` adds by default (kalman.imm_smoother: the IMM's mode
probabilities, 80 B a sample, then a single-model forward pass kept whole for the backward pass, its
priors, posteriors and transitions, about 300 B a sample at the peak, computed after the topics' tables
are written).
``export --no-smoothed`` shows the tables written batch by batch alone. The merged table (``--merged``)
is a k-way merge on the stamps, a batch of angles at a time. Every command also carries its imports:
numba's compiled passes about 110 MiB, pandas and pyarrow.
Writes bag_memory.csv, bag_memory.md and bag_memory.png into the output directory (default out/bench).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from benchmarks import report
from pendulum_accel import generate_bag, load_scene, read_bag

_MIB = 2**20
BYTES_PER_SAMPLE = 1200
"""Upper estimate of a chain bag's bytes per sample (every topic, record overhead): the disk check."""


_MEASURE = (
    "import resource, subprocess, sys, time; t0 = time.perf_counter(); "
    "code = subprocess.run(sys.argv[1:], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL).returncode; "
    "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, time.perf_counter() - t0, code)"
)
"""A bare Python that runs the command and prints its peak RSS (KiB), wall time and exit code: the
kernel counts a child's memory from its fork, so the command must be forked from a small process, not
from this one, which held the generated bag."""


def peak_rss(argv: list[str]) -> tuple[float, float, int]:
    """(peak RSS MiB, wall s, exit code) of running ``argv`` to its end (its output discarded)."""
    out = subprocess.run([sys.executable, "-S", "-c", _MEASURE, *argv], capture_output=True, text=True)
    kib, wall, code = out.stdout.split()
    return int(kib) / 1024, float(wall), int(code)


def main(argv: list[str] | None = None) -> int:
    """Write the bag, run each command in its own process, write the table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("out/bench"))
    parser.add_argument("--scene", default="ftp75", help="bundled scene to generate (default ftp75)")
    parser.add_argument("--rate", type=report.positive, default=600.0, help="sensor rate, Hz (default 600)")
    parser.add_argument("--keep", action="store_true", help="keep the bag and the tables")
    parser.add_argument("--bag", type=Path, help="measure this chain bag (kept) instead of writing one")
    report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    scene = load_scene(args.scene)
    scene = dataclasses.replace(scene, sensor=dataclasses.replace(scene.sensor, rate_hz=args.rate))
    tmp = Path(tempfile.mkdtemp(prefix="bag_memory_"))
    need = 3 * BYTES_PER_SAMPLE * scene.duration * args.rate  # the bag, its CSV tables, room
    if shutil.disk_usage(tmp).free < need:
        print(f"need {need / 2**30:.1f} GiB free in {tmp}", file=sys.stderr)
        shutil.rmtree(tmp)
        return 1
    exe = [sys.executable, "-m", "pendulum_accel.cli.main"]
    rows: list[dict[str, object]] = []
    try:
        if args.bag is None:
            bag = tmp / "bag"
            t0 = time.perf_counter()
            result = generate_bag(scene, bag)
            written = f"written in {time.perf_counter() - t0:.0f} s"
            messages, seconds = result.messages, result.sim_duration
        else:
            bag = args.bag
            held = read_bag(bag)
            written = "written before (--bag)"
            messages, seconds = held.message_count, held.duration_s
            del held
        size = sum(p.stat().st_size for p in bag.iterdir())
        commands = {
            "(floor: python importing the reader)": [
                sys.executable,
                "-c",
                "import pendulum_accel.bag.reader",
            ],
            "info": [*exe, "info", str(bag)],
            "analyze": [*exe, "analyze", str(bag)],
            "export --format parquet": [
                *exe,
                "export",
                str(bag),
                "--format",
                "parquet",
                "--out",
                str(tmp / "parquet"),
            ],
            "export --merged --format parquet": [
                *exe,
                "export",
                str(bag),
                "--merged",
                "--format",
                "parquet",
                "--out",
                str(tmp / "merged"),
            ],
            "export (CSV, a table per topic)": [*exe, "export", str(bag), "--out", str(tmp / "csv")],
            "export --no-smoothed (CSV)": [
                *exe,
                "export",
                str(bag),
                "--no-smoothed",
                "--out",
                str(tmp / "csv_raw"),
            ],
        }
        for name, command in commands.items():
            rss, wall, code = peak_rss(command)
            rows.append({"command": name, "rss_mib": rss, "wall_s": wall, "exit": code})
            print(f"{name}: {rss:.0f} MiB, {wall:.1f} s, exit {code}", flush=True)
    finally:
        if not args.keep:
            shutil.rmtree(tmp, ignore_errors=True)
    args.out.mkdir(parents=True, exist_ok=True)
    with (args.out / "bag_memory.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    lines = [
        f"Bag: {args.scene} at {args.rate:g} Hz, {seconds:.0f} s, {messages} messages, "
        f"{size / 2**30:.2f} GiB ({size / _MIB:.0f} MiB) on disk, {written}.",
        "",
        "| command | peak RSS (MiB) | RSS / bag size | wall (s) | exit |",
        "|---|---|---|---|---|",
    ]
    for row in rows:
        rss = float(row["rss_mib"])  # type: ignore[arg-type]
        lines.append(
            f"| {row['command']} | {rss:.0f} | {rss * _MIB / size:.2f} | {float(row['wall_s']):.1f} | "  # type: ignore[arg-type]
            f"{row['exit']} |"
        )
    (args.out / "bag_memory.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    png = report.bar_plot(
        args.out / "bag_memory.png",
        f"Peak RSS of each command on a {size / 2**30:.2f} GiB bag",
        [(str(row["command"]), float(row["rss_mib"])) for row in rows],  # type: ignore[arg-type]
        "peak RSS (MiB)",
        bound=(size / _MIB, "the bag's size (a command that held it would need this)"),
    )
    report.write_page(
        "bag_memory",
        "Bag commands' memory on a bag over 1 GiB",
        ["\n".join(lines)],
        [(png, "Peak resident memory of each command beside the bag's own size")],
        intro=__doc__ or "",
        docs=args.docs,
        argv=argv,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
