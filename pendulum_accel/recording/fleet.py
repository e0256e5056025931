"""Many bags, one table: ``analyze`` over a fleet's or a test campaign's recordings.

Each bag is one task: it is read, every asked estimator is re-run on its angles, and it gives one row per
estimator (:data:`COLUMNS`). A bag that cannot be analysed (damaged, foreign, empty, unreadable) gives
one row with its ``error`` and the others still finish. One bag runs in this process; several run on
Dask distributed (:func:`analyze_many`): an embedded ``LocalCluster`` sized to the machine, or an
existing cluster by its scheduler address. Workers open the bags by path, so every worker must see the
same paths (one machine, a shared filesystem or a mounted object store).
"""

from __future__ import annotations

import contextlib
import glob
import math
import os
import sys
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.bag.reader import read_bag
from pendulum_accel.errors import BagError, PendulumAccelError
from pendulum_accel.recording.analyze import Analysis, analyze_bag
from pendulum_accel.recording.delay import group_delay

COLUMNS: tuple[tuple[str, str, str], ...] = (
    ("bag", "string", "the bag's path, as found"),
    ("estimator", "string", "the method re-run on the bag's angles"),
    ("motion_model", "string", "the motion model the estimate used (kalman's preset), empty for others"),
    ("rms", "double", "√(mean e²) of e = â − a over the re-run's estimates (m/s²)"),
    ("bias", "double", "mean e (m/s²)"),
    ("max_error", "double", "max |e| (m/s²)"),
    ("delay", "double", "lag τ (s) maximising the cross-correlation of â(t) and a(t − τ)"),
    ("share_2sigma_steady", "double", "share of steady-state errors beyond 2σ of the published variance"),
    ("share_2sigma_after_change", "double", "the same within 2 s after a change of a(t)"),
    ("nees_mean", "double", "mean e²/σ² over every estimate (1 when σ tells the truth)"),
    ("duration", "double", "the bag's span of angles (s)"),
    ("angles", "int64", "joint-state samples in the bag"),
    ("complete", "bool", "the bag read whole: every record framed and every checksum held"),
    ("error", "string", "why the bag gave no figures (empty when it did)"),
)
"""The results table: (column, Arrow type, meaning). docs/fleet.md is generated from it."""

COLUMN_NAMES = tuple(name for name, _, _ in COLUMNS)


def _float(x: float | None) -> float | None:
    """x, or None where it is not a finite number (the table's null, never NaN)."""
    return None if x is None or not math.isfinite(x) else float(x)


def _row(bag: str, **values: Any) -> dict[str, Any]:
    """One table row: every column, None where not given."""
    row: dict[str, Any] = dict.fromkeys(COLUMN_NAMES)
    row.update(bag=bag, **values)
    return row


def _figures(result: Analysis, complete: bool) -> dict[str, Any]:
    """The table's figures of one re-run."""
    keep = np.isfinite(result.accel_est) & (result.t >= result.t[0] + result.skip)
    delay = math.nan
    if keep.sum() >= 8:
        rate = (keep.sum() - 1) / max(float(result.t[keep][-1] - result.t[keep][0]), 1e-12)
        delay = group_delay(result.accel_est[keep], result.accel_true[keep], rate)
    with np.errstate(divide="ignore", invalid="ignore"):
        nees: NDArray[np.float64] = np.where(
            result.variance > 0.0, (result.accel_est - result.accel_true) ** 2 / result.variance, np.nan
        )
    nees = nees[keep & np.isfinite(nees)]
    cal = result.calibration
    return {
        "estimator": result.estimator,
        "motion_model": result.motion.preset if result.motion is not None else "",
        "rms": _float(result.stats.rms),
        "bias": _float(result.stats.bias),
        "max_error": _float(result.stats.max_abs),
        "delay": _float(delay),
        "share_2sigma_steady": _float(cal.steady.share_2sigma) if cal is not None else None,
        "share_2sigma_after_change": _float(cal.after_change.share_2sigma) if cal is not None else None,
        "nees_mean": _float(float(nees.mean())) if nees.size else None,
        "duration": _float(float(result.t[-1] - result.t[0])),
        "angles": int(result.t.size),
        "complete": complete,
        "error": "",
    }


