"""Estimators of the car's acceleration from the pendulum angle — ROS-free (numpy/scipy only).

``make_estimator(name, length=..., noise_std=..., rate_hz=...)`` gives a streaming estimator
(``update(t, θ) -> Estimate | None``, ``reset()``); ``estimate_batch(name, t, θ, ...)`` gives the same
numbers for a whole recording at once. ``guard.InputGuard`` screens the input and reports health.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping

import numpy as np

from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators.base import (
    BIAS_FIELDS,
    TEACHING_NOTE,
    Estimate,
    Estimator,
    EstimatorConfig,
    cramer_rao_std,
)
from pendulum_accel.estimators.dynamic import DynamicEstimator
from pendulum_accel.estimators.instant import InstantEstimator
from pendulum_accel.estimators.kalman import KalmanEstimator, SmootherEstimator
from pendulum_accel.estimators.lowpass import LowpassEstimator
from pendulum_accel.estimators.motion import MotionChoice
from pendulum_accel.estimators.period_mean import PeriodMeanEstimator
from pendulum_accel.physics.params import STANDARD_GRAVITY

ESTIMATORS: Mapping[str, type[Estimator]] = {
    cls.name: cls
    for cls in (
        InstantEstimator,
        PeriodMeanEstimator,
        LowpassEstimator,
        DynamicEstimator,
        KalmanEstimator,
        SmootherEstimator,
    )
}
# What a live node can run: every estimator but the offline-only ones (the smoother needs the whole bag).
LIVE_ESTIMATORS: tuple[str, ...] = tuple(
    name for name, cls in ESTIMATORS.items() if not getattr(cls, "offline_only", False)
)
# Noise-plus-bias variance only, dominated on the real-motion corpus: kept to teach (docs/estimators.md).
TEACHING_ESTIMATORS: tuple[str, ...] = tuple(name for name, cls in ESTIMATORS.items() if cls.teaching)
# The live method of least RMS on the validation cells of docs/benchmarks/real_motion.md (test_docs_figures
# holds it to the page).
DEFAULT_ESTIMATOR = "kalman"
# What a run's summary says of the default: what it is and where it was chosen, no benchmark tally.
DEFAULT_REASON = (
    "the pendulum EKF (IMM): the default, chosen on the real-motion validation cells "
    "(docs/benchmarks/real_motion.md)"
)


def estimator_line(name: str, motion: MotionChoice | None = None) -> str:
    """'estimator: <name> (<why>)[; preset <p>: <why>]': the one line a run's summary gives for the method
    it ran, with the motion preset it ran with (``estimators.motion``) when it takes one; a teaching
    estimator's line says its σ counts noise and bias only."""
    if name == DEFAULT_ESTIMATOR:
        why = DEFAULT_REASON
    elif name in ESTIMATORS and ESTIMATORS[name].teaching:
        why = f"{TEACHING_NOTE}; the default is {DEFAULT_ESTIMATOR}"
    else:
        why = f"chosen; the default is {DEFAULT_ESTIMATOR}"
    return f"estimator: {name} ({why})" + (f"; {motion.line()}" if motion is not None else "")


_CONFIG_FIELDS = ("damping", "clamp_angle", "max_gap", *BIAS_FIELDS)


def method_options(name: str) -> tuple[str, ...]:
    """Keyword options the method ``name`` accepts beyond the shared configuration."""
    cls = _lookup(name)
    params = inspect.signature(cls.__init__).parameters.values()
    return tuple(p.name for p in params if p.kind is inspect.Parameter.KEYWORD_ONLY)


def _lookup(name: str) -> type[Estimator]:
    """The class registered under ``name``, or ParameterError listing the known ones."""
    try:
        return ESTIMATORS[name]
    except KeyError:
        raise ParameterError(f"unknown estimator {name!r}; choose one of {', '.join(ESTIMATORS)}") from None


def make_estimator(
    name: str,
    *,
    length: float,
    gravity: float = STANDARD_GRAVITY,
    noise_std: float = 1e-3,
    rate_hz: float = 200.0,
    **opts: object,
) -> Estimator:
    """Build method ``name`` for a pendulum of length l (m) and angle noise σ (rad) sampled at rate_hz.

    ``opts`` may hold EstimatorConfig fields (damping, clamp_angle, max_gap, the sensor's bias fields)
    and the method's own
    options (``method_options(name)``); anything else raises ParameterError naming it.
    """
    cls = _lookup(name)
    config_opts = {k: opts.pop(k) for k in _CONFIG_FIELDS if k in opts}
    allowed = method_options(name)
    unknown = sorted(set(opts) - set(allowed))
    if unknown:
        raise ParameterError(
            f"estimator {name!r} has no option {unknown[0]!r}; options: {', '.join(allowed) or 'none'}"
        )
    config = EstimatorConfig(
        length=length,
        gravity=gravity,
        noise_std=noise_std,
        rate_hz=rate_hz,
        # EstimatorConfig checks each field's value when built: the names are known here, not their types.
        **config_opts,  # type: ignore[arg-type]
    )
    return cls(config, **opts)


def estimate_batch(
    name: str, t: np.ndarray, theta: np.ndarray, **cfg: object
) -> tuple[np.ndarray, np.ndarray]:
    """(â, var_a) for a whole recording; ``cfg`` as for make_estimator; equals streaming from fresh state."""
    # make_estimator checks every option's value at run time; ``cfg`` holds any of them, by name.
    return make_estimator(name, **cfg).batch(t, theta)  # type: ignore[arg-type]


__all__ = [
    "BIAS_FIELDS",
    "DEFAULT_ESTIMATOR",
    "ESTIMATORS",
    "LIVE_ESTIMATORS",
    "TEACHING_ESTIMATORS",
    "TEACHING_NOTE",
    "Estimate",
    "Estimator",
    "EstimatorConfig",
    "cramer_rao_std",
    "estimate_batch",
    "estimator_line",
    "make_estimator",
    "method_options",
]
