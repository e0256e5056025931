"""benchmarks.real_motion --quick: the report's structure and the properties its figures must have."""

from __future__ import annotations

import math
import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from benchmarks import fit_presets as fp
from benchmarks import motion_designs as md
from benchmarks import motion_scores as ms
from benchmarks import real_motion as rm
from pendulum_accel.estimators import LIVE_ESTIMATORS

# The page's own run covers the whole validation corpus through four designs (tens of minutes); the test
# checks the report's structure and its figures' properties on one validation profile of each kind and one
# held-out design, which exercise every code path of it.
ONE_OF_EACH_KIND = ("udds_p2", "f1tenth_ds5", "comma2k19_imu", "braking")


@pytest.fixture(scope="module")
def quick(tmp_path_factory: pytest.TempPathFactory) -> Iterator[tuple[list[rm.Row], dict, dict, Path]]:
    """One --quick run (first 60 s of each profile, one seed) on ONE_OF_EACH_KIND (and every training
    profile) through the fitted designs and the light held-out one, written under a temporary directory."""
    assert len(rm.REPORTED_HELDOUT) >= 2  # the page reports two designs no fit uses
    out = tmp_path_factory.mktemp("real_motion")
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(
            rm, "PROFILES", tuple(p for p in rm.PROFILES if p.role == "train" or p.name in ONE_OF_EACH_KIND)
        )
        patch.setattr(rm, "REPORTED_HELDOUT", tuple(d for d in rm.REPORTED_HELDOUT if d.short == "light"))
        rows, curves, imm = rm.report(1, True, out, argv=["--quick"])
        yield rows, curves, imm, out


@pytest.mark.slow
def test_report_covers_every_validation_profile_design_and_method(quick: tuple) -> None:
    """Rows for every validation profile × design (the fitted two and the held-out one) × live method, the lag
    row, the smoother and both bounds; no training profile is reported; the Markdown names the split and
    the plot is written."""
    rows, _, _, out = quick
    validation = {p.name for p in rm.PROFILES if p.role == "validate"}
    training = {p.name for p in rm.PROFILES if p.role == "train"}
    assert validation and training and not validation & training
    assert {r.profile for r in rows} == validation
    reported = {r.design for r in rows}
    assert reported == {d.name for d in (*md.designs(), *rm.REPORTED_HELDOUT)}
    for design in (*md.designs(), *rm.REPORTED_HELDOUT):
        for profile in validation:
            methods = {
                r.method.split(" ")[0] for r in rows if r.design == design.name and r.profile == profile
            }
            assert {*LIVE_ESTIMATORS, "smoother", "ekf_hindsight", "rts_hindsight", "rts_best"} <= methods
    text = (out / "benchmarks" / "real_motion.md").read_text()
    assert "| design | profile | method | RMS |" in text and "Targets (issue 33)" in text
    assert "Split (benchmarks.corpus)" in text
    assert (out / "img" / "bench_real_motion.png").stat().st_size > 0
    assert (out / "img" / "bench_real_motion_2.png").stat().st_size > 0  # the reliability diagram
    assert "bench_real_motion_2.png" in text


def test_figures_are_finite_and_bounds_order_as_theory_says(quick: tuple) -> None:
    """Every RMS, NEES and share is finite and in range; on the same data the RTS bound is below the
    filter bound, and the smoother (the IMM at a 1 s lag) below the live filter: later data can only help."""
    rows, _, _, _ = quick
    for r in rows:
        s = r.score
        assert math.isfinite(s.rms) and s.rms > 0.0 and s.max_err >= s.rms
        assert math.isfinite(s.nees) and s.nees > 0.0
        assert math.isnan(s.beyond_steady) or 0.0 <= s.beyond_steady <= 1.0  # NaN: an agile robot is
        # never steady for 3 s (f1tenth_ds5: every sample lies within 2 s of a change)
        assert math.isnan(s.beyond_after) or 0.0 <= s.beyond_after <= 1.0
        # Beyond 3σ is a part of beyond 2σ (NEES > 9 implies NEES > 4), counted over the same samples.
        for two, three in ((s.beyond_steady, s.beyond3_steady), (s.beyond_after, s.beyond3_after)):
            assert (math.isnan(two) and math.isnan(three)) or 0.0 <= three <= two
        # Each share's independent trials: at least one per stretch, at most one per sample.
        for n, eff in ((s.n_steady, s.eff_steady), (s.n_after, s.eff_after)):
            assert (n == 0 and eff == 0.0) or 1.0 <= eff <= n
    for design in md.designs():
        for profile in {r.profile for r in rows}:
            by = {
                r.method.split(" q=")[0]: r for r in rows if r.design == design.name and r.profile == profile
            }
            assert by["rts_hindsight"].score.rms <= by["ekf_hindsight"].score.rms
            assert by["smoother"].score.rms <= by["kalman"].score.rms
            assert by["kalman"].ratio is not None and by["kalman"].ratio > 0.0


