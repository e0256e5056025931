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
import csv
import functools
import glob
import math
import os
import sys
import tempfile
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO, TypedDict, Unpack, cast

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.bag.reader import read_bag
from pendulum_accel.cluster import Progress, map_tasks
from pendulum_accel.errors import BagError, PendulumAccelError
from pendulum_accel.recording import coverage
from pendulum_accel.recording.analyze import Analysis, analyze_bag
from pendulum_accel.recording.delay import group_delay
from pendulum_accel.recording.topic_rules import TopicRules

COLUMNS: tuple[tuple[str, str, str], ...] = (
    ("bag", "string", "the bag's path, as found"),
    ("estimator", "string", "the method re-run on the bag's angles"),
    ("motion_model", "string", "the motion model the estimate used (kalman's preset), empty for others"),
    (
        "truth",
        "bool",
        "the bag has a truth topic; without one (a real sensor's bag) the error and calibration columns "
        "are null",
    ),
    ("estimate_mean", "double", "mean â over the re-run's estimates (m/s²): no truth needed"),
    ("sigma_median", "double", "median published σ of the re-run's estimates (m/s²): no truth needed"),
    ("rms", "double", "√(mean e²) of e = â − a over the re-run's estimates (m/s²)"),
    ("bias", "double", "mean e (m/s²)"),
    ("max_error", "double", "max |e| (m/s²)"),
    (
        "delay",
        "double",
        "lag τ (s) maximising the cross-correlation of â(t) and a(t − τ); null where a(t) "
        "does not vary (a constant has no delay to measure)",
    ),
    ("share_2sigma_steady", "double", "share of steady-state errors beyond 2σ of the published variance"),
    ("trials_steady", "double", "independent errors behind share_2sigma_steady (recording/coverage.py)"),
    ("share_2sigma_steady_low", "double", "lower end of that share's 95 % Wilson interval at those trials"),
    ("share_2sigma_steady_high", "double", "upper end of that interval"),
    (
        "share_3sigma_steady",
        "double",
        "share of steady-state errors beyond 3σ (a calibrated Gaussian σ: 0.27 %)",
    ),
    ("share_2sigma_after_change", "double", "share of errors beyond 2σ within 2 s after a change of a(t)"),
    ("trials_after_change", "double", "independent errors behind share_2sigma_after_change"),
    ("share_2sigma_after_change_low", "double", "lower end of that share's 95 % Wilson interval"),
    ("share_2sigma_after_change_high", "double", "upper end of that interval"),
    ("share_3sigma_after_change", "double", "share of errors beyond 3σ within 2 s after a change of a(t)"),
    ("nees_mean", "double", "mean e²/σ² over every estimate (1 when σ tells the truth)"),
    ("duration", "double", "the bag's span of angles (s)"),
    ("angles", "int64", "joint-state samples in the bag"),
    ("complete", "bool", "the bag read whole: every record framed and every checksum held"),
    ("error", "string", "why the bag gave no figures (empty when it did)"),
)
"""The results table: (column, Arrow type, meaning). docs/fleet.md is generated from it."""

COLUMN_NAMES = tuple(name for name, _, _ in COLUMNS)


class FleetCells(TypedDict, total=False):
    """The cells a row is given, by :data:`COLUMNS`' names (all but ``bag``); None is the table's null."""

    estimator: str
    motion_model: str
    truth: bool
    estimate_mean: float | None
    sigma_median: float | None
    rms: float | None
    bias: float | None
    max_error: float | None
    delay: float | None
    share_2sigma_steady: float | None
    trials_steady: float | None
    share_2sigma_steady_low: float | None
    share_2sigma_steady_high: float | None
    share_3sigma_steady: float | None
    share_2sigma_after_change: float | None
    trials_after_change: float | None
    share_2sigma_after_change_low: float | None
    share_2sigma_after_change_high: float | None
    share_3sigma_after_change: float | None
    nees_mean: float | None
    duration: float | None
    angles: int
    complete: bool
    error: str


class FleetRow(FleetCells):
    """One row of the results table: every column of :data:`COLUMNS`, in its order, None where the row
    was not given it (an unreadable bag's row holds its ``error`` only)."""

    bag: str


def _float(x: float | None) -> float | None:
    """x, or None where it is not a finite number (the table's null, never NaN)."""
    return None if x is None or not math.isfinite(x) else float(x)


def _row(bag: str, **values: Unpack[FleetCells]) -> FleetRow:
    """One table row: every column, None where not given."""
    row: dict[str, object] = dict.fromkeys(COLUMN_NAMES)
    row.update(bag=bag, **values)
    # Every column of COLUMNS, which are FleetRow's keys (test_fleet holds them equal).
    return cast(FleetRow, row)


