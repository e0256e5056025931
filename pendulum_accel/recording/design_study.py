"""A design study: sensor designs × motion profiles × seeds, the default estimator's figures per design.

A design is the pendulum and its angle sensor: length l, damping c, sample rate, white noise σ and
quantisation step. Each case (design × profile × seed) is one task (cluster.map_tasks): θ(t) of the
design's pendulum under the profile's a(t), measured by the design's sensor, run through the default
estimator as the live filter and as the fixed-lag smoother at every asked lag. Per design the cases are
pooled: RMS of e = â − a at each lag (the fixed-lag curve), the live filter's delay (cross-correlation
peak) and its calibration (share of errors beyond 2σ in steady stretches and within 2 s after a change,
a change being |a(t) − a(t − 1 s)| > 0.2 m/s²), each share with the independent trials behind it
(recording.coverage; the cases are independent runs, so their trials add) and its 95 % interval at
those trials, and beside it the share beyond 3σ. The accuracy–latency front is the set of (latency, RMS)
points, latency = lag + delay, that no other point beats on both.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal, NotRequired, TypedDict

import numpy as np
from numpy.typing import NDArray

from pendulum_accel.cluster import Progress, map_tasks
from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators import DEFAULT_ESTIMATOR, make_estimator
from pendulum_accel.physics.params import STANDARD_GRAVITY, Pendulum
from pendulum_accel.recording import coverage
from pendulum_accel.recording.delay import group_delay
from pendulum_accel.scene import load_scene
from pendulum_accel.sensor import MAX_SAMPLES, SensorModel

if TYPE_CHECKING:  # matplotlib is loaded when a plot is drawn
    from matplotlib.figure import Figure

WARMUP = 2.0  # s left out at the start of every case: the filters start from one sample
DEFAULT_LAGS = (0.0, 0.1, 0.25, 0.5, 1.0)  # s: the fixed-lag curve
DEFAULT_PROFILES = ("udds", "hwfet", "husky_odom")  # the bundled real-motion scenes (docs/real_motion.md)
DEFAULT_DURATION = 300.0  # s of each profile (from its start) a case simulates


@dataclass(frozen=True)
class SensorDesign:
    """Pendulum length l (m), damping c (1/s), sample rate (Hz), white noise σ (rad), quantisation (rad)."""

    length: float
    damping: float
    rate_hz: float
    noise_std: float
    quantization: float = 0.0

    @property
    def name(self) -> str:
        """'l 0.2 m, c 4 /s, 200 Hz, σ 1 mrad, q 0.1 mrad'."""
        q = f", q {self.quantization * 1e3:g} mrad" if self.quantization > 0 else ""
        noise = f"σ {self.noise_std * 1e3:g} mrad"
        return f"l {self.length:g} m, c {self.damping:g} /s, {self.rate_hz:g} Hz, {noise}{q}"


def design_grid(
    lengths: Sequence[float],
    damping_ratios: Sequence[float],
    rates: Sequence[float],
    noises: Sequence[float],
    quantizations: Sequence[float] = (0.0,),
) -> list[SensorDesign]:
    """Every combination; damping c = 2 ζ ω₀ with ω₀ = √(g/l) (ζ the damping ratio, 1 critical)."""
    out = []
    for length, zeta, rate, noise, quant in itertools.product(
        lengths, damping_ratios, rates, noises, quantizations
    ):
        if not (length > 0 and zeta >= 0 and rate > 0 and noise >= 0 and quant >= 0):
            raise ParameterError(
                f"a design needs length > 0, damping ratio >= 0, rate > 0, noise and quantisation >= 0; "
                f"got l={length}, ζ={zeta}, rate={rate}, σ={noise}, q={quant}"
            )
        c = 2.0 * zeta * math.sqrt(STANDARD_GRAVITY / length)
        out.append(SensorDesign(length, round(c, 6), rate, noise, quant))
    return out


DEFAULT_DESIGNS = design_grid(
    lengths=(0.05, 0.2, 1.0), damping_ratios=(0.05, 0.7), rates=(50.0, 200.0), noises=(1e-3, 5e-3)
)
"""24 designs: a 5 cm to 1 m bob, lightly or well damped, 50 or 200 Hz, 1 or 5 mrad of noise."""


DESIGN_COLUMNS: tuple[tuple[str, str, str], ...] = (
    ("design", "string", "the design in words: length, damping, rate, noise, quantisation"),
    ("length", "double", "pendulum length l (m)"),
    ("damping", "double", "damping c (1/s): 2 ζ √(g/l) for the damping ratio ζ asked"),
    ("rate_hz", "double", "angle sample rate (Hz)"),
    ("noise_std", "double", "white angle noise σ (rad)"),
    ("quantization", "double", "angle quantisation step (rad; 0: none)"),
    ("cases", "int64", "profiles × seeds pooled in the row"),
    ("rms_lag_LAG", "double", "√(Σe²/n) of the default estimator with a fixed lag of LAG s (0: live), m/s²"),
    (
        "delay",
        "double",
        "median over the cases of the live filter's cross-correlation delay (s); null where "
        "no case's a(t) varies after the warm-up (a constant has no delay to measure)",
    ),
    ("share_2sigma_steady", "double", "share of the live filter's steady-state errors beyond 2σ"),
    ("trials_steady", "double", "independent errors behind share_2sigma_steady, summed over the cases"),
    ("share_2sigma_steady_low", "double", "lower end of that share's 95 % Wilson interval at those trials"),
    ("share_2sigma_steady_high", "double", "upper end of that interval"),
    (
        "share_3sigma_steady",
        "double",
        "share of the live filter's steady-state errors beyond 3σ (a calibrated Gaussian σ: 0.27 %)",
    ),
    ("share_2sigma_after_change", "double", "the same within 2 s after a change of a(t)"),
    ("trials_after_change", "double", "independent errors behind share_2sigma_after_change"),
    ("share_2sigma_after_change_low", "double", "lower end of that share's 95 % Wilson interval"),
    ("share_2sigma_after_change_high", "double", "upper end of that interval"),
    ("share_3sigma_after_change", "double", "the share beyond 3σ within 2 s after a change of a(t)"),
    ("nees_mean", "double", "mean e²/σ² of the live filter (1 when σ tells the truth)"),
)
"""The design table: (column, Arrow type, meaning); one rms_lag_LAG column per asked lag. A share's cells
are null where its window has no samples in any case."""


@dataclass(frozen=True)
class Case:
    """One task: a design, a profile (a bundled scene name or a scene YAML path), a seed."""

    design: SensorDesign
    profile: str
    seed: int
    duration: float
    lags: tuple[float, ...]


Window = Literal["steady", "after_change"]
WINDOWS: tuple[Window, Window] = ("steady", "after_change")
"""The live filter's two calibration windows (recording.changes.after_change splits them)."""


