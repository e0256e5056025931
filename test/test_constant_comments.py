"""A module-level constant's words say what it is and where it was fitted, never a measured figure.

The figures a constant was fitted to live on the page its benchmark script writes (docs/benchmarks/): a
comment that quotes them goes stale the next time the page is regenerated, and nothing checks it.

What is read, for every module-level UPPER_CASE name (``NAME = …`` or ``NAME: T = …``, a leading ``_``
too) of pendulum_accel/, lab_teacher/ and launch_scripts/: the comments on its own lines (trailing, or
inside a multi-line value), the comment lines directly above it (up to a blank line or code), the string
statement right after it (an attribute docstring), and its value when that is a sentence (a message a
user reads, such as the run summary's DEFAULT_REASON). Comments come from ``tokenize``, so a ``#`` inside
a string is not one.

The rule (``measured_figures``) is built to be precise: it flags what only a run can produce, in the
shapes the package's history shows, and says nothing of a number whose context does not settle it. Per
clause (text between ``.``, ``;`` or ``:`` and a space, so a figure is judged with its own words):

1. **a tally**, ``N of M`` / ``N of the M`` (``65 of the 65 cells``, ``2 of 23 runs``): a count of
   outcomes is a result;
2. **a number soon after a word of evidence** (``measured``, ``was``/``were``, ``took``/``takes``,
   ``gave``, ``observed``, ``scored``, ``benchmarked``; at most 30 characters on): ``measured up to 17×``,
   ``1/8 was 4× loose``. "Soon after" lets ``the measured angle``, a quantity of the domain, through;
3. **a statistic's value**: RMS, NEES, χ²/dof, a percentile (p50…p99), peak RSS or RTF followed by a
   number (``χ²/dof 0.2–2.7``, ``p99 latency from 4–124 ms``), which only an evaluation gives;
4. **a ratio or a cost**, a number followed by ``×``/``x`` (``~1.5x``; not a size ``512 × 384``), by a
   time unit of computing (ms, µs, ns; ``s of work``) or a throughput (``12 M trajectory-steps/s``),
   unless the clause states a criterion (within, ≤, <, at most, target, up to, beyond, than, under,
   below, above): ``within 5 % of the least RMS`` says how a value was picked, ``4× loose`` how a
   candidate fared;
5. **a decimal of three or more significant digits** (``0.904``, ``4.55``) that no formula gives:
   a number right after ``=``, ``≈``, an operator or an opening bracket is computed
   (``σ_floor = 0.664 B``, ``Φ⁻¹(0.975)``, ``e^(−56.6)``); one printed bare to three digits rounds a
   result.

Never a figure: the constant's own value restated (any number its value's literals hold, so
``MARGIN = 1.5  # 1.5× the …`` defines it), a σ multiple (``2σ``), a standard's number (``REP-103``,
``REP 105``, ``PEP 562``, ``ISO 8601``, ``RFC 3339``, ``IEEE 754``), a year (as in ``CGPM 1901``), a
version, an identifier's digits (``rk4``, ``float64``), units in brackets (``[m/s²]`` holds no number).
Left alone on purpose, because definitions use them as often as results: percentages (a tolerance
``1 % of a``, a ``10 % grade``, a ``95 %`` point), memory sizes (``400 MB per array`` is MAX_SAMPLES × 8
bytes), integers without a unit, and the units of a design (Hz, m, rad, s: ``the first 60 s`` or
``a 1 kHz chain`` define an experiment, they do not report one). A result in those shapes alone is left
to review.

test_the_rule_* below pin each side of the rule on examples taken from the package's history.
"""

from __future__ import annotations

import ast
import io
import re
import tokenize
from collections.abc import Set as AbstractSet
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SOURCES = sorted(
    [
        *(ROOT / "pendulum_accel").rglob("*.py"),
        *(ROOT / "lab_teacher").glob("*.py"),
        *(ROOT / "launch_scripts").glob("*.py"),
    ]
)
CONSTANT = re.compile(r"^_?[A-Z][A-Z0-9_]*$")
# A string value that is prose (three words in a row), not a name, a pattern or a table of numbers.
PROSE = re.compile(r"[A-Za-z]{2,} [A-Za-z]{2,} [A-Za-z]{2,}")

