"""Chain benchmark: the live ROS 2 chain at several sensor rates, and as fast as possible.

    python -m benchmarks.chain [--rates HZ ...] [--duration S] [--fast-duration S]
                                         [--rt-priority N] [--ceiling-messages N] [--out DIR]

For each rate, the launcher runs simulator, estimator and recorder (separate processes, real-time
pacing, recording on) on ``lecture_constant`` while a listener in this process time-stamps every
angle and every estimate on arrival with one monotonic clock. Reported per rate:

* lost: angles, estimates and Imu messages the recorder did not write, against the scene's sample count;
* latency: estimate arrival − arrival of the angle it was computed from (median, p99), i.e. the
  estimator's turnaround including one DDS hop each way, as seen by a fourth process;
* simulator pacing jitter (p99 of publish − due) and real-time factor, from its log;
* CPU of each node (% of one core, from /proc/<pid>/stat) while data flows.

Then 1 kHz once more with every node at SCHED_FIFO priority N (``pendulum-accel run --rt-priority N``,
default 20), and the same chain as fast as possible at 1 kHz with recording, as ``pendulum-accel run
--fast`` runs it (no listener: latency means nothing there): its real-time factor, losses and CPU.
First, the machine's own floor: the lateness of a bare 1 kHz sleep loop. Last, the bare-rclpy
ceiling (``benchmarks.bare_rclpy``): a plain JointState publisher and subscriber on this machine, with
and without a recorder, in messages per second, beside the chain's samples and recorded messages per
second; CPU is also given in µs per sample (per message for the ceiling), the figure the arithmetic of
the chain's ceiling is made of.
Benchmarks measure; tests never assert on time.
"""

from __future__ import annotations

import argparse
import gc
import re
import tempfile
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmarks import bare_rclpy, report
from benchmarks.bare_rclpy import Ceiling, cpu_seconds

SCENE = "lecture_constant"
RATES = (100, 1000, 5000, 10000)
LISTENER_NODE = "chain_bench_listener"
ROLES = ("simulator", "estimator", "recorder")


@dataclass
class Result:
    """One chain run: counts, latencies (s), jitter/factor from the simulator's log, CPU % per node."""

    mode: str
    rate_hz: float
    duration: float
    expected: int
    angles_written: int
    estimates_written: int
    imu_written: int
    latency: np.ndarray
    jitter_p99_us: float | None
    real_time_factor: float | None
    cpu: dict[str, float] = field(default_factory=dict)
    exit_code: int = 0
    messages_written: int = 0  # every message of the bag, all topics

    @property
    def samples_per_second(self) -> float | None:
        """rate × real-time factor: the samples the chain moved per second of wall time."""
        return None if self.real_time_factor is None else self.rate_hz * self.real_time_factor

    def cpu_us_per_sample(self, role: str) -> float:
        """CPU µs per sample of one node: (CPU % / 100) / (samples per second) · 1e6 (NaN when unknown)."""
        rate = self.samples_per_second
        if not rate or role not in self.cpu:
            return float("nan")
        return self.cpu[role] / 100.0 / rate * 1e6

    @property
    def lost(self) -> int:
        """Angles, estimates and Imu messages the bag lacks: 3 · expected − written."""
        return 3 * self.expected - self.angles_written - self.estimates_written - self.imu_written

    def row(self) -> list[str]:
        """Table cells."""
        lat = self.latency * 1e3
        med, p99 = (f"{np.median(lat):.2f}", f"{np.percentile(lat, 99):.2f}") if lat.size else ("-", "-")
        cpu = " / ".join(f"{self.cpu.get(role, float('nan')):.0f}" for role in ROLES)
        per_sample = " / ".join(f"{self.cpu_us_per_sample(role):.0f}" for role in ROLES)
        jitter = f"{self.jitter_p99_us:.0f}" if self.jitter_p99_us is not None else "-"
        factor = f"{self.real_time_factor:.2f}" if self.real_time_factor is not None else "-"
        return [
            self.mode,
            f"{self.rate_hz:g}",
            f"{self.duration:g}",
            str(self.expected),
            str(self.lost),
            med,
            p99,
            jitter,
            factor,
            cpu,
            per_sample,
        ]


