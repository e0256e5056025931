"""One engine for work that outgrows one process: Dask distributed.

:func:`map_tasks` runs a function over items as one task each: in this process when there is one item
(no cluster start-up cost), else on an embedded ``LocalCluster`` sized to the machine, or on an existing
cluster by its scheduler address (``dask scheduler`` and ``dask worker`` started elsewhere; the
argument, else ``$DASK_SCHEDULER_ADDRESS``). Results come back in the items' order. Ctrl-C cancels
the tasks not yet done and, for a local cluster, ends its worker processes at once.

Dask is the ``fleet`` extra (``pip install 'pendulum_accel[fleet]'``); it is imported on first use.
"""

from __future__ import annotations

import contextlib
import logging
import os
import socket
import struct
from collections.abc import Callable, Iterator, Sequence
from typing import TYPE_CHECKING, TypeVar

from pendulum_accel.errors import PendulumAccelError

if TYPE_CHECKING:  # Dask is the fleet extra, imported on first use
    from distributed import Client

T = TypeVar("T")
R = TypeVar("R")

Progress = Callable[[int], None]
"""Called with the number of tasks just finished (a progress bar's update)."""

CLOSE_TIMEOUT = 10.0  # s given to Dask to close a client or cluster; past it the processes are left to exit


SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")
"""The comms a Dask scheduler listens on from another process (distributed.comm.registry's backends, less
``inproc``, which only reaches a scheduler inside the process that started it)."""

PROBE_TIMEOUT = 3.0
"""s a scheduler is given to accept the connection, then to send its handshake. A TCP connect resends an
unanswered SYN after an initial RTO of 1 s (RFC 6298, Linux's), so 3 s covers one lost SYN and a 2 s
round trip, past any network a cluster runs on; a scheduler writes its handshake as soon as it accepts
(distributed/comm/core.py, Listener.on_connection), and an event loop blocked 3 s is what Dask itself
warns of (distributed.admin.tick.limit). Dask's own connect timeout (30 s) also waits for a scheduler
still starting up: an address given to a command names one that runs."""

HANDSHAKE_MAX = 1 << 20
"""Bytes a Dask handshake may announce: it is a few hundred (a msgpack dict of compression, pickle protocol
and versions); a length read from another protocol's greeting is of order 1e18."""


def scheduler_address(given: str | None) -> str | None:
    """The Dask scheduler to use: ``given``, else $DASK_SCHEDULER_ADDRESS (unset or empty: none), each
    checked by check_address; None for an embedded LocalCluster."""
    if given is not None:
        return check_address(given, "--scheduler")
    env = os.environ.get("DASK_SCHEDULER_ADDRESS")
    return check_address(env, "$DASK_SCHEDULER_ADDRESS") if env else None


def _host_port(location: str) -> tuple[str, str | None]:
    """(host, port text or None) of 'host:port', '[v6]:port', 'host'."""
    if location.startswith("["):
        host, _, rest = location[1:].partition("]")
        return host, rest[1:] if rest.startswith(":") else (rest or None)
    host, sep, port = location.rpartition(":")
    return (host, port) if sep else (location, None)


def check_address(address: str, source: str) -> str:
    """``address`` as Dask's Client takes it, 'SCHEME://HOST:PORT' (SCHEME in SCHEMES, tcp when left out,
    1 ≤ PORT ≤ 65535); a PendulumAccelError naming ``source`` (the option or variable) and what is wrong,
    where Dask would raise its own traceback (missing port number) or find an in-process scheduler."""
    example = "give the scheduler's tcp://HOST:PORT (8786 unless it was told otherwise)"
    if not address.strip():
        raise PendulumAccelError(f"{source} is empty: {example}, or leave it out for a local cluster")
    scheme, sep, location = address.partition("://")
    scheme = scheme.lower() if sep else "tcp"
    location = location if sep else address
    if scheme in ("http", "https"):
        raise PendulumAccelError(
            f"{source} {address!r} is a web address (a dashboard's?), not a Dask scheduler's: {example}"
        )
    if scheme == "inproc":
        raise PendulumAccelError(
            f"{source} {address!r} names a scheduler inside the process that started it, which no other "
            f"process reaches: {example}"
        )
    if scheme not in SCHEMES:
        raise PendulumAccelError(
            f"{source} {address!r}: unknown scheme {scheme!r} (Dask's are {', '.join(SCHEMES)}): {example}"
        )
    host, port = _host_port(location)
    if not host or port is None:
        raise PendulumAccelError(f"{source} {address!r} has no {'host' if port else 'port'}: {example}")
    if not (port.isascii() and port.isdigit() and 1 <= int(port) <= 65535):
        raise PendulumAccelError(f"{source} {address!r}: the port {port!r} is not a number from 1 to 65535")
    return address


