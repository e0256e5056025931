"""A speed trace turned into a(t): the units, the smoothing spline's differentiation and its windows.

The differentiation is a smoothing spline whose gain is H(f) = 1 / (1 + (√2 − 1)(f/f_c)⁴) in its continuous
limit (motion_input/trace.py); the tolerances below come from that H, from the table's chord bound
TABLE_TOLERANCE, and from the spline's end effects, which the checks keep clear of.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.motion_input import profile_from_dict
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
from pendulum_accel.physics.profiles import Table
from test.motion_tables import table_of


def gain(f: float, cutoff: float) -> float:
    """H(f) of the smoothing spline in its continuous limit, −3 dB at ``cutoff``."""
    return 1.0 / (1.0 + (math.sqrt(2.0) - 1.0) * (f / cutoff) ** 4)


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