def test_the_judged_outputs_carry_their_sigma_deciles(quick: tuple) -> None:
    """The live, fixed-lag and smoother rows carry the reliability diagram's bins (ten deciles, ascending
    σ, every error scored once: the bins' samples add to the scored samples), the other rows none."""
    rows, _, _, _ = quick
    judged = {"kalman", f"kalman lag={rm.SHOWN_LAG:g}s", "smoother"}
    for r in rows:
        if r.method not in judged:
            assert r.reliability is None, r.method
            continue
        bins = r.reliability
        assert bins is not None and bins.predicted.size == 10, r.method
        assert np.all(np.diff(bins.predicted) >= 0.0) and np.all(bins.observed > 0.0)
        assert int(bins.samples.sum()) == r.score.n_steady + r.score.n_after


def test_pooled_reliability_bins_the_runs_after_the_warmup(tmp_path: Path) -> None:
    """Two runs' errors and variances after WARMUP, concatenated, binned once (the very arrays: exact);
    the diagram of rows carrying them is written, one panel per judged output."""
    rng = np.random.default_rng(5)
    runs, outs = [], []
    for n in (400, 600):
        t = np.arange(n) / 100.0
        var = 10.0 ** rng.uniform(-4.0, -2.0, n)
        runs.append(md.Run(t, np.zeros(n), np.zeros(n)))
        outs.append((np.sqrt(var) * rng.standard_normal(n), var))
    bins = rm.pooled_reliability(runs, outs)
    keep = [r.t >= ms.WARMUP for r in runs]
    expected = rm.reliability_bins(
        np.concatenate([a[k] for (a, _), k in zip(outs, keep, strict=True)]),
        np.concatenate([v[k] for (_, v), k in zip(outs, keep, strict=True)]),
    )
    for got, want in zip(bins, expected, strict=True):
        np.testing.assert_array_equal(got, want)
    assert int(bins.samples.sum()) == sum(int(k.sum()) for k in keep)
    score = ms.Score(1.0, 1.0, 0.0, 1.0, 0.05, 0.05, 1, 1)
    rows = [rm.Row("d", "p", "validate", m, score, 0.0, reliability=bins) for m in ("kalman", "smoother")]
    png = tmp_path / "reliability.png"
    rm.plot_reliability([*rows, rm.Row("d", "p", "validate", "instant", score, 0.0)], png)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_latency_buys_accuracy(quick: tuple) -> None:
    """The fixed-lag smoother's RMS at the longest lag is below its RMS at lag 0, for every design."""
    _, curves, imm, _ = quick
    for name, curve in curves.items():
        assert curve[rm.LAGS[-1]] < curve[0.0]
        assert math.isfinite(imm[name]) and imm[name] > 0.0


def test_calibration_miss_is_zero_for_a_gaussian_share_and_grows_both_ways() -> None:
    """The IMM fit's criterion: Σ |ln(share/4.55 %)| over steady and after-change; 0 at a Gaussian's
    share (P(|z| > 2) = erfc(√2)), ln 2 per factor 2 either way, a share of 0 floored, empty parts skipped."""
    n = 1e6  # samples: the shares below are exact fractions of it
    gauss = ms.GAUSS_2SIGMA * n
    assert abs(ms.GAUSS_2SIGMA - 0.0455) <= 5e-5  # the textbook 4.55 %, to its printed digits
    assert ms.calibration_miss([0.0, gauss, n, gauss, n]) == pytest.approx(0.0, abs=1e-12)
    # ln 2 each way: 1e-12 covers the round-off of a log of a ratio of doubles
    both = ms.calibration_miss([0.0, 2 * gauss, n, gauss / 2, n])
    assert both == pytest.approx(2 * math.log(2.0), abs=1e-12)
    assert ms.calibration_miss([0.0, gauss, n, 0.0, 0.0]) == pytest.approx(0.0, abs=1e-12)
    floored = ms.calibration_miss([0.0, 0.0, n, gauss, n])
    assert floored == pytest.approx(math.log(ms.GAUSS_2SIGMA / ms.SHARE_FLOOR), abs=1e-12)


