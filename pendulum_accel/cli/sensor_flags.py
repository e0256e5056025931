"""--length and --noise-std: the sensor a bag's offline re-run assumes (``analyze``, ``animate``), needed for
a bag that stores no scene (a real sensor's recording) and overriding a stored scene's otherwise."""

from __future__ import annotations

import argparse

from pendulum_accel.overrides import OVERRIDE_BY_NAME

ESTIMATOR_OVERRIDES = ("length", "noise_std")
"""The scene fields a re-run's flags override, by their override-table names."""


def add_sensor_flags(parser: argparse.ArgumentParser) -> None:
    """--length and --noise-std (ESTIMATOR_OVERRIDES): the sensor a bag's re-run assumes, for a bag that
    stores no scene (a real sensor's recording) or to override the stored scene's."""
    for name in ESTIMATOR_OVERRIDES:
        spec = OVERRIDE_BY_NAME[name]
        parser.add_argument(
            "--" + name.replace("_", "-"),
            type=float,
            default=None,
            help=f"{spec.description} ({spec.unit}), overrides the stored scene's",
        )


def sensor_config(args: argparse.Namespace) -> dict[str, float]:
    """{name: value} of the add_sensor_flags given, each checked against its override's bounds."""
    return {
        name: OVERRIDE_BY_NAME[name].check(getattr(args, name))
        for name in ESTIMATOR_OVERRIDES
        if getattr(args, name) is not None
    }
