"""``design``, the design study: its rows, Pareto front and shares with their trials and Wilson interval, the
same rows on a local cluster, its delay on a constant truth, the CLI's table and plot, and its one-line
refusals.
"""

from __future__ import annotations

import csv
import io
import itertools
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from pendulum_accel.cli.main import main
from pendulum_accel.recording import coverage
from pendulum_accel.recording import design_study as ds
from pendulum_accel.recording.delay import group_delay
from test.conftest import cli
from test.fleet_rows import (
    SHARE_CELLS,
    _no_leftover_workers,  # noqa: F401 (the autouse fixture)
    cells,
)
from test.refusal import error_line


def test_design_study_rows_front_and_the_same_on_a_local_cluster(tmp_path: Path) -> None:
    """Two designs × one profile × two seeds: a row per design with the asked lags, RMS falling (not
    rising) with the lag beyond rounding, the front monotone; a LocalCluster gives the same rows (exact,
    for the reason given in test_local_cluster_gives_the_serial_table)."""
    designs = ds.design_grid([0.2, 1.0], [0.7], [100.0], [1e-3])
    kwargs: dict[str, Any] = {"seeds": 2, "duration": 20.0, "lags": (0.0, 0.5)}
    rows = [cells(r) for r in ds.study(designs, ["husky_odom"], distributed=False, **kwargs)]
    assert [r["design"] for r in rows] == [d.name for d in designs]
    for r in rows:
        assert r["cases"] == 2
        assert 0.0 < r["rms_lag_0.5"] < r["rms_lag_0"], r  # half a second of hindsight helps on real motion
        assert 0.0 <= r["share_2sigma_steady"] <= 1.0
    pts = ds.front(rows)
    assert all(a[0] <= b[0] and a[1] > b[1] for a, b in itertools.pairwise(pts))
    assert ds.study(designs, ["husky_odom"], workers=2, distributed=True, **kwargs) == rows
    _assert_curves_are_named(rows)


def _assert_curves_are_named(rows: list[dict[str, Any]]) -> None:
    """The accuracy–latency plot names every design's curve in its legend (then the front), each curve in
    a colour or line style of its own, its points the row's (latency, RMS) at each lag."""
    import matplotlib.pyplot as plt

    fig = ds.front_figure(rows)
    try:
        (ax,) = fig.axes
        legend = ax.get_legend()
        assert legend is not None
        assert [t.get_text() for t in legend.get_texts()] == [*(r["design"] for r in rows), "front"]
        lines = {line.get_label(): line for line in ax.get_lines()}
        looks = {(str(lines[r["design"]].get_color()), lines[r["design"]].get_linestyle()) for r in rows}
        assert len(looks) == len(rows)
        for r in rows:
            x, y = (np.asarray(v, dtype=float) for v in lines[r["design"]].get_data())
            assert y.tolist() == [r["rms_lag_0"], r["rms_lag_0.5"]]  # the row's floats, drawn as they are
            assert x.tolist() == [ds.design_latency(lag, r) for lag in (0.0, 0.5)]
    finally:
        plt.close(fig)


def _case_trials(case: ds.Case) -> dict[str, tuple[float, int, int]]:
    """(independent trials, samples beyond 3σ, samples) of one design-study case's live filter per window,
    computed here from its signals with coverage's own functions: each window's τ of the NEES after the
    warm-up over that window's stretches, n_eff of the window's mask at it; NEES > 9 counted directly."""
    from pendulum_accel.estimators import DEFAULT_ESTIMATOR, make_estimator
    from pendulum_accel.recording.changes import after_change

    t, theta, accel, settings = ds.case_signals(case)
    est, var = make_estimator(DEFAULT_ESTIMATOR, **settings, lag=0.0).batch(t, theta)
    keep = t >= ds.WARMUP
    nees = ((est - accel) ** 2 / var)[keep]
    assert np.all(np.isfinite(nees))  # var > 0 everywhere: every sample counts in its window
    after = after_change(t, t, accel)[keep]
    return {
        name: (
            coverage.effective_samples(mask, coverage.integrated_time(nees, mask)),
            int(np.sum(nees[mask] > 9.0)),
            int(np.sum(mask)),
        )
        for name, mask in (("steady", ~after), ("after_change", after))
    }


