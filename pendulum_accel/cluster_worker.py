"""Loaded in each worker process of the local Dask cluster (``LocalCluster(preload=[__name__])``): the
worker ends with the nanny that started it.

Dask's own watch (distributed/process.py, ``_immediate_exit_when_closed``) is a thread reading a pipe from
the nanny; it cannot run while the worker's main thread holds the GIL in a long call (a compiled kernel
over a long bag), so a worker whose nanny Ctrl-C had killed ran on, orphaned, after the command exited
(issue 58). Linux's parent-death signal needs no thread: the kernel sends SIGKILL as the nanny's thread
that started the worker ends (prctl(2), PR_SET_PDEATHSIG). Elsewhere this does nothing and Dask's watch
remains.
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys

PR_SET_PDEATHSIG = 1  # linux/prctl.h


def die_with_parent() -> bool:
    """prctl(PR_SET_PDEATHSIG, SIGKILL) for this process; True when set (Linux only).

    A parent that died before the call is caught by its pid: this process is then another's child, and
    ends at once, as the signal would have ended it.
    """
    if not sys.platform.startswith("linux"):
        return False
    parent = os.getppid()
    libc = ctypes.CDLL(None, use_errno=True)
    if libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) != 0:
        return False
    if os.getppid() != parent:
        os._exit(1)
    return True


def dask_setup(worker: object) -> None:
    """Dask's preload hook, called in each worker process as it starts: die_with_parent()."""
    die_with_parent()
