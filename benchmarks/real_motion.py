"""Real-motion benchmark: every estimator on real drive cycles and robot odometry, tuned on a training split,
reported on a validation split, beside the bound (hindsight fixed-q EKF and RTS smoother).

    python -m benchmarks.real_motion [--quick] [--seeds N] [--out-md PATH] [--out-img DIR] [--fit]

Profiles: the real-motion corpus, ``benchmarks.corpus.CORPUS`` (cars' speed traces, robots' wheel odometry,
logged accelerations as (t, a) tables, and the lab's step, stop_and_go and braking), each with its split:
every fit uses the train entries only, the table reports the validate entries only. Whole recordings are held
out (the corpus module names them). The live default runs with no preset from the profile: auto.

Sensor designs, read from the scenes: ``teaching`` (udds_teaching: l = 1 m, c = 0.05 /s, σ = 1 mrad,
100 Hz) and ``short_damped`` (udds: l = 5 cm, c = 19.8 /s, ζ = 0.71, σ = 2 mrad, 200 Hz), the two every
fit uses, and three no fit uses (REPORTED_HELDOUT: mid, l = 0.2 m, ζ = 0.3, 500 Hz, 0.5 mrad; light,
l = 0.5 m, c = 0.1 /s, 50 Hz, 1 mrad; precise, l = 0.1 m, ζ = 0.05, 200 Hz, 0.1 mrad); θ(t) from
physics.simulate (rigid model), white angle noise per seed (seeds 0 … N−1, numpy default_rng).

Per estimator × validation profile × design, pooled over seeds, t ≥ 2 s: RMS, max |e|, group delay (the
shift τ maximising the cross-correlation of â(t) with a(t − τ)), mean NEES, share beyond 2σ in steady
state and after a change (|a(t) − a(t − 1 s)| > 0.2 m/s², from its onset to 2 s after:
``recording.changes.after_change``, the rule ``analyze`` uses) with the independent trials behind each share
(``recording.coverage``: a share is judged outside 1–12 % only when its 95 % interval misses the band),
and µs/sample of streaming
``update`` (on a 20 s slice). The bound: ``ekf_hindsight``, a fixed-q EKF with q chosen per profile and
design for the least RMS over a grid (with the truth: hindsight), and ``rts_hindsight``, the RTS
smoother on that same model; ``rts_best`` is a tighter bound, the RTS at its own hindsight q (every
other grid point). Ratios: kalman / ekf_hindsight, smoother / rts_hindsight (and / rts_best). The
latency–accuracy curve is the RMS of kalman's fixed-lag smoother against its lag (0 … 2 s), per design,
over the validation profiles, beside the live IMM filter at lag 0.

``--fit`` fits on the training split only, pooled over the seeds, on grids, and prints the values to put in
``estimators.kalman.PRESETS``: auto's chain (up and down times, AUTO_CHAINS), its trend partners
(TREND_SPANS × TREND_FACTORS, ``kalman.AUTO_TRENDS``) and its fixed-lag variance map (LAG_POWERS ×
LAG_WEIGHTS, ``kalman.LAG_VARIANCE_POWER`` and ``LAG_REVISION_WEIGHT``) on every training profile;
each prior preset's (car, robot, lab_steps) single q_a with the least RMS (geometric mean over both
designs) and IMM (modes, switch time) on its own training profiles (PRESET_OF). Each IMM is the candidate
whose own variance is best calibrated on training (share beyond 2σ, steady and after changes, closest to a
Gaussian's 4.6 %) among those within 5 % of the least RMS.
"""

from __future__ import annotations

import argparse
import functools
import math
import os
import platform
import statistics
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from benchmarks import report as bench_report
from benchmarks.corpus import CORPUS
from pendulum_accel.cluster import map_tasks
from pendulum_accel.estimators import LIVE_ESTIMATORS, make_estimator
from pendulum_accel.estimators import ekf_kernels as kern
from pendulum_accel.estimators.kalman import (
    PRESETS,
    KalmanEstimator,
    imm_smoother,
    lag_samples,
    lag_variance,
)
from pendulum_accel.physics.params import STANDARD_GRAVITY, Pendulum
from pendulum_accel.physics.profiles import AccelProfile
from pendulum_accel.recording import coverage
from pendulum_accel.recording.changes import after_change
from pendulum_accel.recording.delay import group_delay
from pendulum_accel.scene import load_scene

SCENES_DIR = Path(__file__).resolve().parents[1] / "pendulum_accel" / "scenes"
WARMUP = 2.0  # s left out at the start of every run: the filters start from one sample
Q_GRID = tuple(float(q) for q in np.logspace(-4, 2, 19))  # (m/s²)²/s, 3 per decade
LAGS = (0.0, 0.05, 0.1, 0.2, 0.25, 0.3, 0.5, 0.75, 1.0, 1.5, 2.0)  # s, the latency–accuracy curve
SHOWN_LAG = 0.25  # s: the lag of the table's kalman lag row, the live fixed lag issue 33 judges
COST_SPAN = 20.0  # s of samples timed for µs/sample


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


