"""Road grade: the tilted-gravity equation, the steady angle, the equivalence with a = g tan β, every path.

The reference equation here is derived independently of physics.rigid: gravity (0, −g) in the world,
rotated into the car frame pitched nose-up by β, plus the inertial −a along the car's x axis; the bob's
tangential equation follows from projecting that specific force on the tangent (−cos θ, sin θ).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from pendulum_accel.errors import ParameterError, SceneError
from pendulum_accel.estimators import ESTIMATORS, estimate_batch
from pendulum_accel.lecture.measure import period
from pendulum_accel.physics.params import Pendulum
from pendulum_accel.physics.profiles import Constant, Offset, Sinusoid, Step
from pendulum_accel.physics.rigid import energy, level_equivalent, tension, theta_ddot
from pendulum_accel.physics.simulate import simulate
from pendulum_accel.planner import plan_scene, plan_with
from pendulum_accel.recording.settings import estimator_settings
from pendulum_accel.scene import SCENES_DIR, load_scene, scene_from_yaml, scene_to_yaml
from pendulum_accel.scene_run import run_scene

G = 9.80665
BETA = math.atan(0.1)


def reference_theta_ddot(g: float, length: float, beta: float, a: float, th: float) -> float:
    """θ'' from the car-frame specific force f = R(β)ᵀ(0, −g) − (a, 0) projected on the bob's tangent."""
    # world (horizontal, up) → car (x, z) for a nose-up pitch β: x̂ = (cos β, sin β), ẑ = (−sin β, cos β)
    gx, gz = -g * math.sin(beta), -g * math.cos(beta)
    fx, fz = gx - a, gz
    # bob at (−l sin θ, −l cos θ); ∂/∂θ of the position is l (−cos θ, sin θ)
    return (fx * -math.cos(th) + fz * math.sin(th)) / length


def test_level_equivalent_is_the_tilted_gravity_equation() -> None:
    """θ'' of (g cos β, a + g sin β) equals the rotated-gravity reference at many states."""
    rng = np.random.default_rng(3)
    p = Pendulum(0.7, gravity=G)
    for beta in (BETA, -0.3, 0.6):
        for a in (0.0, 2.5, -4.0):
            q, prof = level_equivalent(p, Constant(a), beta)
            for th in rng.uniform(-3.0, 3.0, 5):
                got = float(theta_ddot(q, th, 0.0, prof.scalar(0.0)))
                # level equivalent (g cos β, a + g sin β) against the tilted-frame formula: ~10 roundings
                # and 4 libm calls on terms ≤ g + |a| ≈ 14 m/s², ≈ 1e-14; 1e-12 is 100× that
                assert got == pytest.approx(reference_theta_ddot(G, 0.7, beta, a, th), rel=1e-12, abs=1e-12)


def test_zero_grade_returns_the_same_objects_and_bad_grades_are_refused() -> None:
    """β = 0 changes nothing (bit-identical runs); |β| ≥ π/2 or NaN is a ParameterError."""
    p = Pendulum(1.0)
    prof = Constant(2.0)
    q, r = level_equivalent(p, prof, 0.0)
    assert q is p and r is prof
    scene = load_scene("lecture_constant")
    assert scene.grade == 0.0 and scene.on_level() is scene
    for bad in (math.pi / 2, -2.0, math.nan):
        with pytest.raises(ParameterError):
            level_equivalent(p, prof, bad)


