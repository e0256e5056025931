"""No benchmark figure is typed by hand: every µs/sample, ×-ratio and RMS (m/s²) figure on a docs page
is one that a generated benchmark page holds.

The benchmark scripts write their figures onto docs/benchmarks/*.md (benchmarks/report.py). Any other
page, and the README, may quote those figures or link the page, never type figures of its own: a typed
figure goes stale at the next benchmark run. Generated pages are not checked: docs/benchmarks/ itself,
docs/reference/ (written by `make docs-reference`) and the lab's teacher key (filled in from a fresh
computation by lab_teacher/key.py; it lives outside docs/).

A figure is of one kind (µs/sample, ×-ratio, RMS m/s²) by its unit, by its table column's header, or by
its table's caption, and it must be held by a benchmark figure of the same kind. Figures are compared
as numbers, never as text: a figure printed to its last digit stands for any value within half a unit
of that digit (test.figures.half_unit), so a docs figure d is held by a benchmark figure b when
|d − b| ≤ half_unit(d) + half_unit(b): the two printed values can be the same number.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import pytest

from test.figures import half_unit

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
BENCHMARK_PAGES = DOCS / "benchmarks"
# Pages generated from the code: their figures are computed, not typed.
GENERATED = (DOCS / "benchmarks", DOCS / "reference", DOCS / "lab" / "teacher")

US, RATIO, RMS = "µs/sample", "×-ratio", "RMS m/s²"
# A printed figure: digits, an optional decimal part and exponent, not glued to a word or to more digits.
NUM = r"(?<![\w.])\d+(?:\.\d+)?(?:[eE][-+]?\d+)?(?![\w]|\.\d)"
# Figures chained before one unit: "0.95–1.07×", "0.120 / 0.039 / 0.090 m/s²", "1.9 against 3.7 µs/sample".
SEP = r"\s?(?:[–\-/→]|to|and|or|against)\s?"
CHAIN = rf"(?P<chain>{NUM}(?:{SEP}{NUM})*)"
UNITS = {
    US: re.compile(CHAIN + r"\s?(?:µs|μs|us)\s?(?:/|per)\s?sample"),
    # "1.07×" and "2x", but not a size such as 3×3 or "1 × 0.6 × 0.2 m".
    RATIO: re.compile(CHAIN + r"[×x](?!\w|\s?\d)"),
    # m/s² (not mm/s², not (m/s²)²/s): an RMS figure when its sentence says RMS.
    RMS: re.compile(CHAIN + r"\s?m/s(?:²|\^2)(?![\w³)])"),
}
RMS_WORD = re.compile(r"\bRMS\b|(?<![a-z])rms(?![a-z])", re.IGNORECASE)
# A sentence ends at '.', ';' or ':' before a space or the end (a decimal point never has one after it).
SENTENCE = re.compile(r"(?:[^.;:]|[.;:](?!\s|$))+")
# In a table cell: a figure followed by another unit (a share, a time, a rate, a length) is not the
# column's kind; one followed by × is a ratio whatever the column.
OTHER_UNIT = r"(?!\s?(?:%|s\b|ms\b|Hz\b|m\b|rad\b|MiB\b|MB\b|kB\b|°|×))"
FENCE = re.compile(r"^\s*(```|~~~)")


@dataclass(frozen=True)
class Rules:
    """How a table column's header names its figures' kind, and whether a sentence that gives a ×
    figure makes each of its figures a ratio (a benchmark page's targets line: '1.02× (target ≤ 1.1)')."""

    us_header: re.Pattern[str]
    ratio_header: re.Pattern[str]
    rms_header: re.Pattern[str]
    ratio_sentences: bool


# A docs page: a column is a ratio only when it says so (its cells' × figures are found by their unit);
# an RMS column that divides ("RMS / hindsight EKF") holds ratios, not RMS in m/s².
DOCS_RULES = Rules(
    us_header=re.compile(r"[µμu]s(?:/| per |_per_)sample"),
    ratio_header=re.compile(r"ratio|×", re.IGNORECASE),
    rms_header=re.compile(r"^(?!.*/)(?:.*\bRMS\b|.*(?<![a-z])rms(?![a-z]))", re.IGNORECASE),
    ratio_sentences=False,
)
# A benchmark page: every way its scripts head a ratio ("ratio", "x real time", "speed-up",
# "ss_over_crb", "/ hindsight EKF").
BENCHMARK_RULES = Rules(
    us_header=re.compile(r"[µμu]s(?:/| per |_per_)sample"),
    ratio_header=re.compile(r"ratio|×|\bx\b|speed-up|_over_|/", re.IGNORECASE),
    rms_header=RMS_WORD,
    ratio_sentences=True,
)


@dataclass(frozen=True)
class Figure:
    """One figure as printed on a page, with where it stands and what kind it is."""

    page: str
    line: int
    kind: str
    printed: str

    @property
    def value(self) -> float:
        return float(self.printed)

    def __str__(self) -> str:
        return f"{self.page}:{self.line}: {self.printed} ({self.kind})"


def checked_pages() -> list[Path]:
    """README.md and every docs page that is not generated."""
    pages = [p for p in sorted(DOCS.rglob("*.md")) if not any(p.is_relative_to(g) for g in GENERATED)]
    return [ROOT / "README.md", *pages]


def blocks(text: str) -> list[tuple[int, str, list[str]]]:
    """The page's blocks as (first line number, kind, lines), kind 'text', 'table' or 'code': split at
    blank lines and at the edges of tables and fences (code is kept: a sample output is typed too)."""
    out: list[tuple[int, str, list[str]]] = []
    current: list[str] = []
    start, kind, in_fence = 0, "", False
    for number, line in enumerate(text.splitlines(), start=1):
        if FENCE.match(line):
            if current:
                out.append((start, kind, current))
            current, start, kind, in_fence = [], number + 1, "code", not in_fence
            continue
        line_kind = "code" if in_fence else "table" if line.lstrip().startswith("|") else "text"
        if (not line.strip() and not in_fence) or line_kind != kind:
            if current:
                out.append((start, kind, current))
            current, start, kind = [], number, line_kind
            if not line.strip():
                continue
        current.append(line)
    if current:
        out.append((start, kind, current))
    return out


def _cells(row: str) -> list[str]:
    """A table row's cells ('| a | b \\| c |' → ['a', 'b \\| c']): split at every pipe not escaped."""
    return [c.strip() for c in re.split(r"(?<!\\)\|", row.strip().removeprefix("|").removesuffix("|"))]


def column_kind(header: str, caption_rms: bool, first: bool, rules: Rules) -> str | None:
    """The kind a column's header names; else RMS for every column but the first (the row's label)
    under a caption that gives RMS in m/s²."""
    if rules.us_header.search(header):
        return US
    if rules.ratio_header.search(header):
        return RATIO
    if rules.rms_header.search(header):
        return RMS
    return RMS if caption_rms and not first else None


def table_figures(page: str, first: int, rows: list[str], caption: str, rules: Rules) -> list[Figure]:
    """Figures in the columns whose header (or the table's caption) names a kind; the separator row is
    skipped."""
    caption_rms = bool(RMS_WORD.search(caption)) and "m/s²" in caption
    header = _cells(rows[0])
    kinds = [column_kind(h, caption_rms, i == 0, rules) for i, h in enumerate(header)]
    found = []
    for offset, row in enumerate(rows[2:], start=2):
        for kind, cell in zip(kinds, _cells(row), strict=False):
            if kind is None:
                continue
            for chain in re.finditer(CHAIN, cell):  # "505–1369 s" is a time span, both ends of it
                if re.match(OTHER_UNIT, cell[chain.end() :]):
                    for number in re.finditer(NUM, chain.group()):
                        found.append(Figure(page, first + offset, kind, number.group()))
    return found


def text_figures(page: str, first: int, lines: list[str], rules: Rules) -> list[Figure]:
    """Figures written with their unit (an m/s² figure counts only in a sentence that says RMS); on a
    benchmark page, every figure of a sentence that gives a ratio."""
    text = "\n".join(lines)
    starts = [m.start() for m in re.finditer(r"^", text, re.MULTILINE)]

    def line_of(at: int) -> int:
        return first + sum(1 for s in starts if s <= at) - 1

    found = []
    for sentence in SENTENCE.finditer(text):
        for kind, unit in UNITS.items():
            if kind == RMS and not RMS_WORD.search(sentence.group()):
                continue
            matches = list(unit.finditer(sentence.group()))
            for match in matches:
                at = sentence.start() + match.start("chain")
                for number in re.finditer(NUM, match.group("chain")):
                    found.append(Figure(page, line_of(at), kind, number.group()))
            if kind == RATIO and matches and rules.ratio_sentences:
                for number in re.finditer(NUM, sentence.group()):
                    at = sentence.start() + number.start()
                    found.append(Figure(page, line_of(at), kind, number.group()))
    return found


def page_figures(path: Path, root: Path = ROOT, rules: Rules = DOCS_RULES) -> list[Figure]:
    """Every µs/sample, ×-ratio and RMS figure the page gives, once per (line, kind, printed)."""
    page = path.relative_to(root).as_posix()
    found: list[Figure] = []
    caption = ""
    for first, kind, lines in blocks(path.read_text(encoding="utf-8")):
        if kind == "table" and len(lines) > 1:
            found += table_figures(page, first, lines, caption, rules)
        found += text_figures(page, first, lines, rules)
        caption = " ".join(lines) if kind == "text" else ""
    return sorted(set(found), key=lambda f: (f.line, f.kind, f.printed))


def benchmark_figures() -> dict[str, list[Figure]]:
    """Every figure of each kind on the generated benchmark pages."""
    by_kind: dict[str, list[Figure]] = {US: [], RATIO: [], RMS: []}
    for path in sorted(BENCHMARK_PAGES.glob("*.md")):
        for figure in page_figures(path, rules=BENCHMARK_RULES):
            by_kind[figure.kind].append(figure)
    return by_kind


def held(figure: Figure, sources: dict[str, list[Figure]]) -> bool:
    """Some benchmark figure b of the same kind has |d − b| ≤ half_unit(d) + half_unit(b)."""
    half = half_unit(figure.printed)
    return any(abs(figure.value - b.value) <= half + half_unit(b.printed) for b in sources[figure.kind])


SAMPLE_PAGE = (
    "kalman costs 3.7–3.9 µs/sample (instant 1.9 against 3.7 µs per sample).\n"          # 1
    "It is within 0.95–1.07× of the bound. A 3×3 matrix, a 1 × 0.6 m box, ×4 for safety.\n"  # 2
    "The RMS is 0.120 / 0.039 m/s² over\n"                                              # 3
    "the scenes. A step of 3 m/s² comes first; 10 mm/s² RMS of noise.\n"                # 4
    "\n"
    "| scene | RMS (m/s²) | beyond 2σ | µs/sample | RMS / bound |\n"                     # 6
    "|---|---|---|---|---|\n"
    "| step | 0.160 | 25.6 % | 20.5–34.7 | 1.3× |\n"                                   # 8
    "\n"
    "```\n"
    "estimate: RMS 0.0458 m/s²\n"                                                       # 11
    "```\n"
    "Validation figures (RMS m/s²):\n"                                                  # 13
    "\n"
    "| profile | kalman | ratio |\n"                                                   # 15
    "|---|---|---|\n"
    "| UDDS 505–1369 s | 0.0250 | 1.02 |\n"                                             # 17
    "| Husky | 0.0511, 200–395 s | 0.97 |\n"                                           # 18
)  # fmt: skip


def test_the_scanner_finds_each_kind_of_figure(tmp_path: Path) -> None:
    """Figures in prose, chains, tables, captions and code are found; sizes, factors, a step of a,
    mm/s² and shares are left alone."""
    page = tmp_path / "page.md"
    page.write_text(SAMPLE_PAGE, encoding="utf-8")
    got = {(f.line, f.kind, f.printed) for f in page_figures(page, tmp_path)}
    assert got == {
        (1, US, "3.7"), (1, US, "3.9"), (1, US, "1.9"),
        (2, RATIO, "0.95"), (2, RATIO, "1.07"),
        (3, RMS, "0.120"), (3, RMS, "0.039"),
        (8, RMS, "0.160"), (8, US, "20.5"), (8, US, "34.7"), (8, RATIO, "1.3"),
        (11, RMS, "0.0458"),
        (17, RMS, "0.0250"), (17, RATIO, "1.02"), (18, RMS, "0.0511"), (18, RATIO, "0.97"),
    }  # fmt: skip


def test_a_ratio_sentence_on_a_benchmark_page_holds_its_targets(tmp_path: Path) -> None:
    """'kalman RMS ≤ 1.02× ekf_hindsight (target ≤ 1.1)': 1.1 is a ratio on a benchmark page."""
    page = tmp_path / "bench.md"
    page.write_text("- teaching: kalman RMS ≤ 1.02× ekf_hindsight (target ≤ 1.1); beyond 2σ 4.5 %.\n")
    got = {f.printed for f in page_figures(page, tmp_path, BENCHMARK_RULES) if f.kind == RATIO}
    assert {"1.02", "1.1"} <= got


def test_held_compares_at_the_printed_precision() -> None:
    """4.0 is held by 4.03 (4.0 stands for 3.95–4.05), 3.7 is not; 0.0250 is held by 0.025; a figure
    of another kind holds nothing."""
    sources = {US: [Figure("b", 1, US, "4.03")], RATIO: [], RMS: [Figure("b", 2, RMS, "0.025")]}
    assert held(Figure("p", 1, US, "4.0"), sources)
    assert not held(Figure("p", 1, US, "3.7"), sources)
    assert held(Figure("p", 1, RMS, "0.0250"), sources)
    assert not held(Figure("p", 1, RMS, "0.0260"), sources)
    assert not held(Figure("p", 1, RATIO, "4.0"), sources)


def test_the_benchmark_pages_give_figures_of_every_kind() -> None:
    """The pages the docs are checked against hold each kind (else every check below would fail)."""
    sources = benchmark_figures()
    assert all(sources[kind] for kind in (US, RATIO, RMS)), {k: len(v) for k, v in sources.items()}


@pytest.mark.parametrize(
    "path", [ROOT / "README.md", *sorted(DOCS.rglob("*.md"))], ids=lambda p: p.relative_to(ROOT).as_posix()
)
def test_every_table_has_as_many_header_cells_as_columns(path: Path) -> None:
    """A header with a bare pipe in a cell (max |e|) has more cells than its delimiter row: the page then
    shows the table as a paragraph of pipes, and its columns cannot be read by kind."""
    for first, kind, lines in blocks(path.read_text(encoding="utf-8")):
        if kind == "table" and len(lines) > 1:
            assert len(_cells(lines[0])) == len(_cells(lines[1])), f"{path.name}:{first}: {lines[0]}"


@pytest.mark.parametrize("path", checked_pages(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_every_benchmark_figure_on_the_page_is_on_a_benchmark_page(path: Path) -> None:
    sources = benchmark_figures()
    stray = [str(f) for f in page_figures(path) if not held(f, sources)]
    assert stray == [], (
        "figures typed by hand that no generated benchmark page holds (quote the page, include its "
        "table, or drop the figure and link the page):\n" + "\n".join(stray)
    )


def test_the_default_is_the_live_method_of_least_rms_on_every_real_motion_cell() -> None:
    """The default's claim (DEFAULT_ESTIMATOR's comment; docs/estimators.md: 'lowest RMS of the live methods
    on every validation cell') holds on docs/benchmarks/real_motion.md: per design × profile, of the live
    methods' RMS rows, compared as numbers, the default's is the least; the run summary's reason names the
    page and quotes no tally of it."""
    from pendulum_accel.estimators import DEFAULT_ESTIMATOR, DEFAULT_REASON, LIVE_ESTIMATORS

    assert "docs/benchmarks/real_motion.md" in DEFAULT_REASON
    rms: dict[tuple[str, str], dict[str, float]] = {}
    for line in (BENCHMARK_PAGES / "real_motion.md").read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) > 3 and cells[2] in LIVE_ESTIMATORS:
            rms.setdefault((cells[0], cells[1]), {})[cells[2]] = float(cells[3])
    best = {cell: min(by_method, key=by_method.__getitem__) for cell, by_method in rms.items()}
    assert len(best) > 0
    assert {cell: m for cell, m in best.items() if m != DEFAULT_ESTIMATOR} == {}
