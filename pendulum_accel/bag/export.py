"""A bag as tables (pandas): one per topic, or one merged on the angle's stamps; CSV or Parquet files.

Column names are PlotJuggler's: topic, then the field path with "/" between names and "[i]" for array
elements (``/car/accel/estimate/accel/accel/linear/x``, ``/pendulum/joint_states/position[0]``).
Every table starts with ``t`` (the message stamp, s) and ``log_time`` (s). Fixed-layout topics are
decoded in bulk by the package's reader; the others (``/diagnostics``: strings, variable lengths) are
deserialised message by message and flattened, strings included. pandas (and pyarrow for Parquet) are
the optional ``export`` extra, imported only here.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.reader import Bag
from pendulum_accel.errors import PendulumAccelError

FORMATS = ("csv", "parquet")
BULK_TYPES = frozenset({bm.JOINT_STATE, bm.ACCEL_STAMPED, bm.ACCEL_WITH_COVARIANCE_STAMPED, bm.CLOCK})
"""Message types whose fields sit at fixed offsets in every message the chain writes: decoded in bulk."""
MERGED_NAME = "merged"
PER_SAMPLE_TOPICS = frozenset({bm.TOPIC_ACCEL_TRUTH, bm.TOPIC_ACCEL_ESTIMATE, bm.TOPIC_STRING})
"""Topics stamped with the angle's stamp: merged on equal stamps (a missing estimate stays missing)."""


class ExportError(PendulumAccelError):
    """Export impossible: a missing optional dependency, an unknown format or topic."""


def _pandas() -> ModuleType:
    """The pandas module; ExportError with the install line when the extra is missing."""
    try:
        import pandas
    except ImportError:
        raise ExportError(
            "export needs pandas (and pyarrow for Parquet): pip install 'pendulum_accel[export]'"
        ) from None
    return pandas


def column_name(topic: str, path: str) -> str:
    """PlotJuggler's name of field ``path`` of ``topic``: topic + "/" + path with "." → "/"."""
    return f"{topic}/{path.replace('.', '/')}"


def _flatten(value: object, path: str, out: dict[str, object]) -> None:
    """out[path.sub.field[i]...] = every leaf (numbers and strings) of a deserialised message."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        for field in dataclasses.fields(value):
            if field.name == "__msgtype__" or field.name.isupper():
                continue  # ROS constants are upper case, fields lower case
            _flatten(getattr(value, field.name), f"{path}.{field.name}" if path else field.name, out)
    elif isinstance(value, (list, tuple, np.ndarray)):
        for i, item in enumerate(value):
            _flatten(item, f"{path}[{i}]", out)
    elif isinstance(value, np.generic):
        out[path] = value.item()
    else:
        out[path] = value


def topic_table(bag: Bag, topic: str) -> Any:
    """DataFrame of one topic: t, log_time, then every field as PlotJuggler names it, one row per message."""
    pd = _pandas()
    msgtype = bag.topics[topic].msgtype if topic in bag.topics else None
    if msgtype in BULK_TYPES:
        arrays = bag.decode(topic)
        t = arrays.stamp
        log_time = arrays.log_time_ns
        columns: dict[str, Any] = {column_name(topic, p): col for p, col in arrays.fields.items()}
    else:
        times, payloads = bag.raw(topic)
        rows: list[dict[str, object]] = []
        for data in payloads:
            row: dict[str, object] = {}
            _flatten(bm.deserialize(data, str(msgtype)), "", row)
            rows.append(row)
        flat = pd.DataFrame.from_records(rows)
        log_time = times
        stamp = ("header.stamp.sec", "header.stamp.nanosec")
        if len(flat) and all(k in flat.columns for k in stamp):
            t = bm.stamp_seconds(flat[stamp[0]].to_numpy(), flat[stamp[1]].to_numpy())
        else:
            t = times.astype(np.float64) * 1e-9
        columns = {column_name(topic, str(p)): flat[p].to_numpy() for p in flat.columns}
    head = {"t": np.asarray(t, dtype=np.float64), "log_time": np.asarray(log_time) * 1e-9}
    return pd.DataFrame({**head, **columns})


def merged_table(bag: Bag, topics: Sequence[str]) -> Any:
    """One DataFrame on the angle's stamps: a per-sample topic's row with the same stamp (truth, estimate,
    string), any other topic's (/clock, /diagnostics) latest row at or before the stamp."""
    pd = _pandas()
    base = topic_table(bag, bm.TOPIC_JOINT_STATES).drop(columns=["log_time"]).sort_values("t", kind="stable")
    for topic in topics:
        if topic == bm.TOPIC_JOINT_STATES:
            continue
        other = topic_table(bag, topic).drop(columns=["log_time"]).sort_values("t", kind="stable")
        if topic in PER_SAMPLE_TOPICS:
            base = base.merge(other.drop_duplicates("t", keep="last"), on="t", how="left")
        else:
            base = pd.merge_asof(base, other, on="t", direction="backward")
    return base.reset_index(drop=True)


def file_stem(topic: str) -> str:
    """File name of a topic's table: the topic without its leading "/", "/" → "__"."""
    return topic.strip("/").replace("/", "__")


def export_bag(
    bag: Bag, out: Path | str, *, fmt: str = "csv", merged: bool = False, topics: Sequence[str] = ()
) -> list[Path]:
    """Write ``topics`` (default: all) of ``bag`` under directory ``out`` as CSV or Parquet; the paths."""
    if fmt not in FORMATS:
        raise ExportError(f"unknown format {fmt!r}; use {' or '.join(FORMATS)}")
    _pandas()
    if fmt == "parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            raise ExportError("Parquet export needs pyarrow: pip install 'pendulum_accel[export]'") from None
    chosen = list(topics) or list(bag.topics)
    unknown = [t for t in chosen if t not in bag.topics]
    if unknown:
        raise ExportError(f"bag {bag.path} has no topic {unknown[0]} (it has {', '.join(bag.topics)})")
    if merged and bm.TOPIC_JOINT_STATES not in bag.topics:
        raise ExportError(f"bag {bag.path} has no {bm.TOPIC_JOINT_STATES} to merge on")
    tables = (
        {MERGED_NAME: merged_table(bag, chosen)}
        if merged
        else {file_stem(t): topic_table(bag, t) for t in chosen}
    )
    directory = Path(out)
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ExportError(f"cannot create {directory}: {err.strerror}") from None
    paths = []
    for stem, table in tables.items():
        path = directory / f"{stem}.{fmt}"
        if fmt == "csv":
            table.to_csv(path, index=False, float_format="%.17g")
        else:
            table.to_parquet(path, index=False)
        paths.append(path)
    return paths
