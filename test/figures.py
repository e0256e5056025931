"""Compare printed lines by their text and the numbers in them, never by a printed last digit.

A figure printed to d significant digits stands for any value within half a unit of its last digit; two
machines may print neighbouring last digits for the same quantity (3.7e-11 against 3.8e-11 when it is
3.75e-11 on one and 3.751e-11 on the other). :func:`assert_same_figures` therefore compares the words
exactly, integers exactly (counts, names such as rk4), and every decimal figure within the two half-units
of its printed last digit plus a stated relative tolerance for what the quantity itself may move. An
integer followed by a unit (``t = 17 s``, ``λ ≈ 0 1/s``) is a measured quantity that ``%g`` printed
without a point, so it is a figure too. :func:`assert_figure` checks one printed figure against a value.
"""

from __future__ import annotations

import math
import re

# A decimal figure: digits with a point and/or an exponent (integers are matched apart, exactly).
_NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?(?![\w.])")


def split_figures(text: str) -> tuple[str, list[str]]:
    """(text with every number replaced by '#', the numbers as printed, in order)."""
    numbers = _NUMBER.findall(text)
    return _NUMBER.sub("#", text), numbers


def half_unit(printed: str) -> float:
    """Half a unit of the printed last digit: 0.05e-11 for '3.8e-11', 0.005 for '9.92', 0.5 for '7'."""
    mantissa, _, exponent = printed.lower().partition("e")
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    return 0.5 * 10.0 ** (int(exponent or 0) - decimals)


# A unit after a number: the number is a quantity (s, ms, rad, rad/s, 1/s, Hz, m, m/s², N, °), not a count.
_UNIT = re.compile(r" ?(?:s|ms|rad|rad/s|1/s|Hz|m|m/s²|N|°)(?![\w/²])")


def is_integer(printed: str) -> bool:
    """A count or a name's digits (no point, no exponent): compared exactly."""
    return re.fullmatch(r"[-+]?\d+", printed) is not None


def _counts(text: str) -> list[bool]:
    """For each number in ``text``: True when it is compared exactly (an integer with no unit after it)."""
    return [is_integer(m.group()) and _UNIT.match(text, m.end()) is None for m in _NUMBER.finditer(text)]


def figure_after(text: str, label: str) -> str:
    """The number printed right after the first ``label`` in ``text`` (spaces between allowed)."""
    at = text.find(label)
    assert at >= 0, f"{label!r} not in {text!r}"
    pos = at + len(label)
    while text[pos : pos + 1] == " ":
        pos += 1
    found = _NUMBER.match(text, pos)
    assert found is not None, f"no number after {label!r} in {text!r}"
    return found.group()


def assert_figure(text: str, label: str, value: float, rel: float) -> None:
    """The figure after ``label`` is ``value`` within half a unit of its printed last digit + rel·|value|."""
    printed = figure_after(text, label)
    tol = half_unit(printed) + rel * abs(value)
    assert math.isclose(float(printed), value, rel_tol=0.0, abs_tol=tol), (
        f"{label}{printed} against {value!r} (± {tol:.2g}) in {text!r}"
    )


def assert_same_figures(got: str, want: str, rel: float, note: str = "") -> None:
    """Same words and integers; each decimal figure within half_unit(got) + half_unit(want) + rel·|want|."""
    got_text, got_numbers = split_figures(got)
    want_text, want_numbers = split_figures(want)
    assert got_text == want_text, f"{got!r} != {want!r} {note}"
    for g, w, exact in zip(got_numbers, want_numbers, _counts(want), strict=True):
        if exact and is_integer(g):
            assert g == w, f"{g} != {w} in {got!r} against {want!r} {note}"
            continue
        tol = half_unit(g) + half_unit(w) + rel * abs(float(w))
        assert math.isclose(float(g), float(w), rel_tol=0.0, abs_tol=tol), (
            f"{g} against {w} (± {tol:.2g}) in {got!r} against {want!r} {note}"
        )
