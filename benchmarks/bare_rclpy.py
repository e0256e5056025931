"""The bare-rclpy ceiling under the live chain: a plain JointState publisher and subscriber on this machine.

    python -m benchmarks.bare_rclpy [--messages N]      (benchmarks.chain runs it and puts it on its page)

Separate processes with nothing of the chain in them but its transport: a talker publishes N JointState
messages, the simulator's own pre-serialised CDR rows, from a tight loop, to a raw subscriber; both use
the chain's QoS (reliable, keep-all), its Fast DDS profile (loopback and shared memory, 10 ms
heartbeat) and its executor (EventsExecutor). Three cases:

* pair: talker → listener, which only counts;
* pair + recorder: the same, with the chain's ``bag_recorder`` node recording the topic as well;
* listener writes the bag: the listener appends every message, as it arrives, to a ``BagWriter`` in
  the recorder's way (buffered, ``write_sorted`` once its flush interval is due) instead of only counting.

Messages per second = N / (the talker's first publish after the handshake → every reader acknowledged
the last and the listener took it); CPU of each process (from /proc, every thread) from that first
publish until every process has settled, µs per message. A chain
sample is several such messages (angle, truth, string, estimate, Imu, a tenth of a /clock), so the
chain's samples per second sit below these figures by design; the chain page says by how much.
"""

from __future__ import annotations

import argparse
import json
import os
import select
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

MESSAGES = 30000
CASES = ("pair", "pair + recorder", "listener writes the bag")
_CLK_TCK = os.sysconf("SC_CLK_TCK")
_WAIT = 60.0  # s: matching, acknowledgement and exit waits


def cpu_seconds(pid: int) -> float | None:
    """utime + stime of a process in seconds (fields 14 and 15 of /proc/<pid>/stat); None once it is gone."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return None
    return (int(fields[11]) + int(fields[12])) / _CLK_TCK


@dataclass
class Ceiling:
    """One case: messages sent and received (and written), the span (s) and CPU µs per message by role."""

    case: str
    messages: int
    seconds: float
    received: int
    written: int | None = None
    cpu_us: dict[str, float] = field(default_factory=dict)

    @property
    def rate(self) -> float:
        """Messages per second: messages / seconds."""
        return self.messages / self.seconds if self.seconds > 0 else float("nan")

    def row(self) -> list[str]:
        """Table cells."""
        cpu = " / ".join(
            f"{self.cpu_us[role]:.1f}" if role in self.cpu_us else "-"
            for role in ("talker", "listener", "recorder")
        )
        written = "-" if self.written is None else str(self.written)
        return [self.case, str(self.messages), f"{self.rate:,.0f}", str(self.received), written, cpu]


HEADER = [
    "case",
    "messages",
    "messages/s",
    "received",
    "written to the bag",
    "CPU µs/message talker / listener / recorder",
]


def _init(name: str) -> tuple[Any, Any]:
    """rclpy initialised with the chain's DDS profile; (rclpy, node named ``name``)."""
    from pendulum_accel.nodes.dds_profile import use_package_profile

    use_package_profile()
    import rclpy
    from rclpy.node import Node

    rclpy.init()
    return rclpy, Node(name)


def _stdin_closed() -> threading.Event:
    """An event set once standard input reaches EOF: the parent's word to exit (after it read our CPU)."""
    closed = threading.Event()

    def wait() -> None:
        sys.stdin.read()
        closed.set()

    threading.Thread(target=wait, daemon=True).start()
    return closed


def talker(messages: int, readers: int, topic: str) -> None:
    """Publish ``messages`` JointState rows once ``readers`` subscriptions matched; 'start', then JSON."""
    import numpy as np
    from sensor_msgs.msg import JointState

    from pendulum_accel.bag import messages as bm
    from pendulum_accel.nodes.qos import DATA_QOS
    from pendulum_accel.nodes.runtime import acked_within, publish_blocking
    from pendulum_accel.recording.generate import simulator_rows

    rclpy, node = _init("bare_talker")
    publisher = node.create_publisher(JointState, topic, DATA_QOS)
    total = messages + 1  # the handshake's, then the timed ones
    t = np.arange(total, dtype=np.float64) * 1e-3
    zeros = np.zeros(total, dtype=np.float64)
    rows = simulator_rows(t, zeros, zeros, zeros, clock_rate_hz=100.0).rows[bm.TOPIC_JOINT_STATES]
    deadline = time.monotonic() + _WAIT
    while publisher.get_subscription_count() < readers and time.monotonic() < deadline:
        time.sleep(0.05)
    never = lambda: False  # noqa: E731
    # The simulator's handshake: one acknowledged sample proves every reader matched this writer.
    publisher.publish(rows[0].tobytes())
    acked_within(publisher, _WAIT, never)
    print("start", flush=True)
    start = time.monotonic()  # CLOCK_MONOTONIC: one clock for every process of the machine
    for i in range(1, total):
        publish_blocking(publisher, rows[i].tobytes(), never)
    acked_within(publisher, _WAIT, never)
    print(json.dumps({"messages": messages, "start": start, "acked": time.monotonic()}), flush=True)
    _stdin_closed().wait(_WAIT)
    node.destroy_node()
    rclpy.try_shutdown()