def plot(results: Sequence[Result], out: Path) -> Path:
    """chain.png: per live run (those with a listener), the estimate's latency from median to p99 (ms, log),
    beside its sample period 1/rate, the bound a chain that keeps up stays under."""
    timed = [r for r in results if r.latency.size]
    fig, ax = report.new_axes(8.0, 0.5 * len(timed) + 1.8)
    for k, r in enumerate(timed):
        lat = r.latency * 1e3
        med, p99 = float(np.median(lat)), float(np.percentile(lat, 99))
        ax.plot(
            [med, p99], [k, k], "-", color="tab:blue", lw=3, label="latency median … p99" if k == 0 else None
        )
        ax.plot([med], [k], "o", color="tab:blue")
        ax.plot(
            [1e3 / r.rate_hz],
            [k],
            "|",
            color="tab:red",
            ms=16,
            mew=2,
            label="sample period" if k == 0 else None,
        )
    ax.set_yticks(range(len(timed)), [f"{r.mode}, {r.rate_hz:g} Hz" for r in timed], fontsize=8)
    ax.invert_yaxis()
    ax.set_xscale("log")
    ax.set_xlabel("ms")
    ax.set_title("Estimate arrival − angle arrival, as a fourth process sees them", fontsize=10)
    ax.grid(True, axis="x", which="both", alpha=0.3)
    if timed:
        ax.legend(fontsize=8, loc="lower right")
    return report.save_figure(fig, out)


HEADER = [
    "mode",
    "rate Hz",
    "scene s",
    "samples",
    "lost",
    "latency median ms",
    "latency p99 ms",
    "jitter p99 µs",
    "real-time factor",
    "CPU % sim / est / rec",
    "CPU µs/sample sim / est / rec",
]


def fast_run(results: Sequence[Result]) -> Result | None:
    """The as-fast-as-possible run (the last of them), if it gave a real-time factor."""
    runs = [r for r in results if r.mode == "as fast as possible" and r.samples_per_second]
    return runs[-1] if runs else None


def ceiling_plot(results: Sequence[Result], ceilings: Sequence[Ceiling], out: Path) -> Path:
    """chain_2.png: each bare-rclpy case's messages per second beside the chain as fast as possible (its
    samples and its recorded messages per second), and the 10x-real-time line of the 1 kHz chain."""
    bars = [(f"bare rclpy: {c.case}, messages", c.rate) for c in ceilings]
    fast = fast_run(results)
    if fast is not None and fast.samples_per_second:
        per_sample = fast.messages_written / fast.expected
        bars += [
            (f"chain, fast {fast.rate_hz:g} Hz: samples", fast.samples_per_second),
            (f"chain, fast {fast.rate_hz:g} Hz: recorded messages", fast.samples_per_second * per_sample),
        ]
    return report.bar_plot(
        out,
        "Bare-rclpy ceiling (JointState, this machine) beside the chain as fast as possible",
        bars,
        "per second",
        bound=(10 * 1000.0, "10x real time at 1 kHz (samples/s)"),
    )


def comparison(results: Sequence[Result], ceilings: Sequence[Ceiling]) -> str:
    """One paragraph: the chain's samples and recorded messages per second beside the bare pair's."""
    fast = fast_run(results)
    if fast is None or not ceilings or fast.samples_per_second is None:
        return "No as-fast-as-possible run gave a real-time factor: nothing to set beside the ceiling."
    rate = fast.samples_per_second
    per_sample = fast.messages_written / fast.expected
    pair = ceilings[0]
    recorded = [c for c in ceilings if c.case == "pair + recorder"]
    line = (
        f"As fast as possible at {fast.rate_hz:g} Hz the chain moved {rate:,.0f} samples/s, "
        f"{rate * per_sample:,.0f} recorded messages/s ({per_sample:.2f} messages per sample reach the "
        f"recorder; the estimator takes 1 and publishes 2). The bare pair moves {pair.rate:,.0f} "
        f"JointState messages/s ({pair.rate / rate:.1f}x the chain's samples)"
    )
    if recorded:
        rec = recorded[0]
        line += (
            f", {rec.rate:,.0f} with the recorder on it too ({rec.rate / rate:.1f}x the chain's samples, "
            f"{rec.rate / (rate * per_sample):.2f}x its recorded messages)"
        )
    total = sum(fast.cpu_us_per_sample(role) for role in ROLES)
    return line + f". Per sample the chain's three nodes spent {total:.0f} µs of CPU in all."


