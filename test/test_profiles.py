"""Acceleration profiles: values, breakpoints, constant pieces, max |a|, dict round trip, CSV loading."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pendulum_accel.errors import ParameterError
from pendulum_accel.motion_input import PROFILE_FIELDS, PROFILE_TYPES, profile_from_dict
from pendulum_accel.motion_input.accel_log import csv_table
from pendulum_accel.motion_input.registry import PROFILE_FIELD_DOCS
from pendulum_accel.physics.profiles import (
    AccelProfile,
    Braking,
    Constant,
    Ramp,
    Sinusoid,
    Step,
    Table,
    scalar_accel,
)

ALL_PROFILES: list[AccelProfile] = [
    Constant(2.5),
    Step(1.0, 0.0, 3.0),
    Ramp(0.5, 2.0, -1.0, 4.0),
    Sinusoid(2.0, 0.7, offset=0.5, phase=0.3),
    Table((0.0, 1.0, 2.0, 3.0), (0.0, 2.0, 2.0, -1.0)),
    Braking(v0=10.0, decel=4.0, t_start=1.0),
]


def test_values_exact():
    """Each profile's formula at chosen times (exact up to 1 ulp-level rounding, tol 1e-15)."""
    t = np.array([0.0, 0.5, 1.0, 1.25, 2.0, 3.0, 4.0])
    np.testing.assert_allclose(Constant(2.5)(t), 2.5, rtol=0, atol=0)
    np.testing.assert_array_equal(Step(1.0, 0.0, 3.0)(t), [0, 0, 3, 3, 3, 3, 3])
    np.testing.assert_allclose(
        Ramp(0.5, 2.0, -1.0, 4.0)(t), [-1, -1, -1 + 5 / 3, -1 + 5 * 0.75 / 1.5, 4, 4, 4]
    )
    np.testing.assert_allclose(
        Sinusoid(2.0, 0.7, 0.5, 0.3)(t), 0.5 + 2.0 * np.sin(2 * np.pi * 0.7 * t + 0.3), rtol=0, atol=1e-15
    )
    np.testing.assert_allclose(
        Table((0.0, 1.0, 2.0, 3.0), (0.0, 2.0, 2.0, -1.0))(t), [0, 1, 2, 2, 2, -1, -1], atol=1e-15
    )
    # Braking from 10 m/s at 4 m/s²: stops 2.5 s after t_start = 1 s.
    np.testing.assert_array_equal(Braking(10.0, 4.0, 1.0)(t), [0, 0, -4, -4, -4, -4, 0])
    assert Braking(10.0, 4.0, 1.0).t_stop == 3.5


@pytest.mark.parametrize("profile", ALL_PROFILES, ids=lambda p: type(p).__name__)
def test_vectorised_shapes(profile):
    """a(t) keeps the shape of t: scalar → 0-d, (3, 4) → (3, 4), and matches element-wise calls exactly."""
    grid = np.linspace(-1.0, 5.0, 12).reshape(3, 4)
    assert profile(0.3).shape == ()
    values = profile(grid)
    assert values.shape == (3, 4)
    np.testing.assert_array_equal(values.ravel(), [float(profile(x)) for x in grid.ravel()])


def test_breakpoints():
    """Breakpoints are exactly where a or a' jumps."""
    assert Constant(1.0).breakpoints() == ()
    assert Step(1.0, 0.0, 3.0).breakpoints() == (1.0,)
    assert Ramp(0.5, 2.0, -1.0, 4.0).breakpoints() == (0.5, 2.0)
    assert Sinusoid(1.0, 1.0).breakpoints() == ()
    # slope 0 → 2 at t=0, 2 → 0 at 1, 0 → -3 at 2, -3 → 0 at 3
    assert Table((0.0, 1.0, 2.0, 3.0), (0.0, 2.0, 2.0, -1.0)).breakpoints() == (0.0, 1.0, 2.0, 3.0)
    # collinear middle point is not a kink
    assert Table((0.0, 1.0, 2.0), (0.0, 1.0, 2.0)).breakpoints() == (0.0, 2.0)
    assert Braking(10.0, 4.0, 1.0).breakpoints() == (1.0, 3.5)


