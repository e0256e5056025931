"""Teardown benchmark: start and stop a chain node many times; how often it ends otherwise than exit 0.

    python -m benchmarks.teardown [--runs N] [--hold S] [--quiet-graph | --peer-leaves] [--out DIR]

Each run starts ``bag_recorder`` (``python -m pendulum_accel.nodes.recorder_node``, recording to a fresh
bag), waits for its "recording" line, lets it record ``--hold`` s, then stops it as the launcher does:
SIGINT (the recorder drains its queues, closes the bag and tears down: ``runtime.run_node``), and a
second SIGINT 1 s later if it still runs (a peer that never pauses keeps the drain from going idle).
Unless ``--quiet-graph``, a peer process in the same domain keeps the teardown busy the way a second
chain or a stranger does: angles and /diagnostics at about 1 kHz, and publishers created and destroyed
all the time, half of them best-effort (discovery and incompatible-QoS events at the recorder).
With ``--peer-leaves`` each run has its own peer, stopped at the same moment as the recorder, as a
test's teardown stops every process it started: both participants leave the graph at once.

Reported: exit codes (0, killed by a signal, other), whether the bag was closed, and the stop time
(first SIGINT to exit). The bound beside the crash count is zero: a node that closed its bag has
nothing left to do but leave the graph. A SIGSEGV's Python stacks (faulthandler, which the
EventsExecutor enables) are copied to the output directory.
"""

from __future__ import annotations

import argparse
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

from benchmarks import report

_READY = "recording "  # the recorder's start-up line ("recording 9 topics to ...")
_CLOSED = "bag closed"
_START_TIMEOUT = 60.0  # s for the node to come up on a loaded machine
_STOP_TIMEOUT = 30.0  # s for the node to exit after the first SIGINT before it counts as hung


def peer() -> None:
    """Traffic and discovery churn on the recorder's topics until SIGINT/SIGTERM (``--peer``)."""
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from rclpy.signals import SignalHandlerOptions
    from sensor_msgs.msg import JointState

    from pendulum_accel.nodes.dds_profile import use_package_profile

    running = [True]

    def stop(signum: int, frame: object) -> None:
        """End the loop."""
        running[0] = False

    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    use_package_profile()  # the nodes' own transports, so that the two discover each other
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node("teardown_peer")
    angles = node.create_publisher(JointState, "pendulum/joint_states", 100)
    diagnostics = node.create_publisher(DiagnosticArray, "/diagnostics", 100)
    best_effort = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
    status = DiagnosticArray(status=[DiagnosticStatus(name="/elsewhere/node: peer")])
    joint = JointState(name=["pendulum_joint"], position=[0.0])
    print("peer: up", flush=True)
    while running[0]:
        for _ in range(20):
            angles.publish(joint)
            diagnostics.publish(status)
            time.sleep(0.001)
        churn = [
            node.create_publisher(JointState, "pendulum/joint_states", best_effort if k % 2 else 10)
            for k in range(4)
        ]
        time.sleep(0.005)
        for publisher in churn:
            node.destroy_publisher(publisher)
    node.destroy_node()
    rclpy.try_shutdown()


