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
import signal
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import IO, Any

import pytest

REPO = Path(__file__).resolve().parent.parent
_LOCK_DIR = Path(tempfile.gettempdir())
# Linux hosts fit domain ids 0-101 (port range); 0 is what users run on, so skip it.
_DOMAIN_IDS = range(1, 102)


def _reserve_domain_id() -> tuple[int, IO[str]]:
    """Hold an exclusive lock on one domain id for the life of this test session."""
    ids = list(_DOMAIN_IDS)
    random.Random(os.getpid()).shuffle(ids)
    for domain in ids:
        handle = open(_LOCK_DIR / f"pendulum_accel_ros_domain_{domain}.lock", "w")  # noqa: SIM115
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            handle.close()
            continue
        return domain, handle
    raise RuntimeError("no free ROS_DOMAIN_ID in 1..101: too many concurrent test runs")


if "PYTEST_XDIST_WORKER" not in os.environ or "ROS_DOMAIN_ID" not in os.environ:
    ROS_DOMAIN_ID, _DOMAIN_LOCK = _reserve_domain_id()
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
