"""The kalman model's smoother over a bag's angles: the hindsight estimate ``export`` adds beside the recorded
one, configured from the bag's stored scene (recording.stored_scene) or the sensor the user gives."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.bag.messages import JOINT_STATE, TOPIC_JOINT_STATES
from pendulum_accel.bag.reader import Bag
from pendulum_accel.bag.writer import CUSTOM_SCENE
from pendulum_accel.estimators import estimate_batch
from pendulum_accel.recording.contract import angle_field
from pendulum_accel.recording.stored_scene import bag_motion, estimator_config


def smoothable(bag: Bag, config: Mapping[str, float] | None = None) -> bool:
    """True when the bag has at least 2 angles and a sensor to configure the smoother with: its stored
    scene, or a ``config`` naming the length (a real sensor's bag): what smoothed_estimate needs."""
    angles = bag.topics.get(bag.chain_topic(TOPIC_JOINT_STATES))
    told = config is not None and "length" in config
    return angles is not None and angles.count >= 2 and (told or bool(bag.custom_data.get(CUSTOM_SCENE)))


def smoothed_estimate(
    bag: Bag, config: Mapping[str, float] | None = None
) -> dict[str, NDArray[np.float64]] | None:
    """{t, a, variance}: the kalman model's smoother (``smoother``) over the bag's angles, configured from
    its stored scene with ``config`` overriding it (length, noise_std); None when neither gives a length
    or the bag has fewer than 2 angles (nothing to configure or smooth)."""
    if not smoothable(bag, config):
        return None
    field = angle_field(bag)
    js = bag.decode(
        bag.chain_topic(TOPIC_JOINT_STATES),
        JOINT_STATE,
        fields=["header.stamp.sec", "header.stamp.nanosec", field],
    )
    if len(js) < 2:
        return None
    t, theta = js.stamp, js[field]
    del js  # only t and θ are held while the smoother runs
    if np.any(np.diff(t) < 0.0):
        order = np.argsort(t, kind="stable")
        t, theta = t[order], theta[order]
    keep = np.concatenate(([True], np.diff(t) > 0.0))  # a repeated stamp: the first sample only
    if not keep.all():
        t, theta = t[keep], theta[keep]
    del keep
    given = config or {}
    cfg = {**estimator_config(bag, t, theta if "noise_std" not in given else None), **given}
    a, var = estimate_batch("smoother", t, theta, **cfg, preset=bag_motion(bag).preset)
    return {"t": t, "a": np.asarray(a, dtype=np.float64), "variance": np.asarray(var, dtype=np.float64)}
