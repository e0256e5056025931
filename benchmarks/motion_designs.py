"""The real-motion benchmarks' sensor designs, profiles (with their split) and the runs simulated of them.

Designs, read from the scenes: ``teaching`` (udds_teaching) and ``short_damped`` (udds), the two every fit
uses (``designs``), and HELDOUT_DESIGNS no fit uses (REPORTED_HELDOUT: the three the real-motion page
reports beside them). Profiles: the real-motion corpus (``benchmarks.corpus.CORPUS``), each with its
split (train or validate) and the preset a user would pick. A run: θ(t) from physics.simulate (rigid
model) through a design, white angle noise per seed (seeds 0 … N−1, numpy default_rng).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from benchmarks.corpus import CORPUS
from pendulum_accel.physics.params import STANDARD_GRAVITY, Pendulum
from pendulum_accel.physics.profiles import AccelProfile
from pendulum_accel.scene import load_scene


@dataclass(frozen=True)
class Design:
    """A sensor design: pendulum length l (m), damping c (1/s), angle noise σ (rad), rate (Hz)."""

    name: str
    length: float
    damping: float
    noise_std: float
    rate_hz: float

    @property
    def short(self) -> str:
        """The design's name without its parenthesised figures: 'mid (l 0.2 m, …)' → 'mid'."""
        return self.name.split(" (")[0]

    def settings(self) -> dict[str, float]:
        """make_estimator keywords for this design."""
        return {
            "length": self.length,
            "damping": self.damping,
            "noise_std": self.noise_std,
            "rate_hz": self.rate_hz,
        }


def design_of(scene_name: str, label: str) -> Design:
    """The sensor design of a bundled scene: its pendulum's l and c, its sensor's σ and rate."""
    scene = load_scene(scene_name)
    return Design(
        label, scene.pendulum.length, scene.pendulum.damping, scene.sensor.noise_std, scene.sensor.rate_hz
    )


# The two designs, as the real-motion scenes state them (udds_teaching.yaml, udds.yaml).
DESIGN_SCENES = (("teaching", "udds_teaching"), ("short_damped", "udds"))


@dataclass(frozen=True)
class Profile:
    """A benchmark profile: its a(t) (built on demand), split role, the preset a user would pick."""

    name: str
    role: str  # "train" or "validate"
    preset: str
    build: Callable[[], AccelProfile] = field(compare=False, repr=False)
    duration: float


PRESET_OF = {
    "udds_p1": "car",
    "stop_and_go": "lab_steps",
    "step": "lab_steps",
    "husky_1": "robot",
    "hwfet": "car",
    "udds_p2": "car",
    "husky_2": "robot",
    "braking": "lab_steps",
}
"""The profiles the priors car, robot and lab_steps were fitted on (train) and the preset a user would pick
for each; the rest of the corpus (benchmarks.corpus.CORPUS: more robots, logged accelerations) has none."""

PROFILES = tuple(Profile(e.name, e.split, PRESET_OF.get(e.name, "auto"), e.build, e.duration) for e in CORPUS)
"""The whole corpus: the default, auto, is fitted on every train entry and reported on every validate one."""


@dataclass
class Run:
    """One simulated recording: sample times, true a, measured θ."""

    t: np.ndarray
    accel: np.ndarray
    theta: np.ndarray


def designs() -> tuple[Design, ...]:
    """The benchmark's sensor designs, the ones every fit uses (DESIGN_SCENES)."""
    return tuple(design_of(scene, label) for label, scene in DESIGN_SCENES)


def _damping(length: float, zeta: float) -> float:
    """c = 2 ζ ω₀, ω₀ = √(g/l): the damping of a pendulum of length l at damping ratio ζ."""
    return 2.0 * zeta * math.sqrt(STANDARD_GRAVITY / length)


