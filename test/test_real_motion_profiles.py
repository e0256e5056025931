"""Real motion as input: speed_csv / speed_table / bag_topic profiles, the bundled drive cycles and robot.

The differentiation is a smoothing spline whose gain is H(f) = 1 / (1 + (√2 − 1)(f/f_c)⁴) in its
continuous limit (motion_input/trace.py); the tolerances below come from that H, from the table's
chord bound TABLE_TOLERANCE, and from the spline's end effects, which the checks keep clear of.
"""

from __future__ import annotations

import datetime as dt
import math
from fractions import Fraction
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pendulum_accel.cli.main import main
from pendulum_accel.errors import ParameterError, SceneError
from pendulum_accel.motion_input import profile_from_dict
from pendulum_accel.motion_input.columns import SNIFF_ROWS, PackedTexts, read_columns
from pendulum_accel.motion_input.speed_trace import SPEED_UNITS
from pendulum_accel.motion_input.trace import (
    DEFAULT_MAX_CUTOFF_HZ,
    TABLE_TOLERANCE,
    check_trace,
    default_cutoff_hz,
    differentiate,
    median_step,
    spline_lambda,
    spline_margin,
)
from pendulum_accel.overrides import OVERRIDE_BY_NAME, SENSOR_DESIGNS, apply_overrides
from pendulum_accel.physics.profiles import Table
from pendulum_accel.scene import (
    BUNDLED_SCENE_NAMES,
    CORPUS_SCENE_NAMES,
    REAL_MOTION_SCENE_NAMES,
    SCENE_NAMES,
    SCENES_DIR,
    load_scene,
    scene_from_yaml,
    scene_to_yaml,
)

DATA = SCENES_DIR / "real_motion"


def gain(f: float, cutoff: float) -> float:
    """H(f) of the smoothing spline in its continuous limit, −3 dB at ``cutoff``."""
    return 1.0 / (1.0 + (math.sqrt(2.0) - 1.0) * (f / cutoff) ** 4)


def table_of(spec: dict[str, object], base_dir: Path | None = None) -> Table:
    """profile_from_dict(spec), which for every real-motion type is a Table."""
    profile = profile_from_dict(spec, base_dir=base_dir)
    assert isinstance(profile, Table)
    return profile


def write_speed_csv(path: Path, rows: list[tuple[float, float]], header: str = "t,v") -> Path:
    """A speed CSV with a comment, a header and ``rows``."""
    lines = ["# test trace", header, *(f"{t!r},{v!r}" for t, v in rows)]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


# ---------------------------------------------------------------- units and differentiation


@pytest.mark.parametrize("units", list(SPEED_UNITS))
def test_units_convert_a_straight_speed_ramp(units: str) -> None:
    """v = 3 + 0.7 t in each unit gives a = 0.7 × (m/s per unit) everywhere.

    A straight line has ∫ s''² = 0, so the spline reproduces it exactly; what is left is the rounding of
    its banded solve, a few hundred ulps of v/h ≈ 100 m/s / 1 s (≤ 1e-11 m/s²), far below 1e-9.
    """
    times = [float(i) for i in range(60)]
    profile = table_of(
        {"type": "speed_table", "units": units, "times": times, "speeds": [3.0 + 0.7 * t for t in times]}
    )
    assert isinstance(profile, Table)
    expected = 0.7 * SPEED_UNITS[units]
    assert np.max(np.abs(np.array(profile.accels) - expected)) <= 1e-9
    assert SPEED_UNITS["mph"] == 0.44704 and SPEED_UNITS["km/h"] == pytest.approx(1 / 3.6, rel=1e-15)


