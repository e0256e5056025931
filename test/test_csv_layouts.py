"""The CSV layouts accel_csv, speed_csv and csv read: columns by number, phyphox's separators and decimal
marks, Excel's sep= line, comments and a units row, and time columns in epoch units or as a ROS 2 stamp.
"The units test's bound" is test_speed_trace's straight-ramp test's.
"""

from __future__ import annotations

import math
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.errors import ParameterError
from pendulum_accel.motion_input import profile_from_dict
from pendulum_accel.motion_input.columns import SNIFF_ROWS, read_columns
from pendulum_accel.physics.profiles import Table
from test.motion_tables import table_of


def test_columns_are_chosen_by_number_in_a_file_with_no_header(tmp_path: Path) -> None:
    """A logger's headerless CSV (t, then x, y, z): ``accel_column: 3`` reads y, and a number works beside a
    name in a file with a header; the values are copied, so the comparison is exact. A number below 1, an
    empty name or a boolean is one line naming the field; a number past the row's end names the line."""
    times = [0.02 * k for k in range(30)]
    ys = [0.25 * math.sin(t) for t in times]
    body = "\n".join(f"{t!r},9.81,{y!r},0.0" for t, y in zip(times, ys, strict=True)) + "\n"
    (tmp_path / "raw.csv").write_text(body, encoding="utf-8")
    (tmp_path / "named.csv").write_text("stamp,ax,ay,az\n" + body, encoding="utf-8")
    by_number = table_of({"type": "accel_csv", "path": "raw.csv", "accel_column": 3}, base_dir=tmp_path)
    assert list(by_number.accels) == ys and "(column 3, 30 samples)" in by_number.origin
    mixed = table_of(
        {"type": "accel_csv", "path": "named.csv", "time_column": "stamp", "accel_column": 3},
        base_dir=tmp_path,
    )
    assert list(mixed.accels) == ys
    speeds = table_of(
        {"type": "speed_csv", "path": "raw.csv", "units": "m/s", "time_column": 1, "speed_column": 2},
        base_dir=tmp_path,
    )
    assert np.max(np.abs(np.array(speeds.accels))) <= 1e-9  # a constant 9.81 m/s: a = 0 (units test's bound)
    for value in (0, -2, "", True):
        with pytest.raises(
            ParameterError, match=r"field 'accel_column' must be a header name or a column number"
        ):
            profile_from_dict(
                {"type": "accel_csv", "path": "raw.csv", "accel_column": value}, base_dir=tmp_path
            )
    with pytest.raises(ParameterError, match=r"raw.csv:1: expected 7 columns, got 4"):
        profile_from_dict({"type": "accel_csv", "path": "raw.csv", "accel_column": 7}, base_dir=tmp_path)


PHYPHOX_LAYOUTS = [(",", "."), ("\t", "."), (";", "."), ("\t", ","), (";", ",")]
"""The (separator, decimal mark) pairs of phyphox's CSV exports (DataExport.java, CsvFormat)."""


def phyphox_text(separator: str, decimal: str, times: np.ndarray, accels: np.ndarray) -> str:
    """An "Acceleration (without g)" export as phyphox writes it: quoted names, "0.000000000E0" numbers."""

    def number(x: float) -> str:
        mantissa, exponent = f"{x:.9E}".split("E")
        return f"{mantissa}E{int(exponent)}".replace(".", decimal)

    names = ["Time (s)", "Acceleration x (m/s^2)", "Acceleration y (m/s^2)", "Acceleration z (m/s^2)"]
    rows = [separator.join(f'"{n}"' for n in names)]
    for t, a in zip(times, accels, strict=True):
        rows.append(separator.join(number(x) for x in (t, 0.25 * a, a, -0.5 * a)))
    return "\n".join(rows) + "\n"