def listener(messages: int, topic: str, bag: str) -> None:
    """Count raw JointStates (each written to the bag ``bag`` unless empty): JSON with the last arrival once
    ``messages`` + 1 came (the handshake's too), JSON with the counts at EOF."""
    from rclpy.clock import Clock, ClockType
    from rclpy.experimental import EventsExecutor
    from sensor_msgs.msg import JointState

    from pendulum_accel.bag import messages as bm
    from pendulum_accel.bag.writer import BagWriter, Stream
    from pendulum_accel.nodes.qos import DATA_QOS
    from pendulum_accel.nodes.recorder_node import stamp_ns

    rclpy, node = _init("bare_listener")
    resolved = node.resolve_topic_name(topic)
    writer = BagWriter(Path(bag)) if bag else None
    if writer is not None:
        writer.add_topic(resolved, bm.JOINT_STATE)
    received = 0
    last = 0.0  # monotonic time of the latest arrival
    times: list[int] = []
    payloads: list[bytes] = []

    def on_message(data: bytes) -> None:
        """Count; buffer (log time = stamp, CDR) for the next write, as the recorder does."""
        nonlocal received, last
        received += 1
        last = time.monotonic()
        if writer is not None:
            times.append(stamp_ns(data, 4))
            payloads.append(data)

    def write() -> None:
        """Write what is buffered (BagWriter.write_sorted), as the recorder's tick does."""
        import numpy as np

        if writer is not None and times:
            writer.write_sorted([Stream(resolved, np.array(times, dtype=np.int64), list(payloads))])
            times.clear()
            payloads.clear()

    node.create_subscription(JointState, topic, on_message, DATA_QOS, raw=True)

    def tick() -> None:
        """Write when the writer's flush interval is due, as the recorder's 0.1 s tick does."""
        if writer is not None and writer.flush_due():
            write()

    node.create_timer(0.1, tick, clock=Clock(clock_type=ClockType.STEADY_TIME))
    executor = EventsExecutor()
    executor.add_node(node)
    closed = _stdin_closed()
    said = False
    while not closed.is_set():
        executor.spin_once(timeout_sec=0.05)
        if not said and received >= messages + 1:  # every message taken: the parent may read our CPU
            said = True
            print(json.dumps({"last": last}), flush=True)
    if not said:  # EOF before every message came: the parent still reads this line first
        print(json.dumps({"last": last}), flush=True)
    write()
    counts = writer.close() if writer is not None else {}
    print(json.dumps({"received": received, "written": counts.get(resolved)}), flush=True)
    executor.shutdown()
    node.destroy_node()
    rclpy.try_shutdown()


def _spawn(args: Sequence[str]) -> subprocess.Popen[str]:
    """A child process with piped text standard streams (stderr to ours)."""
    return subprocess.Popen(
        list(args), stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, start_new_session=True
    )


def _close_stdin(child: subprocess.Popen[str]) -> None:
    """Close a child's standard input: its word to finish (once closed, a second call does nothing)."""
    if child.stdin is not None and not child.stdin.closed:
        child.stdin.close()


def _settle(children: dict[str, subprocess.Popen[str]], quiet: float = 0.002) -> None:
    """Wait (10 s at most) until no child used more than ``quiet`` s of CPU in 0.3 s: their work is done."""
    deadline = time.monotonic() + 10.0
    before = [cpu_seconds(c.pid) or 0.0 for c in children.values()]
    while time.monotonic() < deadline:
        time.sleep(0.3)
        after = [cpu_seconds(c.pid) or 0.0 for c in children.values()]
        if max(a - b for a, b in zip(after, before, strict=True)) <= quiet:
            return
        before = after