def test_design_shares_carry_their_summed_trials_and_wilson_interval() -> None:
    """Each design row's share beyond 2σ comes with the trials of its cases summed (independent runs) and
    the Wilson interval at them, and its share beyond 3σ pools the cases' exceedances; a window no case
    reaches has null cells, never NaN."""
    designs = ds.design_grid([0.2, 1.0], [0.7], [100.0], [1e-3])
    seeds, duration = 2, 20.0
    found = ds.study(designs, ["husky_odom"], seeds=seeds, duration=duration, lags=(0.0,), distributed=False)
    rows = [cells(r) for r in found]
    for design, r in zip(designs, rows, strict=True):
        per_case = [_case_trials(ds.Case(design, "husky_odom", s, duration, (0.0,))) for s in range(seeds)]
        for window in ("steady", "after_change"):
            share, trials = r[f"share_2sigma_{window}"], r[f"trials_{window}"]
            low, high = r[f"share_2sigma_{window}_low"], r[f"share_2sigma_{window}_high"]
            # Both sides add the same two per-case floats (fsum there, + here: each one correctly rounded
            # sum), so they agree to a rounding or two of ~1e-16 relative; 1e-12 is far above that.
            assert trials == pytest.approx(sum(c[window][0] for c in per_case), rel=1e-12), (window, r)
            assert trials >= seeds  # every case reaches both windows on 20 s of husky_odom
            assert low <= share <= high, (window, r)
            assert (low, high) == coverage.wilson(share, trials)  # the same function at the same arguments
            # Pooled like the 2σ share: Σ beyond / Σ n, both sides dividing the same two integers (exact).
            beyond3, n = sum(c[window][1] for c in per_case), sum(c[window][2] for c in per_case)
            assert r[f"share_3sigma_{window}"] == beyond3 / n, (window, r)
    (rest,) = map(
        cells, ds.study(designs[:1], ["at_rest"], seeds=1, duration=5.0, lags=(0.0,), distributed=False)
    )
    assert isinstance(rest["trials_steady"], float) and rest["trials_steady"] >= 1.0
    assert all(rest[k] is None for k in SHARE_CELLS if "after_change" in k), rest


def test_a_constant_truth_has_no_delay() -> None:
    """After the 2 s warm-up, step_start's a(t) is 3 m/s² throughout: a − mean a is rounding, and the
    cross-correlation's peak fell on any lag (−0.75 s was reported). The delay is null there, and the
    front counts the lag alone; a profile that varies keeps its delay."""
    rng = np.random.default_rng(0)
    flat = np.full(500, 3.0)
    assert math.isnan(group_delay(flat + 1e-3 * rng.standard_normal(500), flat, 100.0))
    moving = rng.standard_normal(500)  # white: its autocorrelation peaks at 0 alone
    late = np.concatenate([np.zeros(7), moving[:-7]])  # 7 samples late at 100 Hz
    assert group_delay(late, moving, 100.0) == pytest.approx(0.07, abs=1e-12)  # an exact sample count
    designs = ds.design_grid([0.2], [0.7], [100.0], [1e-3])
    (row,) = ds.study(designs, ["step_start"], seeds=1, duration=5.0, lags=(0.0, 0.5), distributed=False)
    assert row["delay"] is None
    points = ds.front([row])
    assert points and all(p[0] in (0.0, 0.5) for p in points)  # latency = the lag alone
    (row,) = ds.study(
        designs, ["step_start", "husky_odom"], seeds=1, duration=5.0, lags=(0.0,), distributed=False
    )
    assert isinstance(row["delay"], float) and math.isfinite(row["delay"])  # husky's, the one measured


