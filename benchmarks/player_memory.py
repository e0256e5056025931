"""Player memory benchmark: the streaming player's RSS while it reads a ≥ 1 GB bag, and its seek time.

    python -m benchmarks.player_memory [--out DIR] [--gib G] [--keep]

1. Writes a bag of ``--gib`` GiB (default 1.05) in a temporary directory with the project's writer
   (``BagWriter.write_sorted``): JointState and AccelStamped rows of a 1 kHz chain, repeated in
   time, 1 MiB chunks. Checks the free disk space first; the bag is deleted at the end unless --keep.
2. In a fresh process, opens the bag as the player does (``player_node.open_source`` and
   ``StreamTimeline``: the MCAP chunk index, one chunk decoded at a time) and takes every message
   in order, sampling the RSS (/proc/self/statm) every 100 000 messages; then seeks to 20 targets
   spread over the bag and times each (the seek re-reads one chunk and counts the index records).
   "RSS start" is the process after importing the player (rclpy, numpy, numba...): the streaming
   itself adds the difference to "max".

Writes player_memory.csv and player_memory.md into the output directory (default out/bench).
No ROS graph is involved: the node's publishing adds a constant, not a size-dependent, amount.
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks import report
from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.cdr_layout import Layout
from pendulum_accel.bag.writer import BagWriter, Stream

_PAGE = os.sysconf("SC_PAGE_SIZE")
_MIB = 2**20


def rss_mib() -> float:
    """Resident set size of this process, MiB (/proc/self/statm, second field × page size)."""
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * _PAGE / _MIB


def write_bag(path: Path, gib: float) -> tuple[int, float]:
    """A bag of about ``gib`` GiB of 1 kHz JointState + AccelStamped: (messages, bytes on disk)."""
    joint = Layout.of(bm.joint_state(0, [bm.PENDULUM_JOINT], [0.0], [0.0]), bm.JOINT_STATE)
    truth = Layout.of(bm.accel_stamped(0, 0.0), bm.ACCEL_STAMPED)
    block = 200_000  # samples per write: bounded memory while writing too
    per_sample = joint.size + truth.size + 2 * 31  # payloads + message record headers
    samples = int(gib * 2**30 / per_sample)
    written = 0
    with BagWriter(path, overwrite=True) as writer:
        writer.add_topic(bm.TOPIC_JOINT_STATES, bm.JOINT_STATE)
        writer.add_topic(bm.TOPIC_ACCEL_TRUTH, bm.ACCEL_STAMPED)
        for start in range(0, samples, block):
            n = min(block, samples - start)
            ns = (np.arange(start, start + n, dtype=np.int64) + 1) * 1_000_000  # 1 kHz
            sec, nanosec = bm.split_stamp(ns)
            stamp = {"header.stamp.sec": sec, "header.stamp.nanosec": nanosec}
            theta = 0.1 * np.sin(ns * 1e-9)
            rows_j = joint.encode(n, {**stamp, "position[0]": theta, "velocity[0]": np.cos(ns * 1e-9)})
            rows_t = truth.encode(n, {**stamp, "accel.linear.x": np.full(n, 3.0)})
            writer.write_sorted(
                [Stream(bm.TOPIC_JOINT_STATES, ns, rows_j), Stream(bm.TOPIC_ACCEL_TRUTH, ns, rows_t)]
            )
            written += 2 * n
    size = sum(p.stat().st_size for p in path.iterdir())
    return written, float(size)


def measure(path: str) -> dict[str, object]:
    """Child process body: stream every message as the player does, sampling RSS; then time seeks."""
    from pendulum_accel.nodes.player_node import StreamTimeline, open_source

    base = rss_mib()
    source = open_source(path)
    from pendulum_accel.bag.stream import StreamedBag

    assert isinstance(source, StreamedBag), "the bag must have a chunk index"
    topics = list(source.topics)
    t0 = time.perf_counter()
    timeline = StreamTimeline(source, topics, source.start_ns, source.end_ns)
    open_s = time.perf_counter() - t0
    samples: list[tuple[int, float]] = [(0, rss_mib())]
    n = 0
    t0 = time.perf_counter()
    while timeline.peek_ns() is not None:
        timeline.take()
        n += 1
        if n % 100_000 == 0:
            samples.append((n, rss_mib()))
    read_s = time.perf_counter() - t0
    samples.append((n, rss_mib()))
    seeks = []
    for target in np.linspace(source.start_ns, source.end_ns, 20)[::-1]:  # backwards: the worst order
        t0 = time.perf_counter()
        timeline.seek(int(target))
        timeline.peek_ns()
        seeks.append(time.perf_counter() - t0)
    rss = [r for _, r in samples]
    return {
        "messages": n,
        "size_expected": timeline.size,
        "rss_start_mib": base,
        "rss_min_mib": min(rss),
        "rss_max_mib": max(rss),
        "rss_first_tenth_mib": max(r for i, r in samples if i <= n // 10),
        "open_s": open_s,
        "read_s": read_s,
        "messages_per_s": n / read_s if read_s > 0 else 0.0,
        "seek_median_ms": 1e3 * float(np.median(seeks)),
        "seek_max_ms": 1e3 * float(np.max(seeks)),
        "chunks": len(source.chunks),
        "rss_samples": samples,
    }


def main(argv: list[str] | None = None) -> int:
    """Write the bag, measure in a child process, write the table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("out/bench"))
    parser.add_argument(
        "--gib", type=report.positive, default=1.05, help="bag size to write, GiB (default 1.05)"
    )
    parser.add_argument("--keep", action="store_true", help="keep the bag")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    if args.child:
        print(json.dumps(measure(args.child)))
        return 0
    tmp = Path(tempfile.mkdtemp(prefix="player_memory_"))
    free = shutil.disk_usage(tmp).free
    if free < 2.5 * args.gib * 2**30:
        print(f"need {2.5 * args.gib:.1f} GiB free in {tmp}, have {free / 2**30:.1f}", file=sys.stderr)
        return 1
    try:
        bag = tmp / "big"
        t0 = time.perf_counter()
        written, size = write_bag(bag, args.gib)
        write_s = time.perf_counter() - t0
        child = subprocess.run(
            [sys.executable, "-m", "benchmarks.player_memory", "--child", str(bag)],
            capture_output=True,
            text=True,
            check=True,
        )
        result = json.loads(child.stdout.strip().splitlines()[-1])
    finally:
        if not args.keep:
            shutil.rmtree(tmp, ignore_errors=True)
    result.update({"bag_gib": size / 2**30, "written": written, "write_s": write_s})
    args.out.mkdir(parents=True, exist_ok=True)
    samples = result.pop("rss_samples")
    with (args.out / "player_memory.csv").open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(list(result))
        w.writerow(list(result.values()))
    lines = [
        "| bag | messages | chunks | RSS start → max (MiB) | RSS after 1/10 | read | seek median / max |",
        "|---|---|---|---|---|---|---|",
        f"| {result['bag_gib']:.2f} GiB | {result['messages']} | {result['chunks']} | "
        f"{result['rss_start_mib']:.0f} → {result['rss_max_mib']:.0f} | "
        f"{result['rss_first_tenth_mib']:.0f} | "
        f"{result['read_s']:.0f} s ({result['messages_per_s'] / 1e6:.2f} M msg/s) | "
        f"{result['seek_median_ms']:.0f} / {result['seek_max_ms']:.0f} ms |",
    ]
    (args.out / "player_memory.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    plot = plot_rss(samples, args.out / "player_memory.png")
    report.write_page(
        "player_memory",
        "Player memory: RSS and seek time on a bag over 1 GiB",
        ["\n".join(lines)],
        [(plot, "the player's resident memory against the messages read")],
        intro=__doc__ or "",
        docs=args.docs,
        argv=argv,
    )
    return 0


def plot_rss(samples: list[tuple[int, float]], path: Path) -> Path:
    """RSS (MiB) against messages read: flat when the player streams."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.5))
    ax.plot([n / 1e6 for n, _ in samples], [r for _, r in samples], marker=".")
    ax.set_xlabel("messages read (millions)")
    ax.set_ylabel("RSS (MiB)")
    ax.set_ylim(bottom=0)
    ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


if __name__ == "__main__":
    raise SystemExit(main())
