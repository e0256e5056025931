"""A class's lab data, drawn from the teacher's secret: one folder per group, nothing to regenerate it from.

Each group's hidden parameters (the car's acceleration in exercise 1, the release angle in exercise 2,
the stretches of the city cycle in exercise 3, every noise seed) come from a generator seeded by
HMAC-SHA256(secret, "class/group"). A student holds the folder (measured angles, the recorded a(t) of the
drive, and ``params.json``: what the worksheet lets them know) but not the secret, so nothing they install
or read can redo the draw. This module is teacher material: it is not part of the installed package.
"""

from __future__ import annotations

import dataclasses
import hashlib
import hmac
import json
import math
import shutil
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.motion_input import profile_from_dict
from pendulum_accel.physics.profiles import Constant
from pendulum_accel.scene import Scene, load_scene
from pendulum_accel.scene_run import SceneRun, run_scene

SWING_SCENE = "lecture_constant"  # l = 1 m, g = 9.80665 m/s², undamped
SWING_NOISE = 0.02  # rad: a cheap hobby sensor (about 1°), so that a fit's uncertainty is worth stating
SWING_DURATION = 20.0  # s: about 10 periods
BIAS_DURATION = 20.0  # s: the exercise-2 run, released near hanging
DRIVE_SCENE = "udds_teaching"  # EPA city cycle, 1 m pendulum, ζ = 0.008
DRIVE_RUNS = 4  # stretches of the cycle per group: their spread is exercise 3's uncertainty
DRIVE_WINDOW = 60.0  # s per stretch
DRIVE_SETTLE = 10.0  # s cut from each stretch's start: the bob starts hanging and every estimator from zero
UDDS_LENGTH = 1369.0  # s, the EPA schedule's length
# The hidden draw's ranges: wide enough that groups' answers differ by many σ, inside the exercises' models.
ACCEL_RANGE = (1.5, 4.5)  # m/s², exercise 1's a (hidden: the students measure it)
OFFSET_RANGE = (0.03, 0.07)  # rad, exercise 1's release beyond θ_eq (hidden)
BIAS_ACCEL_RANGE = (2.0, 4.0)  # m/s², exercise 2's a (given: the car's reference accelerometer)
RELEASE_RANGE = (-0.03, 0.03)  # rad, exercise 2's release angle near hanging (hidden: sets the amplitude)
MIN_SECRET_BYTES = 16
STUDENT_FILES = ("worksheet.md", "student.ipynb")  # from docs/lab/, copied into each group's handout


@dataclass(frozen=True)
class GroupDraw:
    """One group's hidden parameters, drawn from the secret (``draw``)."""

    class_name: str
    group: str
    accel: float  # m/s², exercise 1
    offset: float  # rad, exercise 1's release beyond θ_eq
    bias_accel: float  # m/s², exercise 2 (shown to the students)
    release: float  # rad, exercise 2's θ0
    drive_starts: tuple[float, ...]  # s into UDDS, exercise 3
    seeds: tuple[int, ...]  # sensor seeds: swing, swing at a = 0, released, then one per drive stretch


def read_secret(path: Path) -> bytes:
    """The secret's bytes (surrounding whitespace stripped); ParameterError when missing or too short."""
    try:
        secret = path.read_bytes().strip()
    except OSError as err:
        raise ParameterError(f"cannot read the secret {path}: {err.strerror}") from None
    if len(secret) < MIN_SECRET_BYTES:
        raise ParameterError(
            f"the secret {path} holds {len(secret)} bytes; use at least {MIN_SECRET_BYTES} random ones "
            "(e.g. head -c 32 /dev/urandom | base64 > secret.txt)"
        )
    return secret


def group_names(count: int) -> list[str]:
    """'group_01' … 'group_NN' (two digits at least, so they sort)."""
    if count < 1:
        raise ParameterError(f"--groups must be at least 1, got {count}")
    width = max(2, len(str(count)))
    return [f"group_{k:0{width}d}" for k in range(1, count + 1)]


def draw(secret: bytes, class_name: str, group: str) -> GroupDraw:
    """The group's parameters: numpy's PCG64 seeded by HMAC-SHA256(secret, "class/group") (256 bits)."""
    digest = hmac.new(secret, f"{class_name}/{group}".encode(), hashlib.sha256).digest()
    rng = np.random.default_rng(int.from_bytes(digest, "big"))
    last_start = UDDS_LENGTH - DRIVE_WINDOW
    return GroupDraw(
        class_name=class_name,
        group=group,
        accel=float(rng.uniform(*ACCEL_RANGE)),
        offset=float(rng.uniform(*OFFSET_RANGE)),
        bias_accel=float(rng.uniform(*BIAS_ACCEL_RANGE)),
        release=float(rng.uniform(*RELEASE_RANGE)),
        drive_starts=tuple(float(s) for s in np.round(rng.uniform(0.0, last_start, DRIVE_RUNS), 1)),
        seeds=tuple(int(s) for s in rng.integers(0, 2**31 - 1, 3 + DRIVE_RUNS)),
    )


