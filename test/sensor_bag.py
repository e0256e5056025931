"""A real sensor's recording, as the tests build it: a step's angles and the live estimate, no truth topic
and no stored scene (nobody knows a(t), and the sensor's length is told on the command line)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from pendulum_accel.bag import messages as bm
from pendulum_accel.estimators import DEFAULT_ESTIMATOR, estimate_batch
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Step
from pendulum_accel.physics.simulate import simulate
from pendulum_accel.recording.generate import chain_streams, write_chain_bag

LENGTH = 0.5
RATE = 200.0
NOISE = 1e-3
A_STEP = 3.0
DAMPING = 0.8
CONFIG = {"length": LENGTH, "noise_std": NOISE, "damping": DAMPING}
T_STEP = 2.0


def write_step_bag(path: Path, truth: bool = True, noise: float = NOISE) -> Path:
    """0 → 3 m/s² step at t = 2 s, damped pendulum, 200 Hz angles with ``noise`` (1 mrad), 12 s, and the
    default estimator's estimate; ``truth`` False: without the truth topic (a real sensor's recording)."""
    pendulum = Pendulum(LENGTH, damping=DAMPING)
    t = np.arange(0.0, 12.0, 1.0 / RATE)
    traj = simulate(pendulum, Step(T_STEP, 0.0, A_STEP), t, theta0=0.0)
    theta = traj.theta + np.random.default_rng(7).normal(0.0, noise, t.size)
    a_est, var = estimate_batch(DEFAULT_ESTIMATOR, t, theta, rate_hz=RATE, **{**CONFIG, "noise_std": noise})
    streams = chain_streams(
        t, theta, traj.theta_dot, traj.accel, a_est, var, estimator=DEFAULT_ESTIMATOR, rate_hz=RATE
    )
    if not truth:
        streams = [s for s in streams if s.topic != bm.TOPIC_ACCEL_TRUTH]
    write_chain_bag(path, streams, custom_data={"pendulum_accel.plan": "rigid/DOP853 (test)"})
    return path