@dataclass(frozen=True)
class Job:
    """What every bag is asked: the estimators to re-run (None: the one each bag was recorded with) and
    analyze's options."""

    estimators: tuple[str | None, ...] = (None,)
    skip: float = 0.0
    lag: float = 0.0
    config: dict[str, float] = field(default_factory=dict)


def bag_rows(path: str, job: Job) -> list[dict[str, Any]]:
    """One row per estimator of ``job`` for the bag at ``path``; one row with ``error`` when the bag
    cannot be analysed. Never raises for a bad bag: a fleet's other bags must still finish."""
    try:
        bag = read_bag(path, salvage=False)
    except PendulumAccelError as err:
        return [_row(path, error=str(err), complete=False)]
    except (OSError, ValueError, MemoryError) as err:
        return [_row(path, error=f"cannot read {path}: {err}", complete=False)]
    rows = []
    for estimator in job.estimators:
        try:
            result = analyze_bag(
                bag, estimator=estimator, config=dict(job.config), skip=job.skip, lag=job.lag
            )
        except PendulumAccelError as err:
            rows.append(_row(path, estimator=estimator or "", error=str(err), complete=bag.problem is None))
            continue
        except (ValueError, ArithmeticError, MemoryError) as err:
            # A bag no contract check foresaw: still a row, never the end of the fleet's run.
            message = f"{type(err).__name__}: {err}"
            rows.append(_row(path, estimator=estimator or "", error=message, complete=bag.problem is None))
            continue
        rows.append(_row(path, **_figures(result, bag.problem is None)))
    return rows


_GLOB_CHARS = frozenset("*?[")


def is_bag_dir(path: Path) -> bool:
    """A bag directory holds its metadata.yaml, or (a recording cut off before writing it) .mcap files
    and no subdirectory; .mcap files beside subdirectories are loose bags of a tree."""
    if (path / "metadata.yaml").is_file():
        return True
    try:
        entries = list(path.iterdir())
    except OSError:
        return False
    return any(e.suffix == ".mcap" and e.is_file() for e in entries) and not any(e.is_dir() for e in entries)


def _bags_below(root: Path) -> Iterator[Path]:
    """Every bag at or below ``root``: bag directories (not entered further) and loose .mcap files, in
    sorted order; symbolic links to directories are not followed (a loop cannot hang the walk)."""
    if is_bag_dir(root):
        yield root
        return
    for top, dirs, files in os.walk(root):
        dirs.sort()
        here = Path(top)
        for name in sorted(f for f in files if f.endswith(".mcap")):
            yield here / name
        keep = []
        for d in dirs:
            if is_bag_dir(here / d):
                yield here / d
            else:
                keep.append(d)
        dirs[:] = keep


def find_bags(inputs: Sequence[str]) -> list[Path]:
    """The bags named by ``inputs``: bag directories, .mcap files, directory trees (every bag below) and
    glob patterns (``**`` recursive), in order, each bag once. BagError for an input that names nothing
    (a typo must not pass as an empty fleet)."""
    found: dict[Path, None] = {}
    for item in inputs:
        if _GLOB_CHARS & set(item) and not Path(item).exists():
            matches = sorted(glob.glob(item, recursive=True))
            if not matches:
                raise BagError(f"{item!r} matches no file or directory")
            paths = [Path(m) for m in matches]
        else:
            paths = [Path(item)]
        for path in paths:
            if path.is_dir():
                for bag in _bags_below(path):
                    found.setdefault(bag, None)
            elif path.exists():
                found.setdefault(path, None)
            else:
                raise BagError(f"bag {path} does not exist")
    return list(found)


Progress = Callable[[int], None]

CLOSE_TIMEOUT = 10.0  # s given to Dask to close a client or cluster; past it the processes are left to exit


def _serial(paths: Sequence[Path], job: Job, progress: Progress) -> list[list[dict[str, Any]]]:
    """bag_rows of each path, in this process."""
    out = []
    for path in paths:
        out.append(bag_rows(str(path), job))
        progress(1)
    return out


def scheduler_address(given: str | None) -> str | None:
    """The Dask scheduler to use: ``given``, else $DASK_SCHEDULER_ADDRESS, else None (an embedded
    LocalCluster)."""
    return given or os.environ.get("DASK_SCHEDULER_ADDRESS") or None


