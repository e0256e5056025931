"""pendulum_accel: a pendulum accelerometer in a car, simulated, estimated, recorded and replayed.

Conventions (REP-103 car frame, SI): x forward, y left, z up. θ is the bob's rotation
about +y, zero hanging straight down; positive θ swings the bob to the rear.
θ'' = -(g/l) sin θ + (a/l) cos θ, so steady forward acceleration a > 0 gives a = g tan θ.

The names a user needs are imported from here::

    from pendulum_accel import load_scene, run_scene, estimate_batch

    run = run_scene(load_scene("step_start"))
    a_hat, var_a = estimate_batch("kalman", run.t, run.theta_measured, length=run.scene.pendulum.length)

Each name is imported on first use (PEP 562), so ``import pendulum_accel`` and ``pendulum-accel
--version`` load none of numpy, scipy or numba.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

__version__ = "0.1.0"

# name → the module that defines it; __getattr__ imports it there on first use.
_HOMES: dict[str, str] = {
    "load_scene": "pendulum_accel.scene",
    "SENSOR_DESIGNS": "pendulum_accel.overrides",
    "apply_overrides": "pendulum_accel.overrides",
    "plan_scene": "pendulum_accel.planner",
    "run_scene": "pendulum_accel.scene_run",
    "make_estimator": "pendulum_accel.estimators",
    "estimate_batch": "pendulum_accel.estimators",
    "read_bag": "pendulum_accel.bag.reader",
    "analyze_bag": "pendulum_accel.recording.analyze",
    "generate_bag": "pendulum_accel.recording.generate",
    "PendulumAccelError": "pendulum_accel.errors",
    "ParameterError": "pendulum_accel.errors",
    "SceneError": "pendulum_accel.errors",
    "BagError": "pendulum_accel.errors",
}

if TYPE_CHECKING:
    from pendulum_accel.bag.reader import read_bag
    from pendulum_accel.errors import BagError, ParameterError, PendulumAccelError, SceneError
    from pendulum_accel.estimators import estimate_batch, make_estimator
    from pendulum_accel.overrides import SENSOR_DESIGNS, apply_overrides
    from pendulum_accel.planner import plan_scene
    from pendulum_accel.recording.analyze import analyze_bag
    from pendulum_accel.recording.generate import generate_bag
    from pendulum_accel.scene import load_scene
    from pendulum_accel.scene_run import run_scene

__all__ = [
    "SENSOR_DESIGNS",
    "BagError",
    "ParameterError",
    "PendulumAccelError",
    "SceneError",
    "__version__",
    "analyze_bag",
    "apply_overrides",
    "estimate_batch",
    "generate_bag",
    "load_scene",
    "make_estimator",
    "plan_scene",
    "read_bag",
    "run_scene",
]


def _import_public(name: str) -> object:
    """The public ``name`` imported from its home module (_HOMES) and kept here; AttributeError else."""
    home = _HOMES.get(name)
    if home is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(home), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    """The module's own names and the lazily imported public ones: sorted(globals() ∪ __all__)."""
    return sorted(set(globals()) | set(__all__))


# Hidden from mypy, which then reports a misspelt name instead of typing it `object`.
if not TYPE_CHECKING:
    __getattr__ = _import_public
