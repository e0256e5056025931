"""A sampled trace (speed or acceleration) → a(t): its checks, windows, and the stated differentiation.

A measured or scheduled speed is differentiated by a cubic smoothing spline (scipy's
``make_smoothing_spline``), which minimises Σ (v_i − s(t_i))² + λ ∫ s''(t)² dt. On samples ``h`` apart
it is, away from the ends, the zero-phase low-pass filter

    H(f) = 1 / (1 + λ h (2π f)⁴),

so a stated −3 dB cut-off f_c (H = 1/√2) sets λ = (√2 − 1) / (h (2π f_c)⁴). a(t) = s'(t) then has the
gain 2π f · H(f) of a differentiator below f_c and falls as f⁻³ above it, which keeps the trace's
quantisation (0.1 mph in the EPA schedules) and an odometer's noise from turning into acceleration
noise. Unless a scene states ``cutoff_hz``, f_c = min(1 / (4 h), 1 Hz): half the trace's Nyquist
frequency, and at most the 1 Hz below which a car's or a wheeled robot's own accelerations lie (above
it are drivetrain and body modes, and the noise of differentiated odometry, which grows as f).

s'(t) is a quadratic spline; the profile is its samples joined linearly (a ``Table``), every ``h/2`` s
or closer, so the simulator and the closed forms take it as any other table. The step is chosen from
the largest |a''| so that the straight segments stay within ``TABLE_TOLERANCE`` of s'(t)
(chord error ≤ Δ² max|a''| / 8).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.motion_input.columns import TIME_UNITS, Columns, read_columns
from pendulum_accel.motion_input.fields import (
    field_column,
    field_number,
    field_path,
    field_text,
    field_time_columns,
    window_fields,
)
from pendulum_accel.physics.lazy import lazy_module
from pendulum_accel.physics.profiles import Table

interpolate = lazy_module("scipy.interpolate")  # imported on first use: start-up (docs/portability.md)

MAX_GAP_STEPS = 5.0
"""A step longer than this many median steps is a gap in the recording, refused: the spline would
invent the motion across it."""

TABLE_TOLERANCE = 2e-3
"""m/s²: the most the piecewise-linear table may differ from the spline's derivative s'(t); a fifth of
the 10 mm/s² RMS that the EPA schedules' 0.1 mph rounding leaves in s'(t) at their 0.25 Hz cut-off."""

TABLE_MIN_STEPS = 2
"""At least this many table points per trace step h, whatever |a''| is."""

MAX_TABLE_POINTS = 5_000_000
"""A table longer than this (about 0.4 GB) is refused: a day at 1 Hz needs 172,800 points (h/2 apart), and
more comes only from an |a''| no vehicle reaches (wrong units, or a corrupt value)."""

MAX_SMOOTHING_STEPS = 2000
"""cutoff_hz ≥ 1/(MAX_SMOOTHING_STEPS h): the spline's solve loses digits as λ/h³ = (√2 − 1)/(2π f_c h)⁴
grows; past it a sinusoid's derivative at f_c/4 departs from the continuous-limit gain H
(docs/benchmarks/constants.md)."""


@dataclass(frozen=True)
class Stretch:
    """The part of a trace a profile is built from: the samples of the gap-free stretch that holds the
    window, and the window [lo, hi] on their own axis (s since the stretch's first sample)."""

    times: np.ndarray
    values: np.ndarray
    lo: float
    hi: float
    rows: np.ndarray
    """Index in the whole trace of each sample's (first) row: what an error about a sample names."""
    whole: bool
    """True when the stretch is the whole trace."""
    repeated: int = 0
    """Rows of the whole trace at the time of the row before, averaged into it (``merge_repeated``)."""

    def note(self) -> str:
        """', k rows at a repeated time averaged' for an origin line, or '' when there were none."""
        if not self.repeated:
            return ""
        return f", {self.repeated} row{'s' if self.repeated > 1 else ''} at a repeated time averaged"

    def around_window(self, margin: float) -> Stretch:
        """This stretch cut, on each side where it reaches more than 2 × ``margin`` s past the window, to
        the sample at or beyond ``margin`` from it; lo, hi on the cut stretch's own axis.

        A spline's a(t) on the window does not depend on data further away than spline_margin (their
        weight is below 1e-24), so a trip cut from a day-long log keeps a minute of it, not the day: in
        the fit and in the bag's copy of the scene. Cutting only what lies beyond 2 × ``margin`` makes
        the cut idempotent: the copy, read back, keeps all it holds, and gives the same profile. A cut
        whose samples would hold a step over MAX_GAP_STEPS × their own median is not made: the copy,
        checked on its own, would refuse it as a gap."""
        t = self.times - self.times[0]
        first, last = 0, t.size - 1
        if self.lo > 2.0 * margin:
            first = int(np.searchsorted(t, self.lo - margin, side="right")) - 1
        if float(t[-1]) - self.hi > 2.0 * margin:
            last = int(np.searchsorted(t, self.hi + margin, side="left"))
        if first == 0 and last == t.size - 1:
            return self
        steps = np.diff(self.times[first : last + 1])
        if steps.max() > MAX_GAP_STEPS * float(np.median(steps)):
            return self  # a step the whole trace's median allowed would be a gap in the copy's own eyes
        span = self.times[first : last + 1] - self.times[first]
        # As check_trace's lo_s and hi_s: clipped, since the shift may move them by an ulp.
        lo = min(max(self.lo - float(t[first]), 0.0), float(span[-1]))
        hi = min(max(self.hi - float(t[first]), lo), float(span[-1]))
        keep = slice(first, last + 1)
        return Stretch(self.times[keep], self.values[keep], lo, hi, self.rows[keep], False, self.repeated)


MAX_REPEATED_SHARE = 0.1
"""Rows at a repeated time are averaged while they are at most this share of all rows; beyond it the time
column is coarser than the samples (a `ros2 topic echo --csv` file's whole-second column, a date without
its time), and averaging would quietly resample the trace, so it is refused."""


def merge_repeated(times: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(times, values, rows) with each run of rows at one time made one sample, its value their mean and its
    row the run's first: v̄ = (Σ v) / k over the k rows at that time.

    Loggers repeat a time now and then (a phone's millisecond clock at 400 Hz, a GPS fix written twice); the
    rows describe the same moment, and their mean is its best estimate. A time that steps back is not merged
    (check_trace refuses it)."""
    rows = np.flatnonzero(np.r_[True, np.diff(times) != 0.0])
    if rows.size == times.size:
        return times, values, rows
    sums = np.add.reduceat(values, rows)
    counts = np.diff(np.r_[rows, times.size])
    return times[rows], sums / counts, rows


def check_trace(
    times: np.ndarray,
    values: np.ndarray,
    where: Callable[[int], str],
    *,
    name: str = "speed",
    start: float | None = None,
    end: float | None = None,
    stamp: Callable[[int], str] | None = None,
) -> Stretch:
    """The usable stretch of a trace around the window [start, end] (s after its first sample), or one
    ParameterError line naming the row by ``where(i)`` (and its time by ``stamp(i)`` when given).

    The window is cut before the gap check, so one trip can be cut from a day-long log with gaps:

    - every time finite and never stepping back, over the whole trace (a time that steps back is refused,
      not sorted; rows at the time of the row before are averaged into it, ``merge_repeated``);
    - 0 ≤ start < end ≤ the trace's length;
    - no step longer than ``MAX_GAP_STEPS`` × the median step (of the whole trace) between the samples
      that bracket the window;
    - the stretch is the window widened on both sides up to the nearest gap or end, so the spline's end
      effects fall outside the window; it holds at least 5 samples (scipy's smoothing spline needs 5),
      every value finite.
    """
    if times.size != values.size:
        raise ParameterError(f"{name} trace has {times.size} times but {values.size} values")
    if times.size < 5:
        raise ParameterError(f"{name} trace needs at least 5 samples to differentiate, got {times.size}")
    shown = stamp or (lambda i: repr(float(times[i])))
    bad = np.flatnonzero(~np.isfinite(times))
    if bad.size:
        raise ParameterError(f"{where(int(bad[0]))}: time is not a finite number ({float(times[bad[0]])!r})")
    back = np.flatnonzero(np.diff(times) < 0.0)
    if back.size:
        i = int(back[0]) + 1
        raise ParameterError(f"{where(i)}: time steps back, got {shown(i)} after {shown(i - 1)}")
    whole_rows, raw_values = times.size, values
    times, values, rows = merge_repeated(times, values)
    if whole_rows - times.size > MAX_REPEATED_SHARE * whole_rows:
        first = int(rows[np.flatnonzero(np.diff(np.r_[rows, whole_rows]) > 1)[0]]) + 1  # its first repeat
        raise ParameterError(
            f"{where(first)}: {whole_rows - times.size} of {whole_rows} rows repeat the time of the row "
            "before: the time column is coarser than the samples (whole seconds?); give a finer one "
            "(time_column, time_units)"
        )
    # ≥ 5 rows and at most a tenth repeated leave ≥ 5 distinct times: no second count check.
    steps = np.diff(times)
    t = times - times[0]
    lo, hi = _window_bounds(t, start, end)
    first = int(np.searchsorted(t, lo, side="right")) - 1  # the samples that bracket [lo, hi]
    last = int(np.searchsorted(t, hi, side="left"))
    median = float(np.median(steps))
    gaps = np.flatnonzero(steps > MAX_GAP_STEPS * median)  # gap k lies between samples k and k + 1
    inside = gaps[(gaps >= first) & (gaps < last)]
    if inside.size:
        i = int(inside[0]) + 1
        hint = "" if start is not None or end is not None else "; start/end can cut a window without it"
        raise ParameterError(
            f"{where(int(rows[i]))}: gap of {steps[i - 1]:.6g} s before this sample, more than "
            f"{MAX_GAP_STEPS:g} × the median step {median:.6g} s{hint}"
        )
    before, after = gaps[gaps < first], gaps[gaps >= last]
    s0 = int(before[-1]) + 1 if before.size else 0
    s1 = int(after[0]) if after.size else times.size - 1
    if s1 - s0 + 1 < 5:
        raise ParameterError(
            f"{where(int(rows[s0]))}: the gap-free stretch around the window has {s1 - s0 + 1} samples; the "
            f"{name} trace needs at least 5 to differentiate"
        )
    bad = np.flatnonzero(~np.isfinite(values[s0 : s1 + 1]))
    if bad.size:
        i = s0 + int(bad[0])
        run = raw_values[
            rows[i] : rows[i + 1] if i + 1 < rows.size else whole_rows
        ]  # its rows (several: a repeat)
        row = int(rows[i]) + int(np.flatnonzero(~np.isfinite(run))[0])
        raise ParameterError(f"{where(row)}: {name} is not a finite number ({float(raw_values[row])!r})")
    span = times[s0 : s1 + 1] - times[s0]
    # On the stretch's own axis; clipped because t[j] − t[s0] and times[j] − times[s0] may differ by an ulp.
    lo_s = min(max(lo - float(t[s0]), 0.0), float(span[-1]))
    hi_s = min(max(hi - float(t[s0]), lo_s), float(span[-1]))
    whole = s0 == 0 and s1 == times.size - 1
    repeated = whole_rows - times.size
    return Stretch(times[s0 : s1 + 1], values[s0 : s1 + 1], lo_s, hi_s, rows[s0 : s1 + 1], whole, repeated)


def csv_trace(
    kind: str, d: Mapping[str, object], base_dir: Path | None, value_field: str, *, name: str
) -> tuple[Stretch, Columns, Path]:
    """A profile's CSV file read (its path, ``time_column``, ``value_field`` column, ``time_format`` and
    ``time_units`` fields), and checked and cut to its ``start``/``end`` window by check_trace."""
    path = field_path(kind, d["path"], base_dir)
    time_column = field_time_columns(kind, d["time_column"]) if "time_column" in d else None
    value_column = field_column(kind, value_field, d[value_field]) if value_field in d else None
    time_format = field_text(kind, "time_format", d["time_format"]) if "time_format" in d else None
    time_units = field_text(kind, "time_units", d["time_units"]) if "time_units" in d else "s"
    if time_units not in TIME_UNITS:
        raise ParameterError(
            f"{kind} profile field 'time_units' must be one of {', '.join(TIME_UNITS)}, got {time_units!r}",
            path="time_units",
        )
    what = value_field.removesuffix("_column")
    columns = read_columns(
        path, time_column, value_column, what=what, time_format=time_format, time_units=time_units
    )
    start, end = window_fields(kind, d, columns.epoch, time_format)
    stretch = check_trace(
        columns.times,
        columns.values,
        lambda i: columns.where(i, path),
        name=name,
        start=start,
        end=end,
        stamp=lambda i: repr(columns.stamp(i)),
    )
    return stretch, columns, path


def median_step(times: np.ndarray) -> float:
    """Median of t[i+1] − t[i], s."""
    return float(np.median(np.diff(times)))


DEFAULT_MAX_CUTOFF_HZ = 1.0
"""Hz: the default cut-off never exceeds this (see the module docstring)."""


def default_cutoff_hz(times: np.ndarray) -> float:
    """f_c = min(1 / (4 h), 1 Hz): half the Nyquist of samples a median step h apart, at most 1 Hz."""
    return min(0.25 / median_step(times), DEFAULT_MAX_CUTOFF_HZ)


def spline_lambda(cutoff_hz: float, step: float) -> float:
    """λ = (√2 − 1) / (h (2π f_c)⁴): the smoothing spline's gain is 1/√2 (−3 dB) at f_c.

    Outside floating-point range it is inf (the denominator underflows to 0) or 0 (it overflows);
    spline_table refuses both.
    """
    try:
        return (math.sqrt(2.0) - 1.0) / (step * (2.0 * math.pi * cutoff_hz) ** 4)
    except ZeroDivisionError:
        return math.inf
    except OverflowError:
        return 0.0


SPLINE_MARGIN_WIDTHS = 80.0
"""How far the data a windowed spline is fitted to reach beyond the window, in the spline's kernel widths
b = (√2 − 1)^¼ / (2π f_c): away from its ends the smoothing spline is a kernel smoother whose kernel
(the inverse transform of H(f) = 1 / (1 + (2π f b)⁴)) decays as e^(−|t| / (b √2)), so a sample 80 b from
the window weighs e^(−56.6) ≈ 3e-25 in it (an impulse's fit against that: docs/benchmarks/constants.md)."""


def spline_margin(cutoff_hz: float) -> float:
    """M = SPLINE_MARGIN_WIDTHS × (√2 − 1)^¼ / (2π f_c), s: the data a window's a(t) depends on lie
    within M of it (10.2 s at f_c = 1 Hz, 41 s at 0.25 Hz)."""
    result: float = SPLINE_MARGIN_WIDTHS * (math.sqrt(2.0) - 1.0) ** 0.25 / (2.0 * math.pi * cutoff_hz)
    return result


def fitted_stretch(kind: str, d: Mapping[str, object], stretch: Stretch) -> tuple[Stretch, float, bool]:
    """(the stretch cut to what its window's spline depends on, f_c, whether f_c is the default): f_c is
    the profile's ``cutoff_hz``, else default_cutoff_hz of the whole stretch; the cut is
    Stretch.around_window at spline_margin(f_c); ParameterError for f_c ≤ 0 (M = … / f_c has no value)."""
    default = "cutoff_hz" not in d
    cutoff = default_cutoff_hz(stretch.times) if default else field_number(kind, "cutoff_hz", d["cutoff_hz"])
    if not (math.isfinite(cutoff) and cutoff > 0.0):
        # Checked here, before spline_margin divides by it; spline_table checks the rest of its range.
        raise ParameterError(f"cutoff_hz must be > 0 Hz, got {cutoff!r}", path="cutoff_hz")
    return stretch.around_window(spline_margin(cutoff)), cutoff, default


def _window_bounds(t: np.ndarray, start: float | None, end: float | None) -> tuple[float, float]:
    """(lo, hi) of the window on the shifted axis; ParameterError unless 0 ≤ lo < hi ≤ t[-1]."""
    lo = 0.0 if start is None else start
    hi = float(t[-1]) if end is None else end
    if not (0.0 <= lo < hi <= t[-1]):
        raise ParameterError(
            f"window start/end must satisfy 0 <= start < end <= {t[-1]:.6g} s (the trace's length), "
            f"got start={lo!r}, end={hi!r}",
            path="start" if not 0.0 <= lo < t[-1] else "end",
        )
    return lo, hi


def spline_table(
    times: np.ndarray,
    values: np.ndarray,
    cutoff_hz: float,
    *,
    order: int = 1,
    start: float | None = None,
    end: float | None = None,
    origin: str = "",
    recipe: Mapping[str, object] | None = None,
) -> Table:
    """Table of s⁽ᵒʳᵈᵉʳ⁾(t) from t = 0, s the smoothing spline of ``values`` (−3 dB at ``cutoff_hz``).

    order 1 differentiates a speed into a(t); order 0 only low-passes an acceleration. ``times`` are
    shifted so the first sample is t = 0; ``start``/``end`` (s, on that shifted axis) keep a window,
    which then starts at t = 0 too. The spline is fitted to all of ``times`` (check_trace's stretch,
    reaching past the window up to the nearest gap or spline_margin, Stretch.around_window), so a window
    has no end effects of its own.
    """
    t = np.asarray(times, dtype=float) - float(times[0])
    step = median_step(t)
    nyquist = 0.5 / step
    if not (math.isfinite(cutoff_hz) and 0.0 < cutoff_hz <= nyquist):
        raise ParameterError(
            f"cutoff_hz must be > 0 and at most the trace's Nyquist frequency {nyquist:.6g} Hz, "
            f"got {cutoff_hz!r}",
            path="cutoff_hz",
        )
    lowest = 1.0 / (MAX_SMOOTHING_STEPS * step)
    if cutoff_hz < lowest:
        raise ParameterError(
            f"cutoff_hz must be at least {lowest:.6g} Hz, 1/({MAX_SMOOTHING_STEPS} × the {step:.6g} s step): "
            f"a lower cut-off smooths over more samples than the spline resolves, got {cutoff_hz!r}",
            path="cutoff_hz",
        )
    lo, hi = _window_bounds(t, start, end)
    lam = spline_lambda(cutoff_hz, step)
    if not 0.0 < lam < math.inf:
        raise ParameterError(
            f"time steps of {step:.6g} s put the smoothing spline's λ = (√2 − 1)/(h (2π f_c)⁴) out of "
            "floating-point range: are the times in seconds?"
        )
    spline = interpolate.make_smoothing_spline(t, np.asarray(values, dtype=float), lam=lam)
    fitted = spline.derivative(order) if order else spline
    # f'' of the fitted curve is piecewise linear (order 0) or constant (order 1) between the knots t,
    # so its largest magnitude is at a knot.
    with np.errstate(over="ignore", invalid="ignore"):
        curvature = float(np.max(np.abs(spline.derivative(order + 2)(t))))
    table_step = step / TABLE_MIN_STEPS
    if curvature > 0.0:
        table_step = min(table_step, math.sqrt(8.0 * TABLE_TOLERANCE / curvature))
    steps = (hi - lo) / table_step if table_step > 0.0 else math.inf
    if not steps < MAX_TABLE_POINTS:
        raise ParameterError(
            f"a(t) varies too fast to tabulate: its largest |a''| {curvature:.3g} m/s⁴ needs more than "
            f"{MAX_TABLE_POINTS:g} points to stay within {TABLE_TOLERANCE:g} m/s² (check the units, or "
            "state a lower cutoff_hz)"
        )
    grid = np.linspace(lo, hi, max(2, math.ceil(steps) + 1))
    with np.errstate(over="ignore", invalid="ignore"):
        accels = fitted(grid)
    if not np.all(np.isfinite(accels)):
        raise ParameterError("a(t) of this trace overflows floating point: check its values and units")
    return Table(tuple((grid - lo).tolist()), tuple(accels.tolist()), origin=origin, recipe=recipe)


def differentiate(
    times: np.ndarray,
    speeds: np.ndarray,
    cutoff_hz: float,
    *,
    start: float | None = None,
    end: float | None = None,
    origin: str = "",
    recipe: Mapping[str, object] | None = None,
) -> Table:
    """a(t) = s'(t), s the smoothing spline of v (−3 dB at ``cutoff_hz``): ``spline_table`` of order 1."""
    return spline_table(times, speeds, cutoff_hz, order=1, start=start, end=end, origin=origin, recipe=recipe)


def windowed_table(
    times: np.ndarray, values: np.ndarray, *, start: float | None, end: float | None, origin: str
) -> Table:
    """The samples themselves joined linearly, shifted to t = 0, cut to [start, end] (ends interpolated)."""
    t = np.asarray(times, dtype=float) - float(times[0])
    lo, hi = _window_bounds(t, start, end)
    inside = (t > lo) & (t < hi)
    grid = np.concatenate(([lo], t[inside], [hi]))
    return Table(tuple((grid - lo).tolist()), tuple(np.interp(grid, t, values).tolist()), origin=origin)


def describe_differentiation(cutoff_hz: float, step: float, default: bool) -> str:
    """'a = d/dt of a smoothing spline of v, -3 dB cut-off f_c Hz (default: …)' for plan lines."""
    rule = f" (default: min(half the Nyquist of the {step:.3g} s samples, 1 Hz))" if default else ""
    return f"a = d/dt of a smoothing spline of v, -3 dB cut-off {cutoff_hz:.3g} Hz{rule}"


def recorded_acceleration(kind: str, d: Mapping[str, object], stretch: Stretch, label: str) -> Table:
    """a(t) used as recorded over the stretch's window: the samples joined linearly, or with ``cutoff_hz``
    the order-0 smoothing spline (low-passed, not differentiated)."""
    if "cutoff_hz" in d:
        near, cutoff, _ = fitted_stretch(kind, d, stretch)
        origin = f"{label}: a as recorded, smoothing spline -3 dB cut-off {cutoff:.3g} Hz"
        return spline_table(
            near.times, near.values, cutoff, order=0, start=near.lo, end=near.hi, origin=origin
        )
    return windowed_table(
        stretch.times, stretch.values, start=stretch.lo, end=stretch.hi, origin=f"{label}: a as recorded"
    )