def test_differentiation_of_a_slow_sinusoid_matches_the_analytic_derivative() -> None:
    """v = 20 + 10 sin(2π f t), f = f_c / 5, 1 Hz samples (as the EPA schedules): a = H(f) · v'(t).

    Bound: the table's chord error (≤ TABLE_TOLERANCE by construction) plus how far the discrete
    spline is from its continuous-limit H at 2π f h = 0.31, which is O((2π f h)⁴ (f/f_c)⁴) of the
    amplitude: 0.1 % of 3.1 m/s² covers it with a margin. Compared with v' itself, the difference is
    the stated (1 − H) = 6.6e-4 relative: the cut-off is where the spline says it is.
    """
    cutoff, f, amplitude = 0.25, 0.05, 10.0
    t = np.arange(0.0, 600.0, 1.0)
    profile = differentiate(t, 20.0 + amplitude * np.sin(2 * np.pi * f * t), cutoff)
    times, accels = np.array(profile.times), np.array(profile.accels)
    exact = amplitude * 2 * np.pi * f * np.cos(2 * np.pi * f * times)
    inside = (times > 4 / cutoff) & (times < times[-1] - 4 / cutoff)  # clear of the spline's end effects
    peak = amplitude * 2 * np.pi * f
    error = np.abs(accels[inside] - gain(f, cutoff) * exact[inside])
    assert np.max(error) <= TABLE_TOLERANCE + 1e-3 * peak
    assert (
        np.max(np.abs(accels[inside] - exact[inside]))
        <= (1 - gain(f, cutoff)) * peak + TABLE_TOLERANCE + 1e-3 * peak
    )


def test_the_stated_cutoff_is_the_minus_3_db_point() -> None:
    """A sinusoid at f = f_c comes out with gain 1/√2 and no phase shift (the spline is symmetric).

    Samples 50 Hz, f_c = 1 Hz: 2π f h = 0.13, where the continuous-limit H is within 1e-4 of the
    discrete spline's gain. A λ off by a factor 2 would move the gain to 0.58 or 0.82, so 1 % is a test.
    """
    cutoff = 1.0
    t = np.arange(0.0, 60.0, 0.02)
    profile = differentiate(t, 5.0 + np.sin(2 * np.pi * cutoff * t), cutoff)
    times, accels = np.array(profile.times), np.array(profile.accels)
    inside = (times > 4 / cutoff) & (times < times[-1] - 4 / cutoff)
    basis = np.c_[np.cos(2 * np.pi * cutoff * times[inside]), np.sin(2 * np.pi * cutoff * times[inside])]
    (c, s), *_ = np.linalg.lstsq(basis, accels[inside], rcond=None)
    assert math.hypot(c, s) / (2 * np.pi * cutoff) == pytest.approx(1 / math.sqrt(2), rel=1e-2)
    assert abs(math.atan2(s, c)) <= 1e-3  # rad: a cosine in, a cosine out


def test_default_cutoff_is_half_nyquist_at_most_one_hz() -> None:
    """1 Hz samples → 0.25 Hz; 50 Hz samples → capped at 1 Hz."""
    assert default_cutoff_hz(np.arange(10.0)) == 0.25
    assert default_cutoff_hz(np.arange(0.0, 2.0, 0.02)) == DEFAULT_MAX_CUTOFF_HZ == 1.0


def test_window_starts_at_zero_and_keeps_the_whole_trace_fit(tmp_path: Path) -> None:
    """start/end cut the table to [start, end], shifted to t = 0; the values are the full fit's.

    Same spline, same evaluation points up to the grids' spacing: the two tables agree to their chord
    error, 2 × TABLE_TOLERANCE.
    """
    t = np.arange(100.0, 400.0, 1.0)  # a trace that does not start at 0
    v = 10 + 5 * np.sin(2 * np.pi * 0.03 * t)
    whole = differentiate(t, v, 0.25)
    part = differentiate(t, v, 0.25, start=50.0, end=120.0)
    assert part.times[0] == 0.0 and part.times[-1] == pytest.approx(70.0, abs=1e-9)
    probe = np.linspace(0.0, 70.0, 301)
    assert np.max(np.abs(part(probe) - whole(probe + 50.0))) <= 2 * TABLE_TOLERANCE


