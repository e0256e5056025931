"""Test-session isolation for ROS: a private DDS domain, localhost-only discovery.

Set at import time, before anything imports rclpy, and inherited by every process
a test starts, so two test runs on one machine never see each other's topics.
"""

from __future__ import annotations

import contextlib
import fcntl
import functools
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

import pytest

from pendulum_accel.nodes.shm_ports import clear_stale_ports

REPO = Path(__file__).resolve().parent.parent

# A suite started as a background job (`make test &`, some CI runners) inherits SIGINT as ignored, and
# every process a test starts would inherit that too: the Ctrl-C tests would then wait for a command that
# never sees its SIGINT, and nodes stopped with SIGINT would close only at SIGKILL. A handler set here
# is reset to the default action in every child at exec, as a user's terminal would have it.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
_LOCK_DIR = Path(tempfile.gettempdir())
# Linux hosts fit domain ids 0-101 (port range); 0 is what users run on, so skip it. Each test process
# (a plain pytest, or each pytest-xdist worker) holds a pair of ids: its own domain, and a spare one that
# no other process uses, for the tests that need "another domain" (test_dds_isolation).
_DOMAIN_PAIRS = [(first, first + 1) for first in range(1, 101, 2)]


def _reserve_domain_pair() -> tuple[tuple[int, int], IO[str]]:
    """Hold an exclusive lock on one pair of domain ids for the life of this test process."""
    pairs = list(_DOMAIN_PAIRS)
    random.Random(os.getpid()).shuffle(pairs)
    for pair in pairs:
        handle = open(_LOCK_DIR / f"pendulum_accel_ros_domains_{pair[0]}_{pair[1]}.lock", "w")  # noqa: SIM115
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        return pair, handle
    raise RuntimeError("no free pair of ROS_DOMAIN_IDs in 1..100: too many concurrent test processes")


# Every process reserves its own pair, an xdist worker too (it inherits the controller's ROS_DOMAIN_ID,
# which must not be shared: two workers' chains on one domain would see each other's topics).
(ROS_DOMAIN_ID, SPARE_DOMAIN_ID), _DOMAIN_LOCK = _reserve_domain_pair()
os.environ["ROS_DOMAIN_ID"] = str(ROS_DOMAIN_ID)
os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
os.environ.pop("ROS_LOCALHOST_ONLY", None)  # deprecated; conflicts with the range above
os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
os.environ["MPLBACKEND"] = "Agg"
os.environ["PYTHONUNBUFFERED"] = "1"


@functools.cache
def rclpy_available() -> bool:
    """True when rclpy and its message packages import (PyPI wheels or a system ROS 2)."""
    try:
        import rclpy  # noqa: F401
        import sensor_msgs.msg  # noqa: F401
    except ImportError:
        return False
    return True


@pytest.fixture(autouse=True)
def _no_stale_shm_port() -> None:
    """Before every test (any may start DDS participants, not all through the nodes, which clear them
    too): no empty Fast DDS port left by a killed process, which would hang them at start-up."""
    clear_stale_ports()


@pytest.fixture(autouse=True)
def _ros_is_installed(request: pytest.FixtureRequest) -> None:
    """A ``ros`` test fails, never skips, without rclpy: ``make test`` installs it, so absence is a bug."""
    if request.node.get_closest_marker("ros") is not None and not rclpy_available():
        pytest.fail(
            "rclpy or its message packages do not import: run the tests through `make test`, which "
            "installs ROS 2 from requirements-ros.txt (or source a ROS 2 install first)",
            pytrace=False,
        )


Spawn = Callable[..., subprocess.Popen[str]]


@pytest.fixture
def spawn() -> Iterator[Spawn]:
    """Start processes in their own process group; every one is stopped at teardown.

    SIGINT first (nodes close bags cleanly), SIGKILL to the whole group if it lingers,
    so nothing is left running even when the test fails.
    """
    procs: list[subprocess.Popen[str]] = []

    def _spawn(args: list[str], **kwargs: object) -> subprocess.Popen[str]:
        kwargs.setdefault("stdout", subprocess.PIPE)
        kwargs.setdefault("stderr", subprocess.PIPE)
        kwargs.setdefault("text", True)
        kwargs.setdefault("cwd", str(REPO))
        proc = subprocess.Popen(args, start_new_session=True, **kwargs)  # type: ignore[call-overload]
        procs.append(proc)
        return proc

    yield _spawn
    stop_processes(procs)


def stop_processes(procs: list[subprocess.Popen[str]]) -> None:
    """Stop each process started in its own group: SIGINT to the group (nodes close their bags), up to 10 s,
    then SIGKILL to the whole group (it may hold children of the child), so nothing is left running."""
    for proc in procs:
        if proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGINT)
    for proc in procs:
        with contextlib.suppress(subprocess.TimeoutExpired):
            proc.wait(timeout=10)
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()