def wait_for(path: Path, text: str, proc: subprocess.Popen[bytes], timeout: float) -> bool:
    """True once ``text`` is in the file ``path``; False if ``proc`` ends or ``timeout`` s pass first."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and proc.poll() is None:
        if text in path.read_text(errors="replace"):
            return True
        time.sleep(0.05)
    return False


def start_peer() -> subprocess.Popen[str]:
    """The peer (``--peer``) in its own session, returned once it publishes."""
    proc = subprocess.Popen(
        [sys.executable, "-m", "benchmarks.teardown", "--peer"],
        stdout=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    assert proc.stdout is not None
    proc.stdout.readline()  # "peer: up"
    return proc


def stop_peer(proc: subprocess.Popen[str]) -> None:
    """SIGINT the peer; SIGKILL its group if it has not ended 10 s later."""
    proc.send_signal(signal.SIGINT)
    try:
        proc.wait(10)
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


SECOND_SIGINT_S = 1.0  # s after the first SIGINT: the launcher's second one (module doc)


def one_run(
    folder: Path, k: int, hold: float, leaving: subprocess.Popen[str] | None = None
) -> tuple[int | None, bool, float, str]:
    """(exit code or None if hung, bag closed, stop time s, stderr) of one recorder start and stop;
    ``leaving``: a peer stopped at the same moment as the recorder (both participants leave at once)."""
    out, err = folder / f"run{k}.out", folder / f"run{k}.err"
    command = [
        sys.executable,
        "-m",
        "pendulum_accel.nodes.recorder_node",
        "--ros-args",
        "-p",
        f"path:={folder / 'bag'}",
        "-p",
        "overwrite:=true",
    ]
    with out.open("w") as fout, err.open("w") as ferr:
        proc = subprocess.Popen(command, stdout=fout, stderr=ferr, start_new_session=True)
    try:
        if not wait_for(err, _READY, proc, _START_TIMEOUT):
            proc.send_signal(signal.SIGINT)
            proc.wait(_STOP_TIMEOUT)
            return proc.returncode, False, float("nan"), err.read_text(errors="replace")
        time.sleep(hold)
        start = time.monotonic()
        proc.send_signal(signal.SIGINT)
        if leaving is not None:
            leaving.send_signal(signal.SIGINT)
        try:
            proc.wait(SECOND_SIGINT_S)
        except subprocess.TimeoutExpired:
            proc.send_signal(signal.SIGINT)
        try:
            proc.wait(_STOP_TIMEOUT)
            code: int | None = proc.returncode
        except subprocess.TimeoutExpired:
            code = None
        stopped = time.monotonic() - start
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    return code, _CLOSED in out.read_text(errors="replace"), stopped, err.read_text(errors="replace")


def describe(code: int | None) -> str:
    """'exit 0', 'SIGSEGV', 'hung' ... for a return code."""
    if code is None:
        return "hung (SIGKILL)"
    if code < 0:
        return signal.Signals(-code).name
    return f"exit {code}"


def plot(stop_times: list[float], out: Path) -> Path:
    """teardown.png: each run's stop time (first SIGINT to exit, s) in run order, with the moment of the
    second SIGINT: a run past it needed that second signal."""
    fig, ax = report.new_axes(8.0, 4.0)
    ax.plot(range(1, len(stop_times) + 1), stop_times, "o", ms=4, label="stop time of a run")
    ax.axhline(SECOND_SIGINT_S, ls="--", color="tab:red", label=f"second SIGINT ({SECOND_SIGINT_S:g} s)")
    ax.set_xlabel("run")
    ax.set_ylabel("first SIGINT to exit (s)")
    ax.set_ylim(bottom=0.0)
    ax.set_title("Recorder teardown per run", fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    return report.save_figure(fig, out)


def main(argv: list[str] | None = None) -> int:
    """Start and stop the recorder ``--runs`` times (with the peer unless --quiet-graph); write the table."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=report.count, default=30, help="start/stop cycles (default 30)")
    parser.add_argument(
        "--hold", type=report.positive, default=1.0, help="s of recording before the stop (default 1)"
    )
    parser.add_argument("--quiet-graph", action="store_true", help="no peer: nothing else on the graph")
    parser.add_argument(
        "--peer-leaves",
        action="store_true",
        help="a peer per run, stopped at the same moment as the recorder (as a test's teardown stops all)",
    )
    parser.add_argument("--out", type=Path, default=Path("out/bench"))
    parser.add_argument("--peer", action="store_true", help=argparse.SUPPRESS)
    report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    if args.peer:
        peer()
        return 0
    args.out.mkdir(parents=True, exist_ok=True)
    outcomes: Counter[str] = Counter()
    closed = 0
    stop_times: list[float] = []
    peer_proc = None
    with tempfile.TemporaryDirectory(prefix="teardown_") as tmp:
        folder = Path(tmp)
        try:
            if not (args.quiet_graph or args.peer_leaves):
                peer_proc = start_peer()
            for k in range(args.runs):
                leaving = start_peer() if args.peer_leaves else None
                try:
                    code, bag_closed, stopped, stderr = one_run(folder, k, args.hold, leaving)
                finally:
                    if leaving is not None:
                        stop_peer(leaving)
                outcomes[describe(code)] += 1
                closed += bag_closed
                if stopped == stopped:  # not NaN: the node came up
                    stop_times.append(stopped)
                if code != 0:
                    (args.out / f"teardown_run{k}.err").write_text(stderr)
                print(f"run {k + 1}/{args.runs}: {describe(code)}, bag closed {bag_closed}", flush=True)
        finally:
            if peer_proc is not None:
                stop_peer(peer_proc)
    if args.quiet_graph:
        graph = "quiet (no other participant)"
    elif args.peer_leaves:
        graph = "busy, the peer stopped with the recorder (one per run)"
    else:
        graph = "busy (the peer: ~1 kHz traffic, churn)"
    rows = [
        "| runs | graph | " + " | ".join(sorted(outcomes)) + " | bag closed | stop time median / max (s) |",
        "|---|---|" + "---|" * len(outcomes) + "---|---|",
        f"| {args.runs} | {graph} | "
        + " | ".join(str(outcomes[k]) for k in sorted(outcomes))
        + f" | {closed} | {statistics.median(stop_times):.2f} / {max(stop_times):.2f} |",
    ]
    table = "\n".join(rows)
    print(table)
    (args.out / "teardown.md").write_text(table + "\n")
    png = plot(stop_times, args.out / "teardown.png")
    report.write_page(
        "teardown",
        "Node teardown",
        [table],
        [(png, "Stop time of each run, first SIGINT to exit, beside the second SIGINT at 1 s")],
        intro=(
            "The recorder started and stopped again and again, as the launcher stops it (SIGINT, a second "
            "one after 1 s): how often it ends otherwise than exit 0. Any signal death here is a crash "
            "after the bag closed (bound: 0)."
        ),
        docs=args.docs,
        argv=argv,
    )
    return 0 if set(outcomes) == {"exit 0"} else 1


if __name__ == "__main__":
    raise SystemExit(main())