def markdown(rows: Sequence[Sequence[str]]) -> str:
    """A markdown table with HEADER."""
    lines = ["| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)]
    lines += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(lines)


class CpuSampler:
    """Per-child CPU use between the first data and the child's last sample before it stops."""

    def __init__(self) -> None:
        """No child sampled yet."""
        self.first: dict[str, tuple[float, float]] = {}
        self.last: dict[str, tuple[float, float]] = {}
        self.active = threading.Event()
        self.stop = threading.Event()

    def run(self, chain: object) -> None:
        """Thread body: every 0.1 s, read each running child's CPU time once data flows."""
        while not self.stop.wait(0.1):
            if not self.active.is_set():
                continue
            for child in list(getattr(chain, "children", [])):
                if child.expected_exit or child.process.poll() is not None:
                    continue
                used = cpu_seconds(child.pid)
                if used is None:
                    continue
                now = time.monotonic()
                self.first.setdefault(child.role, (now, used))
                self.last[child.role] = (now, used)

    def percent(self) -> dict[str, float]:
        """{role: 100 · ΔCPU / Δwall}."""
        out = {}
        for role, (t0, c0) in self.first.items():
            t1, c1 = self.last[role]
            if t1 > t0:
                out[role] = 100.0 * (c1 - c0) / (t1 - t0)
        return out


def _log_figures(text: str) -> tuple[float | None, float | None]:
    """(jitter p99 µs, real-time factor) from the simulator's log lines; the factor is simulated seconds
    over wall seconds of its 'published …' line, which it prints to one decimal only (0.98 must show)."""
    jitter = re.search(r"jitter \(publish − due\): median \d+ µs, p99 (\d+) µs", text)
    span = re.search(r"\(([0-9.]+) s simulated\) in ([0-9.]+) s wall", text)
    factor = float(span.group(1)) / float(span.group(2)) if span and float(span.group(2)) > 0 else None
    return (float(jitter.group(1)) if jitter else None, factor)


class Listener:
    """A fourth process's view of the live chain: arrival times of angles and of the estimates made from them.

    Raw CDR subscriptions: the header stamp sits right after the 4-byte encapsulation header, and reading
    it with struct keeps this listener (a fourth Python process on two cores) from being the chain's
    slowest reliable reader, which would throttle the chain and inflate its own figures.
    """

    def __init__(self, sampler: CpuSampler) -> None:
        """Subscribe and start spinning in a thread; the sampler starts when the first angle arrives."""
        import rclpy
        from geometry_msgs.msg import AccelWithCovarianceStamped
        from rclpy.experimental import EventsExecutor
        from rclpy.node import Node
        from sensor_msgs.msg import JointState

        from pendulum_accel.nodes.qos import DATA_QOS
        from pendulum_accel.nodes.recorder_node import stamp_ns

        self._stamp_ns = stamp_ns
        self._sampler = sampler
        self._angle_arrival: dict[int, int] = {}
        self.latency: list[int] = []
        self._context = rclpy.Context()
        rclpy.init(context=self._context)
        self._node = Node(LISTENER_NODE, context=self._context)
        self._node.create_subscription(
            JointState, "/pendulum/joint_states", self._on_angle, DATA_QOS, raw=True
        )
        self._node.create_subscription(
            AccelWithCovarianceStamped, "/car/accel/estimate", self._on_estimate, DATA_QOS, raw=True
        )
        self._executor = EventsExecutor(context=self._context)
        self._executor.add_node(self._node)
        self._listening = threading.Event()
        self._listening.set()
        gc.freeze()  # as the nodes do (nodes.runtime): no collector pauses walking start-up objects
        self._spinner = threading.Thread(target=self._spin, daemon=True)
        self._spinner.start()

    def _on_angle(self, data: bytes) -> None:
        """Arrival time of an angle, by stamp."""
        self._angle_arrival[self._stamp_ns(data, 4)] = time.monotonic_ns()
        self._sampler.active.set()

    def _on_estimate(self, data: bytes) -> None:
        """latency += estimate arrival − its angle's arrival (ns)."""
        arrived = self._angle_arrival.get(self._stamp_ns(data, 4))
        if arrived is not None:
            self.latency.append(time.monotonic_ns() - arrived)

    def _spin(self) -> None:
        """Short spins until told to stop: shutting down an EventsExecutor inside spin() hangs it."""
        while self._listening.is_set():
            self._executor.spin_once(timeout_sec=0.05)

    def close(self) -> None:
        """Stop spinning, destroy the node, shut the context down."""
        import rclpy

        self._listening.clear()
        self._spinner.join()
        self._executor.shutdown()
        self._node.destroy_node()
        rclpy.try_shutdown(context=self._context)


def _start_on_log_line(sampler: CpuSampler, log: Path, marker: str) -> None:
    """Thread body: set sampler.active once ``marker`` appears in ``log`` (or the sampler stops)."""
    while not sampler.stop.wait(0.02):
        if log.exists() and marker in log.read_text(errors="replace"):
            sampler.active.set()
            return


def run_once(rate: float, duration: float, realtime: bool, folder: Path, rt_priority: int = 0) -> Result:
    """Run the chain once with a CPU sampler, and in real time with a latency listener; the figures.

    As fast as possible there is no listener: latency has no meaning when the simulator runs ahead of
    real time, and a fourth reader on two cores would slow the chain it measures. CPU is then sampled
    from the simulator's "publishing" log line on.
    """
    from pendulum_accel import apply_overrides, load_scene, read_bag
    from pendulum_accel.nodes.launcher import Chain, ChainConfig

    overrides = {"rate_hz": float(rate), "duration": float(duration)}
    expected = apply_overrides(load_scene(SCENE), overrides).sensor.sample_count(duration)
    sampler = CpuSampler()
    listener = Listener(sampler) if realtime else None
    # The chain waits for the listener by name too: an estimate sent before a reader has matched
    # arrives only on a DDS resend (~100 ms later), which would show as start-up latency, not the chain's.
    listeners = [] if listener is None else [LISTENER_NODE]
    mode = "real time" if realtime else "as fast as possible"
    if realtime and rt_priority:
        mode += f", SCHED_FIFO {rt_priority}"
    bag = folder / f"{'rt' if realtime else 'fast'}_{int(rate)}_{rt_priority}"
    log = folder / f"{bag.name}.log"
    config = ChainConfig(
        scene=SCENE,
        record=bag,
        realtime=realtime,
        overrides=overrides,
        simulator_params={"reader_nodes": ["accel_estimator", *listeners]},
        estimator_params={"reader_nodes": listeners or [""]},
        rt_priority=rt_priority,
    )
    chain = Chain(config, log=False, output=log)
    threads = [threading.Thread(target=sampler.run, args=(chain,), daemon=True)]
    if listener is None:
        marker = "subscribers matched: publishing"
        threads.append(threading.Thread(target=_start_on_log_line, args=(sampler, log, marker), daemon=True))
    for thread in threads:
        thread.start()
    try:
        code = chain.run()
    finally:
        sampler.stop.set()
        for thread in threads:
            thread.join()
        if listener is not None:
            listener.close()
    counts = {name: info.count for name, info in read_bag(bag).topics.items()}
    text = log.read_text(errors="replace")
    jitter, factor = _log_figures(text)
    if "cannot take real-time priority" in text:
        mode += " (refused: normal priority)"
    return Result(
        mode=mode,
        rate_hz=rate,
        duration=duration,
        expected=expected,
        angles_written=counts.get("/pendulum/joint_states", 0),
        estimates_written=counts.get("/car/accel/estimate", 0),
        imu_written=counts.get("/imu/data_raw", 0),
        latency=np.asarray([] if listener is None else listener.latency, dtype=np.float64) * 1e-9,
        jitter_p99_us=jitter if realtime else None,
        real_time_factor=factor,
        cpu=sampler.percent(),
        exit_code=code,
        messages_written=sum(counts.values()),
    )


def sleep_loop_floor(rate: float = 1000.0, seconds: float = 2.0) -> tuple[float, float]:
    """(p99, max) lateness in ms of a bare Python loop sleeping to a ``rate`` schedule: this machine's floor.

    Nothing of the chain runs meanwhile; whatever this loop shows (VM steal, wake-up latency of an idle
    vCPU), every process of the chain suffers too, so the chain's p99 cannot be read below it.
    """
    n = int(rate * seconds)
    lateness = np.empty(n)
    start = time.perf_counter()
    for i in range(n):
        due = start + i / rate
        now = time.perf_counter()
        if due > now:
            time.sleep(due - now)
        lateness[i] = time.perf_counter() - due
    return float(np.percentile(lateness, 99) * 1e3), float(lateness.max() * 1e3)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the live chain at each rate, then as fast as possible at 1 kHz; print a markdown table."""
    parser = argparse.ArgumentParser(prog="python -m benchmarks.chain", description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--rates", type=report.positive, nargs="+", default=list(RATES), help="sensor rates, Hz"
    )
    parser.add_argument("--duration", type=report.positive, default=5.0, help="scene seconds per live run")
    parser.add_argument(
        "--fast-duration",
        type=report.positive,
        default=30.0,
        help="scene seconds of the as-fast-as-possible run",
    )
    parser.add_argument(
        "--rt-priority",
        type=int,
        default=20,
        help="SCHED_FIFO priority of the extra real-time 1 kHz run (0: no extra run)",
    )
    parser.add_argument(
        "--ceiling-messages",
        type=report.count,
        default=bare_rclpy.MESSAGES,
        help="messages per case of the bare-rclpy ceiling",
    )
    parser.add_argument("--out", type=Path, default=Path("out/bench"), help="output directory (out/bench)")
    report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    rows = []
    p99, worst = sleep_loop_floor()
    floor = (
        f"Machine floor: a bare 1 kHz Python sleep loop, nothing else running: "
        f"p99 lateness {p99:.2f} ms, max {worst:.2f} ms."
    )
    print(floor, flush=True)
    results: list[Result] = []
    with tempfile.TemporaryDirectory(prefix="pendulum_accel_bench_chain_") as tmp:
        runs = [(rate, args.duration, True, 0) for rate in args.rates]
        if args.rt_priority:
            runs.append((1000.0, args.duration, True, args.rt_priority))
        runs.append((1000.0, args.fast_duration, False, 0))
        for rate, duration, realtime, priority in runs:
            result = run_once(rate, duration, realtime, Path(tmp), priority)
            results.append(result)
            rows.append(result.row())
            print(
                " | ".join(rows[-1])
                + ("" if result.exit_code == 0 else f"  (chain exit {result.exit_code})"),
                flush=True,
            )
    table = markdown(rows)
    print()
    print(table)
    ceilings = []
    for case in bare_rclpy.CASES:
        with tempfile.TemporaryDirectory(prefix="pendulum_accel_bench_bare_") as tmp:
            ceilings.append(bare_rclpy.measure(case, args.ceiling_messages, Path(tmp)))
        print(" | ".join(ceilings[-1].row()), flush=True)
    ceiling = bare_rclpy.markdown([c.row() for c in ceilings])
    versus = comparison(results, ceilings)
    print(ceiling, versus, sep="\n\n")
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "chain.md").write_text("\n\n".join([table, floor, ceiling, versus]) + "\n")
    png = plot(results, args.out / "chain.png")
    png2 = ceiling_plot(results, ceilings, args.out / "chain_ceiling.png")
    page = report.write_page(
        "chain", "Live chain: losses, latency, jitter, CPU, and the bare-rclpy ceiling",
        [table, floor, "Bare-rclpy ceiling (`benchmarks.bare_rclpy`):", ceiling, versus],
        [(png, "Estimate latency per live run (median to p99) beside the sample period"),
         (png2, "Bare-rclpy messages per second beside the chain's samples and recorded messages")],
        intro=__doc__ or "", docs=args.docs, argv=argv,
    )  # fmt: skip
    print(f"wrote {page}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