@pytest.mark.parametrize(("cutoff", "step"), [(0.25, 1.0), (0.05, 0.5)])
def test_a_window_fitted_on_its_margin_alone_is_the_whole_stretchs_fit(cutoff: float, step: float) -> None:
    """Cutting a long stretch to the window and spline_margin on each side (Stretch.around_window) leaves
    the window's a(t) as the whole stretch's spline gives it, and cutting again changes nothing.

    Bound: the data cut off weigh e^(−56.6) ≈ 3e-25 in the window (SPLINE_MARGIN_WIDTHS); what is left is
    each fit's rounding, a banded solve of n ≤ 20,000 equations losing about n ε ≈ 4e-12 of the speeds'
    ≤ 30 m/s, ≲ 1e-10 m/s² in a slope over h ≥ 0.5 s (measured 1.6e-13 and 1.0e-12): 1e-9 m/s²."""
    rng = np.random.default_rng(7)
    n = round(3000 / step) if step == 1.0 else 20_000
    t = 1000.0 + step * np.arange(n)
    v = 15.0 + np.cumsum(rng.normal(0.0, 0.3 * math.sqrt(step), n))  # a wandering speed, m/s
    length = float(t[-1] - t[0])
    stretch = check_trace(t, v, str, start=0.4 * length, end=0.5 * length)
    margin = spline_margin(cutoff)
    near = stretch.around_window(margin)
    assert near.around_window(margin) is near  # idempotent: a bag's copy, read back, is cut no further
    assert near.times.size < stretch.times.size / 3 and not near.whole
    assert near.times[0] <= stretch.times[0] + stretch.lo - margin < near.times[1]
    part = differentiate(near.times, near.values, cutoff, start=near.lo, end=near.hi)
    # The whole stretch's s'(t) at the part's table points (its grid is its own: the step follows max|a''|).
    from scipy.interpolate import make_smoothing_spline

    lam = spline_lambda(cutoff, median_step(stretch.times - stretch.times[0]))
    slope = make_smoothing_spline(stretch.times - stretch.times[0], stretch.values, lam=lam).derivative()
    shift = near.lo + float(near.times[0] - stretch.times[0])  # the part's t = 0 on the whole axis
    assert near.lo > 0.0 and shift == pytest.approx(stretch.lo, abs=1e-9)
    assert np.max(np.abs(np.array(part.accels) - slope(np.array(part.times) + shift))) <= 1e-9


def test_a_window_is_not_cut_where_its_copy_would_see_a_gap() -> None:
    """A log at 1 Hz for hours and 10 Hz around the trip, with one 0.6 s step there: the whole trace's
    median (1 s) allows the step, the trip's own (0.1 s) would not. Cut to its margin, the bag's copy could
    not be read back; so it is not cut, and the copy reads back to the same profile."""
    slow = np.arange(0.0, 3000.0, 1.0)
    fast = 3000.0 + np.round(np.arange(0.0, 300.0, 0.1), 1)
    fast = fast[(fast < 3150.0) | (fast > 3150.5)]  # the 0.6 s step, inside the trip
    t = np.concatenate((slow, fast))
    v = 10.0 + np.sin(t / 30.0)
    spec = {"type": "speed_table", "units": "m/s", "times": t.tolist(), "speeds": v.tolist(),
            "start": 3100.0, "end": 3200.0}  # fmt: skip
    profile = table_of(spec)
    copy = profile.to_dict()
    times = copy["times"]
    assert isinstance(times, list) and len(times) == t.size  # not cut
    assert profile_from_dict(copy) == profile
    # The same trip at 1 Hz throughout is cut to its margin, and reads back too.
    even = np.arange(0.0, 3300.0, 1.0)
    cut = table_of(spec | {"times": even.tolist(), "speeds": (10.0 + np.sin(even / 30.0)).tolist()})
    cut_times = cut.to_dict()["times"]
    assert isinstance(cut_times, list) and len(cut_times) < even.size / 10
    assert profile_from_dict(cut.to_dict()) == cut


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


# ---------------------------------------------------------------- the bundled recordings