def samples_after_warmup(duration: float, rate_hz: float) -> int:
    """#{k : WARMUP ≤ k/f, 0 ≤ k < round(duration f)}: the samples t_k = k/f of a case (case_signals) that
    its figures are computed from; ParameterError past MAX_SAMPLES (duration × rate out of range)."""
    product = duration * rate_hz
    if not product <= MAX_SAMPLES:  # inf and 1e300 Hz alike
        raise ParameterError(
            f"{duration:g} s at {rate_hz:g} Hz gives more than {MAX_SAMPLES} samples a case: lower --rates "
            "or --duration"
        )
    n = round(product)
    first = math.ceil(WARMUP * rate_hz)
    # ceil of a rounded product may be one off the first k whose k/f (as case_signals divides) is ≥ WARMUP.
    while first > 0 and (first - 1) / rate_hz >= WARMUP:
        first -= 1
    while first < n and first / rate_hz < WARMUP:
        first += 1
    return max(0, n - first)


def case_signals(
    case: Case,
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], dict[str, float]]:
    """(t, measured θ, the profile's a(t), the default estimator's settings) of one case: θ(t) of the
    design's pendulum under a(t), started at equilibrium (tan θ₀ = a(0)/g), through the design's sensor."""
    from pendulum_accel.physics.simulate import simulate

    d = case.design
    profile = load_scene(case.profile).profile
    t = np.arange(round(case.duration * d.rate_hz)) / d.rate_hz
    accel = np.asarray(profile(t), dtype=np.float64)
    pendulum = Pendulum(length=d.length, damping=d.damping)
    traj = simulate(
        pendulum, profile, t, theta0=math.atan2(float(accel[0]), STANDARD_GRAVITY), rtol=1e-9, atol=1e-11
    )
    sensor = SensorModel(
        rate_hz=d.rate_hz, noise_std=d.noise_std, quantization=d.quantization, seed=case.seed
    )
    theta = sensor.measure(t, np.asarray(traj.theta, dtype=np.float64))
    # The estimator is told the white noise it faces: σ² plus the quantiser's q²/12.
    sigma = math.sqrt(d.noise_std**2 + d.quantization**2 / 12.0)
    settings = {"length": d.length, "damping": d.damping, "noise_std": max(sigma, 1e-6), "rate_hz": d.rate_hz}
    return t, theta, accel, settings


