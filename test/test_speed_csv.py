"""speed_csv and the logs users bring: named columns, long logs, one-line errors naming the row, rows at a
repeated time, and date-time columns cut to a trip's window (accel_csv's date-times too). A straight
line's bound "as above" is test_speed_trace's straight-ramp test's.
"""

from __future__ import annotations

import datetime as dt
import math
from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.cli.main import main
from pendulum_accel.errors import ParameterError, SceneError
from pendulum_accel.motion_input import profile_from_dict
from pendulum_accel.motion_input.columns import PackedTexts, read_columns
from pendulum_accel.motion_input.trace import (
    spline_margin,
)
from pendulum_accel.physics.profiles import Table
from pendulum_accel.scene import (
    SCENES_DIR,
    load_scene,
)
from test.motion_tables import table_of


def write_speed_csv(path: Path, rows: list[tuple[float, float]], header: str = "t,v") -> Path:
    """A speed CSV with a comment, a header and ``rows``."""
    lines = ["# test trace", header, *(f"{t!r},{v!r}" for t, v in rows)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_speed_csv_reads_named_columns_and_round_trips(tmp_path: Path) -> None:
    """Named columns in any order; to_dict is a standalone speed_table that reads back equal."""
    rows = [(float(i), 3.6 * (2.0 + 0.5 * i)) for i in range(40)]
    lines = ["speed_kmh,time_s", *(f"{v},{t}" for t, v in rows)]
    (tmp_path / "trace.csv").write_text("\n".join(lines) + "\n", encoding="utf-8")
    spec = {"type": "speed_csv", "path": "trace.csv", "units": "km/h", "time_column": "time_s",
            "speed_column": "speed_kmh", "cutoff_hz": 0.2}  # fmt: skip
    profile = table_of(spec, base_dir=tmp_path)
    assert np.max(np.abs(np.array(profile.accels) - 0.5)) <= 1e-9  # a straight line, as above
    assert isinstance(profile, Table) and "cut-off 0.2 Hz" in profile.origin
    again = profile_from_dict(profile.to_dict())
    assert again == profile and profile.to_dict()["type"] == "speed_table"


def test_a_long_logs_rows_keep_their_own_text_and_line_past_each_pack(tmp_path: Path) -> None:
    """read_columns packs the rows' time texts (PackedTexts, PACK to a string) and line numbers as it reads:
    rows on both sides of each pack's edge come back as the file writes them, and a time stepping back
    there is named by its own line and text (the message the whole trace check gives)."""
    pack = PackedTexts.PACK
    n = 2 * pack + 10
    times = [f"{k // 100}.{k % 100:02d}" for k in range(n)]  # as a logger writes them: '0.00', '40.96'
    rows = ["t,a", *(f"{t},{0.001 * k!r}" for k, t in enumerate(times))]
    path = tmp_path / "log.csv"
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    columns = read_columns(path, None, None, what="accel")
    assert len(columns.stamps) == n
    for i in (0, pack - 1, pack, pack + 1, 2 * pack, n - 1):
        assert columns.stamp(i) == times[i]
        assert columns.where(i, path) == f"{path}:{i + 2}"  # the header is line 1
    assert columns.stamp(-1) == times[-1]
    with pytest.raises(IndexError):
        columns.stamp(n)
    # Exact floats from their own texts: '40.96' → 40.96 (float parses each cell correctly rounded).
    assert np.array_equal(columns.times, [float(t) for t in times])
    back = pack + 3
    rows[back + 1] = f"{times[back - 2]},0.0"  # row back (line back + 2) repeats an earlier time
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    with pytest.raises(ParameterError) as err:
        profile_from_dict({"type": "accel_csv", "path": str(path)}, base_dir=tmp_path)
    said = f":{back + 2}: time steps back, got '{times[back - 2]}' after '{times[back - 1]}'"
    assert said in str(err.value)


# ---------------------------------------------------------------- errors: one line each


@pytest.mark.parametrize(
    ("rows", "extra", "message"),
    [
        (
            [(0.0, 1.0), (1.0, 1.0), (1.0, 2.0), (2.0, 2.0), (3.0, 2.0)],
            {},
            ":5: 1 of 5 rows repeat the time of the row before",
        ),
        (
            [(0.0, 1.0), (1.0, 1.0), (0.5, 2.0), (2.0, 2.0), (3.0, 2.0)],
            {},
            ":5: time steps back, got '0.5' after '1.0'",
        ),
        (
            [(0.0, 1.0), (1.0, math.nan), (2.0, 2.0), (3.0, 2.0), (4.0, 2.0)],
            {},
            ":4: speed is not a finite number",
        ),
        ([(0.0, 1.0), (1.0, 1.0), (2.0, 1.0), (30.0, 2.0), (31.0, 2.0)], {}, ":6: gap of 28 s"),
        ([(0.0, 1.0), (1.0, -0.5), (2.0, 1.0), (3.0, 1.0), (4.0, 1.0)], {}, ":4: speed -0.5 mph is negative"),
        ([(0.0, 1.0), (1.0, 1.0), (2.0, 1.0), (3.0, 1.0)], {}, "at least 5 samples"),
        ([(float(i), 1.0) for i in range(8)], {"cutoff_hz": 0.9}, "Nyquist frequency 0.5 Hz"),
        ([(float(i), 1.0) for i in range(8)], {"end": 9.0}, "start < end <= 7 s"),
        ([(float(i), 1.0) for i in range(8)], {"units": "knots"}, "'units' must be one of m/s, km/h, mph"),
        ([(float(i), 1.0) for i in range(8)], {"speed_column": "speed"}, "no column 'speed' in header"),
        ([(float(i), 1.0) for i in range(8)], {"signed": "yes"}, "'signed' must be true or false"),
    ],
)
def test_bad_speed_traces_give_one_line_naming_the_row(
    rows: list[tuple[float, float]], extra: dict[str, object], message: str, tmp_path: Path
) -> None:
    """Each bad trace: one ParameterError line, naming file and line where a row is at fault."""
    path = write_speed_csv(tmp_path / "bad.csv", rows)
    spec: dict[str, object] = {"type": "speed_csv", "path": str(path), "units": "mph", **extra}
    with pytest.raises(ParameterError) as info:
        profile_from_dict(spec)
    text = str(info.value)
    assert message in text and "\n" not in text, text


def test_units_are_required_and_a_bad_scene_is_one_cli_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """No default unit: a scene without 'units' fails; the CLI prints one line and exits 2."""
    write_speed_csv(tmp_path / "trace.csv", [(float(i), 1.0) for i in range(8)])
    text = (SCENES_DIR / "hwfet.yaml").read_text(encoding="utf-8")
    text = text.replace("path: real_motion/hwfet.csv", "path: trace.csv").replace("  units: mph\n", "")
    text = text.replace("  time_column: t_s\n", "").replace("  speed_column: speed_mph\n", "")
    scene_file = tmp_path / "mine.yaml"
    scene_file.write_text(text, encoding="utf-8")
    with pytest.raises(SceneError, match="speed_csv profile is missing field 'units'"):
        load_scene(scene_file)
    assert main(["simulate", str(scene_file), "--duration", "1", "--out", str(tmp_path / "o.csv")]) == 2
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err.count("\n") == 1 and "units" in captured.err


# ---------------------------------------------------------------- logs as users bring them

DAY = dt.datetime(2007, 3, 28, 7, 0, 0)
TRIP = np.arange(0.0, 601.0)  # two 10-minute trips at 1 Hz, 2 h 10 min apart
TRIP_SPEEDS = np.round(30.0 + 20.0 * np.sin(2 * np.pi * TRIP / 120.0), 2)  # km/h, 0.01 resolution
SECOND_TRIP_S = 7800.0


def write_day_log(path: Path, layout: str = "%Y-%m-%d %H:%M:%S") -> Path:
    """A day-long speed log whose time column holds date-times: two trips with a 2 h gap between."""
    rows = ["time,speed_kmh"]
    for base in (0.0, SECOND_TRIP_S):
        for t, v in zip(TRIP, TRIP_SPEEDS, strict=True):
            rows.append(f"{(DAY + dt.timedelta(seconds=float(base + t))).strftime(layout)},{float(v)!r}")
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def one_trip(tmp_path: Path, **window: float) -> Table:
    """The second trip alone, given in seconds in a file of its own, with ``window`` (s) applied."""
    path = write_speed_csv(tmp_path / "trip.csv", list(zip(TRIP.tolist(), TRIP_SPEEDS.tolist(), strict=True)))
    return table_of({"type": "speed_csv", "path": str(path), "units": "km/h", **window})


DAY_SPEC = {"type": "speed_csv", "path": "day.csv", "units": "km/h", "time_column": "time",
            "speed_column": "speed_kmh"}  # fmt: skip


@pytest.mark.parametrize(
    ("layout", "extra"),
    [
        ("%Y-%m-%d %H:%M:%S", {}),  # detected: ISO 8601 with a space
        ("%Y-%m-%dT%H:%M:%S.%fZ", {}),  # detected: ISO 8601 with T, fraction and UTC
        ("%d/%m/%Y %H:%M:%S", {"time_format": "%d/%m/%Y %H:%M:%S"}),  # stated
    ],
)
def test_a_trip_is_cut_by_date_time_from_a_day_long_log_with_gaps(
    layout: str, extra: dict[str, object], tmp_path: Path
) -> None:
    """start/end as date-times pick one trip; the gap outside the window is not refused, and the profile
    is exactly the one of that trip given in seconds on its own (same samples, same spline)."""
    write_day_log(tmp_path / "day.csv", layout)
    start, end = DAY + dt.timedelta(seconds=7920), DAY + dt.timedelta(seconds=8100)
    as_text = {"start": start.strftime(layout), "end": end.strftime(layout)}
    spec = DAY_SPEC | extra | as_text
    profile = table_of(spec, base_dir=tmp_path)
    assert profile == one_trip(tmp_path, start=120.0, end=300.0)
    assert profile.times[-1] == pytest.approx(180.0, abs=1e-9)
    assert profile_from_dict(profile.to_dict()) == profile  # the bag's standalone copy holds the trip only
    # ... and of the trip only what the window's a(t) depends on: the samples that bracket the window
    # widened by spline_margin (41 s at the default 0.25 Hz), not the whole 600 s trip.
    kept = np.array(profile.to_dict()["times"])
    margin = spline_margin(0.25)
    lo, hi = SECOND_TRIP_S + 120.0 - margin, SECOND_TRIP_S + 300.0 + margin
    assert kept[0] <= lo < kept[1] and kept[-2] < hi <= kept[-1]
    assert np.array_equal(kept, np.arange(kept[0], kept[-1] + 1.0))  # every 1 Hz sample between
    # YAML reads an unquoted date-time as a datetime; seconds after the first row work too.
    zone = dt.UTC if layout.endswith("Z") else None  # a zoned column wants zoned bounds
    moments = {"start": start.replace(tzinfo=zone), "end": end.replace(tzinfo=zone)}
    assert table_of(DAY_SPEC | extra | moments, base_dir=tmp_path) == profile
    assert table_of(DAY_SPEC | extra | {"start": 7920.0, "end": 8100.0}, base_dir=tmp_path) == profile


def test_a_headerless_date_time_log_keeps_its_first_row(tmp_path: Path) -> None:
    """No header: the first row's date-time is data, not a header (all 601 samples are read)."""
    stamps = [DAY + dt.timedelta(seconds=float(t)) for t in TRIP]
    rows = [f"{s.isoformat(sep=' ')},{float(v)!r}" for s, v in zip(stamps, TRIP_SPEEDS, strict=True)]
    (tmp_path / "bare.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    columns = read_columns(tmp_path / "bare.csv", None, None)
    assert columns.times.size == TRIP.size and np.array_equal(columns.times, TRIP)
    assert columns.epoch == DAY
    assert table_of(
        {"type": "speed_csv", "path": "bare.csv", "units": "km/h"}, base_dir=tmp_path
    ) == one_trip(tmp_path)


def test_rows_at_a_repeated_time_are_averaged_and_later_errors_name_their_own_rows(tmp_path: Path) -> None:
    """A logger that writes a time twice (a phone's millisecond clock, a GPS fix written again): the rows at
    one time become one sample, their mean (1.0 and 2.0 give 1.5, exact in binary), the origin says how
    many rows were averaged, and an error about a later sample still names that sample's own line."""
    times = [0.01 * k for k in range(40)]
    accels = [0.5] * 40
    rows = [f"{t!r},{a!r}" for t, a in zip(times, accels, strict=True)]
    rows.insert(11, f"{times[10]!r},{1.0!r}")  # line 13: a second row at t = 0.1
    rows[10] = f"{times[10]!r},{2.0!r}"
    rows.insert(21, f"{times[19]!r},{0.5!r}")  # the same row written twice
    (tmp_path / "imu.csv").write_text("t,ax\n" + "\n".join(rows) + "\n", encoding="utf-8")
    spec: dict[str, object] = {"type": "accel_csv", "path": "imu.csv"}
    profile = table_of(spec, base_dir=tmp_path)
    # Used as recorded (no cut-off): the samples joined linearly, one per distinct time.
    assert profile.times == pytest.approx(times, abs=1e-12)  # shifted to t0 = 0: exact here (t0 = 0.0)
    assert profile.accels[10] == 1.5 and profile.accels[19] == 0.5
    assert "40 samples, 2 rows at a repeated time averaged" in profile.origin
    # A NaN after the repeats, in rows[31]: line 1 is the header, so line 33 (the 30th distinct time).
    rows[31] = rows[31].split(",")[0] + ",nan"
    (tmp_path / "imu.csv").write_text("t,ax\n" + "\n".join(rows) + "\n", encoding="utf-8")
    with pytest.raises(ParameterError, match=r"imu.csv:33: acceleration is not a finite number"):
        profile_from_dict(spec, base_dir=tmp_path)
    # A NaN in the second row of a repeated time (rows[11], line 13): that row is named, not the run's first.
    rows[31] = rows[31].split(",")[0] + ",0.5"
    rows[11] = rows[11].split(",")[0] + ",nan"
    (tmp_path / "imu.csv").write_text("t,ax\n" + "\n".join(rows) + "\n", encoding="utf-8")
    with pytest.raises(ParameterError, match=r"imu.csv:13: acceleration is not a finite number \(nan\)"):
        profile_from_dict(spec, base_dir=tmp_path)
    # A negative speed after a repeat: named on its own line too.
    speeds = [(float(k), 3.0) for k in range(12)]
    speeds.insert(3, (2.0, 3.0))
    speeds[9] = (speeds[9][0], -1.0)
    path = write_speed_csv(tmp_path / "v.csv", speeds)  # a comment and a header: row k on line k + 3
    with pytest.raises(ParameterError, match=r"v.csv:12: speed -1.0 mph is negative"):
        profile_from_dict({"type": "speed_csv", "path": str(path), "units": "mph"})
    # Whole seconds for a 10 Hz log (ros2 topic echo --csv's sec column): 9 of every 10 rows repeat a time,
    # past MAX_REPEATED_SHARE, so it is refused, naming the first repeated row (line 4: the 2nd row).
    coarse = [(float(k // 10), 3.0) for k in range(100)]
    path = write_speed_csv(tmp_path / "coarse.csv", coarse)
    with pytest.raises(
        ParameterError, match=r"coarse.csv:4: 90 of 100 rows repeat the time of the row before"
    ):
        profile_from_dict({"type": "speed_csv", "path": str(path), "units": "mph"})


@pytest.mark.parametrize(
    ("edit", "extra", "message"),
    [
        # A time that steps back: the row is named, with its time as the file writes it.
        (lambda r: [*r[:4], r[5], r[4], *r[6:]], {}, "day.csv:6: time steps back, "
         "got '2007-03-28 07:00:03' after '2007-03-28 07:00:04'"),
        (lambda r: r, {"start": "2007-03-28 07:05:00", "end": "2007-03-28 09:15:00"},
         "day.csv:603: gap of 7200 s before this sample"),
        (lambda r: r, {}, "day.csv:603: gap of 7200 s before this sample, more than 5 × the median step "
         "1 s; start/end can cut a window without it"),
        (lambda r: [*r[:3], "03/28/2007 07:00:02,31.0", *r[4:]], {}, "day.csv:4: time '03/28/2007 07:00:02' "
         "is not a number or an ISO 8601 date-time (state time_format"),
        (lambda r: [*r[:3], "2.0,31.0", *r[4:]], {}, "day.csv:4: time '2.0' mixes numbers and date-times"),
        (lambda r: r, {"time_format": "%d/%m/%Y"}, "day.csv:2: time '2007-03-28 07:00:00' is not the "
         "time_format '%d/%m/%Y'"),
        (lambda r: r, {"start": "yesterday"}, "field 'start' must be a number of s or a date-time"),
        (lambda r: r, {"start": "2007-03-28 07:05:00+02:00"},
         "one date-time has a time zone and another none"),
        (lambda r: r, {"start": "2007-03-29 07:05:00"}, "window start/end must satisfy"),
    ],
)  # fmt: skip
def test_date_time_logs_give_one_line_naming_the_row(
    edit: object, extra: dict[str, object], message: str, tmp_path: Path
) -> None:
    """Each bad date-time log or window: one ParameterError line, naming the row where one is at fault."""
    rows = write_day_log(tmp_path / "day.csv").read_text(encoding="utf-8").splitlines()
    (tmp_path / "day.csv").write_text("\n".join(edit(rows)) + "\n", encoding="utf-8")  # type: ignore[operator]
    with pytest.raises(ParameterError) as info:
        profile_from_dict(DAY_SPEC | extra, base_dir=tmp_path)
    assert message in str(info.value) and "\n" not in str(info.value), str(info.value)


def test_a_window_in_seconds_refuses_date_times_for_a_trace_in_seconds(tmp_path: Path) -> None:
    """A date-time start on a trace whose times are seconds has no epoch to count from: one line."""
    path = write_speed_csv(tmp_path / "trip.csv", list(zip(TRIP.tolist(), TRIP_SPEEDS.tolist(), strict=True)))
    with pytest.raises(ParameterError, match=r"is a date-time .* but the trace's times are seconds"):
        profile_from_dict({"type": "speed_csv", "path": str(path), "units": "km/h", "start": DAY})


def test_accel_csv_reads_date_times_and_cuts_a_window_before_the_gap_check(tmp_path: Path) -> None:
    """An IMU log with date-time stamps and a gap: the window before the gap is used as recorded."""
    rows = ["stamp,ax"]
    for t in [*np.arange(0.0, 60.0, 0.5), *np.arange(600.0, 660.0, 0.5)]:
        rows.append(f"{(DAY + dt.timedelta(seconds=float(t))).isoformat()},{math.sin(0.1 * t)!r}")
    (tmp_path / "imu.csv").write_text("\n".join(rows) + "\n", encoding="utf-8")
    spec: dict[str, object] = {
        "type": "accel_csv", "path": "imu.csv", "time_column": "stamp", "accel_column": "ax",
        "start": "2007-03-28T07:00:10", "end": "2007-03-28T07:00:50",
    }  # fmt: skip
    profile = table_of(spec, base_dir=tmp_path)
    assert profile.times[0] == 0.0 and profile.times[-1] == pytest.approx(40.0, abs=1e-9)
    # The window's ends fall on samples, which are copied as recorded.
    assert profile.accels[0] == math.sin(1.0) and profile.accels[-1] == pytest.approx(
        math.sin(5.0), abs=1e-12
    )
    assert "120 samples" in profile.origin  # the stretch before the gap
