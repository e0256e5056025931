"""Allan recovery benchmark: does ``allan`` give back a sensor's noise figures, beside the record's scatter?

    python -m benchmarks.allan_recovery [--seeds N] [--duration S] [--rate HZ] [--out DIR]

For each sensor of the table below, ``--seeds`` static records (a car at rest: the angle is the sensor's
noise alone) of ``--duration`` s at ``--rate`` Hz are drawn from the scenes' sensor model
(``sensor.SensorModel``: white noise ``noise_std``, a bias random walk ``bias_random_walk`` K, a first-order
Gauss-Markov bias ``dynamic_bias_stddev`` σ_b with ``dynamic_bias_correlation_time`` T_c) and fitted by
``allan.allan_deviation`` with the Gauss-Markov term on, as ``pendulum-accel allan`` fits the angle.
Per sensor: on how many records the fit took a Gauss-Markov term, the median and worst error of each
figure it gave back, and the fit's χ²/dof (white noise and a walk stay near 1; MISFIT_LIMIT is 20).

The bound beside each figure is the record's own: σ²(τ) of T seconds scatters by √(τ/T) of itself (NIST
SP 1065's white-noise degrees of freedom, about T/τ), so σ by half that, ½ √(τ/T), at the τ that carries
the figure: τ ≈ 1.9 T_c for σ_b (the bump's peak; T_c moves the bump sideways, where σ changes slowly, so
its error is several times σ's), the first fitted τ for N and the last for K. A worst error within a few
such σ is what any fit of that record can do; "worst / scatter" gives the multiple.
Writes allan_recovery.csv and allan_recovery.png into ``--out`` (default out/bench) and the docs page.
"""

from __future__ import annotations

import argparse
import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from benchmarks import report
from pendulum_accel import PendulumAccelError
from pendulum_accel.allan import MISFIT_LIMIT, AllanResult, allan_deviation
from pendulum_accel.sensor import SensorModel

SEEDS = 20
DURATION = 2000.0  # s: the record test_allan's Gauss-Markov cases use
RATE = 50.0  # Hz
NOISE = 1.0e-3  # rad: the white noise of every sensor below
BUMP_PEAK = 1.9  # τ/T_c where a Gauss-Markov bias's σ(τ) peaks (El-Sheimy et al. 2008)


@dataclass(frozen=True)
class Sensor:
    """One sensor of the table: its label and its noise, the scenes' sensor fields (``sensor.SensorModel``):
    random walk K (``bias_random_walk``, rad/√s), Gauss-Markov σ_b (``dynamic_bias_stddev``, rad/√s) and
    T_c (``dynamic_bias_correlation_time``, s), white noise NOISE on all."""

    label: str
    walk: float = 0.0
    drive: float = 0.0
    time: float = 0.0

    def model(self, rate: float, seed: int) -> SensorModel:
        """The sensor model of this sensor at ``rate`` Hz, drawn with ``seed``."""
        return SensorModel(
            rate_hz=rate,
            noise_std=NOISE,
            bias_random_walk=self.walk,
            dynamic_bias_stddev=self.drive,
            dynamic_bias_correlation_time=self.time,
            seed=seed,
        )


SENSORS = (
    Sensor("white noise alone"),
    Sensor("white + walk K 1e-4", walk=1e-4),
    Sensor("Gauss-Markov σ_b 3e-3, T_c 1 s", drive=3e-3, time=1.0),
    Sensor("Gauss-Markov σ_b 1e-3, T_c 3 s", drive=1e-3, time=3.0),
    Sensor("Gauss-Markov σ_b 1e-3, T_c 0.3 s", drive=1e-3, time=0.3),
    Sensor("faint Gauss-Markov σ_b 3e-4, T_c 10 s", drive=3e-4, time=10.0),
    Sensor("slow Gauss-Markov σ_b 1e-3, T_c 100 s", drive=1e-3, time=100.0),
)
"""The sensors: white noise alone and with a walk (no Gauss-Markov term may be taken), the three biases
test_allan recovers, and the two docs/scenes.md says read otherwise (a faint bump under the white noise,
a bias slower than the record reads as a walk)."""


def _relative(values: Sequence[float] | np.ndarray, true: float) -> np.ndarray:
    """|x − true| / true of each value: its relative error."""
    return np.abs(np.asarray(values, dtype=float) - true) / true