def probe_scheduler(address: str) -> None:
    """Within 2 PROBE_TIMEOUT, a PendulumAccelError unless something at ``address`` (check_address's)
    accepts a connection and, on tcp, begins as a Dask scheduler does: an 8-byte frame length ("Q", as
    distributed/comm/tcp.py reads it) of at most HANDSHAKE_MAX. Dask's Client would allocate whatever
    length another protocol's greeting spells (3 EiB for 'SSH-2.0-'), or wait 30 s for an answer."""
    scheme, sep, location = address.partition("://")
    scheme = scheme.lower() if sep else "tcp"
    if scheme == "ucx":
        return  # UCX connects through its own layer, not a socket of ours
    host, port = _host_port(location if sep else address)
    try:
        sock = socket.create_connection((host, int(port or 0)), timeout=PROBE_TIMEOUT)
    except ConnectionRefusedError:
        raise PendulumAccelError(f"no Dask scheduler at {address}: nothing listens there (refused)") from None
    except TimeoutError:
        raise PendulumAccelError(
            f"cannot reach the Dask scheduler at {address}: no answer within {PROBE_TIMEOUT:g} s"
        ) from None
    except OSError as err:
        raise PendulumAccelError(
            f"cannot reach the Dask scheduler at {address}: {err.strerror or err}"
        ) from None
    with sock:
        if scheme != "tcp":
            return  # tls and websockets speak their own handshake first
        head = b""
        try:
            while len(head) < 8:
                chunk = sock.recv(8 - len(head))
                if not chunk:
                    break
                head += chunk
        except TimeoutError:
            pass
        except OSError as err:
            raise PendulumAccelError(
                f"the Dask scheduler at {address} broke the connection: {err.strerror}"
            ) from None
    if len(head) < 8:
        said = f" (it sent {head!r})" if head else ""
        raise PendulumAccelError(
            f"{address} accepted the connection but sent no Dask handshake within {PROBE_TIMEOUT:g} s{said}: "
            "is it a Dask scheduler?"
        )
    (length,) = struct.unpack("Q", head)
    if not 0 < length <= HANDSHAKE_MAX:
        raise PendulumAccelError(
            f"{address} answers, but not as a Dask scheduler (it began with {head!r}): is it the "
            "scheduler's port?"
        )


def _kill_local_workers() -> None:
    """SIGKILL every child process of this one: the local cluster's nannies, and with each its worker
    (cluster_worker.die_with_parent)."""
    import multiprocessing

    for child in multiprocessing.active_children():
        with contextlib.suppress(OSError, ValueError):
            child.kill()