@dataclass
class Score:
    """Pooled figures of one estimator on one profile × design (over seeds)."""

    rms: float
    max_err: float
    delay: float
    nees: float
    beyond_steady: float
    beyond_after: float
    n_steady: int
    n_after: int
    eff_steady: float = 0.0  # independent trials behind beyond_steady (recording.coverage)
    eff_after: float = 0.0
    nees_median: float = math.nan  # a Gaussian error's: 0.455; far below, σ bounds the error, not its spread

    @staticmethod
    def of(runs: Sequence[Run], outputs: Sequence[tuple[np.ndarray, np.ndarray]], rate_hz: float) -> Score:
        """Pool e = â − a and NEES = e²/var over the runs (t ≥ WARMUP); the shares' effective trials
        (coverage.window_trials of each run's NEES: each window at its own τ)."""
        errs, nees, steady, after, delays = [], [], [], [], []
        eff_steady, eff_after = 0.0, 0.0
        for run, (a, var) in zip(runs, outputs, strict=True):
            keep = run.t >= WARMUP
            e = (a - run.accel)[keep]
            with np.errstate(divide="ignore", invalid="ignore"):
                z = np.where(var[keep] > 0.0, e * e / var[keep], np.inf)
            after_mask = after_change(run.t, run.t, run.accel)[keep]
            errs.append(e)
            nees.append(z)
            steady.append(z[~after_mask] > 4.0)
            after.append(z[after_mask] > 4.0)
            eff_steady += coverage.window_trials(z, ~after_mask)
            eff_after += coverage.window_trials(z, after_mask)
            delays.append(group_delay(a[keep], run.accel[keep], rate_hz))
        e_all = np.concatenate(errs)
        z_all = np.concatenate(nees)
        s_all, c_all = np.concatenate(steady), np.concatenate(after)
        return Score(
            rms=float(np.sqrt(np.mean(e_all**2))),
            max_err=float(np.max(np.abs(e_all))),
            # A profile whose truth is constant has no delay (NaN): the others' median (the same value
            # when every profile varies, as every corpus profile does).
            delay=float(np.nanmedian(delays)) if np.isfinite(delays).any() else math.nan,
            nees=float(np.mean(z_all)),
            nees_median=float(np.median(z_all)),
            beyond_steady=float(np.mean(s_all)) if s_all.size else math.nan,
            beyond_after=float(np.mean(c_all)) if c_all.size else math.nan,
            n_steady=int(s_all.size),
            n_after=int(c_all.size),
            eff_steady=eff_steady,
            eff_after=eff_after,
        )


def pooled_rms(runs: Sequence[Run], estimates: Sequence[np.ndarray]) -> float:
    """RMS of â − a over the runs, t ≥ WARMUP."""
    sq = [((a - r.accel)[r.t >= WARMUP]) ** 2 for r, a in zip(runs, estimates, strict=True)]
    return float(np.sqrt(np.mean(np.concatenate(sq))))


def stream_cost(name: str, design: Design, run: Run, opts: dict[str, object]) -> float:
    """µs per sample of streaming ``update`` over the first COST_SPAN s of ``run``."""
    n = min(run.t.size, round(COST_SPAN * design.rate_hz))
    est = make_estimator(name, **design.settings(), **opts)  # type: ignore[arg-type]
    ts, ys = run.t[:n].tolist(), run.theta[:n].tolist()
    est.update(ts[0], ys[0])  # the first call may load compiled code
    est.reset()
    start = time.perf_counter()
    for ti, yi in zip(ts, ys, strict=True):
        est.update(ti, yi)
    return (time.perf_counter() - start) / n * 1e6


def kalman_q(design: Design, q: float, lag: float = 0.0) -> KalmanEstimator:
    """The kalman estimator of ``design`` at a fixed q_a."""
    est = make_estimator("kalman", **design.settings(), q_accel=q, lag=lag)
    assert isinstance(est, KalmanEstimator)
    return est


def q_scan(
    runs: Sequence[Run], design: Design, grid: Sequence[float] = Q_GRID, *, smoothed: bool = False
) -> np.ndarray:
    """Σ (â − a)² over the runs (t ≥ WARMUP) of the fixed-q filter (``smoothed``: its RTS smoother) at every
    q of the grid."""
    out = np.zeros(len(grid))
    for i, q in enumerate(grid):
        est = kalman_q(design, q)
        run_pass = est.smoothed if smoothed else est.batch
        for r in runs:
            out[i] += float(np.sum(((run_pass(r.t, r.theta)[0] - r.accel)[r.t >= WARMUP]) ** 2))
    return out


def imm_scan(
    runs: Sequence[Run], design: Design, candidates: Sequence[tuple[tuple[float, ...], float]]
) -> np.ndarray:
    """Per (modes, switch_time) candidate, over the runs (t ≥ WARMUP) of the IMM with its own variance:
    [Σ (â − a)², beyond 2σ steady, steady samples, beyond 2σ after a change, samples after a change]."""
    params = kalman_q(design, 1.0)._params
    out = np.zeros((len(candidates), 5))
    for i, (modes, switch) in enumerate(candidates):
        for r in runs:
            rates = kern.chain_rates(len(modes), switch)
            lags = np.zeros(1, np.int64)
            a, var, _ = kern.imm_pass(r.t, r.theta, params, np.array(modes), rates, lags)
            keep = r.t >= WARMUP
            e = (a[:, 0] - r.accel)[keep]
            beyond = e * e > 4.0 * var[keep, 0]
            out[i] += calibration_counts(e, beyond, after_change(r.t, r.t, r.accel)[keep])
    return out


IMM_CANDIDATES = tuple(
    ((q_lo, q_hi), switch)
    for q_lo in (1e-4, 1e-3)
    for q_hi in (0.03, 0.1, 0.3, 1.0)
    for switch in (2.0, 5.0, 10.0, 20.0, 50.0, 200.0)
)
# The IMM's fit on training: among the candidates whose RMS is within RMS_SLACK of the best candidate's (half
# of the 1.1× allowance over the hindsight EKF), the one whose own variance puts the share of errors
# beyond 2σ closest to a Gaussian's (Σ over designs × {steady, after a change} of |ln(share / GAUSS_2SIGMA)|).
RMS_SLACK = 1.05
GAUSS_2SIGMA = math.erfc(2.0 / math.sqrt(2.0))  # 0.0455: P(|z| > 2) of a standard normal
SHARE_FLOOR = 1e-4  # a share of 0 counts as 0.01 % (the log stays finite; 0 is as wrong as 0.01 %)


def calibration_counts(e: np.ndarray, beyond: np.ndarray, after: np.ndarray) -> np.ndarray:
    """[Σ e², beyond ∧ steady, steady, beyond ∧ after, after]: one run's row of the sums the fits pool
    (RMS from the first, ``calibration_miss`` from the rest)."""
    return np.array(
        [
            float(np.sum(e * e)),
            np.count_nonzero(beyond & ~after),
            np.count_nonzero(~after),
            np.count_nonzero(beyond & after),
            np.count_nonzero(after),
        ],
        dtype=float,
    )


