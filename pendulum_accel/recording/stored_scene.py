"""The scene a bag stores (its custom data, as YAML text) and what follows from it for an offline re-run: the
estimator settings (length, gravity, noise_std, rate_hz) and kalman's motion preset.

A bag without one (a real sensor's recording) gets the rate from its stamps and, given its angles, the
noise σ measured from them; the length must then be given. A stored scene that no longer loads (an older
or foreign text) is a BagError that says to give the sensor instead.
"""

from __future__ import annotations

import functools

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.bag.reader import Bag
from pendulum_accel.bag.writer import CUSTOM_SCENE
from pendulum_accel.errors import BagError, PendulumAccelError
from pendulum_accel.estimators.kalman import DEFAULT_PRESET
from pendulum_accel.estimators.motion import MotionChoice
from pendulum_accel.recording.settings import estimator_settings, motion_choice
from pendulum_accel.scene import Scene, scene_from_yaml
from pendulum_accel.scene_yaml import scene_text_without_motion
from pendulum_accel.sensor import noise_from_angles


def bag_motion(bag: Bag) -> MotionChoice:
    """kalman's preset for the bag's re-run: its stored scene's (recording.settings.motion_choice), which is
    the one its recording chose; without a stored scene, the default preset."""
    text = bag.custom_data.get(CUSTOM_SCENE)
    if not text:
        return MotionChoice(DEFAULT_PRESET, "the bag stores no scene: the default preset")
    return motion_choice(scene_but_motion(text))


def estimator_config(
    bag: Bag, t: NDArray[np.float64], theta: NDArray[np.float64] | None = None
) -> dict[str, float]:
    """length, gravity, noise_std, rate_hz from the bag's stored scene; otherwise the rate from the stamps
    and, given the angles ``theta``, noise_std from them (sensor.noise_from_angles: a real sensor's bag
    says neither, and a default σ would make the published variance a guess)."""
    cfg: dict[str, float] = {}
    dt = np.diff(t)
    dt = dt[dt > 0]
    if dt.size:
        cfg["rate_hz"] = float(1.0 / np.median(dt))
    text = bag.custom_data.get(CUSTOM_SCENE)
    if text:
        cfg.update(_scene_config(text))
    elif theta is not None and (noise := noise_from_angles(theta)) is not None:
        cfg["noise_std"] = noise
    return cfg


def _scene_config(text: str) -> dict[str, float]:
    """Estimator settings of a scene stored as YAML text; BagError when it no longer loads."""
    return estimator_settings(scene_but_motion(text))


@functools.lru_cache(maxsize=4)
def scene_but_motion(text: str) -> Scene:
    """The stored scene with a(t) = 0 in place of its profile (scene_yaml.scene_text_without_motion), for what
    does not depend on a(t): its name, estimator settings and motion key; the whole scene when the text
    is not laid out as recorders write it. BagError when it no longer loads."""
    light = scene_text_without_motion(text)
    return _stored_scene(text if light is None else light)


def stored_scene_name(bag: Bag) -> str | None:
    """The name of the scene the bag stores, None when it stores none or it no longer loads."""
    text = bag.custom_data.get(CUSTOM_SCENE)
    if not text:
        return None
    try:
        return scene_but_motion(text).name
    except BagError:
        return None


@functools.lru_cache(maxsize=4)
def _stored_scene(text: str) -> Scene:
    """The scene a bag stores as YAML text; BagError when it no longer loads."""
    try:
        return scene_from_yaml(text, label="the scene stored in the bag")
    except PendulumAccelError as err:
        raise BagError(f"{err}; give --length (and --noise-std) instead") from None


def stored_scene(bag: Bag) -> Scene | None:
    """The scene the bag was recorded from (custom data), None when it stores none."""
    text = bag.custom_data.get(CUSTOM_SCENE)
    return _stored_scene(text) if text else None
