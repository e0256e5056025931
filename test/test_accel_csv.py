"""accel_csv: a phone's accelerometer log (phyphox's CSV export layout) as an a(t) profile."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.errors import ParameterError, SceneError
from pendulum_accel.motion_input import profile_from_dict
from pendulum_accel.motion_input.trace import TABLE_TOLERANCE
from pendulum_accel.physics.profiles import Table
from pendulum_accel.scene import load_scene
from pendulum_accel.scene_run import run_scene

HEADER = '"Time (s)","Acceleration x (m/s^2)","Acceleration y (m/s^2)","Acceleration z (m/s^2)"'
FORWARD = "Acceleration y (m/s^2)"  # a phone lying flat, its top toward the car's front


def write_phyphox(path: Path, t: np.ndarray, forward: np.ndarray) -> Path:
    """A phyphox "Acceleration without g" export: quoted header, x across, y along the screen, z up."""
    rng = np.random.default_rng(0)
    rows = [HEADER]
    for ti, yi in zip(t, forward, strict=True):
        x, z = rng.normal(0.0, 0.05, 2)  # the other axes: noise the profile must ignore
        rows.append(f"{ti:.6E},{x:.6E},{yi:.6E},{z:.6E}")
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def test_named_column_is_used_as_recorded_with_scale(tmp_path: Path) -> None:
    """At its own samples the table returns scale × the column (interpolation at a node is the node).

    Tolerance 1e-6 m/s²: the file stores 7 significant digits, 5e-7 of a 1 m/s² value at most.
    """
    t = 0.25 + np.arange(0.0, 10.0, 0.01)  # phyphox's clock does not start at 0
    a = 0.8 * np.sin(2 * np.pi * 0.3 * t)
    write_phyphox(tmp_path / "log.csv", t, a)
    spec = {"type": "accel_csv", "path": "log.csv", "time_column": "Time (s)", "accel_column": FORWARD}
    profile = profile_from_dict(spec, base_dir=tmp_path)
    assert isinstance(profile, Table) and profile.times[0] == 0.0
    assert np.max(np.abs(profile(t - t[0]) - a)) <= 1e-6
    assert profile.origin.startswith(f"accel_csv log.csv ({FORWARD}, 1000 samples)")
    flipped = profile_from_dict(spec | {"scale": -1.0}, base_dir=tmp_path)
    assert isinstance(flipped, Table)
    assert np.array_equal(np.asarray(flipped.accels), -np.asarray(profile.accels))
    assert profile_from_dict(profile.to_dict()) == profile  # a standalone table when written back


def test_cutoff_low_passes_without_differentiating(tmp_path: Path) -> None:
    """0.2 Hz signal plus a 20 Hz vibration, cut-off 2 Hz: the signal passes, the vibration does not.

    Tolerance, away from the ends (1/f_c): H(0.1 f_c) = 1 − 4e-5 of 0.5, H(10 f_c) ≈ 2.4e-4 of 0.3, the
    table's TABLE_TOLERANCE, and the file's 7-digit rounding: 2 × TABLE_TOLERANCE covers the sum.
    """
    t = np.arange(0.0, 30.0, 0.005)
    slow = 0.5 * np.sin(2 * np.pi * 0.2 * t)
    write_phyphox(tmp_path / "log.csv", t, slow + 0.3 * np.sin(2 * np.pi * 20.0 * t))
    spec = {"type": "accel_csv", "path": str(tmp_path / "log.csv"), "accel_column": FORWARD, "cutoff_hz": 2.0}
    profile = profile_from_dict(spec)
    assert isinstance(profile, Table)
    middle = (t > 2.0) & (t < 28.0)
    assert np.max(np.abs(profile(t[middle]) - slow[middle])) <= 2 * TABLE_TOLERANCE
    assert "cut-off 2 Hz" in profile.origin


def test_scene_with_a_phone_log_runs(tmp_path: Path) -> None:
    """A scene file naming the log beside it loads, and its run's true a is the log's (window applied)."""
    t = np.arange(0.0, 12.0, 0.01)
    write_phyphox(tmp_path / "phone.csv", t, 1.5 * np.tanh(t - 3.0))
    scene_text = (
        "name: phone\ndescription: a phone log\nduration: 8.0\ngravity: 9.80665\n"
        "pendulum: {length: 1.0, mass: 1.0, damping: 0.05, theta0: 0.0, theta_dot0: 0.0}\n"
        f"acceleration: {{type: accel_csv, path: phone.csv, accel_column: '{FORWARD}', "
        "start: 1.0, end: 9.0}\n"
        "sensor: {rate_hz: 100.0, noise_std: 1.0e-3, seed: 1}\noutputs: [angle]\n"
        "accuracy: {max_angle_error: 1.0e-6}\n"
    )
    (tmp_path / "phone.yaml").write_text(scene_text, encoding="utf-8")
    run = run_scene(load_scene(tmp_path / "phone.yaml"))
    # The window starts 1 s into the log: a(t) = 1.5 tanh(t + 1 − 3) up to the file's 7 digits.
    assert np.max(np.abs(run.accel_true - 1.5 * np.tanh(run.t - 2.0))) <= 1e-6
    assert np.all(np.isfinite(run.theta_measured))


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ({"accel_column": "Acceleration w (m/s^2)"}, "no column 'Acceleration w (m/s^2)' in header"),
        ({"scale": 0.0}, "field 'scale' must not be 0"),
        ({"cutoff_hz": 80.0}, "cutoff_hz must be > 0 and at most the trace's Nyquist frequency"),
        ({"colour": "red"}, "accel_csv profile has unknown field 'colour'"),
    ],
)
def test_bad_fields_are_one_line_errors(tmp_path: Path, extra: dict[str, object], message: str) -> None:
    """Each problem is one ParameterError line naming the field or the file."""
    t = np.arange(0.0, 1.0, 0.01)
    write_phyphox(tmp_path / "log.csv", t, np.zeros_like(t))
    with pytest.raises(ParameterError, match=r"^[^\n]*$") as err:
        profile_from_dict({"type": "accel_csv", "path": "log.csv", **extra}, base_dir=tmp_path)
    assert message in str(err.value)


def test_a_bad_row_names_its_line(tmp_path: Path) -> None:
    """A value that is not a number is reported with file and line; a missing file as a scene error too."""
    path = tmp_path / "log.csv"
    path.write_text(f"{HEADER}\n0.0,0,0,0\n0.01,0,oops,0\n", encoding="utf-8")
    with pytest.raises(ParameterError, match=r"log\.csv:3: accel 'oops' is not a number"):
        profile_from_dict({"type": "accel_csv", "path": str(path), "accel_column": FORWARD})
    with pytest.raises((ParameterError, SceneError), match="cannot read accel CSV"):
        profile_from_dict({"type": "accel_csv", "path": str(tmp_path / "missing.csv")})