def scatter(tau: float, duration: float) -> float:
    """½ √(τ/T): the relative 1-σ scatter of σ(τ) in a record of T s (σ² scatters by √(τ/T))."""
    return 0.5 * math.sqrt(tau / duration)


def fit_record(sensor: Sensor, duration: float, rate: float, seed: int) -> AllanResult:
    """allan_deviation (Gauss-Markov term on) of one static record of ``sensor``: the angle of a bob at rest
    (θ = 0) as the sensor model measures it, so the record is the sensor's noise alone."""
    model = sensor.model(rate, seed)
    t = model.sample_times(duration)
    theta = model.measure(t, np.zeros_like(t))
    return allan_deviation(theta, rate, unit="rad", gauss_markov=True)


@dataclass(frozen=True)
class Summary:
    """One sensor over the seeds: records with a Gauss-Markov term, relative errors, χ²/dof, the bounds."""

    sensor: Sensor
    records: int
    taken: int
    drive_err: np.ndarray  # |σ_b − true|/true over the records that took the term
    time_err: np.ndarray
    white_err: np.ndarray  # |N − true|/true over every record
    walk: np.ndarray  # K given back, rad/√s, over every record
    walk_err: np.ndarray  # |K − true|/true over every record (empty without a walk in the sensor)
    misfit: np.ndarray
    drive_scatter: float  # ½ √(1.9 T_c / T), nan without a bias
    white_scatter: float  # ½ √(τ_first / T)
    walk_scatter: float  # ½ √(τ_last / T)

    @staticmethod
    def of(sensor: Sensor, fits: Sequence[AllanResult], duration: float, rate: float) -> Summary:
        """The summary of ``fits``, the records of ``sensor``."""
        took = [f for f in fits if f.bias_time > 0.0]
        walk = np.array([f.random_walk for f in fits])
        none = np.empty(0)
        return Summary(
            sensor=sensor,
            records=len(fits),
            taken=len(took),
            drive_err=_relative([f.bias_drive for f in took], sensor.drive) if sensor.drive else none,
            time_err=_relative([f.bias_time for f in took], sensor.time) if sensor.drive else none,
            white_err=_relative([f.white_density for f in fits], NOISE / math.sqrt(rate)),
            walk=walk,
            walk_err=_relative(walk, sensor.walk) if sensor.walk else none,
            misfit=np.array([f.misfit for f in fits]),
            drive_scatter=scatter(BUMP_PEAK * sensor.time, duration) if sensor.drive else math.nan,
            white_scatter=scatter(float(np.median([f.fit_from for f in fits])), duration),
            walk_scatter=scatter(float(np.median([f.fit_to for f in fits])), duration),
        )


def _pct(values: np.ndarray, how: str) -> str:
    """'median' or 'worst' of relative errors in %, or a dash without values."""
    if not values.size:
        return "—"
    return f"{100 * (np.median(values) if how == 'median' else values.max()):.1f} %"


def _multiple(values: np.ndarray, bound: float) -> str:
    """worst / scatter, or a dash."""
    return "—" if not values.size or not math.isfinite(bound) else f"{values.max() / bound:.2g}"


def table(rows: Sequence[Summary]) -> str:
    """The markdown table of the summaries."""
    cols = [
        "sensor", "Gauss-Markov term taken", "σ_b error median / worst", "σ(τ≈1.9 T_c) scatter",
        "worst / scatter", "T_c error median / worst", "N error worst", "worst / scatter",
        "K median / max, rad/√s", "χ²/dof median / max",
    ]  # fmt: skip
    out = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for s in rows:
        walk = f"{np.median(s.walk):.3g} / {s.walk.max():.3g} (true {s.sensor.walk:g})"
        if s.sensor.walk:
            walk += (
                f"; worst error {_pct(s.walk_err, 'worst')}, {_multiple(s.walk_err, s.walk_scatter)}× scatter"
            )
        cells = [
            s.sensor.label,
            f"{s.taken} of {s.records}",
            f"{_pct(s.drive_err, 'median')} / {_pct(s.drive_err, 'worst')}",
            "—" if math.isnan(s.drive_scatter) else f"{100 * s.drive_scatter:.1f} %",
            _multiple(s.drive_err, s.drive_scatter),
            f"{_pct(s.time_err, 'median')} / {_pct(s.time_err, 'worst')}",
            _pct(s.white_err, "worst"),
            _multiple(s.white_err, s.white_scatter),
            walk,
            f"{np.median(s.misfit):.2g} / {s.misfit.max():.3g}",
        ]
        out.append("| " + " | ".join(cells) + " |")
    return "\n".join(out)


