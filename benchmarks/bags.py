"""Bag benchmark: ``generate``, ``analyze`` and ``export`` throughput against plain rosbags loops, in one run.

    python -m benchmarks.bags [--out DIR] [--scene NAME] [--rates HZ ...] [--duration S] [--repeat N]

Every task runs at each rate of ``--rates`` (default 100 Hz and 1 kHz), on its own bag.

1. generate: a scene at that rate with every topic of the chain, simulated, estimated and written;
   messages/s and × real time, per phase. Then the write alone: the bag's messages, already
   serialised, written again by ``write_chain_bag`` (chunk, data section and summary CRCs included),
   uncompressed and zstd; MB/s of file written.
2. analyze: ``analyze_bag`` on that bag (read, bulk decode, re-run the estimator, metrics) with each
   estimator, and our reader alone, against a plain rosbags ``Reader.messages()`` +
   ``deserialize_cdr`` loop over the same bag. Best of ``--repeat`` runs each. Beside each analyze
   row: the estimator pass alone in µs per angle (``estimate_batch`` on the bag's angles, with the
   options analyze uses), and the read and metrics in µs per angle (``analyze --estimator instant``,
   whose pass is a few ns an angle, over the angles).
3. export: ``export_bag`` to Parquet (one table per topic, and merged) against the loop an analyst
   writes today: rosbags ``Reader.messages()`` + ``deserialize_cdr``, each message flattened into a
   dict, one pandas DataFrame per topic, written to Parquet.

Writes bags.csv, bags.md and bags.png (each task against its plain loop) into the output directory
(default out/bench) and prints the table.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from rosbags.rosbag2 import Reader

from benchmarks import report
from pendulum_accel import analyze_bag, estimate_batch, generate_bag, load_scene, read_bag
from pendulum_accel.bag.cdr_layout import rows_from_bytes
from pendulum_accel.bag.export import export_bag
from pendulum_accel.bag.messages import (
    ACCEL_STAMPED,
    JOINT_STATE,
    TOPIC_ACCEL_TRUTH,
    TOPIC_JOINT_STATES,
    TYPESTORE,
)
from pendulum_accel.bag.writer import Stream
from pendulum_accel.estimators import DEFAULT_ESTIMATOR, ESTIMATORS
from pendulum_accel.recording.contract import angle_field, require_angles
from pendulum_accel.recording.generate import write_chain_bag
from pendulum_accel.recording.settings import estimator_options
from pendulum_accel.scene import Scene


@dataclasses.dataclass(frozen=True)
class Row:
    """One benchmark line: what ran, messages handled, best wall time, and the derived rates."""

    task: str
    messages: int
    seconds: float
    sim_seconds: float
    baseline_seconds: float | None = None
    megabytes: float | None = None
    """MB of file written, for the write rows."""
    pass_us: float | None = None
    """µs per angle of an analyze row's estimator pass alone: estimate_batch on the bag's angles with the
    options analyze uses, best of the runs, over the angles. The cost per sample the read is set beside
    (the difference of two analyze times drowned in a noisy machine's scatter)."""
    read_us: float | None = None
    """µs per angle of the read and the metrics, beside an analyze row's pass: analyze --estimator instant
    (its pass costs a few ns an angle) over the angles, at the row's rate."""
    rate_hz: float | None = None
    """The sensor rate of the bag the row ran on."""

    @property
    def mb_per_s(self) -> float | None:
        """MB written / s, for the write rows."""
        return None if self.megabytes is None else self.megabytes / self.seconds

    @property
    def rate(self) -> float:
        """messages / s."""
        return self.messages / self.seconds if self.seconds > 0 else float("inf")

    @property
    def realtime(self) -> float:
        """sim seconds per wall second (× real time)."""
        return self.sim_seconds / self.seconds if self.seconds > 0 else float("inf")

    @property
    def speedup(self) -> float | None:
        """baseline time / this time, for rows compared with the plain rosbags loop."""
        return None if self.baseline_seconds is None else self.baseline_seconds / self.seconds


def best_of(repeat: int, fn: Callable[[], Any]) -> tuple[float, Any]:
    """(smallest wall time over ``repeat`` calls, last result)."""
    best = float("inf")
    result: Any = None
    for _ in range(repeat):
        t0 = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - t0)
    return best, result


