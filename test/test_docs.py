"""The docs site: it builds strictly, its reference pages match the code, its benchmark pages come from
the benchmark scripts, and the README is a short landing page that links to pages that exist."""

from __future__ import annotations

import argparse
import ast
import datetime as dt
import importlib
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from benchmarks import report
from pendulum_accel.cli.docs_reference import PAGES
from pendulum_accel.cli.main import COMMANDS, build_parser

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
README = ROOT / "README.md"
# Scripts under benchmarks/ that are helpers, not benchmarks.
# corpus: the profiles the benchmarks share; bare_rclpy: the ceiling benchmarks.chain puts on its page.
# Modules beside the scripts: the page writer, shared pieces (the corpus, the real-motion designs, scores and
# preset fits, the work-precision scenes) and bare_rclpy.
NOT_BENCHMARKS = {
    "__init__", "report", "reference", "corpus", "bare_rclpy",
    "motion_designs", "motion_scores", "fit_presets", "work_precision_cases",
}  # fmt: skip


def _nav_files(node: object) -> list[str]:
    """Every page path named in mkdocs.yml's nav (nested lists of {title: path or list})."""
    if isinstance(node, str):
        return [node]
    if isinstance(node, list):
        return [p for item in node for p in _nav_files(item)]
    if isinstance(node, dict):
        return [p for value in node.values() for p in _nav_files(value)]
    return []


def _config() -> dict[str, object]:
    """mkdocs.yml (plain YAML: it uses no !!python tags)."""
    loaded = yaml.safe_load((ROOT / "mkdocs.yml").read_text(encoding="utf-8"))
    assert isinstance(loaded, dict)
    return loaded


@pytest.mark.parametrize("name", sorted(PAGES))
def test_reference_page_matches_the_code(name: str) -> None:
    committed = (DOCS / "reference" / name).read_text(encoding="utf-8")
    assert committed == PAGES[name](), (
        f"docs/reference/{name} differs from what the code generates: run `make docs-reference`"
    )


def test_site_builds_strictly(tmp_path: Path) -> None:
    """mkdocs build --strict: a broken link, a missing page or a missing anchor fails it."""
    env = {**os.environ, "NO_MKDOCS_2_WARNING": "1"}
    result = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stdout + result.stderr
    assert (tmp_path / "site" / "reference" / "parameters" / "index.html").is_file()


def test_every_page_is_in_the_nav() -> None:
    """Every page is in the nav, except those under a folder mkdocs.yml's not_in_nav names (the lab's
    teacher material, served but kept out of what students browse)."""
    nav = set(_nav_files(_config()["nav"]))
    not_in_nav = str(_config().get("not_in_nav") or "")
    hidden = [line.strip().strip("/") + "/" for line in not_in_nav.splitlines() if line.strip()]
    pages = {p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md")}
    pages = {p for p in pages if not any(p.startswith(folder) for folder in hidden)}
    assert pages - nav == set(), "pages missing from mkdocs.yml's nav"
    assert nav - pages == set(), "nav entries without a page"


def test_every_benchmark_writes_its_own_page() -> None:
    """Each benchmarks/*.py calls report.write_page with its own name, and its page is in the nav."""
    nav = set(_nav_files(_config()["nav"]))
    scripts = sorted(p for p in (ROOT / "benchmarks").glob("*.py") if p.stem not in NOT_BENCHMARKS)
    assert scripts
    for script in scripts:
        names = [
            node.args[0].value
            for node in ast.walk(ast.parse(script.read_text(encoding="utf-8")))
            if isinstance(node, ast.Call)
            and isinstance(node.func, ast.Attribute)
            and node.func.attr == "write_page"
            and node.args
            and isinstance(node.args[0], ast.Constant)
        ]
        assert names == [script.stem], (
            f"{script.name} must write its page with write_page({script.stem!r}, …)"
        )
        assert f"benchmarks/{script.stem}.md" in nav


def _benchmark_size_options() -> list[tuple[str, str]]:
    """(benchmark, option) of every add_argument whose type is report.count or report.positive, read from the
    scripts themselves, so an option added later is tested without a list to keep."""
    found = []
    for script in sorted((ROOT / "benchmarks").glob("*.py")):
        for node in ast.walk(ast.parse(script.read_text(encoding="utf-8"))):
            if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)):
                continue
            kind = next((k.value for k in node.keywords if k.arg == "type"), None)
            sized = isinstance(kind, ast.Attribute) and kind.attr in ("count", "positive")
            if node.func.attr == "add_argument" and sized and isinstance(node.args[0], ast.Constant):
                found.append((script.stem, str(node.args[0].value)))
    return found


