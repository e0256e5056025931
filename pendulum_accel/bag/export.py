"""A bag as tables (pandas): one per topic, or one merged on the angle's stamps; CSV or Parquet files.

Column names are PlotJuggler's (its ROS parser, plotjuggler-ros / ParserROS): topic, then the field
path with "/" between names and "[i]" for array elements (``/car/accel/estimate/accel/accel/linear/x``,
``/car/accel/estimate/accel/covariance[0]``), with its two special cases for our types: a JointState
joint's values are ``topic/<joint name>/position`` (``velocity``, ``effort``), and a DiagnosticArray
status's key/value pairs are ``topic/<hardware_id>/<name>/<key>`` (numbers where every value of the
key parses as one), to which ``level`` and ``message`` are added under the same prefix. Every table
starts with ``t`` (the message stamp, s) and ``log_time`` (s). Fixed-layout topics are decoded in
bulk by the package's reader, those of other types too (a robot's Odometry, Twist, …) when every
message has the same numeric fields, at most ``MAX_COLUMNS``; /diagnostics is deserialised message by
message. A topic's table is written as it is decoded, ``BATCH_ROWS`` messages at a time
(``Bag.decode_batches``): memory does not grow with the bag. ``--merged`` is a k-way merge on the
stamps: the angles a batch at a time, each other topic read ahead as far as they go
(``merged_frames``). pandas (and pyarrow for Parquet) are the optional
``export`` extra, imported only here.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, TextIO

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.cdr_layout import Layout
from pendulum_accel.bag.errors import BagError, ExportError
from pendulum_accel.bag.reader import Bag

if TYPE_CHECKING:  # pandas is the optional export extra: imported at run time only by _pandas()
    from pandas import DataFrame

FORMATS = ("csv", "parquet")
BULK_TYPES = frozenset({bm.JOINT_STATE, bm.ACCEL_STAMPED, bm.ACCEL_WITH_COVARIANCE_STAMPED, bm.CLOCK, bm.IMU})
"""Message types whose fields sit at fixed offsets in every message the chain writes: decoded in bulk."""
MERGED_NAME = "merged"
PER_SAMPLE_ROLES = frozenset({bm.ACCEL_TRUTH, bm.ACCEL_ESTIMATE, bm.STRING, bm.IMU_DATA_RAW})
"""Topics (by role, any namespace) stamped with the angle's stamp: merged on equal stamps (a missing
estimate or Imu stays missing)."""


BATCH_ROWS = 1 << 17
"""Messages per batch when a topic's table is written as it is decoded (about 40 MiB for an Imu's)."""
MERGE_ROWS = 1 << 13
"""Angles per batch of the merged table, and rows per batch of each topic read ahead for it: a merged row
holds every topic's columns (113 for the chain), and pandas copies a batch at each join (8192 rows: about
7 MiB a copy)."""
VISUAL_ROLES = frozenset({bm.MARKERS, bm.ROBOT_DESCRIPTION})
"""Topics export leaves out unless named: what RViz and Foxglove draw, no table to flatten."""


Series = Mapping[str, NDArray[np.float64]]
"""A derived series: {"t": stamps, column: values}."""
SeriesSource = Series | Callable[[], Series | None]
"""A derived series, or what computes it when its table is written (None: nothing to write)."""


def _pandas() -> ModuleType:
    """The pandas module; ExportError with the install line when the extra is missing."""
    try:
        import pandas
    except ImportError:
        raise ExportError(
            "export needs pandas (and pyarrow for Parquet): pip install 'pendulum_accel[export]'"
        ) from None
    result: ModuleType = pandas
    return result


def column_name(topic: str, path: str) -> str:
    """PlotJuggler's name of field ``path`` of ``topic``: topic + "/" + path with "." → "/"."""
    return f"{topic}/{path.replace('.', '/')}"


def _joint_renames(bag: Bag, topic: str, paths: Sequence[str]) -> dict[str, str]:
    """{reader path: PlotJuggler series suffix} of a JointState topic: position[i] → <name i>/position
    (the names of its first message's shape)."""
    shapes = bag.shapes(topic, bm.JOINT_STATE)
    names = [str(n) for n in getattr(shapes[0][0], "name", [])] if shapes else []
    renames = {}
    for path in paths:
        head, _, index = path.partition("[")
        if head in ("position", "velocity", "effort") and index and int(index[:-1]) < len(names):
            renames[path] = f"{names[int(index[:-1])]}/{head}"
    return renames


