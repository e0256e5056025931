"""Each benchmark's docs page: its tables and plots, the machine and the date, written by the script itself.

``write_page(name, title, tables, figures)`` writes ``docs/benchmarks/<name>.md`` and copies each plot
to ``docs/img/bench_<name>.png`` (``bench_<name>_2.png`` … for more), so no figure on the docs site is
ever typed by hand: rerunning ``python -m benchmarks.<name>`` rewrites its page.
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import platform
import shlex
import shutil
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

DOCS_DIR = Path(__file__).resolve().parent.parent / "docs"
"""The repository's docs/ (benchmarks/ is not installed, so it always sits beside it)."""


def add_docs_argument(parser: argparse.ArgumentParser) -> None:
    """``--docs DIR``: the docs tree the page and its plots go to (default the repository's docs/)."""
    parser.add_argument(
        "--docs",
        type=Path,
        default=DOCS_DIR,
        help="docs tree for the benchmark's page (default: the repository's docs/)",
    )


def count(text: str) -> int:
    """argparse type of a count (seeds, runs, bags, workers): an integer ≥ 1, else argparse's one-line usage
    error. A zero would run nothing and still rewrite the docs page with empty tables."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}")
    return value


def positive(text: str) -> float:
    """argparse type of a size (s, Hz, GiB, rad): a finite number > 0, else argparse's usage error."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number > 0, got {text!r}") from None
    if not (value > 0.0 and value < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {text!r}")
    return value


def cpu_model() -> str:
    """The CPU's model name from /proc/cpuinfo ('model name'), else platform.processor(), else 'unknown'."""
    try:
        for line in Path("/proc/cpuinfo").read_text(encoding="utf-8", errors="replace").splitlines():
            key, _, value = line.partition(":")
            if key.strip() == "model name" and value.strip():
                return value.strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def memory_gib() -> float | None:
    """MemTotal of /proc/meminfo in GiB (kB ÷ 2²⁰), or None where there is none."""
    try:
        for line in Path("/proc/meminfo").read_text(encoding="utf-8").splitlines():
            if line.startswith("MemTotal:"):
                return int(line.split()[1]) / 2**20
    except (OSError, ValueError, IndexError):
        pass
    return None


def machine_line() -> str:
    """'CPU model, N cores (os.cpu_count), M GiB RAM, Linux …, Python x.y.z': where the figures come from."""
    mem = memory_gib()
    parts = [cpu_model(), f"{os.cpu_count() or '?'} cores"]
    if mem is not None:
        parts.append(f"{mem:.0f} GiB RAM")
    parts += [f"{platform.system()} {platform.release()}", f"Python {platform.python_version()}"]
    return ", ".join(parts)


def command_line(name: str, argv: Sequence[str] | None = None) -> str:
    """'python -m benchmarks.<name> ARGS': the command that wrote the page (ARGS: argv, else sys.argv[1:])."""
    args = list(sys.argv[1:] if argv is None else argv)
    return shlex.join(["python", "-m", f"benchmarks.{name}", *args])


def write_page(
    name: str,
    title: str,
    markdown_tables: Sequence[str],
    figures: Sequence[tuple[Path, str]] = (),
    *,
    intro: str = "",
    docs: Path = DOCS_DIR,
    argv: Sequence[str] | None = None,
    when: dt.datetime | None = None,
) -> Path:
    """Write docs/benchmarks/<name>.md (title, intro, command, machine, date, tables, plots); return it.

    ``figures`` are (png path, caption) pairs; each is copied to docs/img/bench_<name>[_k].png.
    """
    when = when or dt.datetime.now(dt.UTC)
    img_dir, page_dir = docs / "img", docs / "benchmarks"
    img_dir.mkdir(parents=True, exist_ok=True)
    page_dir.mkdir(parents=True, exist_ok=True)
    lines = [f"# {title}", ""]
    if intro:
        lines += [intro.strip(), ""]
    lines += [
        f"Written by `{command_line(name, argv)}` on {when:%Y-%m-%d %H:%M} UTC.",
        "",
        f"Machine: {machine_line()}.",
        "",
    ]
    for table in markdown_tables:
        lines += [table.strip(), ""]
    for k, (png, caption) in enumerate(figures, start=1):
        target = img_dir / (f"bench_{name}.png" if k == 1 else f"bench_{name}_{k}.png")
        if Path(png).resolve() != target.resolve():
            shutil.copyfile(png, target)
        lines += [f"![{caption}](../img/{target.name})", ""]
    lines += [
        f"*This page is written by `python -m benchmarks.{name}`; rerun it to update the figures.*",
        "",
    ]
    page = page_dir / f"{name}.md"
    page.write_text("\n".join(lines), encoding="utf-8")
    return page


def new_axes(width: float, height: float) -> tuple[Any, Any]:
    """(figure, axes) of a ``width`` × ``height`` in. plot on matplotlib's Agg backend (no display)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.subplots(figsize=(width, height), constrained_layout=True)


def save_figure(fig: Any, out: Path) -> Path:
    """Write ``fig`` to ``out`` (PNG, 110 dpi, its folder made), close it, return ``out``."""
    import matplotlib.pyplot as plt

    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def bar_plot(
    out: Path,
    title: str,
    bars: Sequence[tuple[str, float]],
    xlabel: str,
    *,
    bound: tuple[float, str] | None = None,
    log: bool = False,
) -> Path:
    """One horizontal bar per (label, value), top to bottom in the given order, each value written at its
    end, and a dashed line at ``bound`` (value, label): the target or bound a benchmark sets its figures
    beside. With ``log`` a dot per value instead (a bar on a log axis starts nowhere, and its length would
    mislead). Written to ``out`` (PNG); non-finite values are left out (a bar of nothing)."""
    import math

    shown = [(label, value) for label, value in bars if math.isfinite(value)]
    fig, ax = new_axes(9.0, 0.45 * len(shown) + 1.6)
    positions = range(len(shown))
    values = [value for _, value in shown]
    if log:
        ax.plot(values, list(positions), "o", color="tab:blue")
    else:
        ax.barh(list(positions), values, color="tab:blue")
    ax.set_yticks(list(positions), [label for label, _ in shown], fontsize=8)
    ax.invert_yaxis()
    for k, (_, value) in enumerate(shown):
        ax.annotate(f" {value:.3g}", (value, k), va="center", fontsize=8)
    if bound is not None:
        ax.axvline(bound[0], ls="--", color="tab:red", label=bound[1])
        ax.legend(fontsize=8, loc="lower right")
    if log:
        ax.set_xscale("log")
    ax.margins(x=0.12)  # room for the values written at the ends
    ax.set_xlabel(xlabel)
    ax.set_title(title, fontsize=10)
    ax.grid(True, axis="x", which="both", alpha=0.3)
    return save_figure(fig, out)
