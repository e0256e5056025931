"""Two columns (time, value) of a user's CSV file, each failure one line naming the file and line.

The time column holds seconds (any number), or date-times as loggers write them (``2007-03-28 07:33:05``,
``2007-03-28T07:33:05.250Z``). Date-times are read with a stated ``time_format`` (``strptime`` codes,
e.g. ``%d/%m/%Y %H:%M:%S``), or, when none is stated, detected as ISO 8601 (``datetime.fromisoformat``);
other layouts such as ``03/28/2007`` are ambiguous (day or month first) and need the format stated.
A date-time column becomes seconds since its first row, subtracted as datetimes (microseconds exact):
a float epoch of 1.2e9 s would keep only about 0.2 µs. A numeric time column in other units (``time_units``
ms, us, ns: a logger's epoch nanoseconds, 1.6e18, which a float holds only to 256 ns) is counted the
same way from its first row: integer cells as integers, then scaled to seconds. A ROS 2 time stamp split
over two columns (``sec``, ``nanosec``: ``ros2 topic echo --csv`` writes ``header.stamp`` so) is read as
one time, its integer nanoseconds counted exactly from the first row.

Columns are separated by commas, semicolons or tabs, and with a semicolon or a tab numbers may carry a
decimal comma (``1,234E-1``): the five CSV layouts phyphox exports (its ``DataExport.CsvFormat``), and what
spreadsheets write in locales whose decimal mark is a comma. The layout is detected from the file's first
rows (``sniff_layout``); the decimal mark from the first number written with one, which in a log that
starts with whole numbers (``0;0``) may come many rows down (``Layout.decide``).
"""

from __future__ import annotations

import csv
import datetime as dt
import itertools
import re
from array import array
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.textfile import text_lines


class PackedTexts:
    """Strings kept packed, PACK of them joined by NUL into one str: about a byte a character, where a list
    of str holds an object of ~50 B and an 8 B slot for each. A day-long log's time cells are kept so only
    to name a row in a message. A cell never holds NUL: it is stored only once its time has parsed."""

    PACK = 4096

    def __init__(self) -> None:
        """No strings yet."""
        self._packs: list[str] = []
        self._pending: list[str] = []

    def append(self, text: str) -> None:
        """Keep ``text`` as the next string."""
        self._pending.append(text)
        if len(self._pending) == self.PACK:
            self._packs.append("\x00".join(self._pending))
            self._pending = []

    def __len__(self) -> int:
        """How many strings are kept."""
        return len(self._packs) * self.PACK + len(self._pending)

    def __getitem__(self, i: int) -> str:
        """String ``i`` (from 0; negative from the end)."""
        n = len(self)
        if not -n <= i < n:
            raise IndexError(f"string {i} of {n}")
        pack, k = divmod(i % n, self.PACK)
        return self._packs[pack].split("\x00")[k] if pack < len(self._packs) else self._pending[k]


@dataclass(frozen=True)
class Columns:
    """A CSV's time and value columns: ``times`` in s (as written, or since ``epoch`` for date-times),
    ``values``, each row's ``lines`` number in the file, and its time cell's ``stamps`` text."""

    times: np.ndarray
    values: np.ndarray
    lines: array[int]
    stamps: PackedTexts
    epoch: dt.datetime | None
    """The first row's date-time when the time column holds date-times, else None."""

    def where(self, i: int, path: Path) -> str:
        """'path:line' of row ``i``."""
        return f"{path}:{self.lines[i]}"

    def stamp(self, i: int) -> str:
        """Row ``i``'s time as the file writes it."""
        return self.stamps[i]


