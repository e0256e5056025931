"""test.figures: printed lines compared by words, integers and figures within their printed half-units."""

from __future__ import annotations

import pytest

from test.figures import assert_figure, assert_same_figures, figure_after, half_unit, split_figures

LINE = "plan: rigid model, rk4 (dt = 0.005 s), error 3.8e-11 rad (400 steps) at t = 9.92 s"


def test_split_keeps_names_and_finds_every_figure() -> None:
    """rk4 and θ0 stay words; each standalone number is a figure, in order."""
    text, numbers = split_figures(LINE + ", θ0")
    assert numbers == ["0.005", "3.8e-11", "400", "9.92"]
    assert "rk4" in text and "θ0" in text


def test_half_unit_of_the_last_printed_digit() -> None:
    """Half a unit of the last digit, whatever the notation."""
    assert half_unit("3.8e-11") == pytest.approx(0.05e-11)
    assert half_unit("9.92") == pytest.approx(0.005)
    assert half_unit("400") == 0.5


def test_neighbouring_last_digits_agree_and_real_changes_do_not() -> None:
    """3.7e-11 against 3.8e-11 is one value printed twice; 3.5e-11, 401 steps or another word are not."""
    assert_same_figures(LINE.replace("3.8e-11", "3.7e-11"), LINE, rel=0.0)
    for changed in ("3.5e-11 rad", "401 steps", "rk8"):
        old = {"3.5e-11 rad": "3.8e-11 rad", "401 steps": "400 steps", "rk8": "rk4"}[changed]
        with pytest.raises(AssertionError):
            assert_same_figures(LINE.replace(old, changed), LINE, rel=0.0)


def test_an_integer_with_a_unit_is_a_figure_and_a_count_is_not() -> None:
    """'at t = 17 s' is a time %g printed without a point: 16 s is within its half-units and rel 5 %;
    '3 pieces' is a count, compared exactly."""
    line = "closed form over 3 pieces, sensitivity at t = 17 s, λ ≈ 0 1/s"
    assert_same_figures(line.replace("17 s", "16 s"), line, rel=0.05)
    assert_same_figures(line.replace("0 1/s", "0.1 1/s"), line, rel=0.0)
    with pytest.raises(AssertionError):
        assert_same_figures(line.replace("3 pieces", "4 pieces"), line, rel=0.5)


def test_figure_after_a_label_is_parsed_and_compared_within_its_half_unit() -> None:
    """ω=3.16228 stands for √10 to its printed 6 digits; 3.1623 does not stand for 3.163."""
    message = "step h=0.5 s with ω=3.16228 rad/s gives hω=1.581"
    assert figure_after(message, "ω=") == "3.16228"
    assert figure_after(message, "hω=") == "1.581"
    assert_figure(message, "ω=", 10**0.5, rel=0.0)
    with pytest.raises(AssertionError):
        assert_figure(message, "hω=", 1.583, rel=0.0)
