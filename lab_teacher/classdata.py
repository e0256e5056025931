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

from pendulum_accel import ParameterError, load_scene, run_scene
from pendulum_accel.motion_input import profile_from_dict
from pendulum_accel.physics.profiles import Constant
from pendulum_accel.scene import Scene
from pendulum_accel.scene_run import SceneRun
from pendulum_accel.textfile import read_head

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
MAX_SECRET_BYTES = 4096  # a secret is a few dozen random bytes; more is a wrong file, refused unread
MAX_GROUPS = 99  # a class's groups, named group_01 … group_99; a larger course is several --class runs
DIGEST_WORDS = 8  # HMAC-SHA256's 256 bits as 32-bit words: SeedSequence's entropy and pool size
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
    """The secret's bytes (surrounding whitespace stripped); ParameterError when missing, not a regular file
    (a FIFO would block, /dev/zero never ends: refused before any read), too long or too short."""
    try:
        raw = read_head(path, MAX_SECRET_BYTES + 1)
    except OSError as err:
        raise ParameterError(f"cannot read the secret {path}: {err.strerror}") from None
    except ValueError as err:
        raise ParameterError(f"cannot read the secret {path}: {err}") from None
    if len(raw) > MAX_SECRET_BYTES:
        raise ParameterError(
            f"the secret {path} holds more than {MAX_SECRET_BYTES} bytes: is it the right file? "
            "(a secret is a few dozen random bytes)"
        )
    secret = raw.strip()
    if len(secret) < MIN_SECRET_BYTES:
        raise ParameterError(
            f"the secret {path} holds {len(secret)} bytes; use at least {MIN_SECRET_BYTES} random ones "
            "(e.g. head -c 32 /dev/urandom | base64 > secret.txt)"
        )
    return secret


def group_names(count: int) -> list[str]:
    """'group_01' … 'group_NN', two digits (at most MAX_GROUPS groups), so they sort."""
    if not 1 <= count <= MAX_GROUPS:
        raise ParameterError(
            f"--groups must be 1 to {MAX_GROUPS}, got {count} (a larger course: one --class per section)"
        )
    return [f"group_{k:02d}" for k in range(1, count + 1)]


def group_digest(secret: bytes, class_name: str, group: str) -> bytes:
    """HMAC-SHA256(secret, "class/group"): the group's 32 bytes, from which ``draw_from_digest`` draws."""
    return hmac.new(secret, f"{class_name}/{group}".encode(), hashlib.sha256).digest()


def draw(secret: bytes, class_name: str, group: str) -> GroupDraw:
    """The group's parameters, drawn from its HMAC (``group_digest``, ``draw_from_digest``)."""
    return draw_from_digest(class_name, group, group_digest(secret, class_name, group))


def draw_from_digest(class_name: str, group: str, digest: bytes) -> GroupDraw:
    """The group's parameters and noise seeds, every one drawn from all 256 bits of ``digest``.

    The digest's eight 32-bit words are the entropy of a SeedSequence with an eight-word pool (numpy's
    default pool holds 128 bits), so every bit reaches every child. Child 0 seeds the generator of the
    hidden parameters; each sensor's seed is a further child's 256-bit state as one integer, which the
    sensor's PCG64 hashes through its own SeedSequence (a 128-bit pool): finding a group's noise means
    searching 2¹²⁸ states, its parameters 2²⁵⁵ (PCG64 keeps an odd increment).
    """
    words = np.frombuffer(digest, dtype=">u4").astype(np.uint32)
    root = np.random.SeedSequence(words.tolist(), pool_size=DIGEST_WORDS)
    params, *sensors = root.spawn(1 + 3 + DRIVE_RUNS)
    rng = np.random.default_rng(params)
    last_start = UDDS_LENGTH - DRIVE_WINDOW
    return GroupDraw(
        class_name=class_name,
        group=group,
        accel=float(rng.uniform(*ACCEL_RANGE)),
        offset=float(rng.uniform(*OFFSET_RANGE)),
        bias_accel=float(rng.uniform(*BIAS_ACCEL_RANGE)),
        release=float(rng.uniform(*RELEASE_RANGE)),
        drive_starts=tuple(float(s) for s in np.round(rng.uniform(0.0, last_start, DRIVE_RUNS), 1)),
        seeds=tuple(_seed_integer(child) for child in sensors),
    )


def _seed_integer(child: np.random.SeedSequence) -> int:
    """The child's 256-bit state as one integer ≥ 0 (a sensor seed): Σ w_k 2^(32k) over its 8 words."""
    state = child.generate_state(DIGEST_WORDS, np.uint32)
    return sum(int(w) << (32 * k) for k, w in enumerate(state))


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