def test_targets_count_every_judged_cell_once(quick: tuple) -> None:
    """Each JUDGED output's line counts its cells as in, unsure or out (coverage.verdict), and these add up
    to its shares that have samples (the counts parsed from the page's line, never compared as text)."""
    rows, _, _, out = quick
    text = (out / "benchmarks" / "real_motion.md").read_text()
    for method in rm.JUDGED:
        line = next(t for t in text.splitlines() if t.startswith(f"- {method}, cells"))
        found = re.search(r"(\d+) of (\d+);.*reach: (\d+);.*interval: (\d+)", line)
        assert found is not None, line
        inside, total, unsure, outside = (int(x) for x in found.groups())
        mine = [r for r in rows if r.method == method or r.method.split("=")[0] == method]
        shares = [x for r in mine for x in (r.score.beyond_steady, r.score.beyond_after) if math.isfinite(x)]
        assert total == len(shares) == inside + unsure + outside
        kinds = rm.verdicts(rows, method)
        assert (len(kinds["in"]), len(kinds["unsure"]), len(kinds["out"])) == (inside, unsure, outside)


def _tiny_training_split() -> tuple[md.Profile, ...]:
    """One short training profile per preset (a step, a braking and a stop): every fit's code path in
    seconds, not the corpus's minutes."""
    from pendulum_accel.physics.profiles import Braking, Step

    return (
        md.Profile("tiny_car", "train", "car", lambda: Step(3.0, 0.0, 1.0), 6.0),
        md.Profile("tiny_robot", "train", "robot", lambda: Braking(2.0, 2.0, 3.0), 6.0),
        md.Profile("tiny_lab", "train", "lab_steps", lambda: Step(3.0, 1.0, -2.0), 6.0),
    )


def test_fit_runs_every_fit_and_picks_from_its_grids(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``--fit`` (the command every tuned constant names) runs each fit to its end on a training split, and
    each prints a value of its own grid: q_a of Q_GRID and an IMM candidate per preset, auto's chain of
    AUTO_CHAINS, the fixed-lag and the smoother's variance maps of LAG_POWERS × LAG_WEIGHTS."""
    monkeypatch.setattr(fp, "PROFILES", _tiny_training_split())
    assert rm.main(["--fit", "--quick"]) == 0
    out = capsys.readouterr().out
    for preset in ("car", "robot", "lab_steps"):
        q = float(re.search(rf"^{preset}: single q_a = (\S+) ", out, re.M).group(1))  # type: ignore[union-attr]
        # printed to 3 significant digits: within half a unit of the third digit of a grid value
        assert min(abs(q - g) / g for g in ms.Q_GRID) <= 5e-3
        imm = re.search(rf"^{preset}: IMM modes \((\S+), (\S+)\), switch_time (\S+) s", out, re.M)
        assert imm is not None
        modes = (float(imm.group(1)), float(imm.group(2)))
        assert (modes, float(imm.group(3))) in fp.IMM_CANDIDATES
    chain = re.search(r"^auto: chain up (\S+) s, down (\S+) s", out, re.M)
    assert chain is not None and (float(chain.group(1)), float(chain.group(2))) in fp.AUTO_CHAINS
    for name in ("fixed-lag", "smoother"):
        fitted = re.search(rf"^auto: {name} variance map γ (\S+) κ (\S+) ", out, re.M)
        assert fitted is not None, name
        assert float(fitted.group(1)) in fp.LAG_POWERS and float(fitted.group(2)) in fp.LAG_WEIGHTS


def test_imm_scan_counts_what_the_estimator_publishes() -> None:
    """imm_scan's row for car's own IMM (modes 1e-4/0.03, switch 50 s) holds the same Σe² and the same
    counts beyond 2σ, steady and after a change, as KalmanEstimator(preset='car').batch on the same runs."""
    from pendulum_accel.estimators.kalman import PRESETS, KalmanEstimator
    from pendulum_accel.physics.profiles import Step
    from pendulum_accel.recording.changes import after_change

    car = PRESETS["car"]
    candidate = (car.modes, car.switch_time)
    assert candidate in fp.IMM_CANDIDATES
    design = md.designs()[0]
    runs = md.simulate_runs(Step(3.0, 0.0, 1.0), design, 2, 8.0)
    (row,) = fp.imm_scan(runs, design, [candidate])
    est = KalmanEstimator(ms.kalman_q(design, 1.0).config, preset="car")
    expected = [0.0, 0, 0, 0, 0]
    for r in runs:
        a, var = est.batch(r.t, r.theta)
        keep = r.t >= ms.WARMUP
        e = (a - r.accel)[keep]
        beyond = e * e > 4.0 * var[keep]  # the design has no bias: the published var is the IMM's own
        after = after_change(r.t, r.t, r.accel)[keep]
        expected[0] += float(np.sum(e * e))
        for k, mask in ((1, beyond & ~after), (2, ~after), (3, beyond & after), (4, after)):
            expected[k] += int(np.count_nonzero(mask))
    assert list(row[1:]) == expected[1:]
    # the same compiled pass on the same inputs: only the order of the sum may differ (≤ n ε relative)
    assert row[0] == pytest.approx(expected[0], rel=1e-9)