def calibration_miss(counts: Sequence[float] | np.ndarray) -> float:
    """Σ |ln(share / GAUSS_2SIGMA)| over the steady and after-change shares of an imm_scan row."""
    miss = 0.0
    for beyond, n in ((counts[1], counts[2]), (counts[3], counts[4])):
        if n > 0:
            miss += abs(math.log(max(beyond / n, SHARE_FLOOR) / GAUSS_2SIGMA))
    return miss


def scored(runs: Sequence[Run]) -> int:
    """Samples scored over the runs (t ≥ WARMUP)."""
    return sum(int(np.count_nonzero(r.t >= WARMUP)) for r in runs)


@dataclass
class Row:
    """One table row: estimator × profile × design, with its Score and the cost."""

    design: str
    profile: str
    role: str
    method: str
    score: Score
    us: float
    ratio: float | None = None  # RMS over the matching bound
    ratio_best: float | None = None  # the smoother's RMS over rts_best


def _runs_for(profile: Profile, design: Design, seeds: int, quick: bool) -> list[Run]:
    """Simulated runs of a profile (in quick mode: its first 60 s, one seed)."""
    duration = min(profile.duration, 60.0) if quick else profile.duration
    return simulate_runs(profile.build(), design, seeds, duration)


def _training(seeds: int, quick: bool) -> Iterator[tuple[np.ndarray, list[Run]]]:
    """(the fitted design's EKF params, the runs) of every training profile through each fitted design."""
    for design in designs():
        params = kalman_q(design, 1.0)._params
        for profile in PROFILES:
            if profile.role == "train":
                yield params, _runs_for(profile, design, seeds, quick)


def fit_presets(
    seeds: int, quick: bool
) -> dict[str, tuple[float, list[float], tuple[tuple[float, ...], float], list[tuple[float, float]]]]:
    """Per preset, on its training profiles only, pooled over the seeds: the single q_a (argmin over Q_GRID
    of the geometric mean over the designs of the filter's RMS) and the IMM (of IMM_CANDIDATES within
    RMS_SLACK of the least such RMS, the one with the least calibration miss, Σ over the designs); returns
    (q_a, mean RMS per q, (modes, switch_time), (mean RMS, calibration miss) per candidate)."""
    out: dict[str, tuple[float, list[float], tuple[tuple[float, ...], float], list[tuple[float, float]]]] = {}
    for preset in (p for p in PRESETS if p != "auto"):  # auto: fit_auto, fit_trends
        logs = np.zeros(len(Q_GRID))
        logs_imm = np.zeros(len(IMM_CANDIDATES))
        miss = np.zeros(len(IMM_CANDIDATES))
        used = 0
        for design in designs():
            sq, counts, n = np.zeros(len(Q_GRID)), np.zeros((len(IMM_CANDIDATES), 5)), 0
            for profile in PROFILES:
                if profile.role == "train" and profile.preset == preset:
                    runs = _runs_for(profile, design, seeds, quick)
                    sq += q_scan(runs, design)
                    counts += imm_scan(runs, design, IMM_CANDIDATES)
                    n += scored(runs)
            if n:
                logs += 0.5 * np.log(sq / n)
                logs_imm += 0.5 * np.log(counts[:, 0] / n)
                miss += [calibration_miss(row) for row in counts]
                used += 1
        if used:
            scores = [math.exp(x) for x in logs / used]
            rms_imm = np.exp(logs_imm / used)
            eligible = rms_imm <= RMS_SLACK * rms_imm.min()
            best_imm = IMM_CANDIDATES[int(np.argmin(np.where(eligible, miss, np.inf)))]
            table = [(float(r), float(m)) for r, m in zip(rms_imm, miss, strict=True)]
            out[preset] = (Q_GRID[int(np.argmin(scores))], scores, best_imm, table)
    return out


AUTO_CHAINS = tuple((up, down) for up in (2.0, 3.0, 6.0) for down in (0.5, 1.0, 2.0))
"""(up, down) times (s) of auto's birth-death chain tried by ``fit_auto`` (ekf_kernels.chain_rates)."""


def fit_auto(seeds: int, quick: bool) -> tuple[tuple[float, float], list[tuple[float, float]]]:
    """auto's chain on every training profile (all kinds), both designs, pooled over the seeds: of
    AUTO_CHAINS within RMS_SLACK of the least RMS (geometric mean over profiles × designs), the one with the
    least calibration miss (Σ over profiles × designs); returns ((up, down), (mean RMS, miss) per chain).
    The chain is fitted on the random-walk modes alone, before their trend partners (``fit_trends``)."""
    modes = np.array(PRESETS["auto"].modes)
    logs = np.zeros(len(AUTO_CHAINS))
    miss = np.zeros(len(AUTO_CHAINS))
    used = 0
    for params, runs in _training(seeds, quick):
        used += 1
        for i, (up, down) in enumerate(AUTO_CHAINS):
            counts = _imm_counts(runs, params, modes, None, kern.chain_rates(modes.size, up, down))
            logs[i] += 0.5 * math.log(counts[0] / scored(runs))
            miss[i] += calibration_miss(counts)
    rms = np.exp(logs / max(used, 1))
    eligible = rms <= RMS_SLACK * rms.min()
    best = AUTO_CHAINS[int(np.argmin(np.where(eligible, miss, np.inf)))]
    return best, [(float(r), float(m)) for r, m in zip(rms, miss, strict=True)]


MAX_TREND_PARTNERS = 4
"""At most this many of auto's modes get a trend partner: the cost bound. Each partner is a four-state mode;
with four, the IMM's pass costs about 4.0 µs a sample against 2.5 µs for the random walks alone (run_imm at
200 Hz): the streaming update stays ≤ 2× the two-mode presets' (1.6×, docs/benchmarks/estimators.md), and
analyze keeps 6.0× a plain rosbags loop where the random walks alone gave 7.8× (docs/benchmarks/bags.md)."""
TREND_SPANS = tuple(
    (lo, hi)
    for lo in range(len(PRESETS["auto"].modes))
    for hi in range(lo + 1, min(lo + MAX_TREND_PARTNERS, len(PRESETS["auto"].modes)) + 1)
)
"""(first, past-the-last) index of the auto modes that get a trend partner, tried by ``fit_trends``."""
TREND_FACTORS = (3.0, 10.0, 30.0, 100.0)
"""q_j of a trend partner over its mode's q_a ((m/s³)²/s per (m/s²)²/s), tried by ``fit_trends``."""