def plot(rows: Sequence[Summary], fits: dict[str, list[AllanResult]], out: Path) -> Path:
    """σ_b and T_c given back over their true values, a dot per record, beside ±2 scatters of σ(τ_bump)."""
    fig, axes = report.new_axes(9.0, 4.2)
    biased = [s for s in rows if s.sensor.drive]
    for k, s in enumerate(biased):
        took = [f for f in fits[s.sensor.label] if f.bias_time > 0.0]
        jitter = np.linspace(-0.12, 0.12, max(len(took), 1))[: len(took)]
        axes.plot(
            k + jitter - 0.18, [f.bias_drive / s.sensor.drive for f in took], "o", ms=3, color="tab:blue",
            label="σ_b / true" if k == 0 else None,
        )  # fmt: skip
        axes.plot(
            k + jitter + 0.18, [f.bias_time / s.sensor.time for f in took], "s", ms=3, color="tab:orange",
            label="T_c / true" if k == 0 else None,
        )  # fmt: skip
        band = 2.0 * s.drive_scatter
        axes.fill_between(
            [k - 0.4, k + 0.4], 1.0 - band, 1.0 + band, color="tab:blue", alpha=0.15,
            label="±2 scatter of σ(τ ≈ 1.9 T_c)" if k == 0 else None,
        )  # fmt: skip
        axes.annotate(
            f"{s.taken}/{s.records}", (k, 0.05), ha="center", fontsize=8, xycoords=("data", "axes fraction")
        )
    axes.axhline(1.0, color="k", lw=0.7)
    axes.set_xticks(
        range(len(biased)), [s.sensor.label.replace("Gauss-Markov ", "GM\n") for s in biased], fontsize=7
    )
    axes.set_ylabel("given back / true")
    axes.set_title(
        "allan: a Gauss-Markov bias given back (records that took the term: n/N at the bottom)", fontsize=10
    )
    axes.legend(fontsize=8, loc="upper right")
    axes.grid(True, axis="y", alpha=0.3)
    return report.save_figure(fig, out)


def main(argv: Sequence[str] | None = None) -> int:
    """Fit every sensor's records, print the table, write the CSV, the plot and the docs page."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    parser.add_argument(
        "--seeds", type=report.count, default=SEEDS, help=f"records per sensor (default {SEEDS})"
    )
    parser.add_argument("--duration", type=report.positive, default=DURATION, help="record length, s")
    parser.add_argument("--rate", type=report.positive, default=RATE, help="sample rate, Hz")
    parser.add_argument("--out", type=Path, default=Path("out/bench"), help="output directory")
    report.add_docs_argument(parser)
    args = parser.parse_args(argv)
    try:
        fits = {
            s.label: [fit_record(s, args.duration, args.rate, seed) for seed in range(args.seeds)]
            for s in SENSORS
        }
    except PendulumAccelError as err:  # a record too short or too coarse to fit: argparse's one line, exit 2
        parser.error(f"--duration {args.duration:g} s at --rate {args.rate:g} Hz: {err}")
    rows = [Summary.of(s, fits[s.label], args.duration, args.rate) for s in SENSORS]
    text = table(rows)
    print(text)
    args.out.mkdir(parents=True, exist_ok=True)
    with (args.out / "allan_recovery.csv").open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(
            ["sensor", "seed", "bias_drive", "bias_time", "white_density", "random_walk", "misfit"]
        )
        for s in SENSORS:
            for seed, f in enumerate(fits[s.label]):
                writer.writerow(
                    [s.label, seed, f.bias_drive, f.bias_time, f.white_density, f.random_walk, f.misfit]
                )
    png = plot(rows, fits, args.out / "allan_recovery.png")
    intro = (__doc__ or "") + (
        f"\n{args.seeds} records per sensor, {args.duration:g} s at {args.rate:g} Hz, white noise "
        f"{NOISE:g} rad (N = {NOISE / math.sqrt(args.rate):.3g} rad/√Hz); MISFIT_LIMIT {MISFIT_LIMIT:g}."
    )
    page = report.write_page(
        "allan_recovery", "Allan deviation: noise figures given back", [text],
        [(png, "σ_b and T_c given back over their true values, beside the record's own scatter")],
        intro=intro, docs=args.docs, argv=argv,
    )  # fmt: skip
    print(f"wrote {page}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