@contextlib.contextmanager
def dask_client(address: str | None, workers: int | None) -> Iterator[Client]:
    """A distributed.Client on the scheduler at ``address``, or on an embedded LocalCluster of
    ``workers`` single-threaded worker processes (default: one per CPU this process may use)."""
    try:
        from distributed import Client, LocalCluster
    except ImportError as err:
        # Only a missing package is "not installed": an installed one that fails to import (a broken or
        # half-upgraded environment) says why, so the user does not reinstall what is there.
        if isinstance(err, ModuleNotFoundError) and (err.name or "").split(".")[0] in ("distributed", "dask"):
            raise PendulumAccelError(
                "this runs on Dask distributed, which is not installed: pip install 'pendulum_accel[fleet]'"
            ) from None
        raise PendulumAccelError(f"this runs on Dask distributed, which failed to import: {err}") from None
    if address is not None:
        probe_scheduler(address)
        try:
            client = Client(address, timeout=10)
        except (OSError, TimeoutError, MemoryError) as err:
            # MemoryError: a length from a peer that passed the probe and then spoke another protocol.
            raise PendulumAccelError(f"cannot reach the Dask scheduler at {address}: {err}") from None
        try:
            yield client
        finally:
            with contextlib.suppress(TimeoutError, OSError, RuntimeError):
                client.close(timeout=CLOSE_TIMEOUT)
        return
    n = workers or len(os.sched_getaffinity(0))
    # multiprocessing's resource tracker (a child started with the first worker) cleans up what a
    # worker killed on Ctrl-C held, and would print a warning about it after the one-line message.
    quiet = "ignore::UserWarning:multiprocessing.resource_tracker"
    os.environ["PYTHONWARNINGS"] = ",".join(w for w in (os.environ.get("PYTHONWARNINGS"), quiet) if w)
    try:
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            # The scheduler's HTTP server starts even without a dashboard, on port 8787 unless told
            # otherwise; a second run (or any other Dask cluster) then prints a UserWarning. A free
            # port on loopback only: no warning, and nothing listens on the machine's interfaces.
            dashboard_address="127.0.0.1:0",
            silence_logs=40,  # logging.ERROR: the terminal shows the bar and the errors only
            # Each worker ends with its nanny, even while a kernel holds its GIL (cluster_worker).
            preload=["pendulum_accel.cluster_worker"],
        )
        client = Client(cluster)
    except KeyboardInterrupt:
        _kill_local_workers()
        raise
    timeout = CLOSE_TIMEOUT
    interrupted = False
    # silence_logs holds only while Dask's objects live: closing them puts their handlers back to INFO,
    # and the in-process scheduler, still writing to workers Ctrl-C has just killed, then logs "Batched
    # Comm Closed" with a traceback after the one-line message. The "distributed" logger itself stays
    # at ERROR through the shutdown; after an interrupt it is left there (the process is ending).
    dask_logger = logging.getLogger("distributed")
    level = dask_logger.level
    dask_logger.setLevel(logging.ERROR)
    try:
        yield client
    except KeyboardInterrupt:
        # Ctrl-C: the user wants the terminal back now, not after a graceful drain. The local workers
        # are this process's children; killing them ends their tasks at once (their results go nowhere:
        # callers write their output only after every task has returned).
        interrupted = True
        _kill_local_workers()
        timeout = 0.2
        raise
    finally:
        # A slow shutdown (a loaded machine) must not turn finished work into a traceback.
        with contextlib.suppress(TimeoutError, OSError, RuntimeError):
            client.close(timeout=timeout)
        with contextlib.suppress(TimeoutError, OSError, RuntimeError):
            cluster.close(timeout=timeout)
        if not interrupted:
            dask_logger.setLevel(level)


def _on_client(fn: Callable[[T], R], items: Sequence[T], client: Client, progress: Progress) -> list[R]:
    """fn of each item as one Dask task; results in the order of ``items``. On any exception (Ctrl-C
    included) the tasks not yet finished are cancelled before it propagates."""
    from distributed import as_completed

    futures = client.map(fn, list(items), pure=False)
    index = {f.key: i for i, f in enumerate(futures)}
    done: dict[int, R] = {}
    try:
        for future in as_completed(futures):
            done[index[future.key]] = future.result()
            progress(1)
    except BaseException:
        client.cancel(futures, force=True)
        raise
    return [done[i] for i in range(len(futures))]


def map_tasks(
    fn: Callable[[T], R],
    items: Sequence[T],
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Progress | None = None,
    distributed: bool | None = None,
    client: Client | None = None,
) -> list[R]:
    """[fn(x) for x in items], one task per item. ``distributed`` None: one item runs in this process,
    several on Dask (``scheduler`` or $DASK_SCHEDULER_ADDRESS, else a LocalCluster of ``workers``
    processes); True or False forces the choice; a ``client`` given (dask_client's) is used as it is.
    ``fn`` and the items must pickle (a module-level function, a functools.partial of one)."""
    tick = progress or (lambda n: None)
    if client is not None:
        return _on_client(fn, items, client, tick)
    address = scheduler_address(scheduler)
    if distributed is None:
        distributed = address is not None or len(items) > 1
    if not distributed:
        out = []
        for item in items:
            out.append(fn(item))
            tick(1)
        return out
    with dask_client(address, workers) as client:
        return _on_client(fn, items, client, tick)