def trend_candidate(span: tuple[int, int], factor: float) -> tuple[float, ...]:
    """kalman.MotionPreset.trends for a span of auto's modes: q_j = factor · q_a inside it, 0 outside."""
    return tuple(factor * q if span[0] <= k < span[1] else 0.0 for k, q in enumerate(PRESETS["auto"].modes))


def fit_trends(seeds: int, quick: bool) -> tuple[tuple[float, ...], list[tuple[float, float, float]]]:
    """auto's trend partners on every training profile (all kinds), both designs, pooled over the seeds: of
    TREND_SPANS × TREND_FACTORS, the candidates whose every training cell (profile × design) has an RMS
    within RMS_SLACK of auto's random walks alone, then of those within RMS_SLACK of the least RMS
    (geometric mean over profiles × designs), the one with the least calibration miss (Σ over profiles ×
    designs); returns (trends, (mean RMS over the walks', worst cell's, miss) per candidate)."""
    auto = PRESETS["auto"]
    walks, _, rates = auto.imm(walks_only=True)
    cands = [trend_candidate(span, f) for span in TREND_SPANS for f in TREND_FACTORS]
    logs = np.zeros(len(cands))
    worst = np.zeros(len(cands))
    miss = np.zeros(len(cands))
    used = 0
    for params, runs in _training(seeds, quick):
        used += 1
        base = _imm_counts(runs, params, walks, None, rates)
        for i, trends in enumerate(cands):
            qs, jerks, both = kern.with_trends(walks, rates, np.array(trends), auto.cross_time)
            counts = _imm_counts(runs, params, qs, jerks, both)
            ratio = math.sqrt(counts[0] / base[0])
            logs[i] += math.log(ratio)
            worst[i] = max(worst[i], ratio)
            miss[i] += calibration_miss(counts)
    rms = np.exp(logs / max(used, 1))
    safe = worst <= RMS_SLACK
    eligible = safe & (rms <= RMS_SLACK * rms[safe].min())
    best = cands[int(np.argmin(np.where(eligible, miss, np.inf)))]
    return best, [(float(r), float(w), float(m)) for r, w, m in zip(rms, worst, miss, strict=True)]


def _imm_counts(
    runs: Sequence[Run], params: np.ndarray, qs: np.ndarray, jerks: np.ndarray | None, rates: np.ndarray
) -> np.ndarray:
    """calibration_counts of the IMM's own variance over the runs (t ≥ WARMUP), pooled."""
    counts = np.zeros(5)
    for r in runs:
        a, var, _ = kern.imm_pass(r.t, r.theta, params, qs, rates, np.zeros(1, np.int64), False, jerks)
        keep = r.t >= WARMUP
        e = (a[:, 0] - r.accel)[keep]
        counts += calibration_counts(e, e * e > 4.0 * var[keep, 0], after_change(r.t, r.t, r.accel)[keep])
    return counts


LAG_POWERS = tuple(round(1.0 + 0.1 * i, 1) for i in range(31))
"""γ = 1.0 … 4.0 of the variance maps P_f (P_lag/P_f)^γ + κ d² tried by ``fit_lag_map`` and
``fit_smoother_map``."""
FIT_LAGS = (0.25, 1.0)  # s: the live fixed lag the issue names, and a lag past which the curve flattens


LAG_WEIGHTS = (0.0, 0.25, 0.5, 1.0, 1.5, 2.0, 3.0, 4.0)
"""κ of the variance maps min(P_f (P_lag/P_f)^γ + κ d², P_lag) tried by ``fit_lag_map`` and
``fit_smoother_map`` (0: the power alone)."""

GAUSS_MEDIAN_NEES = statistics.NormalDist().inv_cdf(0.75) ** 2  # 0.455: the median of χ²₁
NEES_DECADES = np.linspace(-12.0, 12.0, 2401)  # log10 bin edges of the fits' NEES histograms (2.3 % a bin)


def map_miss(counts: np.ndarray, nees_mean: float, nees_median: float) -> float:
    """calibration_miss + |ln mean NEES| + |ln(median NEES / 0.455)|: the shares beyond 2σ (steady, after
    changes) against a Gaussian's, the mean NEES against 1, and the median against a Gaussian's: the tail,
    the mean and the body of the errors a published variance describes."""
    return (
        calibration_miss(counts)
        + abs(math.log(max(nees_mean, SHARE_FLOOR)))
        + abs(math.log(max(nees_median, SHARE_FLOOR) / GAUSS_MEDIAN_NEES))
    )


MapSums = tuple[np.ndarray, np.ndarray, np.ndarray]  # map_counts' three arrays, pooled over runs


def map_counts(
    e: np.ndarray,
    var_filter: np.ndarray,
    var_lag: np.ndarray,
    a_lag: np.ndarray,
    a_filter: np.ndarray,
    after: np.ndarray,
) -> MapSums:
    """(calibration_counts, Σ NEES, histogram of log10 NEES over NEES_DECADES) of e against
    kalman.lag_variance(var_lag, var_filter, a_lag, a_filter, γ, κ) for every (γ, κ) of LAG_POWERS ×
    LAG_WEIGHTS: the sums fit_lag_map and fit_smoother_map pool (a histogram pools, a median does not). The
    fit scores the very function the estimators publish, not a copy of its formula."""
    shape = (len(LAG_POWERS), len(LAG_WEIGHTS))
    counts, nees = np.zeros((*shape, 5)), np.zeros(shape)
    hist = np.zeros((*shape, NEES_DECADES.size - 1))
    for g, power in enumerate(LAG_POWERS):
        for k, weight in enumerate(LAG_WEIGHTS):
            z = e * e / lag_variance(var_lag, var_filter, a_lag, a_filter, power, weight)
            counts[g, k] = calibration_counts(e, z > 4.0, after)
            nees[g, k] = float(np.sum(z))
            bins = np.searchsorted(NEES_DECADES, np.log10(np.maximum(z, 1e-300)), side="right") - 1
            hist[g, k] = np.bincount(np.clip(bins, 0, NEES_DECADES.size - 2), minlength=NEES_DECADES.size - 1)
    return counts, nees, hist


