"""Ctrl-C on a fleet and the lifetime of its workers: SIGINT cancels the rest and writes nothing, Dask logs
only errors after it, and a local worker ends with its nanny even while its task holds the GIL."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

from test.conftest import REPO, cli, stop_processes
from test.fleet_rows import _no_leftover_workers  # noqa: F401 (the autouse fixture)

# CPU seconds the workers of a LocalCluster spend, together, before they are surely analysing bags: each
# spends about 2.4 s importing numpy, scipy, numba and distributed and loading the compiled kernels
# (measured here), and the 40 bags take about 240 s of CPU, so at 6 s the two have started on the bags
# and nearly all of the work is still to do.
WORKING_CPU_S = 6.0


def _stat(pid: int | str) -> list[str] | None:
    """/proc/PID/stat's fields after the command name (state, ppid, pgrp, session, …); None once gone."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return None


def _pids() -> list[str]:
    """Every process id /proc lists now."""
    return [entry.name for entry in Path("/proc").iterdir() if entry.name.isdigit()]


def _descendants(pid: int) -> list[int]:
    """The processes below ``pid`` (children, grandchildren, …), from /proc."""
    parents: dict[int, int] = {}
    for other in _pids():
        fields = _stat(other)
        if fields is not None:
            parents[int(other)] = int(fields[1])
    found, frontier = [], [pid]
    while frontier:
        here = frontier.pop()
        kids = [child for child, parent in parents.items() if parent == here]
        found += kids
        frontier += kids
    return found


def _cpu_seconds(pid: int) -> float:
    """utime + stime of ``pid`` in seconds (/proc/PID/stat); 0 once it is gone."""
    fields = _stat(pid)
    if fields is None:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def _working(pid: int, workers: int, cpu_s: float, timeout: float) -> bool:
    """True once ``pid`` has at least ``workers`` descendants and they have spent ``cpu_s`` of CPU together,
    polled every 0.2 s for at most ``timeout`` s."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        below = _descendants(pid)
        if len(below) >= workers and sum(_cpu_seconds(p) for p in below) >= cpu_s:
            return True
        time.sleep(0.2)
    return False


def test_ctrl_c_cancels_the_rest_and_writes_nothing(tmp_path: Path) -> None:
    """SIGINT while 40 bags are being analysed: exit 130 with one line, no table under the asked name
    and no temporary beside it, and the workers gone. The bound on the exit time (5 s) is loose on
    purpose: finishing the remaining work instead takes far longer, which is what the test tells
    apart, not the speed of the machine. Each bag is 300 s of udds (about 6 s of work per bag here),
    so 40 of them on 2 workers are about 120 s of work: the signal comes once the workers have spent
    WORKING_CPU_S of CPU, with most of it still to do on any machine. (With 3 s bags, a faster CI machine
    finished all 40 before a fixed 12 s wait was over.) The bags share one MCAP file through hard links,
    so 40 of them cost no disk."""
    source = tmp_path / "udds"
    done = cli("generate", "udds", "--duration", "300", "--out", str(source), timeout=300)
    assert done.returncode == 0, done.stderr
    many = tmp_path / "many"
    many.mkdir()
    for i in range(40):
        bag = many / f"b{i:02d}"
        bag.mkdir()
        for item in source.iterdir():
            os.link(item, bag / item.name)
    shutil.rmtree(source)
    out = tmp_path / "t.parquet"
    # Dask's default HTTP port taken, as by another cluster running on the machine: the one-line
    # output below must not gain Dask's "Port 8787 is already in use" warning.
    taken = socket.socket()
    with contextlib.suppress(OSError):  # already taken by someone else: the same condition
        taken.bind(("127.0.0.1", 8787))
        taken.listen()
    proc = subprocess.Popen(
        [sys.executable, "-m", "pendulum_accel.cli.main", "analyze", str(many), "--out", str(out),
         "-e", "kalman", "-e", "smoother", "--workers", "2"],
        cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    try:
        # The cluster is up and working: its two workers have started and spent CPU beyond their imports.
        assert _working(proc.pid, workers=2, cpu_s=WORKING_CPU_S, timeout=120.0), "the workers never worked"
        assert proc.poll() is None, proc.communicate()
        os.killpg(proc.pid, signal.SIGINT)
        start = time.monotonic()
        _, err = proc.communicate(timeout=60)
        took = time.monotonic() - start
        # Nothing of the command outlives it for long: the workers die with their nannies, and the
        # resource tracker once its pipe closes (issue 58: 3 workers still ran 2 s after the exit). 2 s
        # is the observation, not a speed: an orphaned worker runs on for minutes of its bag.
        deadline = time.monotonic() + 2.0
        while _session(proc.pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        left = _session(proc.pid)
    finally:
        stop_processes([proc])
        taken.close()
    assert not left, left
    assert proc.returncode == 130, err
    assert err.strip().splitlines() == ["pendulum-accel analyze: interrupted"], err
    assert took < 5.0, f"took {took:.2f} s to stop"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["many"]


def test_after_ctrl_c_on_a_local_cluster_dask_logs_only_errors() -> None:
    """Ctrl-C inside dask_client: once the cluster is closed, Dask's loggers still drop INFO records (the
    in-process scheduler's "Batched Comm Closed" with its traceback, which a run once printed after the
    one-line message: closing the cluster puts Dask's own handlers back to INFO) and still pass errors."""
    import logging
    import multiprocessing

    from pendulum_accel.cluster import dask_client

    with contextlib.suppress(KeyboardInterrupt), dask_client(None, 1):
        raise KeyboardInterrupt
    batched = logging.getLogger("distributed.batched")
    assert not batched.isEnabledFor(logging.INFO)
    assert batched.isEnabledFor(logging.ERROR)
    # What the CLI's exit does next (multiprocessing ends its daemon children): a worker the nanny
    # restarted during the 0.2 s close would outlive this test otherwise.
    deadline = time.monotonic() + 30.0
    while multiprocessing.active_children() and time.monotonic() < deadline:
        for child in multiprocessing.active_children():
            child.kill()
            child.join(1.0)