def plain_rosbags_loop(path: Path) -> int:
    """Baseline: every message through rosbags' Reader and typestore.deserialize_cdr; returns the count."""
    count = 0
    with Reader(path) as reader:
        for conn, _, raw in reader.messages():
            TYPESTORE.deserialize_cdr(raw, conn.msgtype)
            count += 1
    return count


def _flat(value: Any, path: str, out: dict[str, Any]) -> None:
    """out[a.b[i]] = every numeric or string leaf of a rosbags message (the loop's hand-written flattener)."""
    if hasattr(value, "__dataclass_fields__"):
        for name in value.__dataclass_fields__:
            if name != "__msgtype__" and not name.isupper():
                _flat(getattr(value, name), f"{path}.{name}" if path else name, out)
    elif isinstance(value, (list, tuple)) or getattr(value, "ndim", 0) == 1:
        for i, item in enumerate(value):
            _flat(item, f"{path}[{i}]", out)
    else:
        out[path] = value


def plain_rosbags_to_pandas(path: Path, out: Path) -> int:
    """Baseline for export: rosbags read + deserialize, flatten each message, DataFrame per topic, Parquet."""
    import pandas as pd

    rows: dict[str, list[dict[str, Any]]] = {}
    with Reader(path) as reader:
        for conn, log_time, raw in reader.messages():
            row: dict[str, Any] = {"log_time": log_time * 1e-9}
            _flat(TYPESTORE.deserialize_cdr(raw, conn.msgtype), "", row)
            rows.setdefault(conn.topic, []).append(row)
    out.mkdir(parents=True, exist_ok=True)
    for topic, records in rows.items():
        pd.DataFrame.from_records(records).to_parquet(out / f"{topic.strip('/').replace('/', '__')}.parquet")
    return sum(len(r) for r in rows.values())


def bag_angles(path: Path) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """(t, θ) of the bag as analyze reads them: its angle topic's stamps and angle column (angle_field), in
    stamp order."""
    bag = read_bag(path)
    field = angle_field(bag)
    js = bag.decode(require_angles(bag), JOINT_STATE, ["header.stamp.sec", "header.stamp.nanosec", field])
    order = np.argsort(js.stamp, kind="stable")
    return js.stamp[order], js[field][order]


def our_read_decode(path: Path) -> int:
    """Our reader: scan the file and bulk-decode the two topics analyze needs; returns messages read."""
    bag = read_bag(path)
    bag.decode(TOPIC_JOINT_STATES, JOINT_STATE)
    bag.decode(TOPIC_ACCEL_TRUTH, ACCEL_STAMPED)
    return bag.message_count


def bag_streams(path: Path) -> tuple[list[Stream], dict[str, str]]:
    """The bag's messages as write_sorted streams (fixed-size topics as (n, size) rows), its custom_data."""
    bag = read_bag(path)
    streams = []
    for topic in bag.topics:
        times, payloads = bag.raw(topic)
        fixed = len({len(p) for p in payloads}) == 1
        streams.append(Stream(topic, times, rows_from_bytes(payloads) if fixed else payloads))
    return streams, bag.custom_data


def write_rows(path: Path, folder: Path, repeat: int, sim: float) -> list[Row]:
    """Write the messages of bag ``path`` again, uncompressed and zstd: best time and MB/s of each."""
    streams, custom = bag_streams(path)
    n = sum(s.log_time_ns.size for s in streams)
    rows = []
    for compression in ("", "zstd"):
        out = folder / f"rewrite_{compression or 'none'}"

        def write(out: Path = out, compression: str = compression) -> None:
            """One write of the whole bag."""
            write_chain_bag(out, streams, custom_data=custom, overwrite=True, compression=compression)

        seconds, _ = best_of(repeat, write)
        size = sum(f.stat().st_size for f in out.iterdir()) / 1e6
        label = f"write bag only, {compression or 'uncompressed'} (CRCs included)"
        rows.append(Row(label, n, seconds, sim, megabytes=size))
    return rows


def scene_at_rate(name: str, rate_hz: float, duration: float) -> Scene:
    """Bundled scene ``name`` with its sensor at ``rate_hz`` and its length set to ``duration`` s."""
    scene = load_scene(name)
    sensor = dataclasses.replace(scene.sensor, rate_hz=float(rate_hz))
    return dataclasses.replace(scene, sensor=sensor, duration=float(duration))