def _median_nees(hist: np.ndarray) -> float:
    """The median of a NEES histogram over NEES_DECADES: the centre (in log10) of the bin holding it."""
    k = int(np.searchsorted(np.cumsum(hist), 0.5 * float(np.sum(hist))))
    return float(10.0 ** (0.5 * (NEES_DECADES[k] + NEES_DECADES[k + 1])))


def _map_fit(cells: Iterator[MapSums]) -> tuple[tuple[float, float], np.ndarray]:
    """((γ, κ), miss per pair): Σ over the cells (each its pooled map_counts) of map_miss, the least."""
    miss = np.zeros((len(LAG_POWERS), len(LAG_WEIGHTS)))
    for counts, nees, hist in cells:
        for g in range(len(LAG_POWERS)):
            for k in range(len(LAG_WEIGHTS)):
                cell = counts[g, k]
                miss[g, k] += map_miss(cell, nees[g, k] / (cell[2] + cell[4]), _median_nees(hist[g, k]))
    best_g, best_k = (int(i) for i in np.unravel_index(int(np.argmin(miss)), miss.shape))
    return (LAG_POWERS[best_g], LAG_WEIGHTS[best_k]), miss


def _pooled(parts: Iterator[MapSums]) -> MapSums:
    """The element-wise sums of map_counts over runs (the seeds of one cell)."""
    counts, nees, hist = next(parts)
    for c, z, h in parts:
        counts, nees, hist = counts + c, nees + z, hist + h
    return counts, nees, hist


def fit_lag_map(seeds: int, quick: bool) -> tuple[tuple[float, float], np.ndarray]:
    """(γ, κ) of kalman.lag_variance on every training profile (all kinds), both designs, lags FIT_LAGS,
    pooled over the seeds: of LAG_POWERS × LAG_WEIGHTS the pair with the least map_miss (Σ over profiles ×
    designs × lags); returns ((γ, κ), the miss per pair as a LAG_POWERS × LAG_WEIGHTS array). The IMM is
    auto's whole: random-walk modes and trend partners."""
    modes, jerks, rates = PRESETS["auto"].imm()

    def per_lag(runs: list[Run], params: np.ndarray, lags: np.ndarray) -> Iterator[list[MapSums]]:
        for r in runs:
            a, var, _ = kern.imm_pass(r.t, r.theta, params, modes, rates, lags, False, jerks)
            keep = r.t >= WARMUP
            after = after_change(r.t, r.t, r.accel)[keep]
            yield [
                map_counts(
                    (a[:, m] - r.accel)[keep], var[keep, 0], var[keep, m], a[keep, m], a[keep, 0], after
                )
                for m in range(1, lags.size)
            ]

    def cells() -> Iterator[MapSums]:
        for design in designs():
            params = kalman_q(design, 1.0)._params
            lags = np.array([0, *(lag_samples(lag, design.rate_hz) for lag in FIT_LAGS)], dtype=np.int64)
            for profile in PROFILES:
                if profile.role == "train":
                    by_run = list(per_lag(_runs_for(profile, design, seeds, quick), params, lags))
                    for m in range(len(FIT_LAGS)):
                        yield _pooled(run[m] for run in by_run)

    return _map_fit(cells())


def fit_smoother_map(seeds: int, quick: bool) -> tuple[tuple[float, float], np.ndarray]:
    """(γ, κ) of the smoother's variance min(P_f (Pˢ/P_f)^γ + κ (âˢ − â_f)², Pˢ) (kalman.imm_smoother, P_f
    and â_f its single-model pass's filtered ones) on every training profile (all kinds), both designs, pooled
    over the seeds: of LAG_POWERS × LAG_WEIGHTS the pair with the least map_miss (Σ over profiles × designs);
    returns ((γ, κ), the miss per pair). The smoother's IMM is auto's random-walk modes alone."""
    modes, _, rates = PRESETS["auto"].imm(walks_only=True)

    def per_run(runs: list[Run], params: np.ndarray) -> Iterator[MapSums]:
        for r in runs:
            a, var_s, var_f, a_f = imm_smoother(r.t, r.theta, params, modes, rates)
            keep = r.t >= WARMUP
            after = after_change(r.t, r.t, r.accel)[keep]
            yield map_counts((a - r.accel)[keep], var_f[keep], var_s[keep], a[keep], a_f[keep], after)

    def cells() -> Iterator[MapSums]:
        for design in designs():
            params = kalman_q(design, 1.0)._params
            for profile in PROFILES:
                if profile.role == "train":
                    yield _pooled(per_run(_runs_for(profile, design, seeds, quick), params))

    return _map_fit(cells())


def evaluate(
    seeds: int, quick: bool, *, scheduler: str | None = None, workers: int | None = None
) -> tuple[list[Row], dict[str, dict[float, float]], dict[str, float]]:
    """Rows for every validation profile × design × method, the lag curves and the hindsight q's: one
    task per design × profile (cluster.map_tasks: a local cluster, or --scheduler)."""
    cases = [
        (design, profile)
        for design in (*designs(), *REPORTED_HELDOUT)
        for profile in PROFILES
        if profile.role == "validate"
    ]
    task: Callable[[tuple[Design, Profile]], CaseResult] = functools.partial(_validate_case, seeds, quick)
    results = map_tasks(task, cases, scheduler=scheduler, workers=workers)
    rows: list[Row] = []
    curves: dict[str, dict[float, float]] = {}
    imm_rms: dict[str, float] = {}
    for design in (*designs(), *REPORTED_HELDOUT):
        mine = [r for (d, _), r in zip(cases, results, strict=True) if d == design]
        for r in mine:
            rows += r.rows
        if design in designs():
            curves[design.name] = {
                lag: math.sqrt(sum(r.lag_sum[lag] for r in mine) / sum(r.lag_n[lag] for r in mine))
                for lag in LAGS
            }
        imm_rms[design.name] = math.sqrt(sum(r.imm_sum for r in mine) / sum(r.imm_n for r in mine))
    return rows, curves, imm_rms