PYTHON = sys.executable


def strict_json(text: str) -> Any:
    """``text`` parsed as strict JSON (RFC 8259): a bare NaN, Infinity or -Infinity, which Python's json
    accepts and most other parsers refuse, raises ValueError."""

    def refuse(constant: str) -> Any:
        """Called by json for NaN/Infinity/-Infinity."""
        raise ValueError(f"not strict JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


def cli(*args: str, timeout: float = 180.0) -> subprocess.CompletedProcess[str]:
    """``pendulum-accel ARGS`` in a subprocess (captured), from the repository (the tests' one CLI runner)."""
    return subprocess.run(
        [PYTHON, "-m", "pendulum_accel.cli.main", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=REPO,
    )


def run_root(factory: pytest.TempPathFactory) -> Path:
    """The temporary directory of this whole pytest run: shared by its xdist workers (each worker's own
    basetemp is a ``popen-gwN`` folder inside it), the basetemp itself without xdist."""
    base = factory.getbasetemp()
    return base.parent if "PYTEST_XDIST_WORKER" in os.environ else base


def shared_once(factory: pytest.TempPathFactory, name: str, make: Callable[[Path], None]) -> Path:
    """A folder ``name`` made once per pytest run by ``make(folder)``, whichever worker asks first; the others
    wait on its lock and reuse it. Made whole or not at all: a folder whose ``make`` raised is made anew by
    the next caller (the ``.done`` mark is written last)."""
    folder = run_root(factory) / "shared" / name
    folder.parent.mkdir(parents=True, exist_ok=True)
    with open(folder.parent / f"{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (folder / ".done").exists():
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir()
            make(folder)
            (folder / ".done").touch()
    return folder


@pytest.fixture(scope="session")
def colcon_workspace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One ``colcon build`` of a clean checkout for the whole run (every xdist worker shares it): the
    workspace, its install/ beside src/. Tests read it and run its scripts; none writes into it."""
    from test.install_paths import build_colcon_workspace

    return shared_once(tmp_path_factory, "colcon_ws", build_colcon_workspace)


@pytest.fixture(scope="session")
def lab_class(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The lab's test class (test/lab_class.py), made once for the whole run: its group folders, zips and
    teacher_key.md."""
    from test.lab_class import make_class

    return shared_once(tmp_path_factory, "lab_class", make_class) / "class"


# --- scheduling on pytest-xdist (make test: --dist loadfile --no-loadscope-reorder) ------------------------
# Each test file runs whole on one worker, so what a module computes once per process (a module-scoped
# fixture, a functools cache) is computed once. (--dist loadgroup would let the other files' tests spread
# one by one, but it groups nothing with pytest 9.2: pytest-xdist#1386.) The files are sent longest first,
# since the longest at the end would be the run's tail: a file's cost is the sum of its tests' durations in
# the last run on this checkout (pytest's cache), else of guesses from their `slow` marks.
DURATIONS_KEY = "pendulum_accel/durations"
SLOW_GUESS_S = 120.0  # s a `slow` test is taken to last when no run has timed it (none is over 5 min)
QUICK_GUESS_S = 0.5  # s any other untimed test is taken to last (the suite's median is below it)


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Order the files longest first (stable: a file's tests keep their order)."""
    cache = getattr(config, "cache", None)  # None with -p no:cacheprovider
    known: dict[str, float] = cache.get(DURATIONS_KEY, {}) if cache is not None else {}
    cost: dict[str, float] = {}
    for item in items:
        guess = SLOW_GUESS_S if item.get_closest_marker("slow") else QUICK_GUESS_S
        path = item.nodeid.split("::", 1)[0]
        cost[path] = cost.get(path, 0.0) + known.get(item.nodeid, guess)
    items.sort(key=lambda item: -cost[item.nodeid.split("::", 1)[0]])


_durations: dict[str, float] = {}


def pytest_runtest_logreport(report: pytest.TestReport) -> None:
    """Each test's setup + call + teardown seconds (on the controller under xdist: every worker's reports)."""
    _durations[report.nodeid] = _durations.get(report.nodeid, 0.0) + report.duration


def pytest_sessionfinish(session: pytest.Session) -> None:
    """Keep this run's durations for the next run's order (the controller's, or a run without xdist)."""
    cache = getattr(session.config, "cache", None)  # None with -p no:cacheprovider
    if "PYTEST_XDIST_WORKER" in os.environ or cache is None or not _durations:
        return
    cache.set(DURATIONS_KEY, {**cache.get(DURATIONS_KEY, {}), **_durations})
