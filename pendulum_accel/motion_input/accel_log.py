"""Logged accelerations used as recorded: the ``accel_csv`` profile (a vehicle's or a phone's
accelerometer log, any time and acceleration columns) and the ``csv`` profile (plain ``t, a`` rows), each
in any layout ``columns.csv_rows`` reads."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path

from pendulum_accel.errors import ParameterError
from pendulum_accel.motion_input.columns import comma_hint, is_number, read_csv_rows
from pendulum_accel.motion_input.fields import field_column, field_scale
from pendulum_accel.motion_input.trace import csv_trace, recorded_acceleration
from pendulum_accel.physics.profiles import Table

PHYPHOX_TIME_COLUMN = "Time (s)"
"""phyphox's "Acceleration (without g)" CSV export: "Time (s)", then "Acceleration x (m/s^2)", y, z (and,
in some versions, "Absolute acceleration (m/s^2)"); x across the screen, y along it, z out of it."""


def accel_csv_profile(d: Mapping[str, object], base_dir: Path | None) -> Table:
    """Table of a(t) from an accel_csv mapping: a column of a logged acceleration, times scale.

    a(t) = scale × the column (default the second), t from the time column (default the first) shifted
    to start at 0; checked as any trace (check_trace), then used as recorded (recorded_acceleration).
    """
    kind = "accel_csv"
    accel_column = field_column(kind, "accel_column", d["accel_column"]) if "accel_column" in d else None
    scale = field_scale(kind, d)
    stretch, _, path = csv_trace(kind, d, base_dir, "accel_column", name="acceleration")
    column = accel_column if isinstance(accel_column, str) else f"column {accel_column or 2}"
    scaled = f", x {scale:g}" if scale != 1.0 else ""
    label = f"accel_csv {path.name} ({column}{scaled}, {stretch.times.size} samples{stretch.note()})"
    return recorded_acceleration(kind, d, replace(stretch, values=stretch.values * scale), label)


def csv_table(path: str | Path) -> Table:
    """The ``csv`` profile: a Table from CSV rows ``t, a`` (s, m/s²); a header row, ``#`` comments skipped."""
    source = Path(path)
    times: list[float] = []
    accels: list[float] = []
    for line_no, cells in read_csv_rows(source, "acceleration"):
        if len(cells) < 2:
            raise ParameterError(f"{source}:{line_no}: expected 't, a', got {','.join(cells)!r}")
        try:
            t_value, a_value = float(cells[0]), float(cells[1])
        except ValueError:
            if not times and not accels:
                continue  # a header row such as "t,a"
            bad = next(c for c in cells[:2] if not is_number(c))
            raise ParameterError(f"{source}:{line_no}: {bad!r} is not a number{comma_hint(bad)}") from None
        if not (math.isfinite(t_value) and math.isfinite(a_value)):
            raise ParameterError(f"{source}:{line_no}: t and a must be finite, got {t_value!r}, {a_value!r}")
        if times and t_value <= times[-1]:
            raise ParameterError(
                f"{source}:{line_no}: times must be strictly increasing, got {t_value!r} after {times[-1]!r}"
            )
        times.append(t_value)
        accels.append(a_value)
    if not times:
        raise ParameterError(f"{source}: no (t, a) rows found")
    return Table(tuple(times), tuple(accels))


def write_table_csv(table: Table, path: Path) -> None:
    """The ``csv`` profile's file of ``table``: a ``t,a`` header, then one row per point, each float at its
    shortest repr, so csv_table reads back the very same floats (float(repr(x)) == x)."""
    with path.open("w", encoding="utf-8", newline="\n") as out:
        out.write("t,a\n")
        out.writelines(f"{t!r},{a!r}\n" for t, a in zip(table.times, table.accels, strict=True))