@dataclass
class CaseResult:
    """One design × profile: its rows and the sums the pooled lag curve and IMM RMS are made of."""

    rows: list[Row]
    lag_sum: dict[float, float]
    lag_n: dict[float, int]
    imm_sum: float
    imm_n: int


def _validate_case(seeds: int, quick: bool, case: tuple[Design, Profile]) -> CaseResult:
    """Every method, the lag curve, the smoother and the bounds on one design × validation profile."""
    design, profile = case
    methods = list(LIVE_ESTIMATORS)
    rows: list[Row] = []
    lag_sum: dict[float, float] = {}
    lag_count: dict[float, int] = {}
    imm_sq: list[np.ndarray] = []
    runs = _runs_for(profile, design, seeds, quick)
    preset_opts: dict[str, object] = {}  # the default, auto: no preset from the profile
    by: dict[str, Score] = {}
    for method in methods:
        opts = preset_opts if method == "kalman" else {}
        built = make_estimator(method, **design.settings(), **opts)  # type: ignore[arg-type]
        outs = [built.batch(r.t, r.theta) for r in runs]
        by[method] = Score.of(runs, outs, design.rate_hz)
        if method == "kalman":
            imm_sq += [((a - r.accel)[r.t >= WARMUP]) ** 2 for r, (a, _) in zip(runs, outs, strict=True)]
        rows.append(
            Row(
                design.name,
                profile.name,
                profile.role,
                method,
                by[method],
                stream_cost(method, design, runs[0], opts),
            )
        )
    # kalman with a lag, and the lag curve (one pass gives every lag; for the fitted designs only:
    # the IMM's fixed-lag pass costs O(modes · N) per sample, and the held-out rates are high)
    est = make_estimator("kalman", **design.settings())
    assert isinstance(est, KalmanEstimator)
    curve_lags = LAGS if design in designs() else (SHOWN_LAG,)
    lag_n = tuple(lag_samples(lag, design.rate_hz) for lag in curve_lags)
    lagged = [est.lagged(r.t, r.theta, lag_n) for r in runs]
    for m, lag in enumerate(curve_lags):
        for r, (a, _) in zip(runs, lagged, strict=True):
            sq = ((a[:, m] - r.accel)[r.t >= WARMUP]) ** 2
            lag_sum[lag] = lag_sum.get(lag, 0.0) + float(np.sum(sq))
            lag_count[lag] = lag_count.get(lag, 0) + int(sq.size)
    shown = curve_lags.index(SHOWN_LAG)
    lag_score = Score.of(runs, [(a[:, shown], v[:, shown]) for a, v in lagged], design.rate_hz)
    rows.append(
        Row(
            design.name,
            profile.name,
            profile.role,
            f"kalman lag={SHOWN_LAG:g}s",
            lag_score,
            stream_cost("kalman", design, runs[0], {**preset_opts, "lag": SHOWN_LAG}),
        )
    )
    smooth = [make_estimator("smoother", **design.settings()).batch(r.t, r.theta) for r in runs]
    smooth_score = Score.of(runs, smooth, design.rate_hz)
    # The bound: q with hindsight.
    grid = Q_GRID[::2] if quick else Q_GRID
    scan = list(q_scan(runs, design, grid))
    q_best = grid[int(np.argmin(scan))]
    best = kalman_q(design, q_best)
    ekf_score = Score.of(runs, [best.batch(r.t, r.theta) for r in runs], design.rate_hz)
    # The RTS smoother on the same model (the bound), and at its own hindsight q (tighter).
    rts_score = Score.of(runs, [best.smoothed(r.t, r.theta) for r in runs], design.rate_hz)
    rts_grid = Q_GRID[::4] if quick else Q_GRID[::2]
    q_rts = rts_grid[int(np.argmin(q_scan(runs, design, rts_grid, smoothed=True)))]
    best_rts = kalman_q(design, q_rts)
    rts_own = Score.of(runs, [best_rts.smoothed(r.t, r.theta) for r in runs], design.rate_hz)
    smooth_row = Row(
        design.name, profile.name, profile.role, "smoother", smooth_score, math.nan,
        smooth_score.rms / rts_score.rms, smooth_score.rms / rts_own.rms,
    )  # fmt: skip
    rows.append(smooth_row)
    rows.append(
        Row(
            design.name,
            profile.name,
            profile.role,
            f"ekf_hindsight q={q_best:.2g}",
            ekf_score,
            math.nan,
        )
    )
    rows.append(
        Row(
            design.name,
            profile.name,
            profile.role,
            f"rts_hindsight q={q_best:.2g}",
            rts_score,
            math.nan,
        )
    )
    rows.append(Row(design.name, profile.name, profile.role, f"rts_best q={q_rts:.2g}", rts_own, math.nan))
    for row in rows:
        if (
            row.design == design.name
            and row.profile == profile.name
            and row.ratio is None
            and not row.method.startswith("rts_")
            and row.method != "smoother"
            and not row.method.startswith("ekf_")
        ):
            row.ratio = row.score.rms / ekf_score.rms
    imm = np.concatenate(imm_sq)
    return CaseResult(rows, lag_sum, lag_count, float(np.sum(imm)), int(imm.size))


def _fmt(x: float, digits: int = 3) -> str:
    """x with ``digits`` significant digits, '—' for NaN."""
    return "—" if not math.isfinite(x) else f"{x:.{digits}g}"


JUDGED = ("kalman", "kalman lag", "smoother")  # the outputs issue 33 asks 1–12 % beyond 2σ of


def share_cell(share: float, n_eff: float) -> str:
    """'p̂ % (n_eff)': a share beyond 2σ with the independent trials behind it (recording.coverage)."""
    return f"{100 * share:.1f} % ({n_eff:.0f})" if math.isfinite(share) else "—"