TIME_UNITS: dict[str, float] = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
"""Seconds per unit of a numeric time column (the ``time_units`` field)."""
SEPARATORS = ("\t", ";", ",")
"""Column separators, in the order ``sniff_layout`` tries them: a comma can also be a decimal mark."""
_EXCEL_SEPARATOR = re.compile(r"sep=([^\"\r\n])")
"""Excel's first-line directive naming a CSV's separator (``sep=;``): its reader obeys it, and exports made
for it in many locales begin with it."""
SNIFF_ROWS = 20
"""Rows (not comments, not blank) ``sniff_layout`` reads: a header and enough data rows to be sure."""
_DECIMAL_COMMA = re.compile(r"[+-]?(\d+,\d*|,\d+)([eE][+-]?\d+)?")
_THOUSANDS = re.compile(r"[+-]?\d{1,3}(,\d{3})+(\.\d*)?([eE][+-]?\d+)?")
_DECIMAL_POINT = re.compile(r"[+-]?(\d+\.\d*|\.\d+)([eE][+-]?\d+)?")


@dataclass(frozen=True)
class Layout:
    """How a CSV file writes its cells: the column ``separator``, and whether numbers use a decimal comma
    (None while no number seen has a decimal mark: whole numbers read the same with either)."""

    separator: str
    decimal_comma: bool | None

    def cell(self, text: str) -> str:
        """A stripped cell, a decimal-comma number written with a point (``1,5E-1`` → ``1.5E-1``)."""
        text = text.strip()
        if self.decimal_comma and _DECIMAL_COMMA.fullmatch(text):
            return text.replace(",", ".")
        return text

    @classmethod
    def of(cls, separator: str) -> Layout:
        """The layout of a file with ``separator`` before any number is seen: a comma file's decimal mark is
        a point, any other's is left to ``decide``."""
        return cls(separator, False if separator == "," else None)

    def decide(self, cells: Iterable[str]) -> Layout:
        """This layout with its decimal mark set by ``cells`` when still undecided: a comma when, the
        separator not being a comma, a cell is a decimal-comma number and none a decimal-point one; a
        point when a cell is a decimal-point number; unchanged when no cell has a mark."""
        if self.decimal_comma is not None:
            return self
        stripped = [c.strip() for c in cells]
        if any(_DECIMAL_POINT.fullmatch(c) for c in stripped):
            return Layout(self.separator, False)
        if self.separator != "," and any(_DECIMAL_COMMA.fullmatch(c) for c in stripped):
            return Layout(self.separator, True)
        return self


def _content(lines: list[str]) -> list[str]:
    """The lines that hold cells: not blank, not ``#`` comments."""
    return [line for line in lines if line.strip() and not line.lstrip().startswith("#")]


def sniff_layout(lines: list[str]) -> Layout:
    """The first of SEPARATORS that splits each of the first SNIFF_ROWS content rows into two non-empty cells
    or more (a comma when none does: a stray trailing tab does not make a tab file). The decimal mark is a
    point in a comma-separated file, else left to the first row that writes a number with a mark
    (``Layout.decide``, called by csv_rows row by row).

    A file that writes ``0.5`` has a decimal point, so its ``1,000`` is a thousands separator, which no
    reader here takes: read as a decimal comma it would be a silent 1.0, so it is left to be refused."""
    sample = _content(lines)[:SNIFF_ROWS]
    for separator in SEPARATORS:
        rows = list(csv.reader(sample, delimiter=separator))
        if rows and all(sum(1 for c in row if c.strip()) >= 2 for row in rows):
            break
    else:
        separator, rows = ",", list(csv.reader(sample))
    return Layout.of(separator)


