"""Soak benchmark: the live chain for a long run at 1 kHz with recording; losses, memory and CPU.

    python -m benchmarks.soak [--minutes M] [--rate HZ] [--out DIR]

The launcher runs simulator, estimator and recorder (separate processes, real-time pacing, recording
on) on ``lecture_constant`` for ``--minutes`` (default 10) at ``--rate`` (default 1000 Hz). Reported:

* per topic, published (the chain's accounting record in the bag: the simulator's and the estimator's
  own end-of-run counts) against recorded (the bag);
* the resident set size (VmRSS, /proc/<pid>/status) of each node sampled every 5 s from the first
  published sample on: first, last, max, and the least-squares slope over the second half (MiB per
  minute), which is what growth would show as once start-up allocations have settled;
* CPU of each node (% of one core) over the run.

Benchmarks measure; tests never assert on time.
"""

from __future__ import annotations

import argparse
import re
import tempfile
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmarks import report
from benchmarks.chain import CpuSampler, _start_on_log_line
from pendulum_accel import read_bag
from pendulum_accel.bag.reader import Bag
from pendulum_accel.nodes.accounting import CUSTOM_ACCOUNTING, Accounting

SCENE = "lecture_constant"
ROLES = ("simulator", "estimator", "recorder")
_RSS_PERIOD = 5.0  # s between memory samples


def rss_mib(pid: int) -> float | None:
    """VmRSS of a process in MiB (from /proc/<pid>/status); None once it is gone."""
    try:
        text = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return None
    match = re.search(r"^VmRSS:\s+(\d+) kB", text, re.MULTILINE)
    return int(match.group(1)) / 1024.0 if match else None


@dataclass
class RssSampler:
    """RSS of each child every _RSS_PERIOD s once data flows: role -> [(s since first sample, MiB)]."""

    active: threading.Event
    stop: threading.Event = field(default_factory=threading.Event)
    series: dict[str, list[tuple[float, float]]] = field(default_factory=dict)

    def run(self, chain: object) -> None:
        """Thread body: sample until told to stop (skipping children that are stopping)."""
        start: float | None = None
        while not self.stop.wait(0.2 if start is None else _RSS_PERIOD):
            if not self.active.is_set():
                continue
            now = time.monotonic()
            start = now if start is None else start
            for child in list(getattr(chain, "children", [])):
                if child.expected_exit or child.process.poll() is not None:
                    continue
                value = rss_mib(child.pid)
                if value is not None:
                    self.series.setdefault(child.role, []).append((now - start, value))


def growth_per_minute(points: Sequence[tuple[float, float]]) -> float:
    """Least-squares slope (MiB/min) of RSS over the second half of the run; 0 with < 3 points."""
    half = [p for p in points if p[0] >= points[-1][0] / 2] if points else []
    if len(half) < 3:
        return 0.0
    t, m = np.array(half).T
    return float(np.polyfit(t / 60.0, m, 1)[0])


def published_counts(bag: Bag) -> dict[str, int]:
    """Per topic, what the chain's nodes counted as published: the bag's accounting record."""
    accounting = Accounting.from_json(bag.custom_data.get(CUSTOM_ACCOUNTING, "{}"))
    counts = {topic: accounting.published(topic) for topic in bag.topics}
    return {topic: n for topic, n in counts.items() if n is not None}