def swing_scene(d: GroupDraw, accel: float | None = None) -> Scene:
    """Exercise 1: constant a (default d.accel), released d.offset beyond θ_eq, σ = SWING_NOISE."""
    base = load_scene(SWING_SCENE)
    a = d.accel if accel is None else accel
    theta_eq = math.atan2(a, base.pendulum.gravity)
    seed = d.seeds[0] if accel is None else d.seeds[1]
    return dataclasses.replace(
        base,
        name="swing",
        profile=Constant(a),
        theta0=theta_eq + d.offset,
        duration=SWING_DURATION,
        sensor=dataclasses.replace(base.sensor, noise_std=SWING_NOISE, seed=seed),
    )


def released_scene(d: GroupDraw) -> Scene:
    """Exercise 2: constant d.bias_accel, released from rest at d.release, the scene's 1 mrad sensor."""
    base = load_scene(SWING_SCENE)
    return dataclasses.replace(
        base,
        name="released",
        profile=Constant(d.bias_accel),
        theta0=d.release,
        duration=BIAS_DURATION,
        sensor=dataclasses.replace(base.sensor, seed=d.seeds[2]),
    )


def drive_scene(d: GroupDraw, run: int) -> Scene:
    """Exercise 3: DRIVE_WINDOW s of the real EPA UDDS cycle from d.drive_starts[run]."""
    base = load_scene(DRIVE_SCENE)
    start = d.drive_starts[run]
    spec = base.profile.to_dict() | {"start": start, "end": start + DRIVE_WINDOW}
    return dataclasses.replace(
        base,
        name=f"drive_{run + 1}",
        profile=profile_from_dict(spec),
        duration=DRIVE_WINDOW,
        sensor=dataclasses.replace(base.sensor, seed=d.seeds[3 + run]),
    )


@dataclass(frozen=True)
class GroupRuns:
    """Every simulated run of one group (truth included: the key uses it, the folder does not)."""

    draw: GroupDraw
    swing: SceneRun
    swing_rest: SceneRun
    released: SceneRun
    drives: tuple[SceneRun, ...]


def simulate_group(d: GroupDraw) -> GroupRuns:
    """Run the group's scenes."""
    return GroupRuns(
        draw=d,
        swing=run_scene(swing_scene(d)),
        swing_rest=run_scene(swing_scene(d, accel=0.0)),
        released=run_scene(released_scene(d)),
        drives=tuple(run_scene(drive_scene(d, k)) for k in range(DRIVE_RUNS)),
    )


def student_params(runs: GroupRuns) -> dict[str, object]:
    """What the students may know (params.json): the pendulum, the sensors, exercise 2's a; no hidden draw."""
    p = runs.swing.scene.pendulum
    return {
        "class": runs.draw.class_name,
        "group": runs.draw.group,
        "length_m": p.length,
        "gravity_m_s2": p.gravity,
        "rate_hz": runs.swing.scene.sensor.rate_hz,
        "exercise1": {"files": ["swing.csv", "swing_rest.csv"], "noise_std_rad": SWING_NOISE},
        "exercise2": {
            "file": "released.csv",
            "noise_std_rad": runs.released.scene.sensor.noise_std,
            "accel_m_s2": runs.draw.bias_accel,
        },
        "exercise3": {
            "files": [f"drive_{k + 1}.csv" for k in range(len(runs.drives))],
            "noise_std_rad": runs.drives[0].scene.sensor.noise_std,
            "settle_s": DRIVE_SETTLE,
            "damping_ratio": _damping_ratio(runs.drives[0].scene),
        },
    }


def _damping_ratio(scene: Scene) -> float:
    """ζ = c / (2 ω₀), ω₀ = √(g/l): the drive pendulum's damping as a fraction of critical."""
    p = scene.pendulum
    return p.damping / (2.0 * math.sqrt(p.gravity / p.length))


def _write_angles(path: Path, run: SceneRun, with_accel: bool = False) -> None:
    """CSV of t (s), the measured θ (rad) and, for a drive, the recorded a (m/s²): the data, no truth."""
    columns = [run.t, run.theta_measured] + ([run.accel_true] if with_accel else [])
    header = "t_s,theta_rad" + (",accel_m_s2" if with_accel else "")
    fmt = ["%.2f", "%.8e"] + (["%.8e"] if with_accel else [])
    np.savetxt(path, np.column_stack(columns), delimiter=",", header=header, comments="", fmt=fmt)


def write_group(runs: GroupRuns, folder: Path, student_docs: Path) -> Path:
    """Write the group's folder (data/, worksheet, notebook) and its zip beside it; the zip's path."""
    data = folder / "data"
    data.mkdir(parents=True)
    _write_angles(data / "swing.csv", runs.swing)
    _write_angles(data / "swing_rest.csv", runs.swing_rest)
    _write_angles(data / "released.csv", runs.released)
    for k, drive in enumerate(runs.drives):
        _write_angles(data / f"drive_{k + 1}.csv", drive, with_accel=True)
    (data / "params.json").write_text(json.dumps(student_params(runs), indent=2) + "\n", encoding="utf-8")
    for name in STUDENT_FILES:
        shutil.copyfile(student_docs / name, folder / name)
    archive = folder.with_suffix(".zip")
    with zipfile.ZipFile(archive, "w", zipfile.ZIP_DEFLATED) as zf:
        for path in sorted(folder.rglob("*")):
            if path.is_file():
                zf.write(path, Path(folder.name) / path.relative_to(folder))
    return archive