def run_benchmark(scene_name: str, rate_hz: float, duration: float, repeat: int, folder: Path) -> list[Row]:
    """All rows of the benchmark for one scene at one rate, writing its bag under ``folder``."""
    scene = scene_at_rate(scene_name, rate_hz, duration)
    bag_path = folder / "bench_bag"
    results = []
    for _ in range(repeat):
        results.append(generate_bag(scene, bag_path, overwrite=True))
    gen = min(results, key=lambda r: r.wall_s)
    sim = gen.sim_duration
    n = gen.messages
    rows = [
        Row("generate: total (simulate + estimate + write)", n, gen.wall_s, sim),
        Row("generate: simulate (run_scene)", n, gen.simulate_s, sim),
        Row("generate: estimate (estimate_batch)", n, gen.estimate_s, sim),
        Row("generate: serialise + write bag", n, gen.write_s, sim),
        *write_rows(bag_path, folder, repeat, sim),
    ]
    base_s, base_n = best_of(repeat, lambda: plain_rosbags_loop(bag_path))
    rows.append(Row("plain rosbags read + deserialize loop", base_n, base_s, sim, base_s))
    read_s, read_n = best_of(repeat, lambda: our_read_decode(bag_path))
    rows.append(Row("our reader: scan + bulk decode", read_n, read_s, sim, base_s))
    t, theta = bag_angles(bag_path)
    analyze_s = {
        name: best_of(repeat, lambda name=name: analyze_bag(bag_path, estimator=name))[0]  # type: ignore[misc]
        for name in ESTIMATORS
    }
    read_us = analyze_s["instant"] / t.size * 1e6
    for name in ESTIMATORS:
        label = f"analyze --estimator {name}" + (" (default)" if name == DEFAULT_ESTIMATOR else "")
        options = estimator_options(scene, name)
        pass_s, _ = best_of(
            repeat,
            lambda name=name, options=options: estimate_batch(name, t, theta, **options),  # type: ignore[misc]
        )
        rows.append(
            Row(label, n, analyze_s[name], sim, base_s, pass_us=pass_s / t.size * 1e6, read_us=read_us)
        )
    pandas_s, pandas_n = best_of(repeat, lambda: plain_rosbags_to_pandas(bag_path, folder / "plain_tables"))
    rows.append(Row("plain rosbags loop -> pandas -> Parquet", pandas_n, pandas_s, sim, pandas_s))
    for merged in (False, True):
        label = "export --format parquet" + (" --merged" if merged else " (one table per topic)")
        ex_s, _ = best_of(
            repeat,
            lambda merged=merged: export_bag(  # type: ignore[misc]
                read_bag(bag_path), folder / "tables", fmt="parquet", merged=merged
            ),
        )
        rows.append(Row(label, n, ex_s, sim, pandas_s))
    return [dataclasses.replace(row, rate_hz=float(rate_hz)) for row in rows]


def _fmt(value: float | None, spec: str) -> str:
    """Format a number, '' for None."""
    return "" if value is None else format(value, spec)


def table(rows: Sequence[Row]) -> list[list[str]]:
    """Header + formatted rows."""
    out = [
        [
            "task",
            "messages",
            "wall s",
            "msg/s",
            "MB/s",
            "x real time",
            "x its plain rosbags loop",
            "read + metrics, µs per angle",
            "estimator pass, µs per angle",
        ]
    ]
    for r in rows:
        out.append(
            [
                r.task,
                str(r.messages),
                f"{r.seconds:.4f}",
                f"{r.rate:,.0f}",
                _fmt(r.mb_per_s, ".0f"),
                f"{r.realtime:.0f}",
                _fmt(r.speedup, ".1f"),
                _fmt(r.read_us, ".2f"),
                _fmt(r.pass_us, ".2f"),
            ]
        )
    return out


def by_rate(rows: Sequence[Row]) -> dict[float | None, list[Row]]:
    """The rows of each rate, in the order the rates ran."""
    out: dict[float | None, list[Row]] = {}
    for r in rows:
        out.setdefault(r.rate_hz, []).append(r)
    return out


def text_table(cells: Sequence[Sequence[str]]) -> list[str]:
    """Lines of ``cells`` in aligned columns (the first left-aligned, the others right)."""
    widths = [max(len(row[i]) for row in cells) for i in range(len(cells[0]))]
    return [
        "  ".join(
            cell.ljust(w) if i == 0 else cell.rjust(w)
            for i, (cell, w) in enumerate(zip(row, widths, strict=True))
        )
        for row in cells
    ]


