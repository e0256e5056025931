"""kalman's motion preset chosen per scene (estimators.motion): the rule, the scene key, and that generate,
analyze and the run summary use it."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from benchmarks.motion_designs import PROFILES
from pendulum_accel.errors import SceneError
from pendulum_accel.estimators import estimate_batch, estimator_line
from pendulum_accel.estimators.kalman import PRESETS
from pendulum_accel.estimators.motion import MOTIONS, motion_of
from pendulum_accel.recording.analyze import analyze_bag
from pendulum_accel.recording.generate import generate_bag
from pendulum_accel.recording.settings import estimator_options, motion_choice
from pendulum_accel.scene import (
    BUNDLED_SCENE_NAMES,
    load_scene,
    scene_from_yaml,
    scene_to_dict,
    scene_to_yaml,
)


def test_motions_are_the_presets() -> None:
    assert MOTIONS == tuple(PRESETS) == ("auto", "car", "robot", "lab_steps")


@pytest.mark.parametrize("name", BUNDLED_SCENE_NAMES)
def test_every_bundled_scene_runs_auto_without_a_motion_key(name: str) -> None:
    """No guess from where the data came from: drive cycles, the Husky's odometry and the lab scenes all
    run auto, learned from the angles."""
    choice = motion_choice(load_scene(name))
    assert choice.preset == "auto"
    assert choice.line().startswith("preset auto: learned from the angles")


@pytest.mark.parametrize("profile", PROFILES, ids=lambda p: p.name)
def test_the_rule_ignores_the_profile(profile: object) -> None:
    """Whatever the benchmark's profile (car, robot, steps), the rule gives auto."""
    assert motion_of(profile.build()).preset == "auto"  # type: ignore[attr-defined]


def test_scene_motion_key_states_the_preset_and_survives_a_round_trip() -> None:
    text = scene_to_yaml(load_scene("stop_and_go")).replace("gravity:", "motion: car\ngravity:", 1)
    scene = scene_from_yaml(text)
    assert scene.motion == "car"
    choice = motion_choice(scene)
    assert choice.preset == "car" and "stated by the scene" in choice.reason
    assert scene_to_dict(scene)["motion"] == "car"
    assert scene_from_yaml(scene_to_yaml(scene)).motion == "car"
    assert "motion" not in scene_to_dict(load_scene("stop_and_go"))


def test_an_unknown_motion_is_one_line() -> None:
    text = scene_to_yaml(load_scene("stop_and_go")).replace("gravity:", "motion: truck\ngravity:", 1)
    expected = r"^<scene>: motion: expected one of auto, car, robot, lab_steps, got 'truck'"
    with pytest.raises(SceneError, match=expected) as err:
        scene_from_yaml(text)
    assert "\n" not in str(err.value)


def test_only_methods_with_a_preset_are_given_one() -> None:
    scene = load_scene("stop_and_go")
    assert estimator_options(scene, "kalman")["preset"] == "auto"
    assert estimator_options(scene, "smoother")["preset"] == "auto"
    assert "preset" not in estimator_options(scene, "instant")


def test_generate_and_analyze_run_the_scene_preset(tmp_path: Path) -> None:
    """stop_and_go through generate: the recorded estimate is kalman with auto (bit for bit the batch pass,
    which the streaming node matches: test_estimators), not with car; analyze re-runs with auto, says so,
    and the summary line names it. A copy stating motion: car is re-run with car."""
    scene = dataclasses.replace(load_scene("stop_and_go"), duration=8.0)
    bag = tmp_path / "sg"
    result = generate_bag(scene, bag)
    assert result.messages > 0
    analysis = analyze_bag(bag)
    assert analysis.motion is not None and analysis.motion.preset == "auto"
    said = [line.strip() for line in analysis.lines()]
    assert any(line.startswith("motion model auto (preset auto: learned from the angles") for line in said)
    assert estimator_line("kalman", analysis.motion).endswith(analysis.motion.line())
    settings = estimator_options(scene, "kalman")
    own, _ = estimate_batch("kalman", analysis.t, analysis.theta, **settings)
    car, _ = estimate_batch("kalman", analysis.t, analysis.theta, **{**settings, "preset": "car"})
    assert np.array_equal(analysis.accel_est, own)  # the same compiled pass on the same inputs
    assert not np.array_equal(own, car)

    stated = dataclasses.replace(scene, motion="car")
    generate_bag(stated, tmp_path / "sg_car")
    again = analyze_bag(tmp_path / "sg_car")
    assert again.motion is not None and again.motion.preset == "car"
    assert "stated by the scene" in again.motion.reason
    assert analyze_bag(bag, estimator="instant").motion is None