CYCLES = {
    # name: (file, units, last time s, rows, max speed in its units)
    "udds": ("udds.csv", "mph", 1369.0, 1370, 56.7),
    "hwfet": ("hwfet.csv", "mph", 765.0, 766, 59.9),
    "ftp75": ("ftp75.csv", "mph", 1874.0, 1875, 56.7),  # the driving phases; the hot soak is left out
    "husky_odom": ("husky_odom.csv", "m/s", 395.30373, 3952, 1.0166270273318876),
}


@pytest.mark.parametrize("name", list(CYCLES))
def test_bundled_recordings_have_their_stated_duration_and_maximum(name: str) -> None:
    """Each file: its rows, span and top speed as documented; both designs' scenes load it whole."""
    filename, units, last, rows, top = CYCLES[name]
    columns = read_columns(DATA / filename, "t_s", "speed_mph" if units == "mph" else "speed_mps")
    times, speeds = columns.times, columns.values
    assert times.size == rows and times[0] == 0.0
    assert times[-1] == pytest.approx(last, abs=1e-6) and np.max(speeds) == top
    for scene_name in (name, f"{name}_teaching"):
        scene = load_scene(scene_name)
        assert isinstance(scene.profile, Table) and scene.profile.times[-1] == pytest.approx(last, abs=1e-6)
        assert scene.duration <= last and scene.profile.origin.startswith(f"speed_csv {filename} ({units})")
        # The scene stored in a bag stands alone: the speeds inline, read back to an equal profile.
        assert scene_from_yaml(scene_to_yaml(scene)) == scene


def test_drive_cycles_are_real_motion_not_core_scenes() -> None:
    """Every drive cycle and the Husky come in both designs, listed after the core scenes, which stay seconds
    long."""
    assert BUNDLED_SCENE_NAMES == SCENE_NAMES + REAL_MOTION_SCENE_NAMES
    both_designs = {n for c in CYCLES for n in (c, f"{c}_teaching")}
    assert set(REAL_MOTION_SCENE_NAMES) == both_designs | set(CORPUS_SCENE_NAMES)  # the corpus: one design
    short = load_scene("udds")
    p = short.pendulum
    omega0 = math.sqrt(p.gravity / p.length)
    assert p.length == 0.05 and 0.5 <= p.damping / (2 * omega0) <= 0.75  # ζ = c / (2 ω0)
    assert short.sensor.rate_hz == 200.0 and short.sensor.noise_std == 2e-3
    teaching = load_scene("udds_teaching")
    assert teaching.pendulum.length == 1.0 and teaching.profile == short.profile


@pytest.mark.parametrize("name", list(CYCLES))
def test_scenes_ship_the_two_sensor_designs_of_the_override_table(name: str) -> None:
    """NAME is the short damped design and NAME_teaching the 1 m one, exactly as SENSOR_DESIGNS says."""
    short, teaching = load_scene(name), load_scene(f"{name}_teaching")
    for scene, design in ((short, "short_damped"), (teaching, "teaching")):
        values = SENSOR_DESIGNS[design]
        assert {key: OVERRIDE_BY_NAME[key].get(scene) for key in values} == values
    moved = apply_overrides(short, SENSOR_DESIGNS["teaching"])
    assert (
        moved.pendulum.length == teaching.pendulum.length and moved.sensor.rate_hz == teaching.sensor.rate_hz
    )
    assert moved.profile == teaching.profile and moved.duration == teaching.duration


