"""Who is writing a bag: a lock its writer holds while the bag is open, which dies with the writer's process.

Every :class:`~pendulum_accel.bag.writer.BagWriter` (the recorder node's, ``generate``'s, ``repair``'s)
takes an exclusive ``flock(2)`` on ``<bag>/recording.lock`` before it creates the MCAP file, writes its
process id, host, program and start time into it, and holds it until the bag is closed; then the file is
removed. The kernel drops an flock when the process that holds it ends, however it ends (SIGKILL, a
crash, a power cut), so a crashed recorder cannot leave a bag locked: it leaves the file without the
lock, which then says whose recording was cut off. A reader probes with a shared, non-blocking flock
(``holder``): refused means a live writer holds it.

The mechanism is Dask distributed's for its worker directories (``distributed/diskutils.py``: a
``.dirlock`` file locked with fcntl, and a directory whose lock can be taken is a dead worker's, purged).
ROS 1's rosbag wrote ``<name>.bag.active`` and renamed it at the end, which a crash leaves behind as if
it were still recording; rosbag2 marks a bag in progress in no way (ros2/rosbag2#1597, open): a
recording by another recorder is recognised by ``open_by_others`` instead (the processes that have its
files open, from /proc, as fuser(1) finds them).

On a network file system flock is shared between hosts on Linux (NFS emulates it with byte-range locks),
but a mount without locking (``nolock``) keeps it local: a lock file that names another host and is not
locked here may still be a live recording there, so ``holder`` reports it as unverified.
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import errno
import fcntl
import json
import os
import socket
import sys
import time
from pathlib import Path
from typing import BinaryIO

from pendulum_accel.bag.errors import ReaderError, WriterError

LOCK_NAME = "recording.lock"
"""The lock file in a bag directory while a writer has the bag open (and after a writer died)."""

_PROBES = 20
_PROBE_PAUSE = 0.005  # s: a reader's shared probe holds the lock for microseconds; 20 tries span 0.1 s


@dataclasses.dataclass(frozen=True)
class Holder:
    """The writer a lock file names: its process id, host, program and start time (ISO 8601, UTC), and
    whether that writer holds the lock now (``live``), or could not be checked (``verified`` False: a lock
    file of another host that is not locked here, see the module docstring)."""

    pid: int
    host: str
    program: str
    since: str
    live: bool = True
    verified: bool = True

    @property
    def ours(self) -> bool:
        """True when this process is the holder (a writer reading its own bag, repair under its lock)."""
        return self.pid == os.getpid() and self.host == socket.gethostname()

    def describe(self) -> str:
        """'bag_recorder (pid 4242 on host1, since 2026-01-05T10:00:00Z)' (no 'since' when unknown)."""
        since = f", since {self.since}" if self.since != "?" else ""
        return f"{self.program} (pid {self.pid} on {self.host}{since})"


def _now() -> str:
    """The current UTC time, ISO 8601 to the second ('2026-01-05T10:00:00Z')."""
    return datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")


class BagLock:
    """The exclusive lock on a bag directory's ``recording.lock``, held until ``release`` (or until this
    object is collected, or the process ends: the file then stays, unlocked, as a crashed writer's)."""

    def __init__(self, directory: Path, program: str | None = None) -> None:
        """Take the lock of ``directory`` (which exists) and write who holds it; BagError naming the holder
        when another process holds it, OSError when the lock file cannot be created (for the caller to
        phrase). A reader's probe takes the lock shared for an instant, so taking it is retried for 0.1 s
        before the holder is taken to be a writer. Who holds it is written if it can be: a full disk
        leaves the file empty, and the lock still holds."""
        self.path = directory / LOCK_NAME
        program = program or Path(sys.argv[0]).name or "python"
        fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW, 0o644)
        self._file: BinaryIO | None = os.fdopen(fd, "r+b", buffering=0)
        for attempt in range(_PROBES):
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if attempt + 1 < _PROBES:
                    time.sleep(_PROBE_PAUSE)
            except OSError:
                # A file system without flock (ENOLCK, EOPNOTSUPP) cannot hold the lock: the recording goes
                # on (it matters more), and readers, whose probe fails alike, learn nothing from the file.
                break
        else:
            self._close()
            found = holder(directory)
            who = found.describe() if found is not None else "another process"
            raise WriterError(f"bag {directory} is being written by {who}")
        self.holder = Holder(os.getpid(), socket.gethostname(), program, _now())
        doc = {
            "pid": self.holder.pid,
            "host": self.holder.host,
            "program": program,
            "since": self.holder.since,
        }
        with contextlib.suppress(OSError):
            os.ftruncate(fd, 0)
            os.pwrite(fd, (json.dumps(doc) + "\n").encode(), 0)

    def _close(self) -> None:
        """Close the lock file (the kernel lets go of the lock)."""
        if self._file is not None:
            self._file.close()
            self._file = None

    def release(self) -> None:
        """Remove the lock file, then let go of the lock (a reader probing in between finds it unlocked,
        and the bag closed); nothing when released already."""
        if self._file is None:
            return
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()
        self._close()