def plot(series: dict[str, list[tuple[float, float]]], out: Path) -> Path:
    """soak.png: each node's RSS (MiB) against time since the first published sample, and the least-squares
    line over the second half (growth_per_minute's), the growth a leak would show."""
    fig, ax = report.new_axes(8.0, 4.5)
    for role in ROLES:
        points = series.get(role, [])
        if not points:
            continue
        t = np.array([p[0] for p in points]) / 60.0
        mib = np.array([p[1] for p in points])
        (line,) = ax.plot(t, mib, "-", lw=1.2, label=f"{role} ({growth_per_minute(points):+.3f} MiB/min)")
        half = t >= t[-1] / 2.0
        if half.sum() >= 2:
            slope, level = np.polyfit(t[half], mib[half], 1)
            ax.plot(t[half], slope * t[half] + level, "--", color=line.get_color(), lw=1)
    ax.set_xlabel("minutes since the first published sample")
    ax.set_ylabel("RSS (MiB)")
    ax.set_title("Resident memory per node (dashed: the second half's fitted slope)", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return report.save_figure(fig, out)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the chain once for the soak duration and print the tables."""
    from pendulum_accel.nodes.launcher import Chain, ChainConfig

    parser = argparse.ArgumentParser(prog="python -m benchmarks.soak", description=__doc__.split("\n\n")[0])
    parser.add_argument("--minutes", type=report.positive, default=10.0, help="scene minutes (10)")
    parser.add_argument("--rate", type=report.positive, default=1000.0, help="sensor rate, Hz (1000)")
    parser.add_argument("--out", type=Path, default=Path("out/bench"), help="output directory (out/bench)")
    report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    duration = args.minutes * 60.0
    cpu = CpuSampler()
    rss = RssSampler(cpu.active)
    with tempfile.TemporaryDirectory(prefix="pendulum_accel_soak_") as tmp:
        bag = Path(tmp) / "soak"
        log = Path(tmp) / "soak.log"
        config = ChainConfig(scene=SCENE, record=bag, overrides={"rate_hz": args.rate, "duration": duration})
        chain = Chain(config, log=False, output=log)
        threads = [
            threading.Thread(target=cpu.run, args=(chain,), daemon=True),
            threading.Thread(target=rss.run, args=(chain,), daemon=True),
            threading.Thread(
                target=_start_on_log_line, args=(cpu, log, "subscribers matched: publishing"), daemon=True
            ),
        ]
        for thread in threads:
            thread.start()
        wall = time.monotonic()
        try:
            code = chain.run()
        finally:
            cpu.stop.set()
            rss.stop.set()
            for thread in threads:
                thread.join()
        wall = time.monotonic() - wall
        bag_data = read_bag(bag)
        recorded = {name: info.count for name, info in bag_data.topics.items()}
        published = published_counts(bag_data)
    lines = [
        f"Soak: {SCENE}, {args.rate:g} Hz, {duration:g} s scene, real time, recording; "
        f"{wall:.0f} s wall, chain exit {code}.",
        "",
        "| topic | published | recorded | lost |",
        "|---|---|---|---|",
    ]
    lost_total = 0
    for name, count in recorded.items():
        sent = published.get(name)
        lost = "-" if sent is None else str(sent - count)
        lost_total += 0 if sent is None else sent - count
        lines.append(f"| {name} | {'-' if sent is None else sent} | {count} | {lost} |")
    lines += ["", "| node | RSS first MiB | RSS last MiB | RSS max MiB | slope, 2nd half MiB/min | CPU % |"]
    lines.append("|---|---|---|---|---|---|")
    percent = cpu.percent()
    for role in ROLES:
        points = rss.series.get(role, [])
        if not points:
            continue
        values = [m for _, m in points]
        lines.append(
            f"| {role} | {values[0]:.1f} | {values[-1]:.1f} | {max(values):.1f} | "
            f"{growth_per_minute(points):+.3f} | {percent.get(role, float('nan')):.0f} |"
        )
    lines += ["", f"lost in all: {lost_total} (topics with a published count)"]
    text = "\n".join(lines)
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "soak.md").write_text(text + "\n")
    png = plot(rss.series, args.out / "soak.png")
    page = report.write_page(
        "soak", "Soak: the live chain for minutes at 1 kHz", [text],
        [(png, "Resident memory of each node over the run, with the second half's fitted slope")],
        intro=__doc__ or "", docs=args.docs, argv=argv,
    )  # fmt: skip
    print(f"wrote {page}")
    series = ["t_s,role,rss_mib"] + [
        f"{t:.1f},{role},{m:.2f}" for role, points in rss.series.items() for t, m in points
    ]
    (args.out / "soak_rss.csv").write_text("\n".join(series) + "\n")
    return 0 if code == 0 and lost_total == 0 else 1


if __name__ == "__main__":
    raise SystemExit(main())