class WindowSums(TypedDict):
    """One window's sums in one case: samples, those beyond 2σ (NEES > 4) and 3σ (NEES > 9), Σ NEES,
    independent trials."""

    n: int
    beyond: int
    nees_sum: float
    trials: float
    beyond_3sigma: int


class CaseSums(TypedDict):
    """What one case gives for pooling: Σe² per lag, samples n; the live filter's windows and delay (set
    by its lag-0 run, which every case has)."""

    sq: dict[float, float]
    n: int
    steady: NotRequired[WindowSums]
    after_change: NotRequired[WindowSums]
    delay: NotRequired[float]


DesignRow = dict[str, str | float | None]
"""One row of the design table (DESIGN_COLUMNS, and an rms_lag_<lag> column per lag asked); None: null."""


def run_case(case: Case) -> CaseSums:
    """Sums for pooling one case: per lag Σe² and n; the live filter's delay and, per window (steady,
    after a change), its samples n, those beyond 2σ (NEES = e²/var > 4) and 3σ (> 9), Σ NEES and the
    independent trials behind them (recording.coverage.nees_windows)."""
    t, theta, accel, settings = case_signals(case)
    keep = t >= WARMUP
    out: CaseSums = {"sq": {}, "n": int(keep.sum())}
    for lag in case.lags:
        est, var = make_estimator(DEFAULT_ESTIMATOR, **settings, lag=lag).batch(t, theta)
        e = np.asarray(est) - accel
        out["sq"][lag] = float(np.sum(e[keep] ** 2))
        if lag == 0.0:
            windows = coverage.nees_windows(t, e, np.asarray(var, dtype=np.float64), t, accel, WARMUP)
            for window, (nees, trials) in zip(WINDOWS, windows, strict=True):
                z = nees[np.isfinite(nees)]
                out[window] = {
                    "n": int(z.size),
                    "beyond": int(np.sum(z > 4.0)),
                    "nees_sum": float(np.sum(z)),
                    "trials": trials,
                    "beyond_3sigma": int(np.sum(z > 9.0)),
                }
            out["delay"] = group_delay(np.asarray(est)[keep], accel[keep], case.design.rate_hz)
    return out


def _share_cells(window: str, counts: Sequence[WindowSums]) -> dict[str, float | None]:
    """share_2sigma_{window} = Σ beyond / Σ n over the cases, trials_{window} = Σ trials (the cases are
    independent runs: their independent trials add), the share's 95 % interval
    share_2sigma_{window}_low/_high (coverage.share_interval_cells), and share_3sigma_{window} =
    Σ beyond_3sigma / Σ n; None where no case has a sample."""
    n = sum(c["n"] for c in counts)
    share = sum(c["beyond"] for c in counts) / n if n else math.nan
    trials = math.fsum(c["trials"] for c in counts if c["n"]) if n else math.nan
    cells = coverage.share_interval_cells(share, trials, f"share_2sigma_{window}", f"trials_{window}")
    cells[f"share_3sigma_{window}"] = sum(c["beyond_3sigma"] for c in counts) / n if n else None
    return cells


def summarise(design: SensorDesign, parts: Sequence[CaseSums], lags: Sequence[float]) -> DesignRow:
    """One table row: the design, RMS = √(Σe²/Σn) per lag pooled over its cases, the median delay, the
    pooled shares beyond 2σ with their trials and 95 % intervals, and the mean NEES of the live filter."""
    n = sum(p["n"] for p in parts)
    row: DesignRow = {
        "design": design.name,
        "length": design.length,
        "damping": design.damping,
        "rate_hz": design.rate_hz,
        "noise_std": design.noise_std,
        "quantization": design.quantization,
        "cases": len(parts),
    }
    for lag in lags:
        row[f"rms_lag_{lag:g}"] = math.sqrt(sum(p["sq"][lag] for p in parts) / n)
    delays = [p["delay"] for p in parts if math.isfinite(p["delay"])]
    row["delay"] = float(np.median(delays)) if delays else None
    for window in WINDOWS:
        row.update(_share_cells(window, [p[window] for p in parts]))
    n_nees = sum(p[w]["n"] for p in parts for w in WINDOWS)
    row["nees_mean"] = sum(p[w]["nees_sum"] for p in parts for w in WINDOWS) / n_nees if n_nees else None
    return row