_NANNY_AND_BUSY_WORKER = """
import json, os, sys, time
from pendulum_accel.cluster import dask_client
with dask_client(None, 1) as client:
    (pids,) = client.run(lambda: (os.getpid(), os.getppid())).values()
    task = client.submit(sum, range(10**13), pure=False)  # C's loop: holds the worker's GIL for minutes
    print(json.dumps(pids), flush=True)
    time.sleep(600)
"""


def _running(pid: int) -> bool:
    """True while ``pid`` exists and is not a zombie (an orphan's new parent may not reap it at once)."""
    fields = _stat(pid)
    return fields is not None and fields[0] != "Z"


def _session(sid: int) -> list[str]:
    """The command lines of the running (not zombie) processes of session ``sid``."""
    found = []
    for pid in _pids():
        fields = _stat(pid)
        if fields is not None and int(fields[3]) == sid and fields[0] != "Z":
            with contextlib.suppress(OSError):
                found.append(Path(f"/proc/{pid}/cmdline").read_text().replace("\0", " ")[:120])
    return found


def test_a_local_worker_ends_with_its_nanny_even_while_its_task_holds_the_gil() -> None:
    """The local cluster's worker is its nanny's child. Dask's own watch of the nanny is a thread in the
    worker, which cannot run while a task holds the GIL; Ctrl-C kills the nannies (the command's children),
    and such a worker ran on, orphaned, after the command had exited (issue 58). Killed with its nanny now."""
    proc = subprocess.Popen(
        [sys.executable, "-c", _NANNY_AND_BUSY_WORKER],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    worker = 0
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        assert line, proc.stderr.read() if proc.stderr else ""
        worker, nanny = json.loads(line)
        # The task is running once the worker has used a CPU second since: its GIL is then held.
        start, deadline = _cpu_seconds(worker), time.monotonic() + 60.0
        while _cpu_seconds(worker) < start + 1.0 and time.monotonic() < deadline:
            time.sleep(0.1)
        assert _cpu_seconds(worker) >= start + 1.0
        os.kill(nanny, signal.SIGKILL)
        # The kernel's parent-death signal ends it at once. Without it, it runs until the sum ends
        # (10^13 additions: hours): the 30 s here only bounds a loaded machine's scheduling.
        deadline = time.monotonic() + 30.0
        while _running(worker) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not _running(worker)
    finally:
        if worker and _running(worker):
            os.kill(worker, signal.SIGKILL)
        stop_processes([proc])