def _diagnostic_columns(
    bag: Bag, topic: str, pd: ModuleType
) -> tuple[NDArray[np.float64], NDArray[np.int64], dict[str, NDArray[np.generic]]]:
    """(t, log time ns, columns) of a DiagnosticArray topic: PlotJuggler's series (hardware_id/name/key)
    plus level and message, one row per message that decodes correctly (messages.canonical_cdr); the
    others are skipped and named in ``bag.problem``, as Bag.decode does."""
    log_times, payloads = bag.raw(topic)
    rows: list[dict[str, object]] = []
    stamps: list[float] = []
    kept: list[int] = []
    for i, data in enumerate(payloads):
        try:
            msg, _ = bm.canonical_cdr(data, bm.DIAGNOSTIC_ARRAY)
        except BagError:
            continue
        if not isinstance(msg, bm.DiagnosticArrayMsg):
            continue
        row: dict[str, object] = {}
        for status in msg.status:
            # A status named by its node's full name (/car1/accel_estimator) joins without a double slash.
            parts = (status.hardware_id.strip("/"), status.name.strip("/"))
            prefix = "/".join([topic, *(p for p in parts if p)])
            row[f"{prefix}/level"] = int(status.level)
            row[f"{prefix}/message"] = status.message
            for kv in status.values:
                row[f"{prefix}/{kv.key}"] = kv.value
        rows.append(row)
        stamps.append(float(bm.stamp_seconds(msg.header.stamp.sec, msg.header.stamp.nanosec)))
        kept.append(i)
    skipped = len(payloads) - len(kept)
    if skipped:
        note = f"topic {topic}: skipped {skipped} damaged message(s) that do not decode"
        bag.problem = note if bag.problem is None else f"{bag.problem}; {note}"
    table = pd.DataFrame.from_records(rows, index=range(len(rows)))
    columns: dict[str, NDArray[np.generic]] = {}
    for name in table.columns:
        if str(name).endswith("/message"):
            columns[str(name)] = table[name].to_numpy()
            continue
        # Numbers when every value of the key is one (PlotJuggler: per value), else strings. "none" (how
        # the estimator reports a figure it does not have yet: input_rate_hz before two angles) is a
        # missing number, so the key's column stays numeric rather than all strings.
        values = table[name]
        try:
            columns[str(name)] = pd.to_numeric(values.where(values != "none")).to_numpy()
        except (ValueError, TypeError):
            columns[str(name)] = table[name].to_numpy()
    return np.array(stamps, dtype=np.float64), log_times[np.array(kept, dtype=np.int64)], columns


def topic_table(bag: Bag, topic: str) -> DataFrame:
    """DataFrame of one topic: t, log_time, then every field as PlotJuggler names it, one row per message."""
    return next(topic_frames(bag, topic, rows=None))


def topic_frames(bag: Bag, topic: str, rows: int | None = BATCH_ROWS) -> Iterator[DataFrame]:
    """topic_table of ``topic`` in consecutive pieces of about ``rows`` rows (None: one piece)."""
    pd = _pandas()
    msgtype = bag.topics[topic].msgtype if topic in bag.topics else None
    if msgtype == bm.DIAGNOSTIC_ARRAY:
        yield _frame(pd, *_diagnostic_columns(bag, topic, pd))
    elif msgtype in BULK_TYPES or flatten_problem(bag, topic) is None:
        batches = [bag.decode(topic)] if rows is None else bag.decode_batches(topic, rows=rows)
        renames: dict[str, str] | None = None
        for arrays in batches:
            if renames is None:
                paths = list(arrays.fields)
                renames = _joint_renames(bag, topic, paths) if msgtype == bm.JOINT_STATE else {}
            columns: dict[str, NDArray[np.generic]] = {
                column_name(topic, renames.get(p, p)): col for p, col in arrays.fields.items()
            }
            yield _frame(pd, arrays.stamp, arrays.log_time_ns, columns)
    else:
        raise ExportError(
            f"topic {topic} has type {msgtype}, which export does not flatten ({flatten_problem(bag, topic)})"
        )


MAX_COLUMNS = 1000
"""Numbers a message of another type than the chain's may hold to be exported (an Odometry holds 87, an
Image or a point cloud hundreds of thousands: not a table)."""


def flatten_problem(bag: Bag, topic: str) -> str | None:
    """None when ``topic``'s messages (of any type) flatten into one table: every message has the same
    numeric fields (strings may differ), at most MAX_COLUMNS of them; else why not (a phrase). A topic
    of the chain's types, or with no message, flattens."""
    msgtype = bag.topics[topic].msgtype
    if msgtype in BULK_TYPES or msgtype == bm.DIAGNOSTIC_ARRAY:
        return None
    shapes = bag.shapes(topic)
    fields = {tuple(Layout.of(msg, msgtype).fields) for msg, _ in shapes}
    if len(fields) > 1:
        return f"its messages come in {len(fields)} shapes with different fields (arrays of varying length)"
    width = len(next(iter(fields))) if fields else 0
    if shapes and width == 0:
        return "its messages hold no numbers"
    if width > MAX_COLUMNS:
        return f"{width} numbers a message; a table takes at most {MAX_COLUMNS} columns"
    return None