HELDOUT_DESIGNS = (
    Design("mid (l 0.2 m, ζ 0.3, 500 Hz, 0.5 mrad)", 0.2, _damping(0.2, 0.3), 0.5e-3, 500.0),
    Design("tiny (l 2 cm, ζ 1, 1 kHz, 3 mrad)", 0.02, _damping(0.02, 1.0), 3e-3, 1000.0),
    Design("light (l 0.5 m, c 0.1 /s, 50 Hz, 1 mrad)", 0.5, 0.1, 1e-3, 50.0),
    Design("noisy (l 0.1 m, ζ 0.7, 100 Hz, 10 mrad)", 0.1, _damping(0.1, 0.7), 10e-3, 100.0),
    Design("precise (l 0.1 m, ζ 0.05, 200 Hz, 0.1 mrad)", 0.1, _damping(0.1, 0.05), 0.1e-3, 200.0),
    Design("overdamped (l 5 cm, ζ 2, 200 Hz, 1 mrad)", 0.05, _damping(0.05, 2.0), 1e-3, 200.0),
    Design("slow (l 1 m, c 0.5 /s, 10 Hz, 1 mrad)", 1.0, 0.5, 1e-3, 10.0),
    Design("long (l 3 m, ζ 0.02, 50 Hz, 0.5 mrad)", 3.0, _damping(3.0, 0.02), 0.5e-3, 50.0),
    Design("coarse (l 0.1 m, ζ 0.7, 100 Hz, 30 mrad)", 0.1, _damping(0.1, 0.7), 30e-3, 100.0),
)
"""Sensor designs no fit ever uses: a mid-size one, a tiny critically damped one, a light one, a cheap
noisy one (angle noise 5× short_damped's at half its rate: a 1 s mean of its angles is √50 ≈ 7× noisier)
and a precise, lightly damped one (a 14-bit encoder's quantisation, 2π/2¹⁴/√12 ≈ 0.11 mrad: there g·tanθ
lags a(t) by only 2ζ/ω₀ = 10 ms and is nearly noise-free, the hardest bound a smooth a(t) sets); then four
at the edges of what a pendulum accelerometer is (benchmarks.heldout only): an overdamped bob (ζ 2: the
swing never rings), a slow sample rate (10 Hz, 20 samples a swing period of the 1 m bob), a long, barely
damped bob (3 m: f₀ 0.29 Hz, so a car's changes lie above its resonance) and a coarse one (30 mrad: a 1 s
mean of its angles is 21× noisier than short_damped's, 3× the noisy design's)."""
REPORTED_HELDOUT = (HELDOUT_DESIGNS[0], HELDOUT_DESIGNS[2], HELDOUT_DESIGNS[4])
"""The held-out designs the validation table reports beside the two fitted ones (the 1 kHz one is in
benchmarks.heldout only: at 1 kHz the table's hindsight scans would take most of its time)."""


def simulate_runs(profile: AccelProfile, design: Design, seeds: int, duration: float) -> list[Run]:
    """θ(t) of the design's pendulum (rigid, starting at rest at θ_eq(a(0))) plus white noise per seed."""
    from pendulum_accel.physics.simulate import simulate

    t = np.arange(round(duration * design.rate_hz)) / design.rate_hz
    accel = np.asarray(profile(t), dtype=float)
    theta0 = math.atan2(float(accel[0]), STANDARD_GRAVITY)
    traj = simulate(
        Pendulum(length=design.length, damping=design.damping),
        profile,
        t,
        theta0=theta0,
        rtol=1e-9,
        atol=1e-11,
    )
    theta = np.asarray(traj.theta, dtype=float)
    runs = []
    for seed in range(seeds):
        rng = np.random.default_rng(seed)
        runs.append(Run(t, accel, theta + rng.normal(0.0, design.noise_std, t.size)))
    return runs


def runs_for(profile: Profile, design: Design, seeds: int, quick: bool) -> list[Run]:
    """Simulated runs of a profile (in quick mode: its first 60 s, one seed)."""
    duration = min(profile.duration, 60.0) if quick else profile.duration
    return simulate_runs(profile.build(), design, seeds, duration)