def test_constant_pieces():
    """Pieces cover [t0, t1] without gaps and carry the profile's value; None where a varies."""
    assert Step(1.0, 0.0, 3.0).constant_pieces(0.0, 2.0) == [(0.0, 1.0, 0.0), (1.0, 2.0, 3.0)]
    assert Step(1.0, 0.0, 3.0).constant_pieces(1.5, 2.0) == [(1.5, 2.0, 3.0)]
    assert Braking(10.0, 4.0, 1.0).constant_pieces(0.0, 5.0) == [
        (0.0, 1.0, 0.0),
        (1.0, 3.5, -4.0),
        (3.5, 5.0, 0.0),
    ]
    ramp = Ramp(0.5, 2.0, -1.0, 4.0)
    assert ramp.constant_pieces(0.0, 1.0) is None
    assert ramp.constant_pieces(2.0, 3.0) == [(2.0, 3.0, 4.0)]
    assert Sinusoid(1.0, 2.0).constant_pieces(0.0, 1.0) is None
    assert Sinusoid(0.0, 2.0, offset=1.5).constant_pieces(0.0, 1.0) == [(0.0, 1.0, 1.5)]
    table = Table((0.0, 1.0, 2.0, 3.0), (1.0, 1.0, 5.0, 5.0))
    assert table.constant_pieces(0.0, 1.0) == [(0.0, 1.0, 1.0)]
    assert table.constant_pieces(0.0, 2.5) is None
    assert table.constant_pieces(2.0, 9.0) == [(2.0, 3.0, 5.0), (3.0, 9.0, 5.0)]


@pytest.mark.parametrize("profile", ALL_PROFILES, ids=lambda p: type(p).__name__)
def test_max_abs_bounds_dense_sampling(profile):
    """max_abs ≥ max over 20001 samples and exceeds it by ≤ 1e-6 (the sampled max is within 1e-6)."""
    t = np.linspace(-0.3, 4.1, 20001)
    sampled = float(np.max(np.abs(profile(t))))
    bound = profile.max_abs(-0.3, 4.1)
    assert bound >= sampled - 1e-12
    assert bound - sampled <= 1e-6


@pytest.mark.parametrize("profile", ALL_PROFILES, ids=lambda p: type(p).__name__)
def test_dict_round_trip(profile):
    """profile_from_dict(p.to_dict()) == p, and the type key names a known kind."""
    d = profile.to_dict()
    assert d["type"] in PROFILE_TYPES
    assert profile_from_dict(d) == profile


@pytest.mark.parametrize("profile", ALL_PROFILES, ids=lambda p: type(p).__name__)
def test_scalar_accel_matches_profile(profile):
    """The float lookup used in tight loops equals a(t) away from breakpoints (exactly for pieces)."""
    f = scalar_accel(profile, 0.0, 4.0)
    t = np.linspace(0.01, 3.99, 397)
    t = t[np.min(np.abs(t[:, None] - np.array([*profile.breakpoints(), 1e9])[None, :]), axis=1) > 1e-9]
    # the same piece formulas, scalar (math) against vectorised (numpy): ≤ 2 ulp of |a| ≤ 3 m/s²
    # (8.9e-16), the constant pieces exact
    np.testing.assert_allclose([f(x) for x in t], profile(t), rtol=0, atol=1e-15)