def _frame(
    pd: ModuleType,
    t: NDArray[np.float64],
    log_time: NDArray[np.int64],
    columns: dict[str, NDArray[np.generic]],
) -> DataFrame:
    """DataFrame: t (s), log_time (s), then ``columns``."""
    head = {"t": np.asarray(t, dtype=np.float64), "log_time": np.asarray(log_time) * 1e-9}
    frame: DataFrame = pd.DataFrame({**head, **columns})
    return frame


def merged_table(bag: Bag, topics: Sequence[str]) -> DataFrame:
    """One DataFrame on the angle's stamps: a per-sample topic's row with the same stamp (truth, estimate,
    string), any other topic's (/clock, /diagnostics) latest row at or before the stamp."""
    pd = _pandas()
    joint = bag.chain_topic(bm.TOPIC_JOINT_STATES)
    base = topic_table(bag, joint).drop(columns=["log_time"]).sort_values("t", kind="stable")
    for topic in topics:
        if topic == joint:
            continue
        other = topic_table(bag, topic).drop(columns=["log_time"]).sort_values("t", kind="stable")
        if bm.role_of(topic) in PER_SAMPLE_ROLES:
            base = base.merge(other.drop_duplicates("t", keep="last"), on="t", how="left")
        else:
            base = pd.merge_asof(base, other, on="t", direction="backward")
    return base.reset_index(drop=True)


def _topic_stamps(bag: Bag, topic: str) -> NDArray[np.float64]:
    """The t column of a bulk topic's table (header stamp, or clock), decoded alone a batch at a time."""
    prefix = "clock" if bag.topics[topic].msgtype == bm.CLOCK else "header.stamp"
    fields = [f"{prefix}.sec", f"{prefix}.nanosec"]
    parts = [b.stamp for b in bag.decode_batches(topic, fields=fields, rows=BATCH_ROWS)]
    return np.concatenate([np.zeros(0), *parts])


def _ascending(t: NDArray[np.float64]) -> bool:
    """t non-decreasing (a stable sort on t leaves it as it is)."""
    return not bool(np.any(np.diff(t) < 0.0))


class _Joined:
    """One topic of a streamed merge: its rows read ahead of the angles, as far as the batch being joined.

    ``per_sample``: the row with the angle's stamp (the last of equal stamps), else the latest row at or
    before it (merge_asof); ``widen``: some angle gets no row, so the whole join's integer columns are
    floats (NaN) and its booleans objects, in every batch alike.
    """

    def __init__(self, frames: Iterator[DataFrame], per_sample: bool, widen: bool) -> None:
        """Rows from ``frames`` (sorted on t), joined as ``per_sample`` says, widened when ``widen``."""
        self.frames = frames
        self.per_sample = per_sample
        self.widen = widen
        self.buffer: DataFrame | None = None
        self.done = False

    def join(self, pd: ModuleType, batch: DataFrame) -> DataFrame:
        """``batch`` (angles sorted on t) with this topic's columns joined, as merged_table joins them."""
        upto = float(batch["t"].iat[-1])
        while not self.done and (
            self.buffer is None or len(self.buffer) == 0 or float(self.buffer["t"].iat[-1]) <= upto
        ):
            more = next(self.frames, None)
            if more is None:
                self.done = True
                continue
            more = more.drop(columns=["log_time"])
            self.buffer = more if self.buffer is None else pd.concat([self.buffer, more], ignore_index=True)
        assert self.buffer is not None
        t = self.buffer["t"].to_numpy()
        cut = int(np.searchsorted(t, upto, side="right"))
        ready = self.buffer.iloc[:cut]
        if self.per_sample:  # later angles are stamped at or after upto
            joined = batch.merge(ready.drop_duplicates("t", keep="last"), on="t", how="left")
            keep = int(np.searchsorted(t, upto, side="left"))
        else:  # a later angle may still take the last stamp at or before upto (its last equal rows)
            joined = pd.merge_asof(batch, ready, on="t", direction="backward")
            keep = int(np.searchsorted(t, t[cut - 1], side="left")) if cut else 0
        self.buffer = self.buffer.iloc[keep:]
        if self.widen:
            for name in ready.columns:
                kind = joined[name].dtype.kind
                if kind in "iu":
                    joined[name] = joined[name].astype(np.float64)
                elif kind == "b":
                    joined[name] = joined[name].astype(object)
        return joined


