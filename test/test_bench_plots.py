"""Every benchmark writes its own plot beside its table: the page each one writes names a figure, and each
plot function draws a PNG from the rows its benchmark measures (made up here: no timing is asserted)."""

from __future__ import annotations

import ast
import csv
import math
from pathlib import Path

import numpy as np
import pytest

from benchmarks import allan_recovery, bags, bare_rclpy, chain, fleet, report, soak, teardown

BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks"
PNG = b"\x89PNG\r\n\x1a\n"


def _figures_argument(call: ast.Call) -> ast.expr | None:
    """The ``figures`` argument of a write_page call: its fourth positional, or the keyword."""
    if len(call.args) >= 4:
        return call.args[3]
    return next((k.value for k in call.keywords if k.arg == "figures"), None)


def test_every_benchmark_page_carries_a_figure() -> None:
    """Each benchmark script that writes a docs page (report.write_page) passes it a figure: a non-empty
    list, never none or []. The figure is the plot the guide asks of every benchmark."""
    writers = []
    for path in sorted(BENCHMARKS.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "write_page":
                writers.append(path.name)
                figures = _figures_argument(node)
                assert figures is not None, f"{path.name}: write_page without a figure"
                assert not (isinstance(figures, ast.List) and not figures.elts), f"{path.name}: no figure"
    assert len(set(writers)) >= 15, writers  # every benchmark with a page, not a module that lost its call


def test_bar_plot_draws_the_finite_bars_and_the_bound(tmp_path: Path) -> None:
    png = report.bar_plot(
        tmp_path / "bars.png", "t", [("a", 1.0), ("b", math.nan), ("c", 30.0)], "x", bound=(10.0, "target")
    )
    assert png.read_bytes()[:8] == PNG


def test_bags_plot_compares_each_task_with_its_loop(tmp_path: Path) -> None:
    rows = [
        bags.Row("plain rosbags read + deserialize loop", 100, 2.0, 60.0, 2.0),
        bags.Row("analyze --estimator kalman (default)", 100, 0.3, 60.0, 2.0, pass_us=3.8),
        bags.Row("generate: total", 100, 0.3, 60.0),
    ]
    assert bags.plot(rows, tmp_path / "bags.png").read_bytes()[:8] == PNG
    cells = bags.table(rows)
    assert cells[0][-1] == "estimator pass, µs per angle" and cells[1][-1] == ""
    # The cell is parsed, not compared as text: 3.8 printed to 3 significant digits is within 5e-3 of it.
    assert float(cells[2][-1]) == pytest.approx(3.8, abs=5e-3)


def test_chain_soak_and_teardown_plots(tmp_path: Path) -> None:
    timed = chain.Result("real time", 1000.0, 5.0, 5001, 5001, 5001, 5001, np.full(100, 2e-4), 100.0, 1.0)
    fast = chain.Result(
        "as fast as possible", 1000.0, 30.0, 30001, 30001, 30001, 30001, np.array([]), None, 10.0
    )
    assert chain.plot([timed, fast], tmp_path / "chain.png").read_bytes()[:8] == PNG
    fast.cpu, fast.messages_written = {"simulator": 50.0, "estimator": 60.0, "recorder": 40.0}, 5 * 30001
    ceilings = [
        bare_rclpy.Ceiling("pair", 30000, 1.5, 30000, None, {"talker": 20.0, "listener": 25.0}),
        bare_rclpy.Ceiling("pair + recorder", 30000, 3.0, 30000, 30000, {"recorder": 40.0}),
    ]
    assert chain.ceiling_plot([timed, fast], ceilings, tmp_path / "c.png").read_bytes()[:8] == PNG
    # 10x real time at 1 kHz is 10,000 samples/s; 60 % of a core over them is 60 µs a sample (three float
    # steps, each within half an ulp, 1.1e-16, of exact: 1e-12 relative leaves a wide margin).
    assert fast.cpu_us_per_sample("estimator") == pytest.approx(60.0, rel=1e-12)
    line = chain.comparison([timed, fast], ceilings)
    assert "10,000 samples/s" in line and "50,000 recorded messages/s" in line and "20,000 JointState" in line
    assert timed.cpu_us_per_sample("estimator") != timed.cpu_us_per_sample("estimator")  # NaN: no CPU figures
    series = {"simulator": [(5.0 * k, 80.0 + 0.01 * k) for k in range(40)], "recorder": [(0.0, 90.0)]}
    assert soak.plot(series, tmp_path / "soak.png").read_bytes()[:8] == PNG
    assert teardown.plot([1.1, 1.2, 0.9], tmp_path / "teardown.png").read_bytes()[:8] == PNG


def test_allan_recovery_writes_its_table_plot_and_page(tmp_path: Path) -> None:
    """One short record per sensor: the CSV holds a parsable row per sensor and seed, the page names the
    plot, and no Gauss-Markov term is given to white noise alone or to white noise and a walk (what
    test_allan asserts over 1000 records; one record each here)."""
    out, docs = tmp_path / "out", tmp_path / "docs"
    assert (
        allan_recovery.main(["--seeds", "1", "--duration", "500", "--out", str(out), "--docs", str(docs)])
        == 0
    )
    with (out / "allan_recovery.csv").open(encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    assert [r["sensor"] for r in rows] == [s.label for s in allan_recovery.SENSORS]
    for r in rows[:2]:
        assert float(r["bias_time"]) == 0.0 and float(r["misfit"]) < allan_recovery.MISFIT_LIMIT
    assert (out / "allan_recovery.png").read_bytes()[:8] == PNG
    assert "../img/bench_allan_recovery.png" in (docs / "benchmarks" / "allan_recovery.md").read_text()


def test_allan_recovery_refuses_a_record_too_short_in_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    """1 s at 50 Hz is 51 samples, below allan's 100: argparse's usage error, exit 2, one 'error:' line."""
    with pytest.raises(SystemExit) as stop:
        allan_recovery.main(["--seeds", "1", "--duration", "1"])
    assert stop.value.code == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if "error:" in line]
    assert len(errors) == 1 and "at least 100 samples" in errors[0], errors


def test_fleet_prediction_names_the_first_limit_from_the_measured_figures() -> None:
    """benchmarks.fleet's 10-node paragraph from made-up figures: 100 bags, 0.5 s each serially, the 1-worker
    cluster 0.01 s a bag dearer, 2 workers at 90 % efficiency: 20 workers give 20 · 0.9 / 0.5 = 36 bags/s,
    under the scheduler's cap of 1/0.01 = 100 bags/s and the links' 10 · 125 / 2 = 625 bags/s."""
    one = fleet.ClusterRun(1, 1.0, 51.0, (300.0,))
    many = fleet.ClusterRun(2, 1.5, 100 * 0.5 / (2 * 0.9), (300.0, 310.0))
    text = fleet.prediction(100, 50.0, one, many, bag_mb=2.0)
    rate = float(text.split("about **")[1].split(" bags/s")[0])
    assert rate == pytest.approx(36.0, abs=0.5)  # printed to the unit
    assert "20 workers at the 90% efficiency" in text
    slow_scheduler = fleet.ClusterRun(1, 1.0, 50.0 + 100 * 0.1, (300.0,))  # 0.1 s a bag: cap 10 bags/s
    text = fleet.prediction(100, 50.0, slow_scheduler, many, bag_mb=2.0)
    assert float(text.split("about **")[1].split(" bags/s")[0]) == pytest.approx(10.0, abs=0.5)
    assert "the scheduler" in text.split("The first limit is")[1]
