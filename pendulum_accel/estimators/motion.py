"""Which of kalman's motion presets (``kalman.PRESETS``) an a(t) calls for, chosen from where it comes from.

The filter's process model is a property of the motion, not of the sensor (``kalman`` module doc), so the
choice is made the way the planner chooses a solver: from the scene, with the reason in one line.

* a recorded speed trace (``speed_csv``, ``speed_table``, ``bag_topic`` odometry or twist) whose speed
  never exceeds ROBOT_MAX_SPEED: ``robot`` (fitted on a Husky's odometry);
* any other recorded speed trace: ``car`` (fitted on the EPA UDDS);
* everything else (constant, step, ramp, braking, sinusoid, (t, a) tables, recorded accelerations):
  ``lab_steps``, whose manoeuvre mode follows a step of a within about a swing period (fitted on the
  stop_and_go scene and a step).

A scene's ``motion:`` key states the preset instead (``robot`` for a fast robot, ``car`` for a phone's
accelerometer log in a car). The rule reads only ``profile.to_dict()``, which a bag stores: a bag's
``analyze`` re-run picks what its recording picked.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators.kalman import PRESETS
from pendulum_accel.motion_input.speed_trace import SPEED_UNITS
from pendulum_accel.physics.profiles import AccelProfile

ROBOT_MAX_SPEED = 3.0
"""m/s: a speed trace that never exceeds this is a ground robot's (the Husky's tops out at 1.0 m/s, the
slowest EPA cycle's peak is 25.3 m/s; walking pace is about 1.4 m/s)."""
MOTIONS: tuple[str, ...] = tuple(PRESETS)


@dataclass(frozen=True)
class MotionChoice:
    """A kalman preset and the one-line reason it was chosen."""

    preset: str
    reason: str

    def line(self) -> str:
        """'preset <name>: <reason>', the line a run's summary and ``analyze`` print."""
        return f"preset {self.preset}: {self.reason}"


def check_motion(value: str) -> str:
    """``value`` if it names a preset (MOTIONS), else ParameterError listing them."""
    if value not in PRESETS:
        raise ParameterError(f"motion must be one of {', '.join(MOTIONS)}, got {value!r}")
    return value


def stated_motion(preset: str, by: str = "the scene") -> MotionChoice:
    """The choice ``by`` states: a scene's ``motion:`` key, or a node's ``preset`` parameter."""
    return MotionChoice(check_motion(preset), f"stated by {by} ({PRESETS[preset].fitted_on})")


def motion_of(profile: AccelProfile) -> MotionChoice:
    """The preset for a(t) = ``profile`` by the module's rule: robot / car for recorded speed traces by their
    top speed (ROBOT_MAX_SPEED), lab_steps for everything else."""
    spec = profile.to_dict()
    kind = str(spec.get("type", ""))
    if kind == "speed_table":
        speeds = np.abs(np.asarray(spec["speeds"], dtype=float)) * SPEED_UNITS[str(spec["units"])]
        top = float(np.max(speeds)) if speeds.size else 0.0
        if top <= ROBOT_MAX_SPEED:
            why = f"a recorded speed trace never above {top:.3g} m/s (≤ {ROBOT_MAX_SPEED:g}), a robot's"
            return MotionChoice("robot", why)
        return MotionChoice("car", f"a recorded speed trace up to {top:.3g} m/s, a road vehicle's")
    return MotionChoice("lab_steps", f"a(t) from a {kind or 'made-up'} profile, a lab scene's made-up motion")