def merged_frames(
    bag: Bag, topics: Sequence[str], derived: Mapping[str, SeriesSource] | None = None
) -> Iterator[DataFrame]:
    """merged_table (then each ``derived`` series merged on t like a per-sample topic) a batch of angles at
    a time: a k-way merge of the topics' batches on t, each topic read once, as far as the angles go.

    A first pass reads the stamps alone: streaming needs every topic's stamps in order (as the chain
    writes them), and the dtypes of the whole join depend on whether some angle finds no row. A bag whose
    stamps go back, or with an empty topic, is joined whole (merged_table).
    """
    pd = _pandas()
    joint = bag.chain_topic(bm.TOPIC_JOINT_STATES)
    series = {name: derived_table(name, columns) for name, columns in _resolved(derived).items()}
    base_t = _topic_stamps(bag, joint)
    joins: list[_Joined] | None = []
    if base_t.size == 0 or not _ascending(base_t):
        joins = None
    for topic in topics:
        if joins is None:
            break
        if topic == joint:
            continue
        if bag.topics[topic].msgtype == bm.DIAGNOSTIC_ARRAY:  # deserialised message by message: held
            held = topic_table(bag, topic)
            t, frames = held["t"].to_numpy(), iter([held])
        else:
            t, frames = _topic_stamps(bag, topic), topic_frames(bag, topic, rows=MERGE_ROWS)
        per_sample = bm.role_of(topic) in PER_SAMPLE_ROLES
        if t.size == 0 or not _ascending(t):
            joins = None
            break
        widen = not np.isin(base_t, t).all() if per_sample else bool(t[0] > base_t[0])
        joins.append(_Joined(frames, per_sample, widen))
    for frame in series.values():
        if joins is not None and (len(frame) == 0 or np.any(np.diff(frame["t"].to_numpy()) <= 0.0)):
            joins = None
    if joins is None:
        whole = merged_table(bag, topics)
        for frame in series.values():
            whole = whole.merge(frame, on="t", how="left")
        yield whole
        return
    del base_t
    for batch in topic_frames(bag, joint, rows=MERGE_ROWS):
        batch = batch.drop(columns=["log_time"])
        if len(batch) == 0:
            continue
        for join in joins:
            batch = join.join(pd, batch)
        t = batch["t"].to_numpy()
        for frame in series.values():
            st = frame["t"].to_numpy()
            part = frame.iloc[
                np.searchsorted(st, t[0], side="left") : np.searchsorted(st, t[-1], side="right")
            ]
            batch = batch.merge(part, on="t", how="left")
        yield batch


def derived_table(name: str, columns: Mapping[str, NDArray[np.float64]]) -> DataFrame:
    """DataFrame of a derived series (not a topic; e.g. the smoother's): t, then ``name/<column>``."""
    pd = _pandas()
    data = {"t": np.asarray(columns["t"], dtype=np.float64)}
    data.update({column_name(name, k): np.asarray(v) for k, v in columns.items() if k != "t"})
    return pd.DataFrame(data)


def file_stem(topic: str) -> str:
    """File name of a topic's table: the topic without its leading "/", "/" → "__"."""
    return topic.strip("/").replace("/", "__")


def export_bag(
    bag: Bag,
    out: Path | str,
    *,
    fmt: str = "csv",
    merged: bool = False,
    topics: Sequence[str] = (),
    derived: Mapping[str, SeriesSource] | None = None,
) -> list[Path]:
    """Write ``topics`` (default: all) of ``bag`` under directory ``out`` as CSV or Parquet; the paths.

    ``derived``: {name: {"t": stamps, column: values}} series computed from the bag (the smoother's
    acceleration; or a function computing one), merged on the angle's stamps like a per-sample topic, or
    written as their own tables after the topics' (a function is called then: what it holds is not held
    while the topics are written). Each table is written in batches of its rows (export_tables).
    """
    tables = export_tables(bag, fmt=fmt, merged=merged, topics=topics, derived=derived)
    directory = Path(out)
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ExportError(f"cannot create {directory}: {err.strerror}") from None
    paths = []
    for stem, frames in tables.items():
        path = directory / f"{stem}.{fmt}"
        _write(path, frames, fmt)
        paths.append(path)
    return paths


