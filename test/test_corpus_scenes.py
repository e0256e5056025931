"""The real-motion corpus: each corpus scene loads, and its duration and a(t) range are those its README
row states; the benchmark corpus holds out whole recordings and names only bundled scenes."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from benchmarks.corpus import CORPUS, KINDS, SPLIT_IN_TIME, SPLITS, entries
from pendulum_accel.cli.main import main
from pendulum_accel.physics.profiles import Table
from pendulum_accel.scene import BUNDLED_SCENE_NAMES, CORPUS_SCENE_NAMES, SCENES_DIR, load_scene

README = SCENES_DIR / "real_motion" / "README.md"
NUMBER = r"([−-]?\d+(?:\.\d+)?)"
MAX_FILE_BYTES = 300 * 1024  # the corpus files stay small (a derived table, not the source data)


def readme_rows() -> dict[str, tuple[str, float, float, float, float]]:
    """scene → (file, cut-off Hz, duration s, a min, a max) from the README's corpus scene table."""
    rows = {}
    for line in README.read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 7 or not cells[0].startswith("`") or cells[2] not in ("speed_csv", "accel_csv"):
            continue
        match = re.fullmatch(f"{NUMBER} to {NUMBER}", cells[5])
        assert match, f"README row {cells[0]}: a(t) cell {cells[5]!r} is not 'MIN to MAX'"
        low, high = (float(x.replace("−", "-")) for x in match.groups())
        rows[cells[0].strip("`")] = (cells[1].split("`")[1], float(cells[3]), float(cells[4]), low, high)
    return rows


def test_readme_has_a_row_for_every_corpus_scene() -> None:
    assert set(readme_rows()) == set(CORPUS_SCENE_NAMES)
    assert set(CORPUS_SCENE_NAMES) <= set(BUNDLED_SCENE_NAMES)


@pytest.mark.parametrize("name", CORPUS_SCENE_NAMES)
def test_corpus_scene_matches_its_readme_row(name: str) -> None:
    """The scene's duration, cut-off and file are the row's; its a(t) over [0, duration] spans the row's
    range. The row gives two decimals, so each end is within half a unit of the last digit, 0.005 m/s²;
    the spline behind the table is solved in floating point (its rounding is below 1e-9 m/s² for these
    sizes), which the 1e-6 slack covers."""
    file, cutoff, duration, low, high = readme_rows()[name]
    scene = load_scene(name)
    assert scene.duration == duration and scene.motion is None
    profile = scene.profile
    assert isinstance(profile, Table)
    assert f" {file} (" in profile.origin and f"cut-off {cutoff:g} Hz" in profile.origin
    times, accels = np.array(profile.times), np.array(profile.accels)
    assert times[0] == 0.0 and times[-1] >= duration  # the recording covers the scene
    inside = accels[times <= duration]
    assert abs(float(inside.min()) - low) <= 0.005 + 1e-6
    assert abs(float(inside.max()) - high) <= 0.005 + 1e-6
    assert np.all(np.isfinite(accels))
    # The recording starts mid-motion, so the bob starts at rest at θ_eq = atan(a(0)/g), written to 6
    # decimals: within 5e-7 rad of it.
    theta_eq = math.atan2(float(accels[0]), scene.pendulum.gravity)
    assert abs(scene.theta0 - theta_eq) <= 5e-7 + 1e-12 and scene.theta_dot0 == 0.0


@pytest.mark.parametrize("name", CORPUS_SCENE_NAMES)
def test_corpus_files_are_small_and_name_their_source_and_licence(name: str) -> None:
    file = readme_rows()[name][0]
    path = SCENES_DIR / "real_motion" / file
    head = [line for line in path.read_text(encoding="utf-8").splitlines() if line.startswith("#")]
    text = "\n".join(head)
    assert path.stat().st_size < MAX_FILE_BYTES
    assert "github.com/" in text and re.search(r"commit [0-9a-f]{40}", text) and "Licence: " in text


def test_split_holds_out_whole_recordings() -> None:
    """Validation covers every kind with real recordings; a recording in both splits is one of those
    split in time, and then its windows do not overlap."""
    assert {e.kind for e in CORPUS} == set(KINDS) and {e.split for e in CORPUS} == set(SPLITS)
    assert len({e.name for e in CORPUS}) == len(CORPUS)
    for kind in KINDS:
        assert entries("train", kind) and entries("validate", kind)
    real_robots = [e for e in entries("validate", "robot") if e.recording != "jackal_sim"]
    assert len(real_robots) >= 2 and len(entries("validate", "accel_table")) >= 2
    train_recordings = {e.recording for e in entries("train")}
    for e in entries("validate"):
        if e.recording not in train_recordings:
            continue
        assert e.recording in SPLIT_IN_TIME
        for t in entries("train"):
            if t.recording == e.recording:
                assert t.end is not None and e.start is not None and t.end <= e.start
    assert all(e.scene is None or e.scene in BUNDLED_SCENE_NAMES for e in CORPUS)
    assert "jackal_sim" not in {e.recording for e in entries("validate")}  # a simulation is not reported


@pytest.mark.parametrize("entry", CORPUS, ids=lambda e: e.name)
def test_corpus_entries_build_their_stated_span(entry: object) -> None:
    """Every entry's a(t) is defined and finite over its duration (a window's table starts at 0)."""
    profile = entry.build()  # type: ignore[attr-defined]
    t = np.linspace(0.0, entry.duration, 2001)  # type: ignore[attr-defined]
    assert np.all(np.isfinite(profile(t)))
    if isinstance(profile, Table):
        assert profile.times[0] == 0.0 and profile.times[-1] >= entry.duration - 1e-6  # type: ignore[attr-defined]


@pytest.mark.parametrize("name", CORPUS_SCENE_NAMES)
def test_each_corpus_scene_runs_through_simulate(name: str, tmp_path: Path) -> None:
    """`simulate NAME --duration 3`: exit 0, 601 rows (200 Hz), θ finite."""
    out = tmp_path / f"{name}.csv"
    assert main(["simulate", name, "--duration", "3", "--out", str(out)]) == 0
    data = np.loadtxt(out, delimiter=",", skiprows=1)
    assert data.shape[0] == 601 and np.all(np.isfinite(data))