def csv_rows(lines: Iterable[str], where: Path) -> Iterator[tuple[int, list[str]]]:
    """(line number, cells) of each row that holds cells, in the file's own layout (the separator its
    first line names, as Excel's ``sep=;``, else ``sniff_layout`` on its first SNIFF_ROWS content rows;
    the decimal mark from the first row that writes one): cells stripped, decimal-comma numbers rewritten
    with a point; blank rows and ``#`` comments skipped. ``lines`` are read as the rows are
    (textfile.text_lines streams a file); a row the csv module refuses is a ParameterError naming
    ``where`` and the line."""
    stream = iter(lines)
    line_no = 0
    try:
        head: list[str] = []
        content = 0
        for line in stream:
            head.append(line)
            content += len(_content([line]))
            if content >= SNIFF_ROWS:
                break
        directive = _EXCEL_SEPARATOR.fullmatch(head[0].rstrip("\r\n")) if head else None
        layout = Layout.of(directive[1]) if directive else sniff_layout(head)  # a named separator: no guess
        first = 2 if directive else 1  # the directive is no row
        rows = csv.reader(itertools.chain(head[first - 1 :], stream), delimiter=layout.separator)
        for line_no, row in enumerate(rows, start=first):
            if not any(c.strip() for c in row) or row[0].strip().startswith("#"):
                continue  # a comment's numbers ("# 0,5 g") decide no mark and are not refused
            if layout.decimal_comma is None:
                layout = layout.decide(row)
            if layout.decimal_comma and any("." in c for c in row):  # a substring scan before the regex
                _refuse_decimal_point(row, f"{where}:{line_no}")
            yield line_no, [layout.cell(c) for c in row]
    except csv.Error as err:  # e.g. a cell past csv's field size limit: binary data
        raise ParameterError(f"{where}:{line_no + 1}: not a CSV row ({err})") from None


def _refuse_decimal_point(row: list[str], where: str) -> None:
    """ParameterError for a cell written with a decimal point (``1.000``) in a decimal-comma file: there a
    point groups thousands, and float() would read the cell as 1.0, silently."""
    stray = next((c.strip() for c in row if _DECIMAL_POINT.fullmatch(c.strip())), None)
    if stray is not None:
        raise ParameterError(
            f"{where}: {stray!r} has a decimal point in a file whose numbers have a decimal comma (seen in "
            "its earlier rows): a point grouping thousands is not read; write the number without it"
        )


def read_csv_rows(path: Path, what: str) -> Iterator[tuple[int, list[str]]]:
    """csv_rows of the file at ``path`` (textfile.text_lines: streamed, in its own encoding); a file that
    cannot be opened or is not text is one ParameterError naming the ``what`` CSV and the path."""
    try:
        with text_lines(path) as lines:
            yield from csv_rows(lines, path)
    except OSError as exc:
        raise ParameterError(f"cannot read {what} CSV {path}: {exc.strerror or exc}", path="path") from None
    except ParameterError:
        raise
    except ValueError as exc:
        raise ParameterError(f"cannot read {what} CSV {path}: {exc}", path="path") from None


def parse_datetime(text: str, time_format: str | None) -> dt.datetime:
    """``text`` as a datetime: ``strptime(text, time_format)``, or ISO 8601 when no format is stated.

    A plain date is its midnight. ValueError when it does not parse.
    """
    if time_format is not None:
        return dt.datetime.strptime(text, time_format)
    if not text[:1].isdigit():  # fromisoformat would take "T07:33"-like fragments; a date starts with a digit
        raise ValueError(f"not an ISO 8601 date-time: {text!r}")
    return dt.datetime.fromisoformat(text)


def since(moment: dt.datetime, epoch: dt.datetime) -> float:
    """(moment − epoch) in s; ValueError when one has a time zone and the other none."""
    try:
        return (moment - epoch) / dt.timedelta(seconds=1)
    except TypeError:
        raise ValueError("one date-time has a time zone and another none") from None


def _time_value(text: str, time_format: str | None) -> float | dt.datetime:
    """A time cell: a float when it is a number (and no format is stated), else a datetime."""
    if time_format is None:
        try:
            return float(text)
        except ValueError:
            pass
    return parse_datetime(text, time_format)


ColumnSpec = str | int
"""A column: its header name, or its number counted from 1."""
TimeColumns = ColumnSpec | tuple[ColumnSpec, ColumnSpec]
"""The time column, or a ROS 2 stamp's two (sec, nanosec)."""
NANOS = 1_000_000_000  # ns per s: a builtin_interfaces/Time's nanosec is below it


def stamp_nanoseconds(sec: str, nanosec: str) -> int:
    """sec × 10⁹ + nanosec of a ROS 2 time stamp's two cells (builtin_interfaces/Time); ValueError unless
    both are integers and 0 ≤ nanosec < 10⁹."""
    try:
        whole, part = int(sec), int(nanosec)
    except ValueError:
        raise ValueError("sec and nanosec must be whole numbers") from None
    if not 0 <= part < NANOS:
        raise ValueError(f"nanosec {nanosec!r} is not in 0 … 999999999")
    return whole * NANOS + part