@pytest.mark.parametrize("name", list(CYCLES))
def test_each_recording_runs_through_simulate(
    name: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`simulate NAME --duration 3`: the plan line and its a(t) origin, 601 rows, θ finite."""
    out = tmp_path / f"{name}.csv"
    assert main(["simulate", name, "--duration", "3", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert err.startswith("acceleration: speed_csv ") and "cut-off" in err and "\nplan: " in err
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape[0] == 601 and np.all(np.isfinite(data))


# ---------------------------------------------------------------- bag_topic


def odometry(typestore: object, stamp_ns: int, vx: float) -> object:
    """nav_msgs/Odometry with twist.twist.linear.x = vx, of ``typestore``'s classes."""
    types = typestore.types  # type: ignore[attr-defined]
    time = types["builtin_interfaces/msg/Time"](sec=stamp_ns // 10**9, nanosec=stamp_ns % 10**9)
    ros1 = "seq" in types["std_msgs/msg/Header"].__dataclass_fields__  # ROS 1 headers count messages
    header = types["std_msgs/msg/Header"](stamp=time, frame_id="odom", **({"seq": 0} if ros1 else {}))
    vec = types["geometry_msgs/msg/Vector3"]
    twist = types["geometry_msgs/msg/Twist"](linear=vec(x=vx, y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=0.0))
    pose = types["geometry_msgs/msg/Pose"](
        position=types["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
        orientation=types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
    )
    return types["nav_msgs/msg/Odometry"](
        header=header,
        child_frame_id="base_link",
        pose=types["geometry_msgs/msg/PoseWithCovariance"](pose=pose, covariance=np.zeros(36)),
        twist=types["geometry_msgs/msg/TwistWithCovariance"](twist=twist, covariance=np.zeros(36)),
    )


EPOCH_NS = 1_700_000_000 * 10**9  # a recorded bag's stamps are wall-clock times
TIMES = np.arange(0.0, 30.0, 0.05)  # 20 Hz odometry
SPEEDS = 1.0 + 0.4 * TIMES  # a straight ramp: a = 0.4 m/s² exactly (see the units test's bound)


def write_odometry(path: Path, storage: str, stamps_s: np.ndarray = TIMES) -> Path:
    """A bag of /odom (nav_msgs/Odometry, v = SPEEDS) written with rosbags' own writers."""
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    ros1 = storage == "ros1"
    typestore = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    msgtype = "nav_msgs/msg/Odometry"
    if ros1:
        writer: object = Writer1(path)
    else:
        plugin = StoragePlugin.SQLITE3 if storage == "sqlite3" else StoragePlugin.MCAP
        writer = Writer2(path, version=9, storage_plugin=plugin)
    with writer as w:  # type: ignore[attr-defined]
        conn = w.add_connection("/odom", msgtype, typestore=typestore)
        # Logged in order at TIMES; the header stamps are ``stamps_s``, which may go back.
        for log_s, t, v in zip(TIMES, stamps_s, SPEEDS, strict=True):
            ns = EPOCH_NS + round(t * 1e9)
            msg = odometry(typestore, ns, float(v))
            raw = typestore.serialize_ros1(msg, msgtype) if ros1 else typestore.serialize_cdr(msg, msgtype)
            w.write(conn, EPOCH_NS + round(log_s * 1e9), raw)
    return path


@pytest.mark.parametrize("storage", ["ros1", "sqlite3", "mcap"])
def test_bag_topic_differentiates_odometry_from_any_bag(storage: str, tmp_path: Path) -> None:
    """ROS 1 bag, rosbag2 sqlite3 and MCAP (rosbags' writers): v = 1 + 0.4 t gives a = 0.4 from t = 0."""
    path = write_odometry(tmp_path / ("odom.bag" if storage == "ros1" else "odom"), storage)
    profile = table_of({"type": "bag_topic", "path": str(path), "topic": "/odom"})
    assert profile.times[0] == 0.0 and profile.times[-1] == pytest.approx(TIMES[-1], abs=1e-9)
    assert np.max(np.abs(np.array(profile.accels) - 0.4)) <= 1e-9  # a straight line (units test's bound)
    assert "nav_msgs/msg/Odometry twist.twist.linear.x, 600 messages, header stamps" in profile.origin
    assert profile_from_dict(profile.to_dict()) == profile  # a standalone speed_table


def test_bag_topic_reads_the_projects_own_mcap_truth(tmp_path: Path) -> None:
    """AccelStamped written by pendulum_accel's BagWriter: a(t) is the samples as recorded, t from 0."""
    from pendulum_accel.bag import messages as bm
    from pendulum_accel.bag.writer import BagWriter

    accels = np.sin(TIMES)
    with BagWriter(tmp_path / "truth") as writer:
        writer.add_topic("/car/accel/true", bm.ACCEL_STAMPED)
        for t, a in zip(TIMES, accels, strict=True):
            ns = EPOCH_NS + round(t * 1e9)
            writer.write(
                "/car/accel/true", ns, bm.serialize(bm.accel_stamped(ns, float(a)), bm.ACCEL_STAMPED)
            )
    for path in (tmp_path / "truth", next((tmp_path / "truth").glob("*.mcap"))):
        profile = table_of({"type": "bag_topic", "path": str(path), "topic": "/car/accel/true"})
        assert np.array_equal(np.array(profile.accels), accels)  # copied, not computed
        assert np.max(np.abs(np.array(profile.times) - TIMES)) <= 1e-9  # ns stamps, exact to 1 ns
    window = table_of(
        {
            "type": "bag_topic",
            "path": str(tmp_path / "truth"),
            "topic": "/car/accel/true",
            "start": 10.0,
            "end": 20.0,
        }
    )
    # Window ends interpolated linearly between 50 ms samples of sin: error ≤ (0.05)²/8 × max|sin''|.
    assert window.times[0] == 0.0 and window.times[-1] == pytest.approx(10.0, abs=1e-9)
    assert window.accels[0] == pytest.approx(math.sin(10.0), abs=0.05**2 / 8)


def split_mcap(source: Path, out_dir: Path, parts: int) -> None:
    """``source``'s messages in ``parts`` MCAP files of out_dir (a split recording, ros2 profile), each
    with the schemas and channels it uses, and no metadata.yaml (written with the mcap library)."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with source.open("rb") as stream:
        messages = list(make_reader(stream).iter_messages())
    out_dir.mkdir()
    for part, chunk in enumerate(np.array_split(np.arange(len(messages)), parts)):
        with (out_dir / f"part_{part}.mcap").open("wb") as out:
            writer = Writer(out)
            writer.start(profile="ros2")
            schemas: dict[int, int] = {}
            channels: dict[int, int] = {}
            for i in chunk:
                schema, channel, message = messages[i]
                if schema.id not in schemas:
                    schemas[schema.id] = writer.register_schema(schema.name, schema.encoding, schema.data)
                if channel.id not in channels:
                    channels[channel.id] = writer.register_channel(
                        channel.topic, channel.message_encoding, schemas[schema.id], channel.metadata
                    )
                writer.add_message(channels[channel.id], message.log_time, message.data, message.publish_time)
            writer.finish()


def test_bag_topic_reads_mcap_files_in_a_directory_without_metadata(tmp_path: Path) -> None:
    """A rosbag2 directory that lost its metadata.yaml (a recorder killed before writing it), or MCAP
    files copied into one: its .mcap files are read, one or a split recording's several, merged in log
    order, and give the table of the whole bag, float for float. With none: one line saying so."""
    bag = write_odometry(tmp_path / "odom", "mcap")
    whole = table_of({"type": "bag_topic", "path": str(bag), "topic": "/odom"})
    lone = tmp_path / "lone"
    lone.mkdir()
    mcap_file = next(bag.glob("*.mcap"))
    (lone / mcap_file.name).write_bytes(mcap_file.read_bytes())
    split_mcap(mcap_file, tmp_path / "split", parts=3)
    for directory in (lone, tmp_path / "split"):
        profile = table_of({"type": "bag_topic", "path": str(directory), "topic": "/odom"})
        assert np.array_equal(profile.times, whole.times) and np.array_equal(profile.accels, whole.accels)
    (tmp_path / "empty").mkdir()
    with pytest.raises(ParameterError, match=r"^cannot read bag .*empty: no metadata\.yaml and no \.mcap"):
        profile_from_dict({"type": "bag_topic", "path": str(tmp_path / "empty"), "topic": "/odom"})


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ({"topic": "/nope"}, "has no topic '/nope' (topics: /odom)"),
        ({"topic": "/odom", "path": "missing.bag"}, "no such file or directory"),
        ({"topic": "/odom", "cutoff_hz": 50.0}, "Nyquist frequency 10 Hz"),
    ],
)
def test_bag_topic_errors_are_one_line(spec: dict[str, object], message: str, tmp_path: Path) -> None:
    """Unknown topic, missing bag, cut-off beyond Nyquist: one line each."""
    write_odometry(tmp_path / "odom.bag", "ros1")
    full = {"type": "bag_topic", "path": "odom.bag", **spec}
    with pytest.raises(ParameterError) as info:
        profile_from_dict(full, base_dir=tmp_path)
    assert message in str(info.value) and "\n" not in str(info.value)


def write_imu(path: Path, forward: np.ndarray) -> Path:
    """An MCAP bag of /imu (sensor_msgs/Imu at TIMES) from an IMU mounted z backward, x up: the car's forward
    acceleration is −z and x holds g, as a robot's IMU often is (the Husky's in robot_localization)."""
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_HUMBLE)
    types = typestore.types
    msgtype = "sensor_msgs/msg/Imu"
    vec, quat = types["geometry_msgs/msg/Vector3"], types["geometry_msgs/msg/Quaternion"]
    with Writer2(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        conn = w.add_connection("/imu", msgtype, typestore=typestore)
        for t, a in zip(TIMES, forward, strict=True):
            ns = EPOCH_NS + round(t * 1e9)
            time = types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
            msg = types[msgtype](
                header=types["std_msgs/msg/Header"](stamp=time, frame_id="imu"),
                orientation=quat(x=0.0, y=0.0, z=0.0, w=1.0),
                orientation_covariance=np.zeros(9),
                angular_velocity=vec(x=0.0, y=0.0, z=0.0),
                angular_velocity_covariance=np.zeros(9),
                linear_acceleration=vec(x=9.81, y=0.0, z=-float(a)),
                linear_acceleration_covariance=np.zeros(9),
            )
            w.write(conn, ns, typestore.serialize_cdr(msg, msgtype))
    return path


def test_bag_topic_reads_the_stated_field_and_scale(tmp_path: Path) -> None:
    """An IMU mounted z backward: ``field: linear_acceleration.z`` with ``scale: -1`` gives the forward a(t)
    exactly (a copy times −1: no rounding), where the default field reads the IMU's x (g here); and
    odometry with ``scale: -1`` (an odometry whose x points backward) gives a = −0.4 to the units test's
    bound. The origin names the field and the scale, and the standalone copy keeps the scaled speeds."""
    accels = 0.8 * np.sin(0.5 * TIMES)
    path = write_imu(tmp_path / "imu", accels)
    spec: dict[str, object] = {"type": "bag_topic", "path": str(path), "topic": "/imu"}
    stated = table_of({**spec, "field": "linear_acceleration.z", "scale": -1})
    assert np.array_equal(np.array(stated.accels), accels)
    assert "sensor_msgs/msg/Imu linear_acceleration.z x -1," in stated.origin
    default = table_of(spec)
    assert np.all(np.array(default.accels) == 9.81)
    assert "sensor_msgs/msg/Imu linear_acceleration.x," in default.origin
    odom = write_odometry(tmp_path / "odom.bag", "ros1")
    backward = table_of({"type": "bag_topic", "path": str(odom), "topic": "/odom", "scale": -1})
    assert np.max(np.abs(np.array(backward.accels) + 0.4)) <= 1e-9
    assert profile_from_dict(backward.to_dict()) == backward


def test_bag_topic_reads_twist_with_covariance_and_vector3_stamped(tmp_path: Path) -> None:
    """robot_localization's twist input (TwistWithCovarianceStamped: a speed, differentiated: a = 0.4 to the
    units test's bound) and an IMU driver's free acceleration (Vector3Stamped: copied exactly), each from an
    MCAP bag written by rosbags."""
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    typestore = get_typestore(Stores.ROS2_HUMBLE)
    types = typestore.types
    vec = types["geometry_msgs/msg/Vector3"]
    accels = 0.3 * np.cos(TIMES)

    def header(ns: int) -> Any:  # a rosbags message class instance
        time = types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
        return types["std_msgs/msg/Header"](stamp=time, frame_id="base_link")

    def twist(ns: int, k: int) -> object:
        moving = types["geometry_msgs/msg/Twist"](
            linear=vec(x=float(SPEEDS[k]), y=0.0, z=0.0), angular=vec(x=0.0, y=0.0, z=0.0)
        )
        with_cov = types["geometry_msgs/msg/TwistWithCovariance"](twist=moving, covariance=np.zeros(36))
        return types["geometry_msgs/msg/TwistWithCovarianceStamped"](header=header(ns), twist=with_cov)

    def vector(ns: int, k: int) -> object:
        return types["geometry_msgs/msg/Vector3Stamped"](
            header=header(ns), vector=vec(x=float(accels[k]), y=0.0, z=0.0)
        )

    cases = (
        ("geometry_msgs/msg/TwistWithCovarianceStamped", twist),
        ("geometry_msgs/msg/Vector3Stamped", vector),
    )
    for msgtype, build in cases:
        path = tmp_path / msgtype.rsplit("/", 1)[1]
        with Writer2(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
            conn = w.add_connection("/motion", msgtype, typestore=typestore)
            for k, t in enumerate(TIMES):
                ns = EPOCH_NS + round(t * 1e9)
                w.write(conn, ns, typestore.serialize_cdr(build(ns, k), msgtype))
        profile = table_of({"type": "bag_topic", "path": str(path), "topic": "/motion"})
        assert msgtype in profile.origin
        if build is twist:
            assert np.max(np.abs(np.array(profile.accels) - 0.4)) <= 1e-9
        else:
            assert np.array_equal(np.array(profile.accels), accels)


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        (
            {"field": "linear_acceleration.w"},
            "sensor_msgs/msg/Imu has no number field 'linear_acceleration.w' (its number fields: "
            "orientation.x, orientation.y",
        ),
        ({"field": "header"}, "has no number field 'header'"),
        ({"field": ""}, "sensor_msgs/msg/Imu has no number field ''"),
        ({"field": "orientation_covariance"}, "has no number field 'orientation_covariance'"),
        ({"field": 3}, "bag_topic profile field 'field' must be text, got 3"),
        ({"scale": 0}, "bag_topic profile field 'scale' must not be 0"),
    ],
)
def test_bag_topic_field_and_scale_errors_are_one_line(
    spec: dict[str, object], message: str, tmp_path: Path
) -> None:
    """A field the type lacks (or that is no single number), a field that is not text, a zero scale: one
    line each, the first listing the type's number fields."""
    write_imu(tmp_path / "imu", np.zeros(TIMES.size))
    with pytest.raises(ParameterError) as info:
        profile_from_dict({"type": "bag_topic", "path": "imu", "topic": "/imu", **spec}, base_dir=tmp_path)
    assert message in str(info.value) and "\n" not in str(info.value)


def test_bag_topic_refuses_stamps_that_go_back_and_gaps(tmp_path: Path) -> None:
    """A header stamp before the previous one, or a hole of 5+ median steps: the message is named."""
    back = TIMES.copy()
    back[100] = back[98]
    write_odometry(tmp_path / "back.bag", "ros1", back)
    with pytest.raises(ParameterError, match=r"/odom message 100: time steps back"):
        profile_from_dict({"type": "bag_topic", "path": str(tmp_path / "back.bag"), "topic": "/odom"})
    holed = TIMES.copy()
    holed[300:] += 2.0
    write_odometry(tmp_path / "holed.bag", "ros1", holed)
    with pytest.raises(ParameterError, match=r"/odom message 300: gap of 2.05 s"):
        profile_from_dict({"type": "bag_topic", "path": str(tmp_path / "holed.bag"), "topic": "/odom"})
