"""benchmarks.heldout on a speed trace made here: every design gets a row, and the verdict follows the
figures in its own row."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from benchmarks import heldout


@pytest.mark.slow
def test_heldout_page_has_a_row_per_design_and_a_verdict_from_its_figures(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    t = np.arange(0.0, 41.0)
    v = np.clip(np.minimum(t, 40.0 - t) * 1.2, 0.0, None)  # a 1.2 m/s² pull-away and a stop, peak 24 m/s
    rows = "".join(f"{a:g},{b:g}\n" for a, b in zip(t, v, strict=True))
    (tmp_path / "trace.csv").write_text("t,v\n" + rows)
    (tmp_path / "trace.yaml").write_text(
        "name: trace\ndescription: made-up pull-away\nduration: 40\n"
        "pendulum: {length: 0.1, damping: 9.9}\n"
        "acceleration: {type: speed_csv, path: trace.csv, units: m/s}\n"
        "sensor: {rate_hz: 100.0, noise_std: 1.0e-3}\naccuracy: {max_angle_error: 1.0e-6}\n"
    )
    results = heldout.evaluate(tmp_path / "trace.yaml", seeds=1)
    assert len(results) == 2 + len(heldout.HELDOUT_DESIGNS) + 1
    assert {r.preset for r in results} == {"auto"}  # no preset from where the trace came from
    for r in results:
        k = r.kalman
        shares = [s for s in (k.beyond_steady, k.beyond_after) if s == s]
        expected = (
            k.rms <= min(r.gtan.rms, 1.1 * r.hindsight.rms)
            and all(0.01 <= s <= 0.12 for s in shares)
            and r.smoother <= 1.5 * r.rts_hindsight
        )
        assert r.meets == expected
        assert np.isfinite(k.rms) and k.rms > 0.0
    # The page from the command line, on the rows just checked: main's evaluate is that call again (the same
    # scene, seed and designs), so it hands them back instead of running every design a second time.
    asked: list[tuple[Path, int]] = []

    def same_rows(path: Path, seeds: int, **_: object) -> list[heldout.Result]:
        asked.append((path, seeds))
        return results

    monkeypatch.setattr(heldout, "evaluate", same_rows)
    assert heldout.main([str(tmp_path / "trace.yaml"), "--seeds", "1", "--docs", str(tmp_path / "docs")]) == 0
    assert asked == [(tmp_path / "trace.yaml", 1)]
    page = (tmp_path / "docs" / "benchmarks" / "heldout.md").read_text()
    assert page.count("| trace | auto |") == len(results)
    assert (tmp_path / "docs" / "img" / "bench_heldout.png").stat().st_size > 0
    # A window without samples (a trace that never holds still has no steady stretch) reads "—", never nan.
    quiet = dataclasses.replace(
        results[0].kalman, beyond_steady=math.nan, eff_steady=math.nan, nees=math.nan, beyond3_steady=math.nan
    )
    empty = dataclasses.replace(results[0], kalman=quiet)
    for text in (heldout.line(empty), heldout.table([empty])):
        words = {w.strip("|,%()").lower() for w in text.split()}
        assert not words & {"nan", "+nan", "-nan", "inf"}, text
        assert "steady —" in text or "| — |" in text, text


def test_a_scene_that_does_not_load_stops_heldout_before_any_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Every scene is read before any design runs: a missing or malformed one (the last given, after a good
    one) is argparse's usage error, exit 2, one 'error:' line naming the file, no traceback and no page."""
    (tmp_path / "bad.yaml").write_text("x: [\n", encoding="utf-8")
    good = Path(heldout.__file__).parent.parent / "pendulum_accel" / "scenes" / "f1tenth_ds5_odom.yaml"
    cases = ((tmp_path / "missing.yaml", "scene file not found"), (tmp_path / "bad.yaml", "malformed"))
    for bad, said in cases:
        with pytest.raises(SystemExit) as stop:
            heldout.main([str(good), str(bad), "--seeds", "1", "--docs", str(tmp_path / "docs")])
        assert stop.value.code == 2
        err = capsys.readouterr().err
        errors = [line for line in err.splitlines() if "error:" in line]
        assert len(errors) == 1 and str(bad) in errors[0] and said in errors[0], err
        assert "Traceback" not in err and not (tmp_path / "docs").exists()