BENCHMARK_SIZE_OPTIONS = _benchmark_size_options()
"""Every count (report.count) and size (report.positive) option of the benchmarks."""


@pytest.mark.parametrize(("name", "option"), BENCHMARK_SIZE_OPTIONS)
def test_a_benchmark_refuses_a_zero_count_or_size_before_it_writes_its_page(
    name: str, option: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """0 seeds, runs or seconds would run nothing and still rewrite the docs page with empty tables:
    argparse's usage error instead (exit 2, one 'error:' line naming the option), and no page written."""
    module = importlib.import_module(f"benchmarks.{name}")
    extra = ["scene.yaml"] if name == "heldout" else []  # its one positional argument
    with pytest.raises(SystemExit) as stop:
        module.main([*extra, option, "0", "--docs", str(tmp_path / "docs")])
    assert stop.value.code == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if "error:" in line]
    assert len(errors) == 1 and f"argument {option}" in errors[0] and "got '0'" in errors[0], errors
    assert not (tmp_path / "docs").exists()


def test_the_benchmark_argument_types_take_what_they_name() -> None:
    """count: an integer >= 1; positive: a finite number > 0; each refuses the rest as a usage error."""
    assert report.count("3") == 3 and report.positive("0.25") == 0.25 and report.positive("1e3") == 1000.0
    for bad in ("0", "-1", "2.5", "x", ""):
        with pytest.raises(argparse.ArgumentTypeError):
            report.count(bad)
    for bad in ("0", "-0.1", "nan", "inf", "x"):
        with pytest.raises(argparse.ArgumentTypeError):
            report.positive(bad)


def test_write_page_records_the_machine_the_date_and_the_plot(tmp_path: Path) -> None:
    png = tmp_path / "plot.png"
    png.write_bytes(b"\x89PNG\r\n\x1a\nnot a real image")
    when = dt.datetime(2026, 1, 2, 3, 4, tzinfo=dt.UTC)
    page = report.write_page(
        "demo_bench", "Demo", ["| a | b |\n|---|---|\n| 1 | 2 |"], [(png, "a plot")],
        docs=tmp_path / "docs", argv=["--quick"], when=when,
    )  # fmt: skip
    text = page.read_text(encoding="utf-8")
    assert page == tmp_path / "docs" / "benchmarks" / "demo_bench.md"
    assert text.startswith("# Demo\n")
    assert "`python -m benchmarks.demo_bench --quick` on 2026-01-02 03:04 UTC" in text
    assert f"Machine: {report.machine_line()}." in text and f"{os.cpu_count()} cores" in text
    assert "| 1 | 2 |" in text and "![a plot](../img/bench_demo_bench.png)" in text
    assert (tmp_path / "docs" / "img" / "bench_demo_bench.png").read_bytes() == png.read_bytes()


def test_readme_is_a_short_landing_page() -> None:
    """≤ 200 lines; the two commands CI and a newcomer run; every subcommand named; its links resolve."""
    text = README.read_text(encoding="utf-8")
    assert len(text.splitlines()) <= 200
    assert "make test" in text and "make demo" in text  # .ci/run runs `make test`
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    assert sub.choices is not None
    names = set(sub.choices)
    assert len(names) == len(COMMANDS)
    missing = sorted(n for n in names if f"`{n}`" not in text)
    assert missing == [], f"README names no line for these subcommands: {missing}"
    for target in re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", text):
        if "://" not in target:
            assert (ROOT / target).exists(), f"README links to a missing file: {target}"
    assert (ROOT / "CHANGELOG.md").is_file()
