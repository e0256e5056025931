"""Fast DDS shared-memory ports left half-made by a killed process, cleared before a node starts.

A port is a file in /dev/shm that Fast DDS creates empty (``shm_open``) and sizes and initialises in the
same call, microseconds later. A process killed in between (a SIGKILL while a loaded machine starts it)
leaves the file empty, and every later participant that opens that port, on any ROS_DOMAIN_ID, spins
forever in boost's ``open_or_create`` waiting for an initialisation that never comes (eProsima/Fast-DDS
#3878): the node hangs in its constructor. ``fastdds shm clean`` removes zombie ports by their lock files,
which such a port never got. No ROS import: it runs before rclpy initialises.
"""

from __future__ import annotations

import contextlib
import os
import time
from pathlib import Path

SHM_DIR = Path("/dev/shm")
PORT_PREFIX = "fastdds_port"
LOCK_SUFFIXES = ("_el", "_sl")  # Fast DDS's lock files beside a port: its own, left alone
STALE_EMPTY_S = 3.0  # s an empty port may be young (being made now); one older was never finished


def clear_stale_ports(shm_dir: Path = SHM_DIR, now: float | None = None) -> list[str]:
    """Remove the empty ``fastdds_port*`` files (not their lock files) last modified over STALE_EMPTY_S ago;
    the names removed. Files it may not remove, or that vanish meanwhile, are left to others."""
    now = time.time() if now is None else now
    try:
        entries = list(os.scandir(shm_dir))
    except OSError:
        return []
    removed: list[str] = []
    for entry in entries:
        if not entry.name.startswith(PORT_PREFIX) or entry.name.endswith(LOCK_SUFFIXES):
            continue
        with contextlib.suppress(OSError):
            info = entry.stat(follow_symlinks=False)
            if info.st_size == 0 and now - info.st_mtime > STALE_EMPTY_S:
                os.unlink(entry.path)
                removed.append(entry.name)
    return removed