def verdicts(rows: Sequence[Row], method: str) -> dict[str, list[str]]:
    """Each steady and after-change cell of ``method`` (a JUDGED name) by coverage.verdict: 'in', 'unsure'
    and 'out' to 'design profile part p̂ (n_eff)'."""
    out: dict[str, list[str]] = {"in": [], "unsure": [], "out": []}
    for r in rows:
        if r.method.split("=")[0] != method and r.method != method:
            continue
        sc = r.score
        for part, share, eff in (
            ("steady", sc.beyond_steady, sc.eff_steady),
            ("after", sc.beyond_after, sc.eff_after),
        ):
            kind = coverage.verdict(share, eff)
            if kind in out:
                out[kind].append(f"{r.design.split(' (')[0]} {r.profile} {part} {share_cell(share, eff)}")
    return out


def targets(rows: Sequence[Row]) -> list[str]:
    """The issue's done-when checks per design over the validation profiles, one Markdown line each, and a
    line per JUDGED output counting its cells within 1–12 % beyond 2σ, outside it but within reach of
    their 95 % interval, and outside beyond it (coverage.verdict)."""
    out = []
    for design in dict.fromkeys(r.design for r in rows):
        mine = [r for r in rows if r.design == design]
        profiles = list(dict.fromkeys(r.profile for r in mine))
        worst_ratio, worst_tan, beyond_s, beyond_a, smooth, smooth_best = 0.0, 0.0, [], [], 0.0, 0.0
        for prof in profiles:
            by = {r.method.split(" q=")[0]: r for r in mine if r.profile == prof}
            k = by["kalman"]
            worst_ratio = max(worst_ratio, k.ratio or math.nan)
            worst_tan = max(worst_tan, k.score.rms / by["instant"].score.rms)
            beyond_s.append((k.score.beyond_steady, k.score.n_steady))
            beyond_a.append((k.score.beyond_after, k.score.n_after))
            smooth = max(smooth, by["smoother"].ratio or math.nan)
            smooth_best = max(smooth_best, by["smoother"].ratio_best or math.nan)

        def pooled(parts: list[tuple[float, int]]) -> float:
            n = sum(c for _, c in parts)
            return sum(f * c for f, c in parts if c) / n if n else math.nan

        out.append(
            f"- {design}: kalman RMS ≤ {worst_ratio:.2f}× ekf_hindsight (target ≤ 1.1) and "
            f"≤ {worst_tan:.2f}× g·tanθ (target ≤ 1) on every validation profile; beyond 2σ "
            f"{100 * pooled(beyond_s):.1f} % steady, {100 * pooled(beyond_a):.1f} % after changes "
            f"(target 1–12 %); smoother ≤ {smooth:.2f}× "
            f"rts_hindsight (target ≤ 1.5), ≤ {smooth_best:.2f}× rts_best."
        )
    for method in JUDGED:
        kinds = verdicts(rows, method)
        total = sum(len(v) for v in kinds.values())
        out.append(
            f"- {method}, cells (profile × design × steady/after) with 1–12 % beyond 2σ: "
            f"{len(kinds['in'])} of {total}; outside it but within their 95 % interval's reach: "
            f"{len(kinds['unsure'])}; outside it beyond their 95 % interval: {len(kinds['out'])}"
            + (f" ({'; '.join(kinds['out'])})" if kinds["out"] else "")
            + "."
        )
    return out


def markdown(
    rows: Sequence[Row], curves: dict[str, dict[float, float]], imm: dict[str, float], quick: bool, seeds: int
) -> str:
    """The report: header (machine, date, split), the targets, the table, the lag curve table."""
    head = [
        f"Seeds 0-{seeds - 1}{', quick (first 60 s of each profile)' if quick else ''}. "
        + f"{platform.machine()}, {os.cpu_count()} CPUs.",
        "",
        "Split (benchmarks.corpus): validation profiles only in the table, "
        + ", ".join(p.name for p in PROFILES if p.role == "validate")
        + "; training (every fit): "
        + ", ".join(p.name for p in PROFILES if p.role == "train")
        + ". Designs: teaching and short_damped are the fits' designs; "
        + ", ".join(d.short for d in REPORTED_HELDOUT[:-1])
        + f" and {REPORTED_HELDOUT[-1].short}"
        + " are never used in a fit. "
        "kalman: the live default (preset auto on every profile); kalman lag: its fixed-lag smoother; "
        "smoother: the RTS smoother at the IMM's smoothed mode mix. ratio: RMS over ekf_hindsight (smoother: "
        "over rts_hindsight; ratio to rts_best after the slash). NEES (mean and median; a Gaussian's "
        "median is 0.45) and >2σ from the published variance; "
        "µs/sample of streaming update. After each share beyond 2σ, in brackets, the independent trials "
        "behind it (n_eff, recording.coverage: a filter's errors are correlated over its memory, so one short"
        " stretch is a few trials, not one per sample); a cell is judged outside 1–12 % only when its 95 % "
        "Wilson interval at n_eff misses the band.",
        "",
        "Targets (issue 33), pooled over the validation profiles and seeds:",
        "",
        *targets(rows),
        "",
    ]
    # The pipes of |e| are escaped: a bare one would split the header and the page would show no table.
    cols = ["design", "profile", "method", "RMS", "ratio", r"max \|e\|", "delay s", "NEES", "NEES median",
            ">2σ steady (n_eff)", ">2σ after (n_eff)", "µs/sample"]  # fmt: skip
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for r in rows:
        sc = r.score
        cells = [
            r.design,
            r.profile,
            r.method,
            _fmt(sc.rms),
            _fmt(r.ratio if r.ratio is not None else math.nan)
            + ("" if r.ratio_best is None else f" / {_fmt(r.ratio_best)}"),
            _fmt(sc.max_err),
            f"{sc.delay:.3f}",
            _fmt(sc.nees),
            _fmt(sc.nees_median),
            share_cell(sc.beyond_steady, sc.eff_steady),
            share_cell(sc.beyond_after, sc.eff_after),
            _fmt(r.us),
        ]
        lines.append("| " + " | ".join(cells) + " |")
    lag_lines = [
        "",
        "Latency–accuracy (RMS m/s² over the validation profiles): the single-model fixed-lag smoother at "
        "the preset's q_a against its lag, and the live IMM filter (lag 0):",
        "",
        "| design | IMM (lag 0) | " + " | ".join(f"lag {lag:g} s" for lag in LAGS) + " |",
        "|" + "---|" * (len(LAGS) + 2),
    ]
    for name, curve in curves.items():
        lag_lines.append(
            f"| {name} | {_fmt(imm[name])} | " + " | ".join(_fmt(curve[lag]) for lag in LAGS) + " |"
        )
    return "\n".join(head + lines + lag_lines) + "\n"


