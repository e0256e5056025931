"""The bundled real-motion recordings (the EPA drive cycles and the Husky's odometry): their rows, span and
maximum, their scenes in the two sensor designs, and 3 s of each through simulate.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.cli.main import main
from pendulum_accel.motion_input.columns import read_columns
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