# A number as written in prose: 4, 0.904, 1e-3, 1/8 (each side a number), not a digit glued to a word.
NUMBER = r"(?<![\w.\-/])(?:\d+(?:\.\d+)?(?:[eE][-+]?\d+)?)(?![\w.]\d|[A-Za-z_]\w)"
NUMBER_RE = re.compile(NUMBER)
CLAUSE = re.compile(r"(?:[^.;:]|[.;:](?!\s|$))+")
# Rule 1: a tally.
TALLY = re.compile(rf"{NUMBER}\s+of\s+(?:the\s+)?{NUMBER}")
# Rule 2: a word of evidence with a number after it in its clause (close: "the measured angle" is a quantity).
EVIDENCE = re.compile(
    rf"\b(?:measured|measuring|was|were|took|takes|gave|observed|scored|benchmarked)\b[^.;:]{{0,30}}?{NUMBER}",
    re.I,
)
# Rule 3: a statistic's value (RMS 0.31, χ²/dof 0.2–2.7, p99 4 ms, NEES of 1.2, peak RSS 220).
STATISTIC = re.compile(
    r"(?:\bRMS|\bNEES|χ²/dof|\bp(?:50|90|95|99)\b[^.;:\d]{0,20}|\bpeak RSS|\bRTF)"
    rf"\s*(?:of\s+|=\s*|:\s*|is\s+)?{NUMBER}"
)
# Rule 4: a ratio (0.9×, 4x; not a size 512 × 384), a cost in time or a throughput.
RATIO = re.compile(rf"{NUMBER}\s?(?:×|x)(?![\w\d]|\s?\d)")
COST = re.compile(
    rf"{NUMBER}\s?(?:ms|µs|μs|us|ns)\b|{NUMBER}\s?s of (?:work|CPU|wall)"
    rf"|{NUMBER}\s?[kM]?\s?(?:[\w-]*steps|samples|messages|msgs)/s"
)
CRITERION = re.compile(
    r"within|≤|≥|<|>|at most|at least|target|up to|beyond|\bthan\b|\bunder\b|\bbelow\b|\babove\b",
    re.I,
)
# Rule 5: a decimal of three or more significant digits, unless a formula gives it (after =, ≈, an operator
# or an opening bracket: σ_floor = 0.664 B, Φ⁻¹(0.975), e^(−56.6)).
PRECISE = re.compile(rf"(?<![=≈(−\-+^·*/]\s)(?<![=≈(−\-+^·*/]){NUMBER}")
# Digits that are a name, not a quantity.
NOT_A_FIGURE = re.compile(
    r"\b(?:REP|PEP|ISO|RFC|IEEE|IEC)[\s\-]?\d+"  # a standard's number
    r"|\b(?:19|20)\d\d\b"  # a year
    r"|\bv?\d+\.\d+\.\d+\b|\bPython\s+\d\.\d+"  # a version
    r"|\d+σ"  # a σ multiple
)


def significant_digits(number: str) -> int:
    """Digits of a printed number from its first non-zero one, exponent left out: '0.904' → 3, '124' → 3."""
    mantissa = re.split(r"[eE]", number)[0].replace(".", "").lstrip("0")
    return len(mantissa)


def own_values(value: ast.expr | None) -> set[float]:
    """The numbers the constant's value is written with (its literals, and -x for each)."""
    out: set[float] = set()
    for node in ast.walk(value) if value is not None else ():
        literal = node.value if isinstance(node, ast.Constant) else None
        if isinstance(literal, (int, float)) and not isinstance(literal, bool):
            out |= {float(literal), -float(literal)}
    return out


def _is_own(printed: str, own: AbstractSet[float]) -> bool:
    """True when the first number of ``printed`` restates one of the constant's own values."""
    number = NUMBER_RE.search(printed)
    return number is not None and float(number.group(0)) in own


def measured_figures(text: str, own: AbstractSet[float] = frozenset()) -> list[str]:
    """The figures in ``text`` that can only have come from a run (the module docstring's rules 1-5)."""
    found: list[str] = []
    for clause in (m.group(0) for m in CLAUSE.finditer(NOT_A_FIGURE.sub(" ", text))):
        hits = [m.group(0) for m in TALLY.finditer(clause)]
        hits += [m.group(0) for m in EVIDENCE.finditer(clause)]
        hits += [m.group(0) for m in STATISTIC.finditer(clause)]
        if CRITERION.search(clause) is None:
            hits += [m.group(0) for m in RATIO.finditer(clause)] + [m.group(0) for m in COST.finditer(clause)]
        hits += [
            m.group(0)
            for m in PRECISE.finditer(clause)
            if "." in m.group(0) and significant_digits(m.group(0)) >= 3
        ]
        found += [hit for hit in hits if not _is_own(hit, own)]
    return sorted(set(found))


@dataclass(frozen=True)
class ConstantText:
    """A module-level constant and the words written about it."""

    where: str
    name: str
    text: str
    own: frozenset[float]


def _string_value(value: ast.expr) -> str | None:
    """The text of a string constant, of implicitly or +-joined literals; None for any other value."""
    if isinstance(value, ast.Constant):
        return value.value if isinstance(value.value, str) else None
    if isinstance(value, ast.BinOp) and isinstance(value.op, ast.Add):
        left, right = _string_value(value.left), _string_value(value.right)
        return None if left is None or right is None else left + right
    return None