@pytest.mark.parametrize(("beta", "a"), [(BETA, 0.0), (0.2, 1.5), (-0.15, 3.0), (-BETA, G * math.sin(BETA))])
def test_steady_angle_on_a_grade(beta: float, a: float) -> None:
    """A damped bob on grade β settles at tan θ = (a + g sin β)/(g cos β), with T = m |f|."""
    p = Pendulum(1.0, mass=1.3, gravity=G, damping=4.0)
    q, prof = level_equivalent(p, Constant(a), beta)
    traj = simulate(q, prof, np.array([0.0, 15.0]), theta0=0.0, model="rigid", rtol=1e-11, atol=1e-13)
    expected = math.atan2(a + G * math.sin(beta), G * math.cos(beta))
    assert traj.theta[-1] == pytest.approx(expected, abs=1e-9)
    assert traj.tension is not None
    assert traj.tension[-1] == pytest.approx(
        1.3 * math.hypot(a + G * math.sin(beta), G * math.cos(beta)), abs=1e-9
    )


def test_grade_and_acceleration_give_the_same_steady_angle() -> None:
    """Grade β at a = 0 and level a = g tan β: one steady angle (β), different tension and period."""
    p = Pendulum(1.0, gravity=G, damping=4.0)
    hill = simulate(
        *level_equivalent(p, Constant(0.0), BETA),
        np.array([0.0, 15.0]),
        theta0=0.0,
        model="rigid",
        rtol=1e-11,
    )
    flat = simulate(
        p, Constant(G * math.tan(BETA)), np.array([0.0, 15.0]), theta0=0.0, model="rigid", rtol=1e-11
    )
    assert hill.theta[-1] == pytest.approx(BETA, abs=1e-9)
    assert flat.theta[-1] == pytest.approx(BETA, abs=1e-9)
    assert hill.tension is not None and flat.tension is not None
    assert flat.tension[-1] / hill.tension[-1] == pytest.approx(1.0 / math.cos(BETA), rel=1e-9)


def test_period_on_the_grade_is_that_of_the_level_road() -> None:
    """Undamped small swings on a grade: ω² = g/l (|f| = g), not g sec β/l as on the level at g tan β."""
    p = Pendulum(1.0, gravity=G)
    t = np.linspace(0.0, 20.0, 4001)
    hill = simulate(*level_equivalent(p, Constant(0.0), BETA), t, theta0=BETA + 0.01, rtol=1e-11, atol=1e-13)
    flat = simulate(p, Constant(G * math.tan(BETA)), t, theta0=BETA + 0.01, rtol=1e-11, atol=1e-13)
    # amplitude 0.01 rad: the exact period exceeds 2π/ω by A²/16 ≈ 6e-6 relative
    assert period(t, hill.theta, hill.theta_dot) == pytest.approx(2 * math.pi * math.sqrt(1.0 / G), rel=2e-5)
    assert period(t, flat.theta, flat.theta_dot) == pytest.approx(
        2 * math.pi * math.sqrt(math.cos(BETA) / G), rel=2e-5
    )


def test_energy_is_conserved_on_a_grade() -> None:
    """Undamped, constant a on a grade: E of the level equivalent is constant along the swing."""
    p = Pendulum(0.8, gravity=G)
    q, prof = level_equivalent(p, Constant(1.0), 0.3)
    t = np.linspace(0.0, 10.0, 1001)
    traj = simulate(q, prof, t, theta0=1.2, model="rigid", rtol=1e-12, atol=1e-14)
    e = energy(q, traj.theta, traj.theta_dot, prof(t))
    assert np.max(np.abs(e - e[0])) < 1e-9
    tq = tension(q, traj.theta, traj.theta_dot, prof(t))
    assert traj.tension is not None
    # the same tension formula on the same θ, θ' (numpy inside simulate, numpy here): a few ulp of T
    np.testing.assert_allclose(traj.tension, tq, rtol=1e-12)