def plot(
    curves: dict[str, dict[float, float]], imm: dict[str, float], rows: Sequence[Row], path: Path
) -> None:
    """The latency–accuracy curve per design, with the live IMM filter, g·tanθ and the smoother."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(curves), figsize=(5.5 * len(curves), 4), constrained_layout=True)
    for ax, (name, curve) in zip(np.atleast_1d(axes), curves.items(), strict=True):
        ax.plot(list(curve), list(curve.values()), "o-", label="kalman fixed-lag smoother (preset q_a)")
        ax.plot([0.0], [imm[name]], "s", color="tab:red", label="kalman live (IMM, lag 0)")
        for method, style in (("instant", "k--"), ("smoother", "g:")):
            sel = [r for r in rows if r.design == name and r.method == method]
            if sel:
                # Pooled over samples, as the curve is: each profile weighs by its scored samples.
                counts = [r.score.n_steady + r.score.n_after for r in sel]
                pooled = math.sqrt(
                    sum(r.score.rms**2 * n for r, n in zip(sel, counts, strict=True)) / sum(counts)
                )
                ax.axhline(pooled, ls=style[1:], color=style[0], label=f"{method} (pooled over profiles)")
        ax.set_xlabel("lag = latency (s)")
        ax.set_ylabel("RMS error (m/s²)")
        ax.set_yscale("log")
        ax.set_title(f"{name}: latency against accuracy")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: Sequence[str] | None = None) -> int:
    """Fit (``--fit``) or evaluate; print and write the Markdown table and the plot."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="first 60 s of each profile, 1 seed")
    parser.add_argument("--seeds", type=bench_report.count, default=3, help="sensor noise seeds 0 … N−1")
    parser.add_argument("--fit", action="store_true", help="fit the presets' q_a on the training split")
    parser.add_argument(
        "--out", type=Path, default=Path("out/bench"), help="where the table's Markdown also goes"
    )
    parser.add_argument(
        "--workers", type=bench_report.count, default=None, help="local cluster's workers (default: CPUs)"
    )
    bench_report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    seeds = 1 if args.quick else max(1, args.seeds)
    if args.fit:
        for preset, (q, scores, imm, scores_imm) in fit_presets(seeds, args.quick).items():
            curve = ", ".join(f"{g:.2g}:{s:.3g}" for g, s in zip(Q_GRID, scores, strict=True))
            print(f"{preset}: single q_a = {q:.3g} (m/s²)²/s   [geometric-mean RMS per q: {curve}]")
            cands = ", ".join(
                f"{c}: RMS {r:.3g} miss {m:.2f}" for c, (r, m) in zip(IMM_CANDIDATES, scores_imm, strict=True)
            )
            print(f"{preset}: IMM modes {imm[0]}, switch_time {imm[1]} s   [per candidate: {cands}]")
        chain, per_chain = fit_auto(seeds, args.quick)
        cands = ", ".join(
            f"{c}: RMS {r:.3g} miss {m:.2f}" for c, (r, m) in zip(AUTO_CHAINS, per_chain, strict=True)
        )
        print(f"auto: chain up {chain[0]:g} s, down {chain[1]:g} s   [per (up, down): {cands}]")
        trends, per_trend = fit_trends(seeds, args.quick)
        cands = ", ".join(
            f"{span} ×{f:g}: RMS {r:.3f} worst {w:.2f} miss {m:.1f}"
            for (span, f), (r, w, m) in zip(
                ((s, f) for s in TREND_SPANS for f in TREND_FACTORS), per_trend, strict=True
            )
        )
        print(f"auto: trend partners q_j {trends}   [per (span, factor), over the walks alone: {cands}]")
        for name, fit in (("fixed-lag", fit_lag_map), ("smoother", fit_smoother_map)):
            (power, weight), per_pair = fit(seeds, args.quick)
            best = np.argsort(per_pair, axis=None)[:10]
            cands = ", ".join(
                f"({LAG_POWERS[g]:g}, {LAG_WEIGHTS[k]:g}): {per_pair[g, k]:.1f}"
                for g, k in zip(*np.unravel_index(best, per_pair.shape), strict=True)
            )
            print(f"auto: {name} variance map γ {power:g} κ {weight:g}   [least misses, (γ, κ): {cands}]")
        return 0
    rows, curves, imm_rms = report(seeds, args.quick, args.docs, argv, workers=args.workers)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "real_motion.md").write_text(markdown(rows, curves, imm_rms, args.quick, seeds))
    return 0


def report(
    seeds: int,
    quick: bool,
    docs: Path = bench_report.DOCS_DIR,
    argv: Sequence[str] | None = None,
    *,
    workers: int | None = None,
) -> tuple[list[Row], dict[str, dict[float, float]], dict[str, float]]:
    """Evaluate, print, and write the page docs/benchmarks/real_motion.md with the latency–accuracy plot
    (benchmarks.report.write_page); the figures."""
    rows, curves, imm = evaluate(seeds, quick, workers=workers)
    text = markdown(rows, curves, imm, quick, seeds)
    print(text)
    with tempfile.TemporaryDirectory() as tmp:
        png = Path(tmp) / "lag.png"
        plot(curves, imm, rows, png)
        page = bench_report.write_page(
            "real_motion",
            "Real-motion benchmark",
            [text],
            [(png, "RMS error against the fixed-lag smoother's lag, for each sensor design")],
            intro=(__doc__ or "").split("\n\n")[0],
            docs=docs,
            argv=argv,
        )
    print(f"wrote {page}")
    return rows, curves, imm


if __name__ == "__main__":
    raise SystemExit(main())
