"""Two columns (time, value) of a user's CSV file, each failure one line naming the file and line."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.textfile import read_text_file


def read_columns(
    path: Path, time_column: str | None, value_column: str | None, *, what: str = "speed"
) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """(t, v, line numbers) from a CSV file: ``#`` comments and blank lines skipped.

    A first row that is not all numbers is the header; the named columns are read from it (the first
    and second column when unnamed; quoted names such as phyphox's "Time (s)" work). Every failure is one
    ParameterError naming file and line; ``what`` (speed, accel) names the file and the column field.
    """
    try:
        text = read_text_file(path)
    except OSError as exc:
        raise ParameterError(f"cannot read {what} CSV {path}: {exc.strerror or exc}", path="path") from None
    except ValueError as exc:
        raise ParameterError(f"cannot read {what} CSV {path}: {exc}", path="path") from None
    header: list[str] | None = None
    columns = [0, 1]
    times: list[float] = []
    values: list[float] = []
    lines: list[int] = []
    for line_no, row in enumerate(csv.reader(text.splitlines()), start=1):
        cells = [c.strip() for c in row]
        if not cells or not any(cells) or cells[0].startswith("#"):
            continue
        if header is None and not times:
            try:
                [float(c) for c in cells]
            except ValueError:
                header = cells
                for k, name in enumerate((time_column, value_column)):
                    if name is not None:
                        if name not in cells:
                            raise ParameterError(
                                f"{path}:{line_no}: no column {name!r} in header {','.join(cells)!r}",
                                path="time_column" if k == 0 else f"{what}_column",
                            ) from None
                        columns[k] = cells.index(name)
                continue
        if not times and header is None and (time_column is not None or value_column is not None):
            raise ParameterError(f"{path}:{line_no}: column names are given but the file has no header row")
        if len(cells) <= max(columns):
            raise ParameterError(f"{path}:{line_no}: expected {max(columns) + 1} columns, got {len(cells)}")
        try:
            t_value, v_value = float(cells[columns[0]]), float(cells[columns[1]])
        except ValueError:
            raise ParameterError(f"{path}:{line_no}: not a number in {','.join(cells)!r}") from None
        times.append(t_value)
        values.append(v_value)
        lines.append(line_no)
    if not times:
        raise ParameterError(f"{path}: no (t, v) rows found", path="path")
    return np.array(times), np.array(values), lines