@pytest.mark.parametrize(
    "profile", [Constant(0.5), Step(2.0, 0.0, 3.0), Sinusoid(1.0, 0.3, offset=0.2)], ids=lambda p: p.kind
)
def test_compiled_kernels_take_the_grade(profile: Constant | Step | Sinusoid) -> None:
    """RK8 through the compiled kernel on an Offset profile agrees with DOP853 on the numpy rhs."""
    p = Pendulum(1.0, gravity=G)
    q, prof = level_equivalent(p, profile, -0.2)
    assert isinstance(prof, Offset)
    t = np.linspace(0.0, 8.0, 801)
    compiled = simulate(q, prof, t, theta0=0.3, model="rigid", method="rk8", dt=2e-3)
    reference = simulate(q, prof, t, theta0=0.3, model="rigid", method="DOP853", rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(compiled.theta, reference.theta, atol=1e-9)
    # a(t) + g sin β evaluated twice from the same floats (≤ 2 roundings of |a| + g ≈ 12: 5e-15)
    np.testing.assert_allclose(compiled.accel, profile(t) + G * math.sin(-0.2), atol=1e-12)


def test_hill_scene_plans_a_closed_form_and_reports_the_physical_acceleration() -> None:
    """The bundled hill: closed form (constant a on a constant grade), true a = 0, θ about β, T ≈ m g."""
    scene = load_scene("hill")
    assert scene.grade == pytest.approx(BETA)
    plan = plan_scene(scene)
    assert plan.model == "exact"
    run = run_scene(scene)
    assert np.all(run.accel_true == 0.0)
    # released hanging: swings between 0 and 2β about β
    assert float(np.max(run.theta_true)) == pytest.approx(2 * BETA, abs=1e-4)
    stepped = run_scene(scene, plan_with(scene, model="rigid", method="rk8", dt=1e-3))
    np.testing.assert_allclose(stepped.theta_true, run.theta_true, atol=1e-8)


@pytest.mark.parametrize("name", ESTIMATORS)
def test_estimators_read_g_tan_beta_on_a_hill_at_constant_speed(name: str) -> None:
    """Every estimator on the hill scene (a = 0) reads g tan β once settled: it cannot see the grade."""
    scene = dataclasses.replace(load_scene("hill"), duration=40.0)
    run = run_scene(dataclasses.replace(scene, pendulum=dataclasses.replace(scene.pendulum, damping=0.5)))
    est, _ = estimate_batch(name, run.t, run.theta_measured, **estimator_settings(scene))
    tail = run.t > 30.0
    assert float(np.mean(est[tail])) == pytest.approx(G * math.tan(BETA), abs=0.01)


def test_grade_round_trips_and_is_checked(tmp_path: Path) -> None:
    """grade is written only when non-zero, reads back equal, and a bad value is one SceneError line."""
    hill = load_scene("hill")
    again = scene_from_yaml(scene_to_yaml(hill))
    assert again == dataclasses.replace(hill, source=None)
    assert "grade" not in scene_to_yaml(load_scene("lecture_constant"))
    text = (SCENES_DIR / "hill.yaml").read_text(encoding="utf-8")
    for bad, expected in (
        ("1.6", "grade: expected a number of rad with |grade| < pi/2"),
        ("'steep'", "grade"),
    ):
        with pytest.raises(SceneError, match=r"grade") as err:
            scene_from_yaml(text.replace("grade: 0.09966865249116204", f"grade: {bad}"), label="h.yaml")
        assert expected in str(err.value) and "\n" not in str(err.value)


def test_a_copied_scene_is_named_after_its_file(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    """A copy keeping the bundled name takes the file's stem (one log line); a renamed copy keeps its name."""
    copy = tmp_path / "my run.yaml"
    shutil.copy(SCENES_DIR / "lecture_constant.yaml", copy)
    with caplog.at_level(logging.WARNING, logger="pendulum_accel.scene"):
        scene = load_scene(copy)
    assert scene.name == "my_run"
    assert len(caplog.records) == 1 and "lecture_constant" in caplog.records[0].getMessage()
    assert load_scene("lecture_constant").name == "lecture_constant"
    renamed = tmp_path / "other.yaml"
    renamed.write_text(
        copy.read_text(encoding="utf-8").replace("name: lecture_constant", "name: mine"), "utf-8"
    )
    assert load_scene(renamed).name == "mine"