def test_csv_loader(tmp_path: Path):
    """Header row, comments and blank lines are skipped; values are read exactly."""
    path = tmp_path / "a.csv"
    path.write_text("t,a\n# a comment\n0, 0\n\n1.5, 2.0\n3, -1\n", encoding="utf-8")
    table = csv_table(path)
    assert table == Table((0.0, 1.5, 3.0), (0.0, 2.0, -1.0))
    rel = profile_from_dict({"type": "csv", "path": "a.csv"}, base_dir=tmp_path)
    assert rel == table


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        ("t,a\n0,0\n1,x\n", ":3: 'x' is not a number"),
        ("0,0\n1,1\n1,2\n", ":3: times must be strictly increasing"),
        ("0,0\n1\n", ":2: expected 't, a'"),
        ("0,0\n1,nan\n", ":2: t and a must be finite"),
        ("t,a\n# nothing\n", "no (t, a) rows"),
    ],
)
def test_csv_errors_name_file_and_line(tmp_path: Path, text: str, needle: str):
    """Every CSV problem is a ParameterError whose message names the file and, where it applies, the line."""
    path = tmp_path / "bad.csv"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ParameterError) as info:
        csv_table(path)
    assert "bad.csv" in str(info.value)
    assert needle in str(info.value)


def test_every_profile_field_is_documented() -> None:
    """The scene reference's field table (PROFILE_FIELD_DOCS) covers every field of every type."""
    fields = {name for required, optional in PROFILE_FIELDS.values() for name in required + optional}
    assert fields == set(PROFILE_FIELD_DOCS)


def test_csv_missing_file(tmp_path: Path):
    """A missing file is a one-line ParameterError naming it."""
    with pytest.raises(ParameterError, match=r"nope\.csv"):
        profile_from_dict({"type": "csv", "path": "nope.csv"}, base_dir=tmp_path)


@pytest.mark.parametrize(
    ("d", "needle"),
    [
        ({"type": "warp"}, "'type'"),
        ({"a": 1.0}, "'type'"),
        ({"type": "step", "t_step": 1.0, "a_before": 0.0}, "'a_after'"),
        ({"type": "constant", "a": 1.0, "acel": 2.0}, "'acel'"),
        ({"type": "constant", "a": "fast"}, "'a'"),
        ({"type": "constant", "a": float("nan")}, "'a'"),
        ({"type": "sinusoid", "amplitude": 1.0, "frequency_hz": True}, "'frequency_hz'"),
        ({"type": "table", "times": [0.0, 1.0], "accels": 3.0}, "'accels'"),
        ({"type": "table", "times": [0.0, 0.0], "accels": [1.0, 2.0]}, "strictly increasing"),
        ({"type": "braking", "v0": -1.0, "decel": 2.0}, "v0"),
        ({"type": "ramp", "t_start": 2.0, "t_end": 1.0, "a_start": 0.0, "a_end": 1.0}, "t_end"),
    ],
)
def test_from_dict_errors_name_the_field(d, needle):
    """Bad mappings raise ParameterError naming the offending field."""
    with pytest.raises(ParameterError, match=needle.replace("(", r"\(")):
        profile_from_dict(d)


def test_constructor_rejects_non_finite():
    """NaN/inf in any profile parameter is refused with the parameter's name."""
    with pytest.raises(ParameterError, match="a_after"):
        Step(1.0, 0.0, float("inf"))
    with pytest.raises(ParameterError, match="amplitude"):
        Sinusoid(float("nan"), 1.0)
    with pytest.raises(ParameterError, match=r"accels\[1\]"):
        Table((0.0, 1.0), (0.0, float("nan")))


_SCALAR_CASES = (
    Constant(2.0),
    Step(1.0, 0.0, 3.0),
    Ramp(1.0, 3.0, -2.0, 5.0),
    Sinusoid(1.5, 0.3, offset=0.2, phase=0.7),
    Table((0.0, 1.0, 2.5, 4.0), (1.0, -3.0, 2.0, 2.0)),
    Braking(14.0, 4.0, t_start=2.0),
)


@settings(max_examples=200, deadline=None)
@given(st.sampled_from(_SCALAR_CASES), st.floats(-10.0, 50.0, allow_nan=False))
def test_scalar_is_the_array_value_bit_for_bit(profile: AccelProfile, t: float) -> None:
    """profile.scalar(t), the integrators' fast path, equals profile(t) exactly: any t, every breakpoint."""
    for time in (t, *profile.breakpoints()):
        assert profile.scalar(time) == float(profile(np.array([time]))[0])