def study(
    designs: Sequence[SensorDesign],
    profiles: Sequence[str],
    *,
    seeds: int = 2,
    duration: float = DEFAULT_DURATION,
    lags: Sequence[float] = DEFAULT_LAGS,
    scheduler: str | None = None,
    workers: int | None = None,
    progress: Progress | None = None,
    distributed: bool | None = None,
) -> list[DesignRow]:
    """One row per design (summarise), from designs × profiles × seeds cases run as tasks. Each profile
    is cut to min(duration, its scene's)."""
    if seeds < 1:
        raise ParameterError(f"seeds must be >= 1, got {seeds}")
    if not lags or any(not (math.isfinite(g) and 0.0 <= g <= 10.0) for g in lags):
        raise ParameterError(f"lags must be in 0..10 s, got {list(lags)}")
    lag_set = tuple(sorted({0.0, *map(float, lags)}))
    spans = {p: min(duration, load_scene(p).duration) for p in profiles}
    for p, span in spans.items():
        for rate in sorted({d.rate_hz for d in designs}):
            if samples_after_warmup(span, rate) < 1:
                # Checked before any case runs: the RMS pools Σe²/n over the samples after the warm-up.
                raise ParameterError(
                    f"{span:g} s of {p} at {rate:g} Hz leave no sample after the {WARMUP:g} s warm-up each "
                    f"case leaves out: give a --duration over {WARMUP:g} s by a sample period or more"
                )
    cases = [Case(d, p, s, spans[p], lag_set) for d in designs for p in profiles for s in range(seeds)]
    results = map_tasks(
        run_case, cases, scheduler=scheduler, workers=workers, progress=progress, distributed=distributed
    )
    per_design: dict[SensorDesign, list[CaseSums]] = {}
    for case, result in zip(cases, results, strict=True):
        per_design.setdefault(case.design, []).append(result)
    return [summarise(d, per_design[d], lag_set) for d in designs]


def design_latency(lag: float, row: Mapping[str, object]) -> float:
    """lag + max(delay, 0) of a design row: a filter's delay is a latency only when it lags; an unmeasured
    delay (null: a constant a(t)) counts as 0, so the lag alone is the latency."""
    delay = row["delay"]
    return lag + (max(float(delay), 0.0) if isinstance(delay, float | int) else 0.0)


def front(rows: Sequence[Mapping[str, object]]) -> list[tuple[float, float, str]]:
    """(latency, RMS, design) points on the accuracy–latency front: latency = lag + the live filter's
    delay (``design_latency``); a point is on the front when no other has both a lower latency and a
    lower RMS."""
    points = []
    for row in rows:
        for key, value in row.items():
            if key.startswith("rms_lag_") and isinstance(value, float | int):
                lag = float(key[len("rms_lag_") :])
                points.append((design_latency(lag, row), float(value), str(row["design"])))
    points.sort()
    best, out = math.inf, []
    for latency, rms, name in points:
        if rms < best:
            best = rms
            out.append((latency, rms, name))
    return out


def plot_front(rows: Sequence[Mapping[str, object]], path: Path) -> None:
    """front_figure of ``rows``, saved to ``path`` at 110 dpi."""
    import matplotlib.pyplot as plt

    fig = front_figure(rows)
    fig.savefig(path, dpi=110)
    plt.close(fig)


CURVE_STYLES = ("-", "--", ":", "-.")
"""Line styles cycled once the colour cycle (tab20) is used up, so no two of 80 designs' curves look alike."""


def front_figure(rows: Sequence[Mapping[str, object]]) -> Figure:
    """Every design's fixed-lag curve (latency, RMS), each in its own colour and named in the legend beside
    the axes (its design string), the front on top in bold."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colours = matplotlib.colormaps["tab20"]
    fig, ax = plt.subplots(figsize=(11, 5.5))
    for i, row in enumerate(rows):
        lags = sorted(float(k[len("rms_lag_") :]) for k in row if k.startswith("rms_lag_"))
        x = [design_latency(g, row) for g in lags]
        y = np.array([row[f"rms_lag_{g:g}"] for g in lags], dtype=float)
        style = CURVE_STYLES[(i // colours.N) % len(CURVE_STYLES)]
        colour = colours(i % colours.N)
        ax.plot(x, y, color=colour, ls=style, lw=1.0, marker=".", ms=3, label=str(row["design"]))
    pts = front(rows)
    ax.plot([p[0] for p in pts], [p[1] for p in pts], color="black", lw=2.5, marker="o", label="front")
    ax.set_xlabel("latency: lag + delay (s)")
    ax.set_ylabel("RMS of â − a (m/s²)")
    ax.set_yscale("log")
    ax.set_title(
        f"accuracy–latency of {len(rows)} sensor designs ({DEFAULT_ESTIMATOR}, each design's fixed-lag curve)"
    )
    # Beside the axes, one column per 30 names: the curves stay unhidden whatever their number.
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, ncols=1 + len(rows) // 30)
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    return fig
