"""The URDF: a continuous pendulum_joint, the bob's inertial, and the installed file equal to `pendulum-accel
urdf`'s output for the default scene."""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from pendulum_accel.bag import messages as bm
from pendulum_accel.cli.main import main
from pendulum_accel.recording.visual import bob_radius, urdf
from pendulum_accel.scene import DEFAULT_SCENE, load_scene

INSTALLED = Path(__file__).resolve().parent.parent / "urdf" / "pendulum_accel.urdf"
PRINTED_REL = 5e-9
"""Numbers are printed with 9 (mass, inertia) or 6 (lengths, :.6g) significant digits; the lengths here
are short decimals (1, 0.5, 1.55) printed exactly, and 9 digits are within 5e-10 relative of the value."""


def _numbers(element: ET.Element) -> list[tuple[str, str, list[str | float]]]:
    """(tag, attribute, its tokens: floats where they parse) of every attribute under ``element``."""

    def token(text: str) -> str | float:
        """A float when ``text`` is one."""
        try:
            return float(text)
        except ValueError:
            return text

    return [
        (e.tag, k, [token(t) for t in v.split()]) for e in element.iter() for k, v in sorted(e.attrib.items())
    ]


def _same(a: list[tuple[str, str, list[str | float]]], b: list[tuple[str, str, list[str | float]]]) -> bool:
    """Equal structure and strings; numbers within PRINTED_REL."""
    if [(t, k, len(v)) for t, k, v in a] != [(t, k, len(v)) for t, k, v in b]:
        return False
    for (_, _, xs), (_, _, ys) in zip(a, b, strict=True):
        for x, y in zip(xs, ys, strict=True):
            if isinstance(x, float) and isinstance(y, float):
                if abs(x - y) > PRINTED_REL * max(abs(x), abs(y)):
                    return False
            elif x != y:
                return False
    return True


def test_installed_urdf_is_the_command_output_for_the_default_scene(
    capsys: pytest.CaptureFixture[str],
) -> None:
    assert main(["urdf"]) == 0
    printed = ET.fromstring(capsys.readouterr().out)
    assert _same(_numbers(ET.parse(INSTALLED).getroot()), _numbers(printed))
    pendulum = load_scene(DEFAULT_SCENE).pendulum
    assert _same(_numbers(printed), _numbers(ET.fromstring(urdf(pendulum.length, mass=pendulum.mass))))


def test_joint_is_continuous_and_the_bob_carries_the_scene_mass() -> None:
    """pendulum_joint continuous about +y (no limits); bob_link's mass is the scene's, I = 2/5 m r²."""
    robot = ET.fromstring(urdf(0.8, mass=0.25))
    (joint,) = [j for j in robot.iter("joint") if j.get("name") == bm.PENDULUM_JOINT]
    assert joint.get("type") == "continuous" and joint.find("limit") is None
    assert joint.find("axis").get("xyz").split() == ["0", "1", "0"]  # type: ignore[union-attr]
    inertials = {link.get("name"): link.find("inertial") for link in robot.iter("link")}
    assert [name for name, inertial in inertials.items() if inertial is not None] == ["bob_link"]
    bob = inertials["bob_link"]
    assert bob is not None
    mass = bob.find("mass")
    assert mass is not None
    assert float(mass.get("value", "nan")) == pytest.approx(0.25, rel=PRINTED_REL)
    inertia = bob.find("inertia")
    assert inertia is not None
    expected = 0.4 * 0.25 * bob_radius(0.8) ** 2
    for axis in ("ixx", "iyy", "izz"):
        assert float(inertia.get(axis, "nan")) == pytest.approx(expected, rel=PRINTED_REL)


def test_frame_prefix_moves_the_markers_into_their_own_frame() -> None:
    """Swing markers and the estimate's arrow carry the frame they are given (frame_prefix + base_link)."""
    import numpy as np

    from pendulum_accel.recording.visual import estimate_marker_writer, swing_marker_rows

    rows = swing_marker_rows(
        np.array([1_000_000], dtype=np.int64), np.zeros(1), np.zeros(1), 1.0, "car1/base_link"
    )
    swing = bm.deserialize(rows[0].tobytes(), bm.MARKER_ARRAY)
    arrow = bm.deserialize(estimate_marker_writer(1.0, "car1/base_link")(0, 5, 1.0), bm.MARKER_ARRAY)
    frames = {m.header.frame_id for m in (*swing.markers, *arrow.markers)}  # type: ignore[attr-defined]
    assert frames == {"car1/base_link"}