def test_design_cli_table_plot_and_one_line_refusals(tmp_path: Path) -> None:
    """The command writes its table and plot; a bad grid or scene is one line, exit 2, nothing written."""
    out, png = tmp_path / "d.csv", tmp_path / "d.png"
    done = cli("design", "--out", str(out), "--plot", str(png), "--lengths", "0.2", "--damping-ratios", "0.7",
               "--rates", "100", "--noises", "1e-3", "--profiles", "husky_odom", "--duration", "10",
               "--seeds", "1", "--lags", "0,0.25")  # fmt: skip
    assert done.returncode == 0, done.stderr
    header = out.read_text().splitlines()[0].split(",")
    assert "rms_lag_0.25" in header and "share_2sigma_after_change" in header
    assert "share_3sigma_steady" in header and "share_3sigma_after_change" in header
    (row,) = list(csv.DictReader(io.StringIO(out.read_text())))
    for window in ("steady", "after_change"):
        share, trials = float(row[f"share_2sigma_{window}"]), float(row[f"trials_{window}"])
        low, high = float(row[f"share_2sigma_{window}_low"]), float(row[f"share_2sigma_{window}_high"])
        assert trials >= 1.0 and low <= share <= high, row
    assert png.stat().st_size > 0
    for bad in (["--lengths", "-1"], ["--profiles", "no_such_scene"], ["--lags", "x"], ["--seeds", "0"]):
        target = tmp_path / "bad.csv"
        refused = cli("design", "--out", str(target), "--duration", "5", *bad)
        assert refused.returncode == 2, (bad, refused.stderr)
        assert len(refused.stderr.strip().splitlines()) == 1 and "Traceback" not in refused.stderr
        assert not target.exists()


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (
            ["--duration", "2", "--profiles", "udds"],
            "2 s of udds at 50 Hz leave no sample after the 2 s warm-up",
        ),
        (["--duration", "2.01", "--profiles", "udds"], "2.01 s of udds at 50 Hz leave no sample"),
        (["--rates", "1e300", "--profiles", "udds"], "1e+300 Hz gives more than 50000000 samples a case"),
        (["--rates", "1e-300", "--profiles", "udds"], "at 1e-300 Hz leave no sample after the 2 s warm-up"),
    ],
    ids=["duration_2", "duration_2.01", "rates_1e300", "rates_1e-300"],
)
def test_design_without_a_sample_to_pool_is_one_line(
    tmp_path: Path, args: list[str], words: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """A case keeps t ≥ the 2 s warm-up: --duration 2 (accepted, in (0, 1e6]) kept none and the pooled
    RMS divided by 0 after every case had run; 1e-300 Hz has no sample at all, 1e300 Hz asked for 3e302.
    Each is one line before any case runs, exit 2, nothing written."""
    out = tmp_path / "d.csv"
    grid = ["--lengths", "1", "--damping-ratios", "0.7", "--noises", "1e-3", "--seeds", "1"]
    rates = [] if "--rates" in args else ["--rates", "50"]
    code = main(["design", "--out", str(out), *grid, *rates, *args])
    error_line(code, capsys.readouterr().err, words)
    assert not out.exists()


def test_samples_after_warm_up_count_what_a_case_keeps() -> None:
    """samples_after_warmup equals the count of case_signals' t_k = k/f ≥ WARMUP, at the edges too."""
    for duration, rate in [
        (2.0, 50.0),
        (2.01, 50.0),
        (2.02, 50.0),
        (3.0, 1.0),
        (2.5, 1.0),
        (4.0, 3.0),
        (7.3, 7.7),
    ]:
        t = np.arange(round(duration * rate)) / rate
        assert ds.samples_after_warmup(duration, rate) == int(np.sum(t >= ds.WARMUP)), (duration, rate)
