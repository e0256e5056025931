"""The lab's measured data: each group's own noisy runs, made from the bundled scenes (docs/lab/).

A group picks a :class:`LabRun` (its seed and the car's acceleration); every data set below follows from
it and nothing else, so two groups get different data and different answers, and a teacher can
reproduce either. This module hands out data only: the fits and answers are in ``lab_answers``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from pendulum_accel.errors import ParameterError
from pendulum_accel.motion_input import profile_from_dict
from pendulum_accel.physics.profiles import Constant
from pendulum_accel.scene import Scene, load_scene
from pendulum_accel.scene_run import SceneRun, run_scene

SWING_SCENE = "lecture_constant"  # l = 1 m, g = 9.80665 m/s², undamped
SWING_NOISE = 0.02  # rad: a cheap hobby sensor (about 1°), so that a fit's uncertainty is worth stating
SWING_OFFSET = 0.05  # rad: released this far beyond θ_eq, a small swing (finite-amplitude shift A²/16)
SWING_DURATION = 20.0  # s: about 10 periods
BIAS_DURATION = 20.0  # s: the exercise-2 run, released hanging straight down
DRIVE_SCENE = "udds_teaching"  # EPA city cycle, 1 m pendulum, ζ = 0.008
DRIVE_WINDOW = 120.0  # s of the cycle, from the group's chosen start
UDDS_LENGTH = 1369.0  # s, the EPA schedule's length
LAST_DRIVE_START = UDDS_LENGTH - DRIVE_WINDOW
MAX_ACCEL = 9.80665  # m/s²: up to one g (θ_eq = 45°); beyond, the small-swing fit of exercise 1 still works


@dataclass(frozen=True)
class LabRun:
    """One group's choices: ``seed`` (sensor noise), ``accel`` a (m/s²), ``drive_start`` (s into UDDS)."""

    seed: int = 27
    accel: float = 3.0
    drive_start: float = 180.0

    def __post_init__(self) -> None:
        """ParameterError (one line) unless seed ≥ 0, 0 < accel ≤ MAX_ACCEL, 0 ≤ drive_start ≤ last start."""
        if isinstance(self.seed, bool) or not isinstance(self.seed, int) or self.seed < 0:
            raise ParameterError(f"seed must be a whole number >= 0, got {self.seed!r}")
        if not (math.isfinite(self.accel) and 0.0 < self.accel <= MAX_ACCEL):
            raise ParameterError(f"accel must be > 0 and <= {MAX_ACCEL:g} m/s², got {self.accel!r}")
        if not (math.isfinite(self.drive_start) and 0.0 <= self.drive_start <= LAST_DRIVE_START):
            raise ParameterError(
                f"drive_start must be between 0 and {LAST_DRIVE_START:g} s (UDDS lasts {UDDS_LENGTH:g} s, "
                f"the window {DRIVE_WINDOW:g} s), got {self.drive_start!r}"
            )


def swing_scene(run: LabRun, accel: float | None = None) -> Scene:
    """Exercise 1: constant a (default run.accel), released at θ_eq + SWING_OFFSET, σ = SWING_NOISE."""
    base = load_scene(SWING_SCENE)
    a = run.accel if accel is None else accel
    theta_eq = math.atan2(a, base.pendulum.gravity)
    sensor = dataclasses.replace(base.sensor, noise_std=SWING_NOISE, seed=run.seed)
    return dataclasses.replace(
        base,
        name=f"swing_a{a:g}_seed{run.seed}",
        profile=Constant(a),
        theta0=theta_eq + SWING_OFFSET,
        duration=SWING_DURATION,
        sensor=sensor,
    )


def swing_data(run: LabRun, accel: float | None = None) -> SceneRun:
    """The exercise-1 recording: t and the measured θ are the data; the rest is the simulator's truth."""
    return run_scene(swing_scene(run, accel))


def released_scene(run: LabRun) -> Scene:
    """Exercise 2: constant run.accel, released hanging straight down (θ0 = 0), the scene's 1 mrad sensor."""
    base = load_scene(SWING_SCENE)
    return dataclasses.replace(
        base,
        name=f"released_a{run.accel:g}_seed{run.seed}",
        profile=Constant(run.accel),
        theta0=0.0,
        duration=BIAS_DURATION,
        sensor=dataclasses.replace(base.sensor, seed=run.seed),
    )


def released_data(run: LabRun) -> SceneRun:
    """The exercise-2 recording (see released_scene)."""
    return run_scene(released_scene(run))


def drive_scene(run: LabRun) -> Scene:
    """Exercise 3: DRIVE_WINDOW s of the real EPA UDDS cycle from run.drive_start, the group's seed."""
    base = load_scene(DRIVE_SCENE)
    spec = base.profile.to_dict()  # the speed_table recipe (speeds inline), windowed below
    spec |= {"start": run.drive_start, "end": run.drive_start + DRIVE_WINDOW}
    return dataclasses.replace(
        base,
        name=f"udds_{run.drive_start:g}s_seed{run.seed}",
        profile=profile_from_dict(spec),
        duration=DRIVE_WINDOW,
        sensor=dataclasses.replace(base.sensor, seed=run.seed),
    )


def drive_data(run: LabRun) -> SceneRun:
    """The exercise-3 recording: the pendulum carried through the group's window of the city cycle."""
    return run_scene(drive_scene(run))
