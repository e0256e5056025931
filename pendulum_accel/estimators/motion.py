"""Which of kalman's motion presets (``kalman.PRESETS``) a run uses: ``auto`` unless one is stated.

``auto`` learns the motion from the angles: an IMM whose modes span a constant a(t) to a step, with no
guess about where the data came from (a real sensor's angles have no scene). A scene's ``motion:`` key or
the node's ``preset`` parameter states another preset (``car``, ``robot``, ``lab_steps``) as a prior; nothing
requires them.
"""

from __future__ import annotations

from dataclasses import dataclass

from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators.kalman import DEFAULT_PRESET, PRESETS
from pendulum_accel.physics.profiles import AccelProfile

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
    """The preset for a(t) = ``profile`` when nothing states one: ``auto``, whatever the profile (where
    the data came from is not used; the argument keeps the callers' signature)."""
    del profile
    why = "learned from the angles (an IMM from a constant a(t) to steps and trends)"
    return MotionChoice(DEFAULT_PRESET, why)