def constant_texts(path: Path) -> list[ConstantText]:
    """Every module-level UPPER_CASE constant of ``path`` with its comments and attribute docstring."""
    source = path.read_text(encoding="utf-8")
    lines = source.splitlines()
    comments: dict[int, str] = {}
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.COMMENT:
            comments[token.start[0]] = token.string.lstrip("#").strip()
    body = ast.parse(source).body
    out: list[ConstantText] = []
    for i, node in enumerate(body):
        if isinstance(node, ast.Assign) and len(node.targets) == 1:
            target: ast.expr = node.targets[0]
        elif isinstance(node, ast.AnnAssign):
            target = node.target
        else:
            continue
        if not (isinstance(target, ast.Name) and CONSTANT.match(target.id)):
            continue
        end = node.end_lineno or node.lineno
        parts = [comments[n] for n in range(node.lineno, end + 1) if n in comments]
        above = node.lineno - 1
        preceding: list[str] = []
        while above >= 1 and above in comments and lines[above - 1].lstrip().startswith("#"):
            preceding.insert(0, comments[above])
            above -= 1
        parts = preceding + parts
        if isinstance(node.value, (ast.Constant, ast.JoinedStr, ast.BinOp)):
            message = _string_value(node.value)
            if message is not None and PROSE.search(message):  # a sentence a user reads (DEFAULT_REASON)
                parts.append(message)
        nxt = body[i + 1] if i + 1 < len(body) else None
        if (
            isinstance(nxt, ast.Expr)
            and isinstance(nxt.value, ast.Constant)
            and isinstance(nxt.value.value, str)
        ):
            parts.append(nxt.value.value)
        where = f"{path.relative_to(ROOT)}:{node.lineno}"
        out.append(ConstantText(where, target.id, " ".join(parts), frozenset(own_values(node.value))))
    return out


ALL_CONSTANTS = [c for path in SOURCES for c in constant_texts(path)]


def test_no_constant_comment_quotes_a_measured_figure() -> None:
    offenders = [
        f"{c.where} {c.name}: {', '.join(found)}"
        for c in ALL_CONSTANTS
        if (found := measured_figures(c.text, c.own))
    ]
    assert offenders == [], (
        "say what the constant is and which benchmark page or script fitted it; the figures belong on "
        "that page:\n" + "\n".join(offenders)
    )


def test_the_reader_sees_the_constants_and_their_words() -> None:
    """The scan finds constants, their trailing and preceding comments and attribute docstrings."""
    sample = (
        "A = 1\n"
        "# above B, line one\n"
        "# above B, line two\n"
        "B: float = 2.0  # trailing\n"
        '"""B\'s docstring."""\n'
        "\n"
        "# far above: a blank line between\n"
        "\n"
        'C = {"x": 1}  # "#" inside a string is no comment\n'
        "lower = 3  # not a constant\n"
    )
    path = ROOT / "test" / "_constant_sample.py"
    try:
        path.write_text(sample, encoding="utf-8")
        found = {c.name: c.text for c in constant_texts(path)}
    finally:
        path.unlink()
    assert found == {
        "A": "",
        "B": "above B, line one above B, line two trailing B's docstring.",
        "C": '"#" inside a string is no comment',
    }


@pytest.mark.parametrize(
    "text",
    [
        "the pendulum EKF (IMM): lowest RMS of the live methods on 65 of the 65 real-motion validation cells",
        "each of the n argument doublings adds this share (measured: 1/8 was 4× loose)",
        "its own rounding was measured up to 17× that of the h run",
        "took the 1 kHz chain's p99 latency from 4–124 ms to 0.7–37 ms",
        "relative to the random walks alone: 0.904, 0.897 and 0.895 on teaching",
        "the streaming update costs 1.9 µs per sample",
        "the smoother is 0.9× the filter's RMS on braking",
    ],
)
def test_the_rule_flags_a_measured_figure(text: str) -> None:
    assert measured_figures(text) != []


@pytest.mark.parametrize(
    ("text", "own"),
    [
        ("m/s², standard gravity (CGPM 1901)", {9.80665}),
        ("the car frame of REP-103 and the frames of REP 105", set()),
        ("a share of errors beyond 2σ, steady and after changes", set()),
        ("× ε (Θ + 2kω span): the closed form's round-off, fitted by benchmarks/error_bounds.py", {2.0}),
        ("of the candidates within 5 % of the least RMS, the best calibrated", set()),
        ("teaching design: l = 1 m, 100 Hz; short damped l = 5 cm, 200 Hz, the first 60 s, seed 0", set()),
        ("[m/s²] the acceleration's unit; 1.5× the filter's σ", {1.5}),
        ("rk4 and rk8 on float64 arrays (Python 3.11)", set()),
        ("a timeout of at most 50 ms before the node gives up", set()),
    ],
)
def test_the_rule_lets_a_definition_through(text: str, own: set[float]) -> None:
    assert measured_figures(text, own) == []