@pytest.mark.parametrize(("separator", "decimal"), PHYPHOX_LAYOUTS)
def test_accel_csv_reads_every_layout_phyphox_exports(separator: str, decimal: str, tmp_path: Path) -> None:
    """Each of phyphox's five CSV layouts gives the a(t) of its comma/point twin, bit for bit: the same
    digits are parsed, only the separator and the decimal mark differ."""
    times = np.arange(200) * 0.01
    accels = np.sin(2.0 * times) - 0.3
    (tmp_path / "twin.csv").write_text(phyphox_text(",", ".", times, accels), encoding="utf-8")
    (tmp_path / "phone.csv").write_text(phyphox_text(separator, decimal, times, accels), encoding="utf-8")
    spec: dict[str, object] = {"type": "accel_csv", "time_column": "Time (s)",
                               "accel_column": "Acceleration y (m/s^2)"}  # fmt: skip
    twin = table_of(spec | {"path": "twin.csv"}, base_dir=tmp_path)
    profile = table_of(spec | {"path": "phone.csv"}, base_dir=tmp_path)
    assert np.array_equal(profile.times, twin.times) and np.array_equal(profile.accels, twin.accels)
    # Against the values written: "0.000000000E0" keeps 10 significant digits, a relative error ≤ 5e-10.
    assert np.allclose(profile.accels, accels, rtol=0.0, atol=5e-10 * 1.3)
    # The plain `csv` profile (t, a in the first two columns) reads the same layouts.
    plain = profile_from_dict({"type": "csv", "path": "phone.csv"}, base_dir=tmp_path)
    assert isinstance(plain, Table) and np.array_equal(plain.times, twin.times)