@contextlib.contextmanager
def dask_client(address: str | None, workers: int | None) -> Iterator[Any]:
    """A distributed.Client on the scheduler at ``address``, or on an embedded LocalCluster of
    ``workers`` single-threaded worker processes (default: one per CPU this process may use)."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        raise PendulumAccelError(
            "analysing several bags runs on Dask distributed, which is not installed: "
            "pip install 'pendulum_accel[fleet]'"
        ) from None
    if address is not None:
        try:
            client = Client(address, timeout=10)
        except (OSError, TimeoutError) as err:
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
            dashboard_address=None,
            silence_logs=40,  # logging.ERROR: a fleet run's terminal shows the bar and the errors only
        )
        client = Client(cluster)
    except KeyboardInterrupt:
        _kill_local_workers()
        raise
    timeout = CLOSE_TIMEOUT
    try:
        yield client
    except KeyboardInterrupt:
        # Ctrl-C: the user wants the terminal back now, not after a graceful drain. The local workers
        # are this process's children; killing them ends their tasks at once (nothing they hold is
        # written anywhere: the table is written only after every task has returned).
        _kill_local_workers()
        timeout = 0.2
        raise
    finally:
        # A slow shutdown (a loaded machine) must not turn a finished table into a traceback.
        with contextlib.suppress(TimeoutError, OSError, RuntimeError):
            client.close(timeout=timeout)
        with contextlib.suppress(TimeoutError, OSError, RuntimeError):
            cluster.close(timeout=timeout)


def _kill_local_workers() -> None:
    """SIGKILL every child process of this one (the local cluster's nannies and workers)."""
    import multiprocessing

    for child in multiprocessing.active_children():
        with contextlib.suppress(OSError, ValueError):
            child.kill()


def _distributed(
    paths: Sequence[Path], job: Job, client: Any, progress: Progress
) -> list[list[dict[str, Any]]]:
    """bag_rows of each path as one Dask task per bag; results in the order of ``paths``. On
    KeyboardInterrupt the tasks not yet finished are cancelled before it propagates."""
    from distributed import as_completed

    futures = client.map(bag_rows, [str(p) for p in paths], job=job, pure=False)
    index = {f.key: i for i, f in enumerate(futures)}
    out: list[list[dict[str, Any]]] = [[] for _ in paths]
    try:
        for future in as_completed(futures):
            out[index[future.key]] = future.result()
            progress(1)
    except BaseException:
        client.cancel(futures, force=True)
        raise
    return out


def analyze_many(
    paths: Sequence[Path],
    job: Job,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Progress | None = None,
    distributed: bool | None = None,
) -> list[dict[str, Any]]:
    """Rows (:data:`COLUMNS`) of every bag × estimator, in the order of ``paths``.

    ``distributed`` None: one bag runs in this process (no cluster start-up cost), several on Dask
    (``scheduler`` or $DASK_SCHEDULER_ADDRESS, else a LocalCluster of ``workers``)."""
    tick = progress or (lambda n: None)
    address = scheduler_address(scheduler)
    if distributed is None:
        distributed = address is not None or len(paths) > 1
    if not distributed:
        parts = _serial(paths, job, tick)
    else:
        with dask_client(address, workers) as client:
            parts = _distributed(paths, job, client, tick)
    return [row for part in parts for row in part]


def write_table(rows: Sequence[dict[str, Any]], path: Path) -> None:
    """Write ``rows`` to ``path`` as Parquet (.parquet) or CSV (.csv), columns in :data:`COLUMNS` order
    (the caller makes the write atomic)."""
    if path.suffix.lower() == ".parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        schema = pa.schema([(name, pa.type_for_alias(kind)) for name, kind, _ in COLUMNS])
        pq.write_table(pa.Table.from_pylist(list(rows), schema=schema), path)
        return
    with path.open("w", newline="", encoding="utf-8") as handle:
        write_csv(rows, handle)


def write_csv(rows: Sequence[dict[str, Any]], handle: Any) -> None:
    """``rows`` as CSV with a header line; a null is an empty field."""
    import csv

    writer = csv.DictWriter(handle, fieldnames=COLUMN_NAMES, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if v is None else v) for k, v in row.items()})


def stderr_progress(total: int) -> tuple[Progress, Callable[[], None]]:
    """(tick, close) of a tqdm bar on standard error when it is a terminal, silent otherwise."""
    from tqdm import tqdm

    bar = tqdm(total=total, unit="bag", disable=not sys.stderr.isatty(), file=sys.stderr, leave=False)
    return bar.update, bar.close
