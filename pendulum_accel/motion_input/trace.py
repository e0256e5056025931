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

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.motion_input.fields import field_number, window_fields
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


def check_trace(
    times: np.ndarray, values: np.ndarray, where: Callable[[int], str], *, name: str = "speed"
) -> None:
    """Raise ParameterError (one line, naming the row by ``where(i)``) unless the trace is usable.

    Usable: at least 5 samples (scipy's smoothing spline needs 5), every value finite, times strictly
    increasing, and no step longer than ``MAX_GAP_STEPS`` × the median step.
    """
    if times.size != values.size:
        raise ParameterError(f"{name} trace has {times.size} times but {values.size} values")
    if times.size < 5:
        raise ParameterError(f"{name} trace needs at least 5 samples to differentiate, got {times.size}")
    for label, column in (("time", times), (name, values)):
        bad = np.flatnonzero(~np.isfinite(column))
        if bad.size:
            value = float(column[bad[0]])
            raise ParameterError(f"{where(int(bad[0]))}: {label} is not a finite number ({value!r})")
    steps = np.diff(times)
    back = np.flatnonzero(steps <= 0.0)
    if back.size:
        i = int(back[0]) + 1
        now, before = float(times[i]), float(times[i - 1])
        raise ParameterError(f"{where(i)}: times must be strictly increasing, got {now!r} after {before!r}")
    median = float(np.median(steps))
    gaps = np.flatnonzero(steps > MAX_GAP_STEPS * median)
    if gaps.size:
        i = int(gaps[0]) + 1
        raise ParameterError(
            f"{where(i)}: gap of {steps[i - 1]:.6g} s before this sample, more than {MAX_GAP_STEPS:g} × "
            f"the median step {median:.6g} s"
        )


def median_step(times: np.ndarray) -> float:
    """Median of t[i+1] − t[i], s."""
    return float(np.median(np.diff(times)))


DEFAULT_MAX_CUTOFF_HZ = 1.0
"""Hz: the default cut-off never exceeds this (see the module docstring)."""


def default_cutoff_hz(times: np.ndarray) -> float:
    """f_c = min(1 / (4 h), 1 Hz): half the Nyquist of samples a median step h apart, at most 1 Hz."""
    return min(0.25 / median_step(times), DEFAULT_MAX_CUTOFF_HZ)


def spline_lambda(cutoff_hz: float, step: float) -> float:
    """λ = (√2 − 1) / (h (2π f_c)⁴): the smoothing spline's gain is 1/√2 (−3 dB) at f_c."""
    return (math.sqrt(2.0) - 1.0) / (step * (2.0 * math.pi * cutoff_hz) ** 4)


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
    which then starts at t = 0 too. The spline is fitted to the whole trace, so a window has no end
    effects of its own.
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
    lo, hi = _window_bounds(t, start, end)
    lam = spline_lambda(cutoff_hz, step)
    spline = interpolate.make_smoothing_spline(t, np.asarray(values, dtype=float), lam=lam)
    fitted = spline.derivative(order) if order else spline
    # f'' of the fitted curve is piecewise linear (order 0) or constant (order 1) between the knots t,
    # so its largest magnitude is at a knot.
    curvature = float(np.max(np.abs(spline.derivative(order + 2)(t))))
    table_step = step / TABLE_MIN_STEPS
    if curvature > 0.0:
        table_step = min(table_step, math.sqrt(8.0 * TABLE_TOLERANCE / curvature))
    count = max(2, math.ceil((hi - lo) / table_step) + 1)
    grid = np.linspace(lo, hi, count)
    return Table(tuple((grid - lo).tolist()), tuple(fitted(grid).tolist()), origin=origin, recipe=recipe)


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


def recorded_acceleration(
    kind: str, d: Mapping[str, object], times: np.ndarray, values: np.ndarray, label: str
) -> Table:
    """a(t) used as recorded: the samples joined linearly, or with ``cutoff_hz`` the order-0 smoothing
    spline (low-passed, not differentiated); the optional ``start``/``end`` window of ``d`` applies."""
    start, end = window_fields(kind, d)
    if "cutoff_hz" in d:
        cutoff = field_number(kind, "cutoff_hz", d["cutoff_hz"])
        origin = f"{label}: a as recorded, smoothing spline -3 dB cut-off {cutoff:.3g} Hz"
        return spline_table(times, values, cutoff, order=0, start=start, end=end, origin=origin)
    return windowed_table(times, values, start=start, end=end, origin=f"{label}: a as recorded")
