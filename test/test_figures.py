"""test.figures: printed lines compared by words, integers and figures within their printed half-units."""

from __future__ import annotations

import pytest

from test.figures import assert_same_figures, half_unit, split_figures

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