def _figures(result: Analysis, complete: bool) -> FleetCells:
    """The table's figures of one re-run."""
    keep = np.isfinite(result.accel_est) & (result.t >= result.t[0] + result.skip)
    delay = math.nan
    if keep.sum() >= 8 and result.has_truth:  # a delay behind the truth: none without one
        rate = (keep.sum() - 1) / max(float(result.t[keep][-1] - result.t[keep][0]), 1e-12)
        delay = group_delay(result.accel_est[keep], result.accel_true[keep], rate)
    with np.errstate(divide="ignore", invalid="ignore"):
        nees: NDArray[np.float64] = np.where(
            result.variance > 0.0, (result.accel_est - result.accel_true) ** 2 / result.variance, np.nan
        )
    nees = nees[keep & np.isfinite(nees)]
    cal = result.calibration
    # One window's cells: the shares beyond 2σ and 3σ, the trials and interval; None without samples.
    steady = coverage.nees_cells(None if cal is None else cal.steady)
    after = coverage.nees_cells(None if cal is None else cal.after_change)
    return {
        "estimator": result.estimator,
        "motion_model": result.motion.preset if result.motion is not None else "",
        "truth": result.has_truth,
        "estimate_mean": _float(result.offline_figures.values.mean),
        "sigma_median": _float(result.offline_figures.values.sigma_median),
        "rms": _float(result.stats.rms),
        "bias": _float(result.stats.bias),
        "max_error": _float(result.stats.max_abs),
        "delay": _float(delay),
        "share_2sigma_steady": steady.share_2sigma,
        "trials_steady": steady.trials,
        "share_2sigma_steady_low": steady.share_2sigma_low,
        "share_2sigma_steady_high": steady.share_2sigma_high,
        "share_3sigma_steady": steady.share_3sigma,
        "share_2sigma_after_change": after.share_2sigma,
        "trials_after_change": after.trials,
        "share_2sigma_after_change_low": after.share_2sigma_low,
        "share_2sigma_after_change_high": after.share_2sigma_high,
        "share_3sigma_after_change": after.share_3sigma,
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
    topics: TopicRules = field(default_factory=TopicRules)
    """--topic, --namespace and --joint, applied to every bag."""


def bag_rows(path: str, job: Job) -> list[FleetRow]:
    """One row per estimator of ``job`` for the bag at ``path``; one row with ``error`` when the bag
    cannot be analysed. Never raises for a bad bag: a fleet's other bags must still finish."""
    try:
        bag = job.topics.apply(read_bag(path, salvage=False))
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


def analyze_many(
    paths: Sequence[Path],
    job: Job,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Progress | None = None,
    distributed: bool | None = None,
) -> list[FleetRow]:
    """Rows (:data:`COLUMNS`) of every bag × estimator, in the order of ``paths``: one task per bag
    (cluster.map_tasks: one bag in this process, several on Dask)."""
    parts = map_tasks(
        functools.partial(bag_rows, job=job),
        [str(p) for p in paths],
        scheduler=scheduler,
        workers=workers,
        progress=progress,
        distributed=distributed,
    )
    return [row for part in parts for row in part]


def write_rows(
    rows: Sequence[Mapping[str, object]], path: Path, columns: Sequence[tuple[str, str, str]] | None = None
) -> None:
    """Write ``rows`` to ``path`` as Parquet (.parquet) or CSV (.csv): under a temporary name beside it,
    then renamed onto it, so an interrupted or failed write leaves nothing under the asked name (a
    device or FIFO is written as it is). ``columns`` (name, Arrow type, meaning) fixes the order and
    types; None takes the first row's keys and lets Arrow infer the types."""
    names = [c[0] for c in columns] if columns is not None else list(rows[0]) if rows else []
    if path.exists() and not path.is_file():
        _write_rows(rows, path, names, columns)
        return
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        _write_rows(rows, Path(tmp), names, columns)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def _write_rows(
    rows: Sequence[Mapping[str, object]],
    path: Path,
    names: Sequence[str],
    columns: Sequence[tuple[str, str, str]] | None,
) -> None:
    """The table in the format its suffix names."""
    if path.suffix.lower() == ".parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        schema = None if columns is None else pa.schema([(n, pa.type_for_alias(k)) for n, k, _ in columns])
        pq.write_table(pa.Table.from_pylist(list(rows), schema=schema), path)
        return
    with path.open("w", newline="", encoding="utf-8") as handle:
        write_csv(rows, handle, names)


def write_csv(
    rows: Sequence[Mapping[str, object]], handle: TextIO, names: Sequence[str] = COLUMN_NAMES
) -> None:
    """``rows`` as CSV with a header line; a null is an empty field."""
    writer = csv.DictWriter(handle, fieldnames=list(names), lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if v is None else v) for k, v in row.items()})


def stderr_progress(total: int, unit: str = "bag") -> tuple[Progress, Callable[[], None]]:
    """(tick, close) of a tqdm bar on standard error when it is a terminal, silent otherwise."""
    from tqdm import tqdm

    bar = tqdm(total=total, unit=unit, disable=not sys.stderr.isatty(), file=sys.stderr, leave=False)
    return bar.update, bar.close