def _write(path: Path, frames: Iterable[DataFrame], fmt: str) -> None:
    """Write ``frames`` one after the other as one CSV (header once) or Parquet file (a row group each)."""
    if fmt == "csv":
        with path.open("w", newline="") as handle:
            for i, frame in enumerate(frames):
                frame.to_csv(handle, index=False, header=i == 0, float_format="%.17g")
        return
    import pyarrow as pa
    import pyarrow.parquet as pq

    # The file's schema is the first batch's, but a column all missing in it (a status reported late,
    # pyarrow's null type) takes its type from the first batch that has a value: batches are held until
    # then (a column missing everywhere stays null, as in a table written whole).
    writer = None
    pending: list[pa.Table] = []
    try:
        for frame in frames:
            table = pa.Table.from_pandas(frame, preserve_index=False)
            if writer is not None:
                writer.write_table(table if table.schema.equals(writer.schema) else table.cast(writer.schema))
                continue
            pending.append(table)
            schema = pa.unify_schemas([p.schema for p in pending])
            if any(pa.types.is_null(field.type) for field in schema):
                continue
            writer = pq.ParquetWriter(path, schema)
            for held in pending:
                writer.write_table(held if held.schema.equals(schema) else held.cast(schema))
            pending = []
        if pending:
            schema = pa.unify_schemas([p.schema for p in pending])
            writer = pq.ParquetWriter(path, schema)
            for held in pending:
                writer.write_table(held if held.schema.equals(schema) else held.cast(schema))
    finally:
        if writer is not None:
            writer.close()


def write_csv_table(frames: Iterable[DataFrame], target: Path | TextIO) -> None:
    """One table (its batches of rows) as CSV to a path or an open text stream: no index, header once,
    17 significant digits (a double round-trips)."""
    if isinstance(target, Path):
        _write(target, frames, "csv")
        return
    for i, frame in enumerate(frames):
        frame.to_csv(target, index=False, header=i == 0, float_format="%.17g")


def export_tables(
    bag: Bag,
    *,
    fmt: str = "csv",
    merged: bool = False,
    topics: Sequence[str] = (),
    derived: Mapping[str, SeriesSource] | None = None,
) -> dict[str, Iterable[DataFrame]]:
    """{file stem: its rows as pandas DataFrames, in batches}: the tables export_bag writes (one,
    MERGED_NAME, when ``merged``)."""
    if fmt not in FORMATS:
        raise ExportError(f"unknown format {fmt!r}; use {' or '.join(FORMATS)}")
    _pandas()
    if fmt == "parquet":
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            raise ExportError("Parquet export needs pyarrow: pip install 'pendulum_accel[export]'") from None
    # By default every topic but the visual ones (markers, the URDF), which are for RViz and Foxglove.
    chosen = list(topics) or [t for t in bag.topics if bm.role_of(t) not in VISUAL_ROLES]
    unknown = [t for t in chosen if t not in bag.topics]
    if unknown:
        raise ExportError(f"bag {bag.path} has no topic {unknown[0]} (it has {', '.join(bag.topics)})")
    if merged and bag.chain_topic(bm.TOPIC_JOINT_STATES) not in bag.topics:
        raise ExportError(f"bag {bag.path} has no {bm.TOPIC_JOINT_STATES} to merge on")
    # Checked before any file is written: a topic that cannot be a table leaves nothing half-exported.
    for topic in chosen:
        problem = flatten_problem(bag, topic)
        if problem is not None:
            msgtype = bag.topics[topic].msgtype
            raise ExportError(f"topic {topic} has type {msgtype}, which export does not flatten ({problem})")
    if merged:
        return {MERGED_NAME: merged_frames(bag, chosen, derived)}
    tables: dict[str, Iterable[DataFrame]] = {file_stem(t): topic_frames(bag, t) for t in chosen}
    for name, columns in (derived or {}).items():
        tables[file_stem(name)] = _derived_frames(name, columns)
    return tables


def _resolved(derived: Mapping[str, SeriesSource] | None) -> dict[str, Series]:
    """The derived series, each function called (those returning None left out)."""
    out = {}
    for name, source in (derived or {}).items():
        series = source() if callable(source) else source
        if series is not None:
            out[name] = series
    return out


def _derived_frames(name: str, source: SeriesSource) -> Iterator[DataFrame]:
    """derived_table of the series (computed now if given as a function) in consecutive pieces of
    BATCH_ROWS rows (at least one piece; only t when the function gives nothing)."""
    columns = _resolved({name: source}).get(name, {"t": np.zeros(0)})
    size = len(columns["t"])
    for start in range(0, max(size, 1), BATCH_ROWS):
        yield derived_table(name, {k: v[start : start + BATCH_ROWS] for k, v in columns.items()})