def _read_holder(path: Path) -> Holder:
    """The Holder a lock file names (fields it lacks: pid 0, host '?', program 'a writer')."""
    try:
        doc = json.loads(path.read_text(errors="replace") or "{}")
    except (OSError, ValueError):
        doc = {}
    doc = doc if isinstance(doc, dict) else {}
    pid = doc.get("pid")
    return Holder(
        pid if isinstance(pid, int) else 0,
        str(doc.get("host", "?")),
        str(doc.get("program", "a writer")),
        str(doc.get("since", "?")),
    )


def holder(directory: Path) -> Holder | None:
    """Who writes the bag in ``directory``: its lock file's Holder, ``live`` when a process holds the lock
    now, not live when the file is left by a writer that died before it closed the bag (``verified`` False
    when that file names another host: its lock may not reach this one); None without a lock file."""
    path = directory / LOCK_NAME
    try:
        fd = os.open(path, os.O_RDONLY | os.O_CLOEXEC | os.O_NOFOLLOW | os.O_NONBLOCK)
    except FileNotFoundError:
        return None
    except OSError as err:
        if err.errno in (errno.ELOOP, errno.EISDIR, errno.ENXIO):
            return None  # not a lock file of ours (a symlink, a directory, a FIFO without a writer)
        raise ReaderError(f"cannot read the lock {path}: {err.strerror}") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except BlockingIOError:  # held exclusively: a live writer
            return _read_holder(path)
        except OSError:
            return None  # no flock on this file system: nothing can be told from the file
        fcntl.flock(fd, fcntl.LOCK_UN)
        found = _read_holder(path)
        if not path.exists():  # removed by a writer that closed the bag while we looked
            return None
        here = found.host in ("?", socket.gethostname())
        return dataclasses.replace(found, live=False, verified=here)
    finally:
        os.close(fd)


def writer_of(paths: list[Path]) -> Holder | None:
    """The first other process that has one of ``paths`` open for writing (a recorder of another make,
    ``ros2 bag record``, which takes no lock of ours), as a live Holder without a start time; None."""
    for _, pid, command in open_by_others(paths, writing=True):
        return Holder(pid, socket.gethostname(), command, "?")
    return None


def _writes(fdinfo: Path) -> bool:
    """True when the open file /proc/PID/fdinfo/FD describes is open for writing (O_WRONLY or O_RDWR in
    its octal 'flags:' line)."""
    for line in fdinfo.read_text().splitlines():
        if line.startswith("flags:"):
            return int(line.split()[1], 8) & (os.O_WRONLY | os.O_RDWR) != 0
    return False


def open_by_others(paths: list[Path], *, writing: bool = False) -> list[tuple[Path, int, str]]:
    """(path, pid, command) for each of ``paths`` another process has open (``writing``: open for
    writing), read from /proc/*/fd as fuser(1) does: a recorder other than ours (``ros2 bag record``)
    writing the file. Only processes whose /proc entries this user may read are seen (all of them as
    root)."""
    wanted: dict[tuple[int, int], Path] = {}
    for path in paths:
        with contextlib.suppress(OSError):
            st = path.stat()
            wanted[(st.st_dev, st.st_ino)] = path
    found: list[tuple[Path, int, str]] = []
    if not wanted:
        return found
    me = os.getpid()
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit() or int(entry.name) == me:
            continue
        with contextlib.suppress(OSError):
            for fd in (entry / "fd").iterdir():
                with contextlib.suppress(OSError):
                    st = fd.stat()
                    match = wanted.get((st.st_dev, st.st_ino))
                    if match is not None and (not writing or _writes(entry / "fdinfo" / fd.name)):
                        command = (entry / "comm").read_text().strip()
                        found.append((match, int(entry.name), command))
    return found