def measure(case: str, messages: int, folder: Path) -> Ceiling:
    """Run one case in fresh processes; the talker's span and every process's CPU over it."""
    from pendulum_accel.bag import messages as bm
    from pendulum_accel.nodes.launcher import node_command

    me = [sys.executable, "-m", "benchmarks.bare_rclpy"]
    count = ["--messages", str(messages)]
    bag = folder / f"bare_{CASES.index(case)}"
    children: dict[str, subprocess.Popen[str]] = {}
    summary = folder / "bare_recorder.json"
    try:
        bag_arg = ["--bag", str(bag)] if case == "listener writes the bag" else []
        children["listener"] = _spawn([*me, "--role", "listener", *count, *bag_arg])
        readers = 1
        if case == "pair + recorder":
            params: dict[str, str | list[str]] = {
                "path": str(bag),
                "topics": [bm.JOINT_STATES],
                "summary_file": str(summary),
            }
            children["recorder"] = _spawn(node_command("recorder_node", params))
            readers = 2
        children["talker"] = _spawn([*me, "--role", "talker", *count, "--readers", str(readers)])
        talker_out = children["talker"].stdout
        assert talker_out is not None
        if talker_out.readline().strip() != "start":
            raise RuntimeError(f"{case}: the talker did not start (see its error above)")
        cpu0 = {role: cpu_seconds(child.pid) for role, child in children.items()}
        done = json.loads(talker_out.readline())
        listener_out = children["listener"].stdout
        assert listener_out is not None
        # Acknowledged is not yet taken: wait for the listener to have every message (at most _WAIT s)
        # and for the recorder's CPU to settle, so each CPU figure covers all the messages' work.
        if not select.select([listener_out], [], [], _WAIT)[0]:
            _close_stdin(children["listener"])
        arrived = json.loads(listener_out.readline())
        _settle(children)
        cpu1 = {role: cpu_seconds(child.pid) for role, child in children.items()}
        for role in ("talker", "listener"):
            _close_stdin(children[role])
        heard = json.loads(listener_out.readline())
        written = heard["written"]
        if "recorder" in children:
            children["recorder"].send_signal(signal.SIGINT)
            children["recorder"].wait(_WAIT)
            written = json.loads(summary.read_text())["written"].get("/" + bm.JOINT_STATES)
        for child in children.values():
            child.wait(_WAIT)
    finally:
        for child in children.values():
            if child.poll() is None:
                child.kill()
                child.wait()
    n = int(done["messages"])
    cpu = {
        role: (after - before) / n * 1e6
        for role, before, after in ((r, cpu0[r], cpu1[r]) for r in children)
        if before is not None and after is not None
    }
    # From the first timed publish to the later of: every reader acknowledged, the listener took the last.
    seconds = max(float(done["acked"]), float(arrived["last"])) - float(done["start"])
    # received and written count the handshake's message too; the span covers the other n.
    written_n = None if written is None else int(written) - 1
    return Ceiling(case, n, seconds, int(heard["received"]) - 1, written_n, cpu)


def markdown(rows: Sequence[Sequence[str]]) -> str:
    """A markdown table with HEADER."""
    lines = ["| " + " | ".join(HEADER) + " |", "|" + "---|" * len(HEADER)]
    return "\n".join(lines + ["| " + " | ".join(r) + " |" for r in rows])


def run_all(messages: int) -> list[Ceiling]:
    """Every case, in order, in a scratch folder."""
    with tempfile.TemporaryDirectory(prefix="pendulum_accel_bench_bare_") as tmp:
        return [measure(case, messages, Path(tmp)) for case in CASES]


def main(argv: Sequence[str] | None = None) -> int:
    """A role (the child processes), or every case with its table printed."""
    parser = argparse.ArgumentParser(
        prog="python -m benchmarks.bare_rclpy", description=(__doc__ or "").split("\n\n")[0]
    )
    parser.add_argument("--messages", type=int, default=MESSAGES, help="messages per case")
    parser.add_argument("--role", choices=("talker", "listener"), help=argparse.SUPPRESS)
    parser.add_argument("--readers", type=int, default=1, help=argparse.SUPPRESS)
    parser.add_argument("--bag", default="", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    from pendulum_accel.bag import messages as bm

    if args.role == "talker":
        talker(args.messages, args.readers, bm.JOINT_STATES)
        return 0
    if args.role == "listener":
        listener(args.messages, bm.JOINT_STATES, args.bag)
        return 0
    rows = []
    for result in run_all(args.messages):
        rows.append(result.row())
        print(" | ".join(rows[-1]), flush=True)
    print(markdown(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