ANALYZE_TARGET = 10.0
"""× a plain rosbags loop that analyze is to reach for every estimator (issue 33), drawn beside the rows."""


def plot(rows: Sequence[Row], out: Path) -> Path:
    """bags.png: each row compared with a plain rosbags loop, its speed-up (log), and ANALYZE_TARGET."""
    bars = [
        (r.task if r.rate_hz is None else f"{r.task}, {r.rate_hz:g} Hz", r.speedup)
        for r in rows
        if r.speedup is not None and r.baseline_seconds != r.seconds
    ]
    return report.bar_plot(
        out,
        "Speed-up over the plain rosbags loop doing the same work",
        [(task, float(speedup)) for task, speedup in bars if speedup is not None],
        "× its plain rosbags loop",
        bound=(ANALYZE_TARGET, f"analyze target {ANALYZE_TARGET:g}×"),
        log=True,
    )


def write_outputs(rows: Sequence[Row], header: str, out: Path) -> list[Path]:
    """bags.csv and bags.md into ``out``."""
    out.mkdir(parents=True, exist_ok=True)
    csv_path, md_path = out / "bags.csv", out / "bags.md"
    with csv_path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(
            [
                "task",
                "messages",
                "seconds",
                "messages_per_s",
                "mb_per_s",
                "x_realtime",
                "x_plain_rosbags",
                "read_us_per_angle",
                "pass_us_per_angle",
                "rate_hz",
            ]
        )
        for r in rows:
            writer.writerow(
                [
                    r.task,
                    r.messages,
                    f"{r.seconds:.6f}",
                    f"{r.rate:.1f}",
                    _fmt(r.mb_per_s, ".1f"),
                    f"{r.realtime:.2f}",
                    _fmt(r.speedup, ".3f"),
                    _fmt(r.read_us, ".3f"),
                    _fmt(r.pass_us, ".3f"),
                    _fmt(r.rate_hz, "g"),
                ]
            )
    lines = [header]
    for rate, group in by_rate(rows).items():
        cells = table(group)
        lines += ["", f"At {rate:g} Hz:" if rate is not None else "", ""]
        lines += ["| " + " | ".join(cells[0]) + " |", "|" + "---|" * len(cells[0])]
        lines += ["| " + " | ".join(c) + " |" for c in cells[1:]]
    md_path.write_text("\n".join(lines) + "\n")
    return [csv_path, md_path]


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark, print the table, write bags.csv and bags.md."""
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bags", description=__doc__.split("\n")[0])
    parser.add_argument(
        "--out", type=Path, default=Path("out/bench"), help="output directory (default out/bench)"
    )
    parser.add_argument(
        "--scene", default="lecture_constant", help="bundled scene (default lecture_constant)"
    )
    parser.add_argument(
        "--rates",
        type=report.positive,
        nargs="+",
        default=[100.0, 1000.0],
        metavar="HZ",
        help="sensor rates in Hz, a bag each (default 100 1000)",
    )
    parser.add_argument(
        "--duration", type=report.positive, default=60.0, help="scene length in s (default 60)"
    )
    parser.add_argument("--repeat", type=report.count, default=3, help="runs per task, best kept (default 3)")
    report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    rows: list[Row] = []
    for rate in args.rates:
        with tempfile.TemporaryDirectory(prefix="pendulum_accel_bench_") as folder:
            rows += run_benchmark(args.scene, rate, args.duration, args.repeat, Path(folder))
    rates = " and ".join(f"{rate:g} Hz" for rate in args.rates)
    header = (
        f"Bag benchmark: scene {args.scene} at {rates}, {args.duration:g} s of sim time each, "
        f"all topics; best of {args.repeat} runs."
    )
    print(header)
    for rate, group in by_rate(rows).items():
        print(f"\nAt {rate:g} Hz:")
        print("\n".join(text_table(table(group))))
    paths = write_outputs(rows, header, args.out)
    paths.append(plot(rows, args.out / "bags.png"))
    paths.append(
        report.write_page(
            "bags", "Bags: generate, analyze and export throughput", [paths[1].read_text()],
            [(paths[2], "Each read, analyze and export against its plain rosbags loop (× faster)")],
            intro=__doc__ or "", docs=args.docs, argv=argv,
        )
    )  # fmt: skip
    for path in paths:
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