def test_a_comma_file_whose_header_holds_a_semicolon_stays_comma_separated(tmp_path: Path) -> None:
    """The layout is the separator that splits every row, not the first one seen: a quoted header with a
    semicolon in it does not turn a comma file into a one-column semicolon file."""
    rows = ['"t (s)","a; forward (m/s^2)"', *(f"{0.1 * k!r},{0.5 * k!r}" for k in range(10))]
    (tmp_path / "log.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    columns = read_columns(tmp_path / "log.csv", "t (s)", "a; forward (m/s^2)", what="accel")
    assert np.array_equal(columns.values, [0.5 * k for k in range(10)])


def test_a_comma_file_with_trailing_tabs_stays_comma_separated(tmp_path: Path) -> None:
    """A tab at the end of every row (a hand-edited file) splits it into one cell and an empty one: that is
    not a tab layout, and the file reads as the comma file it is."""
    rows = ["t,a\t", *(f"{0.1 * k!r},{0.5 * k!r}\t" for k in range(10))]
    (tmp_path / "log.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    columns = read_columns(tmp_path / "log.csv", "t", "a", what="accel")
    assert np.array_equal(columns.values, [0.5 * k for k in range(10)])


def test_a_decimal_comma_needs_a_separator_that_is_not_a_comma(tmp_path: Path) -> None:
    """ "1,5" in a comma file is two cells: the file reads as written (columns 1 and 2), nothing guessed."""
    (tmp_path / "log.csv").write_text("t,a\n0,5,1\n1,5,2\n", encoding="utf-8")
    columns = read_columns(tmp_path / "log.csv", "t", "a", what="accel")
    assert np.array_equal(columns.times, [0.0, 1.0]) and np.array_equal(columns.values, [5.0, 5.0])


@pytest.mark.parametrize("separator", ["\t", ";"])
def test_a_thousands_comma_in_a_decimal_point_file_is_refused_not_read_as_a_decimal_comma(
    separator: str, tmp_path: Path
) -> None:
    """A tab or semicolon file whose numbers have a decimal point (0.5) writes "1,000" for a thousand, not
    for 1.0: the layout is a decimal point, and the cell is refused on its own line, naming it (both readers:
    accel_csv's columns and the plain csv profile), where it was once read as 1.0."""
    rows = ["t,a", "0.0,0.5", "0.1,1,000", "0.2,0.7"]
    (tmp_path / "log.csv").write_text("\n".join(r.replace(",", separator, 1) for r in rows) + "\n", "utf-8")
    with pytest.raises(ParameterError, match=r"log\.csv:3: accel '1,000' is not a number \(a comma grouping"):
        read_columns(tmp_path / "log.csv", None, None, what="accel")
    with pytest.raises(ParameterError, match=r"log\.csv:3: '1,000' is not a number \(a comma grouping"):
        profile_from_dict({"type": "csv", "path": "log.csv"}, base_dir=tmp_path)
    # Without a decimal point anywhere the same cells are a decimal comma, as phyphox writes them.
    (tmp_path / "comma.csv").write_text(f"t{separator}a\n0{separator}1,000\n1{separator}1,25\n", "utf-8")
    assert np.array_equal(read_columns(tmp_path / "comma.csv", None, None, what="accel").values, [1.0, 1.25])


@pytest.mark.parametrize("separator", ["\t", ";"])
def test_a_file_has_one_decimal_mark_and_a_cell_with_the_other_is_refused(
    separator: str, tmp_path: Path
) -> None:
    """A decimal-comma file (its first rows say so) writes "1.000" for a thousand, not for 1.0: a cell
    with a decimal point further down is refused on its line, as is a decimal comma in a file whose first
    rows write decimal points; neither is read as a number of the other mark."""
    rows = ["t,a", *(f"{k},{k}|5" for k in range(30)), "30,1.000"]
    text = "\n".join(r.replace(",", separator).replace("|", ",") for r in rows) + "\n"
    (tmp_path / "comma.csv").write_text(text, encoding="utf-8")
    with pytest.raises(ParameterError, match=r"comma\.csv:32: '1\.000' has a decimal point in a file whose"):
        read_columns(tmp_path / "comma.csv", None, None, what="accel")
    (tmp_path / "mixed.csv").write_text(f"t{separator}a\n0{separator}0.5\n1{separator}1,5\n", "utf-8")
    with pytest.raises(ParameterError, match=r"mixed\.csv:3: accel '1,5' is not a number \(the file writes"):
        read_columns(tmp_path / "mixed.csv", None, None, what="accel")


@pytest.mark.parametrize("separator", ["\t", ";"])
@pytest.mark.parametrize("whole_rows", [0, 5, SNIFF_ROWS, 3 * SNIFF_ROWS])
def test_the_decimal_mark_is_the_first_one_the_file_writes_however_far_down(
    separator: str, whole_rows: int, tmp_path: Path
) -> None:
    """A log that starts at rest in whole numbers (``0;0``, ``1;0``) and only later writes ``0,5`` has a
    decimal comma: the mark is decided by the first number that has one, not by the first SNIFF_ROWS
    rows, and the file reads as its decimal-point twin, float for float. After that the other mark is
    refused on its line in both directions, as in a file whose first rows show the mark."""
    times = [f"{k}" for k in range(whole_rows)] + [f"{whole_rows + k}{{}}25" for k in range(10)]
    accels = ["0"] * whole_rows + [f"{k}{{}}5" for k in range(10)]

    def text(mark: str, last: str = "") -> str:
        pairs = zip(times, accels, strict=True)
        rows = [f"t{separator}a", *(f"{t.format(mark)}{separator}{a.format(mark)}" for t, a in pairs)]
        return "\n".join([*rows, *([last] if last else [])]) + "\n"

    (tmp_path / "point.csv").write_text(text("."), encoding="utf-8")
    (tmp_path / "comma.csv").write_text(text(","), encoding="utf-8")
    point = read_columns(tmp_path / "point.csv", "t", "a", what="accel")
    comma = read_columns(tmp_path / "comma.csv", "t", "a", what="accel")
    assert np.array_equal(comma.times, point.times) and np.array_equal(comma.values, point.values)
    assert comma.values[-1] == 9.5  # read as a decimal comma, not refused and not 9 or 95
    plain = profile_from_dict({"type": "csv", "path": "comma.csv"}, base_dir=tmp_path)
    assert isinstance(plain, Table) and np.array_equal(plain.accels, point.values)
    line = whole_rows + 12  # the header, the data rows, then the added row
    (tmp_path / "late_point.csv").write_text(text(",", f"{whole_rows + 10}{separator}1.000"), "utf-8")
    with pytest.raises(ParameterError, match=rf"late_point\.csv:{line}: '1\.000' has a decimal point"):
        read_columns(tmp_path / "late_point.csv", "t", "a", what="accel")
    (tmp_path / "late_comma.csv").write_text(text(".", f"{whole_rows + 10}{separator}1,5"), "utf-8")
    with pytest.raises(ParameterError, match=rf"late_comma\.csv:{line}: accel '1,5' is not a number \(the"):
        read_columns(tmp_path / "late_comma.csv", "t", "a", what="accel")


@pytest.mark.parametrize(("separator", "decimal"), [*PHYPHOX_LAYOUTS, ("|", ","), ("|", ".")])
def test_excels_sep_line_names_the_separator(separator: str, decimal: str, tmp_path: Path) -> None:
    """A first line ``sep=;`` (Excel's directive, which exports made for it in many locales begin with)
    names the separator: the rows read as the same file's without it, line numbers kept, in the plain csv
    profile too; any one character works, as in Excel ("|")."""
    rows = ["t,a (m/s^2)", *(f"{k}.25,{0.5 * k - 1.0!r}" for k in range(10))]
    plain = "\n".join(rows) + "\n"
    text = plain.replace(",", "\0").replace(".", decimal).replace("\0", separator)
    (tmp_path / "plain.csv").write_text(plain, encoding="utf-8")
    (tmp_path / "excel.csv").write_text(f"sep={separator}\n{text}", encoding="utf-8-sig")  # with its BOM
    want = read_columns(tmp_path / "plain.csv", "t", "a (m/s^2)", what="accel")
    got = read_columns(tmp_path / "excel.csv", "t", "a (m/s^2)", what="accel")
    assert np.array_equal(got.times, want.times) and np.array_equal(got.values, want.values)
    assert list(got.lines) == [line + 1 for line in want.lines]
    table = profile_from_dict({"type": "csv", "path": "excel.csv"}, base_dir=tmp_path)
    assert isinstance(table, Table) and np.array_equal(table.accels, want.values)


@pytest.mark.parametrize("separator", ["\t", ";"])
def test_a_comment_decides_no_decimal_mark(separator: str, tmp_path: Path) -> None:
    """A ``#`` comment is not data: its "0,5" neither makes the file a decimal-comma one nor is refused
    when the data write points, and its "1.5" is not refused in a decimal-comma file."""
    rows = ["t;a", "# tilt;0,5 deg", "0;0", "# rev;1.5", "1;0.25", "2;0.75"]
    (tmp_path / "log.csv").write_text("\n".join(r.replace(";", separator) for r in rows) + "\n", "utf-8")
    point = read_columns(tmp_path / "log.csv", "t", "a", what="accel")
    comma = [r.replace("0.", "0,") for r in rows]
    (tmp_path / "comma.csv").write_text("\n".join(r.replace(";", separator) for r in comma) + "\n", "utf-8")
    for columns in (point, read_columns(tmp_path / "comma.csv", "t", "a", what="accel")):
        assert np.array_equal(columns.values, [0.0, 0.25, 0.75])


@pytest.mark.parametrize("named", [True, False])
def test_a_units_row_under_the_header_is_skipped_and_a_second_text_row_is_refused(
    named: bool, tmp_path: Path
) -> None:
    """Loggers often write a units row under the names ("s", "m/s^2"): it is skipped, and the columns are
    the ones of the same file without it, bit for bit. Only one such row: a second row of text is data
    that does not parse, refused with its line."""
    data = [f"{0.01 * k!r},{math.sin(0.01 * k)!r}" for k in range(50)]
    (tmp_path / "plain.csv").write_text("\n".join(["t,ax", *data]) + "\n", encoding="utf-8")
    (tmp_path / "units.csv").write_text("\n".join(["t,ax", "s,m/s^2", *data]) + "\n", encoding="utf-8")
    names: tuple[str | None, str | None] = ("t", "ax") if named else (None, None)
    plain = read_columns(tmp_path / "plain.csv", *names, what="accel")
    units = read_columns(tmp_path / "units.csv", *names, what="accel")
    assert np.array_equal(units.times, plain.times) and np.array_equal(units.values, plain.values)
    assert list(units.lines) == [line + 1 for line in plain.lines]  # rows keep their own line numbers
    (tmp_path / "two.csv").write_text("\n".join(["t,ax", "s,m/s^2", "sec,g", *data]) + "\n", encoding="utf-8")
    with pytest.raises(ParameterError, match=r"two\.csv:3: time 'sec' is not a number"):
        read_columns(tmp_path / "two.csv", *names, what="accel")


EPOCH_NS = 1_616_000_000_123_456_789  # a logger's epoch stamp in ns: a float keeps it only to 256 ns


def test_accel_csv_reads_epoch_nanoseconds_as_rostopic_echo_writes_them(tmp_path: Path) -> None:
    """`rostopic echo -p` writes %time in integer epoch ns: with time_units ns the times are the integer
    differences from the first row, scaled once (exact to the last bit of that product), and the window is
    in s after the first row as for any time column."""
    steps = [10_000_000 * k + (k % 3) * 1_000 for k in range(400)]  # 100 Hz with µs jitter
    accels = [math.sin(0.05 * k) for k in range(400)]
    rows = ["%time,field.header.seq,field.linear_acceleration.x"]
    rows += [f"{EPOCH_NS + n},{k},{a!r}" for k, (n, a) in enumerate(zip(steps, accels, strict=True))]
    (tmp_path / "imu.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    spec: dict[str, object] = {"type": "accel_csv", "path": "imu.csv", "time_column": "%time",
                               "accel_column": "field.linear_acceleration.x", "time_units": "ns"}  # fmt: skip
    profile = table_of(spec, base_dir=tmp_path)
    assert np.array_equal(profile.times, np.array(steps, dtype=float) * 1e-9)
    assert np.array_equal(profile.accels, accels)
    window = table_of(spec | {"start": 1.0, "end": 3.0}, base_dir=tmp_path)
    assert window.times[0] == 0.0 and window.times[-1] == pytest.approx(2.0, abs=1e-12)
    # Milliseconds with a fraction are read as floats, then scaled the same way.
    rows_ms = ["t_ms,a", *(f"{1.6e12 + n / 1e6!r},{a!r}" for n, a in zip(steps, accels, strict=True))]
    (tmp_path / "ms.csv").write_text("\n".join(rows_ms) + "\n", encoding="utf-8")
    ms = table_of({"type": "accel_csv", "path": "ms.csv", "time_units": "ms"}, base_dir=tmp_path)
    # 1.6e12 ms in a float is held to 2.4e-4 ms, so each time is within 2.4e-7 s of the true one.
    assert np.allclose(ms.times, np.array(steps) * 1e-9, rtol=0.0, atol=2.5e-7)


STAMPED: dict[str, object] = {"type": "accel_csv", "time_column": [1, 2]}
"""An accel_csv spec whose time is a ROS 2 stamp in columns 1 and 2 (sec, nanosec)."""


def ros2_echo_csv_imu(stamp_ns: int, accel_x: float) -> str:
    """One sensor_msgs/Imu line as ``ros2 topic echo --csv`` prints it: rosidl_runtime_py's message_to_csv
    (convert.py), the fields in .msg order with arrays flattened and no header: header.stamp.sec,
    .nanosec, frame_id, orientation (4), its covariance (9), angular_velocity (3), its covariance (9),
    linear_acceleration (3: x is column 29), its covariance (9)."""
    sec, nanosec = divmod(stamp_ns, 10**9)
    nine = ",".join(["0.0"] * 9)
    return f"{sec},{nanosec},imu_link,0.0,0.0,0.0,1.0,{nine},0.0,0.0,0.0,{nine},{accel_x!r},0.0,9.81,{nine}"


def test_accel_csv_reads_the_two_stamp_columns_ros2_topic_echo_csv_writes(tmp_path: Path) -> None:
    """time_column [1, 2] reads a ROS 2 stamp's sec and nanosec as one time: the integer ns difference from
    the first row divided by 10⁹ once, correctly rounded (the difference, below 2⁵³, is exact as a float),
    so each time is within half an ulp of its exact value, across whole-second boundaries too. The value
    column is copied exactly. Named columns (an exporter's header) read the same."""
    first = 1_700_000_000_995_000_000  # 5 ms before a second boundary
    stamps = [first + 10_000_000 * k + (k % 3) * 1_000 for k in range(400)]  # 100 Hz with µs jitter
    accels = [0.5 * math.sin(0.01 * k) for k in range(400)]
    rows = [ros2_echo_csv_imu(n, a) for n, a in zip(stamps, accels, strict=True)]
    (tmp_path / "imu.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    spec = STAMPED | {"path": "imu.csv", "accel_column": 29}
    profile = table_of(spec, base_dir=tmp_path)
    for t, n in zip(profile.times, stamps, strict=True):
        exact = Fraction(n - first, 10**9)
        assert abs(Fraction(float(t)) - exact) <= Fraction(math.ulp(float(t))) / 2
    assert np.array_equal(profile.accels, accels)
    named = ["header.stamp.sec,header.stamp.nanosec,a"]
    named += [f"{n // 10**9},{n % 10**9},{a!r}" for n, a in zip(stamps, accels, strict=True)]
    (tmp_path / "named.csv").write_text("\n".join(named) + "\n", encoding="utf-8")
    stamp = ["header.stamp.sec", "header.stamp.nanosec"]
    again = table_of(spec | {"path": "named.csv", "time_column": stamp, "accel_column": "a"}, tmp_path)
    assert np.array_equal(again.times, profile.times) and np.array_equal(again.accels, profile.accels)


@pytest.mark.parametrize(
    ("extra", "line", "message"),
    [
        ({"time_column": [1, 2, 3]}, None, "'time_column' must be one column or two .*got 3"),
        ({"time_column": [1, True]}, None, "'time_column' must be a header name or a column number"),
        ({"accel_column": None}, None, "needs accel_column stated"),
        ({"time_units": "ns"}, None, "takes no time_format or time_units"),
        (
            {},
            "1,1000000000,0.5",
            r"log\.csv:3: time '1\.1000000000' is no ROS 2 stamp .*nanosec '1000000000'",
        ),
        ({}, "1,5e8,0.5", r"log\.csv:3: time '1\.5e8' is no ROS 2 stamp .*whole numbers"),
    ],
)
def test_a_stamp_time_column_is_refused_in_one_line_naming_what_is_wrong(
    extra: dict[str, object], line: str | None, message: str, tmp_path: Path
) -> None:
    """A stamp needs exactly two columns, the value column stated, no time_units or time_format, integer
    cells and nanosec below 10⁹; each failure is one ParameterError naming the field or the line."""
    rows = ["0,0,0.5", "0,10000000,0.5", line or "0,20000000,0.5", "0,30000000,0.5"]
    (tmp_path / "log.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    spec = {
        k: v for k, v in (STAMPED | {"path": "log.csv", "accel_column": 3} | extra).items() if v is not None
    }
    with pytest.raises(ParameterError, match=message):
        profile_from_dict(spec, base_dir=tmp_path)


@pytest.mark.parametrize(
    ("extra", "rows", "message"),
    [
        ({"time_units": "minutes"}, ["0,1", "1,1"],
         "'time_units' must be one of s, ms, us, ns, got 'minutes'"),
        ({"time_units": "ns"}, ["2007-03-28 07:00:00,1", "2007-03-28 07:00:01,1"],
         "log.csv:1: time_units 'ns' is for a numeric time column, and this one holds date-times"),
    ],
)  # fmt: skip
def test_time_units_errors_are_one_line(
    extra: dict[str, object], rows: list[str], message: str, tmp_path: Path
) -> None:
    """A unit not in the list, or a unit for a date-time column: one line naming the field or the row."""
    (tmp_path / "log.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    with pytest.raises(ParameterError) as err:
        table_of({"type": "accel_csv", "path": "log.csv"} | extra, base_dir=tmp_path)
    assert message in str(err.value) and "\n" not in str(err.value)