def _time_text(cells: list[str], columns: list[int]) -> str:
    """The row's time as written: its time cell, or a stamp's sec.nanosec (columns[:-1] the time's)."""
    if len(columns) == 2:
        return cells[columns[0]]
    sec, nanosec = cells[columns[0]], cells[columns[1]]
    return f"{sec}.{nanosec.zfill(9)}" if nanosec.isdigit() else f"{sec}.{nanosec}"


def _is_data(cells: list[str], columns: list[int], time_format: str | None) -> bool:
    """True when the row's time and value cells parse (a data row), False for a header."""
    if len(cells) <= max(columns):
        return False
    try:
        if len(columns) == 3:
            stamp_nanoseconds(cells[columns[0]], cells[columns[1]])
        else:
            _time_value(cells[columns[0]], time_format)
        float(cells[columns[-1]])
    except ValueError:
        return False
    return True


def read_columns(
    path: Path,
    time_column: TimeColumns | None,
    value_column: ColumnSpec | None,
    *,
    what: str = "speed",
    time_format: str | None = None,
    time_units: str = "s",
) -> Columns:
    """The time and value columns of a CSV file: ``#`` comments and blank lines skipped.

    A first row whose time and value cells do not parse is the header; the named columns are read from
    it (the first and second column when unnamed; quoted names such as phyphox's "Time (s)" work). One
    row under it with no number in any cell is its units row, skipped. The
    time column is numbers or date-times (module doc), not a mix; a pair of time columns is a ROS 2 stamp's
    (sec, nanosec), which needs the value column stated. Every failure is one ParameterError naming file
    and line; ``what`` (speed, accel) names the file and the column field.
    """
    stamped = isinstance(time_column, tuple)
    if stamped and (value_column is None or time_format is not None or time_units != "s"):
        raise ParameterError(
            f"{what} CSV {path}: a time in two columns (sec, nanosec) is a ROS 2 stamp in s and ns: it "
            f"needs {what}_column stated, and takes no time_format or time_units",
            path="time_column",
        )
    specs: list[ColumnSpec | None] = [*(time_column if isinstance(time_column, tuple) else (time_column,))]
    specs.append(value_column)
    field_names = ["time_column"] * (len(specs) - 1) + [f"{what}_column"]
    named = any(isinstance(c, str) for c in specs)
    numbered = any(isinstance(c, int) for c in specs)
    header: list[str] | None = None
    # A column number (from 1) picks its column with or without a header row; a name needs the header.
    columns = [c - 1 if isinstance(c, int) else d for d, c in enumerate(specs)]
    # Packed as the rows come (array, PackedTexts: ~46 B a row, where lists of floats, ints and str held
    # ~204): each time is stored as what it becomes, its difference from the first row's where exact
    # differences need the first row (stamps, date-times, other units), the value as a float.
    times_read = array("d")  # s as written, or since the first row (a stamp's, a date-time's)
    count_diffs: array[float] | None = array("d") if time_units != "s" else None  # exact integer ones
    values = array("d")
    lines = array("q")
    stamps = PackedTexts()
    epoch: dt.datetime | None = None
    first_tick, first_count, first_float = 0, 0, 0.0
    units_row = False
    for line_no, cells in read_csv_rows(path, what):
        if header is not None and not lines and not units_row and not any(is_number(c) for c in cells):
            # One row of text only under the header is its units ("s", "m/s^2"), as many loggers write;
            # a row with any number in it is data and is read (or refused) as such.
            units_row = True
            continue
        if header is None and not lines:
            if named and not all(is_number(c) for c in cells):
                header = cells
                for k, name in enumerate(specs):
                    if isinstance(name, str):
                        if name not in cells:
                            raise ParameterError(
                                f"{path}:{line_no}: no column {name!r} in header {','.join(cells)!r}",
                                path=field_names[k],
                            ) from None
                        columns[k] = cells.index(name)
                continue
            if named:
                raise ParameterError(
                    f"{path}:{line_no}: column names are given but the file has no header row"
                )
            if not (numbered and len(cells) <= max(columns)) and not _is_data(cells, columns, time_format):
                header = cells  # (a first row too short for a stated column number is no header: refused)
                continue
        if len(cells) <= max(columns):
            raise ParameterError(f"{path}:{line_no}: expected {max(columns) + 1} columns, got {len(cells)}")
        t_text = _time_text(cells, columns)
        try:
            if stamped:
                tick = stamp_nanoseconds(cells[columns[0]], cells[columns[1]])
            t_value = float(tick) if stamped else _time_value(t_text, time_format)
        except ValueError as exc:
            if stamped:
                raise ParameterError(
                    f"{path}:{line_no}: time {t_text!r} is no ROS 2 stamp (integer sec, nanosec): {exc}"
                ) from None
            layout = (
                f"the time_format {time_format!r}" if time_format else "a number or an ISO 8601 date-time"
            )
            raise ParameterError(
                f"{path}:{line_no}: time {t_text!r} is not {layout} (state time_format for other layouts)"
            ) from None
        first = not lines
        if not first and isinstance(t_value, dt.datetime) != (epoch is not None):
            raise ParameterError(
                f"{path}:{line_no}: time {t_text!r} mixes numbers and date-times in one column"
            )
        v_text = cells[columns[-1]]
        try:
            v_value = float(v_text)
        except ValueError:
            raise ParameterError(
                f"{path}:{line_no}: {what} {v_text!r} is not a number{comma_hint(v_text)}"
            ) from None
        if isinstance(t_value, dt.datetime):
            if first:
                if time_units != "s":
                    raise ParameterError(
                        f"{path}:{line_no}: time_units {time_units!r} is for a numeric time column, and this "
                        f"one holds date-times ({t_text!r})",
                        path="time_units",
                    )
                epoch = t_value
            assert epoch is not None
            try:
                times_read.append(since(t_value, epoch))
            except ValueError as exc:
                raise ParameterError(f"{path}:{line_no}: {exc} ({t_text!r} after {stamps[0]!r})") from None
        elif stamped:  # integer ns: exact differences from the first row, scaled once at the end
            if first:
                first_tick = tick
            times_read.append(float(tick - first_tick))
        elif time_units != "s":  # (tᵢ − t₀) in the unit, exact where every cell is an integer
            if first:
                first_float = t_value
            times_read.append(t_value - first_float)
            count = _whole(t_text) if count_diffs is not None else None
            if count_diffs is None or count is None:
                count_diffs = None  # one cell that is no integer: every difference is the floats'
            else:
                if first:
                    first_count = count
                count_diffs.append(float(count - first_count))
        else:
            times_read.append(t_value)
        values.append(v_value)
        lines.append(line_no)
        stamps.append(t_text)
    if not lines:
        raise ParameterError(f"{path}: no (t, v) rows found", path="path")
    times = np.array(times_read if count_diffs is None else count_diffs, dtype=float)
    if stamped:
        times /= NANOS
    elif time_units != "s":
        times *= TIME_UNITS[time_units]
    return Columns(times, np.array(values, dtype=float), lines, stamps, epoch)


def comma_hint(text: str) -> str:
    """Why a cell such as ``1,000.5`` or ``1,5`` is no number: its file writes a decimal point (its first
    number with a mark has one: Layout.decide), so the comma groups thousands, which a reader could take
    for a decimal mark only by guessing, or the file mixes the two marks."""
    if _THOUSANDS.fullmatch(text):
        return " (a comma grouping thousands is not read: write the number without it)"
    if _DECIMAL_COMMA.fullmatch(text):
        return " (the file writes numbers with a decimal point up to here, and a file has one decimal mark)"
    return ""


def _whole(text: str) -> int | None:
    """The cell as an integer when it writes one (``int``), else None."""
    try:
        return int(text)
    except ValueError:
        return None


def is_number(text: str) -> bool:
    """True when ``float(text)`` parses."""
    try:
        float(text)
    except ValueError:
        return False
    return True
