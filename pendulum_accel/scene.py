"""Scenes: one YAML file describes one run (physics, car acceleration, sensor, outputs, accuracy).

File layout (every key is checked; unknown keys are errors so a typo never passes silently)::

    name: lecture_constant          # [A-Za-z0-9_-]+
    description: one line of text
    duration: 20.0                  # s, > 0
    gravity: 9.80665                # m/s², > 0 (optional, default standard gravity)
    grade: 0.0                      # rad, |β| < π/2 (optional, 0): the road's constant pitch, nose-up
                                    # (climbing) > 0; a 10 % grade is atan(0.10) = 0.0997 rad
    motion: car                     # optional: kalman's preset as a prior, auto, car, robot or lab_steps
                                    # (default: auto, learned from the angles, estimators.motion)
    pendulum:
      length: 1.0                   # m, > 0
      mass: 1.0                     # kg, > 0 (optional, 1)
      damping: 0.0                  # 1/s, >= 0 (optional, 0)
      theta0: 0.0                   # rad (optional, 0)
      theta_dot0: 0.0               # rad/s (optional, 0)
      stiffness: 1.0e5              # N/m, > 0 (optional; the elastic string's k)
    acceleration: {type: constant, a: 2.0}   # any motion_input profile type; file paths (csv, speed_csv,
                                             # bag_topic, accel_csv) are relative to this file
    sensor:
      rate_hz: 100                  # Hz, > 0
      noise_std: 1.0e-3             # rad per sample, >= 0 (optional, 0; Gazebo stddev)
      noise_density: 7.1e-5         # rad/√Hz, >= 0: instead of noise_std, σ = noise_density·√rate_hz
      bias: 0.0                     # rad (optional, 0; Gazebo mean)
      bias_random_walk: 0.0         # rad/√s, >= 0 (optional, 0; Kalibr random_walk)
      bias_mean: 0.0                # rad (optional, 0): turn-on bias ±N(bias_mean, bias_stddev) per seed
      bias_stddev: 0.0              # rad, >= 0 (optional, 0)
      dynamic_bias_stddev: 0.0      # rad/√s, >= 0 (optional, 0): Gauss-Markov driving density σ_b
      dynamic_bias_correlation_time: 0.0  # s, >= 0 (> 0 when dynamic_bias_stddev is set)
      quantization: 0.0             # rad, >= 0 (optional, 0 = none; Gazebo precision)
      range: 0.0                    # rad, >= 0 (optional, 0 = unlimited): readings saturate at ±range
      seed: 1                       # integer >= 0 (optional, 0)
    outputs: [angle, tension]       # angle always; tension, stretch optional (optional, [angle])
    accuracy:
      max_angle_error: 1.0e-6       # rad, > 0
    force:                          # optional: teaching comparisons
      model: multiplier             # one of physics.simulate.MODELS
      method: DOP853                # optional, one of physics.integrators.METHODS

Files are read with a safe loader (no object construction). Every problem is one line naming the file,
the field path and what was expected, raised as SceneError.

A copied bundled scene that keeps its bundled ``name`` is named after its file instead (``my.yaml`` →
``my``, said in one log line), so a student's runs are never logged under the bundled name.
"""

from __future__ import annotations

import bisect
import logging
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TypeGuard

import yaml

from pendulum_accel.errors import ParameterError, SceneError
from pendulum_accel.estimators.motion import MOTIONS
from pendulum_accel.motion_input import profile_from_dict
from pendulum_accel.motion_input.accel_log import write_table_csv
from pendulum_accel.physics.integrators import METHODS
from pendulum_accel.physics.params import STANDARD_GRAVITY, Pendulum
from pendulum_accel.physics.profiles import AccelProfile, Table
from pendulum_accel.physics.rigid import level_equivalent
from pendulum_accel.physics.simulate import CLOSED_FORM_METHOD, MODELS
from pendulum_accel.scene_yaml import dump_scene_data, load_scene_data, scene_text_without_motion
from pendulum_accel.sensor import SENSOR_LIMITS, SensorModel, check_sensor_field, noise_std_from_density
from pendulum_accel.textfile import read_text_file

SCENES_DIR = Path(__file__).resolve().parent / "scenes"
SCENE_NAMES: tuple[str, ...] = (
    "at_rest",
    "lecture_constant",
    "step_start",
    "braking",
    "stop_and_go",
    "large_swing",
    "elastic_string",
    "multiplier_lecture",
    "hill",
    "resonant_drive",
)
"""The core scenes: seconds long, each run in full by the golden bags and the per-scene tests."""
CORPUS_SCENE_NAMES: tuple[str, ...] = (
    "jackal_odom",
    "husky_imu",
    "f1tenth_ds1_odom",
    "f1tenth_ds2_odom",
    "f1tenth_ds3_odom",
    "f1tenth_ds4_odom",
    "f1tenth_ds5_odom",
    "f1tenth_ds1_imu",
    "f1tenth_ds5_imu",
    "comma2k19_speed",
    "comma2k19_imu",
    "phone_corolla_trip1",
    "phone_corolla_trip2",
    "bus_gps_speed",
)
"""Recorded robots, a car's CAN speed and logged accelerations (accel_csv) that widen the real-motion
corpus (scenes/real_motion/README.md names each one's source, licence and conversion)."""
REAL_MOTION_SCENE_NAMES: tuple[str, ...] = (
    "udds",
    "hwfet",
    "ftp75",
    "husky_odom",
    "udds_teaching",
    "hwfet_teaching",
    "ftp75_teaching",
    "husky_odom_teaching",
    *CORPUS_SCENE_NAMES,
)
"""Recorded motion (drive cycles, robots' odometry, logged accelerations; docs/real_motion.md): up to
minutes long, so kept out of the loops that run every core scene in full. The drive cycles and the Husky's
odometry come in the short damped design and in the 1 m teaching design (``*_teaching``); the
CORPUS_SCENE_NAMES in the short damped design only."""
BUNDLED_SCENE_NAMES: tuple[str, ...] = SCENE_NAMES + REAL_MOTION_SCENE_NAMES
"""Every scene file shipped in scenes/, as ``pendulum-accel scenes`` lists them."""
DEFAULT_SCENE = "lecture_constant"
OUTPUTS: tuple[str, ...] = ("angle", "tension", "stretch")
_NAME_RE = re.compile(r"^[A-Za-z0-9_-]+$")
# θ0 is periodic and is wrapped into (-π, π] with 2π as a double-double (fl(2π) + its rounding), so the
# wrapped value is rounded once, by ≤ ½ ulp ≤ 2.2e-16 rad, whatever the turns; the planner carries that
# rounding through the run's sensitivity (Scene.wrap_error, planner.with_conditioning). 16 turns: past them
# the given value's own ulp (1.4e-14 rad at 100 rad) dwarfs any rounding of the run.
THETA0_MAX = 32.0 * math.pi
TWO_PI_LO = 2.4492935982947064e-16  # 2π − fl(2π), to double precision: fl(2π) + this is 2π within 1e-31
_TWO_PI_DD_ERROR = 1e-31  # |2π − (fl(2π) + TWO_PI_LO)| (2.4e-16 · 2⁻⁵³ < 3e-32), per turn


def wrap_angle(theta: float) -> float:
    """θ − 2πk in (-π, π], rounded once: r = remainder(θ, fl(2π)) = θ − k fl(2π) exactly (IEEE), then
    r − k (2π − fl(2π)); a result just outside (-π, π] moves one turn (r ± fl(2π) is exact there), and one
    that rounds past ±fl(π) (θ = −fl(π): π + 2.4e-16) is held at the bound (1 ulp at most, in wrap_error)."""
    two_pi = 2.0 * math.pi
    r = math.remainder(theta, two_pi)
    k = round((theta - r) / two_pi)
    wrapped = r - k * TWO_PI_LO
    if wrapped <= -math.pi:
        wrapped = (r + two_pi) - (k - 1) * TWO_PI_LO
    elif wrapped > math.pi:
        wrapped = (r - two_pi) - (k + 1) * TWO_PI_LO
    return min(max(wrapped, math.nextafter(-math.pi, 0.0)), math.pi)


def wrap_error(given: float, wrapped: float) -> float:
    """|wrapped − (given − 2πk)| (rad): the wrap's own rounding, k = round((given − wrapped)/2π), formed
    exactly in rationals from fl(2π) + TWO_PI_LO, plus k × the double-double's own error."""
    from fractions import Fraction

    k = round((given - wrapped) / (2.0 * math.pi))
    exact = Fraction(given) - k * (Fraction(2.0 * math.pi) + Fraction(TWO_PI_LO))
    return float(abs(Fraction(wrapped) - exact)) + abs(k) * _TWO_PI_DD_ERROR


_LOG = logging.getLogger(__name__)


@dataclass(frozen=True)
class Scene:
    """One run: pendulum (with g), θ(0), θ'(0), a(t), sensor, duration, outputs, accuracy, forced model.

    ``grade`` is the road's constant pitch β (rad, nose-up > 0); the motion on it is that of
    ``on_level()``, while ``pendulum`` and ``profile`` stay the physical g and the car's own a(t).
    ``accuracy`` is the max |θ_simulated − θ_true| allowed, rad. ``motion`` names kalman's preset (None:
    ``auto``, learned from the angles, ``estimators.motion``). ``model``/``method`` force the planner's
    choice (None: the planner decides). ``source`` is the file it came from (None when built in code).
    Construction re-checks the fields that depend on each other (SceneError naming the field).
    """

    name: str
    description: str
    duration: float
    pendulum: Pendulum
    profile: AccelProfile
    sensor: SensorModel
    theta0: float = 0.0
    theta_dot0: float = 0.0
    outputs: tuple[str, ...] = ("angle",)
    accuracy: float = 1e-6
    model: str | None = None
    method: str | None = None
    grade: float = 0.0
    motion: str | None = None
    source: Path | None = field(default=None, compare=False)
    theta0_given: float | None = field(default=None, compare=False)  # θ0 as given when it was wrapped

    def __post_init__(self) -> None:
        """Wrap θ0 into (-π, π] (noting the given value); check every field and the cross-field rules;
        raise SceneError('<field>: <expected>')."""
        theta0 = self.theta0
        if _finite(theta0) and abs(theta0) <= THETA0_MAX and not -math.pi < theta0 <= math.pi:
            object.__setattr__(self, "theta0_given", theta0)
            object.__setattr__(self, "theta0", wrap_angle(theta0))
        elif self.theta0_given is not None and (
            not _finite(self.theta0_given) or wrap_angle(self.theta0_given) != theta0
        ):
            object.__setattr__(self, "theta0_given", None)  # θ0 replaced since: the note no longer holds
        _check_scene(self)

    def wrap_note(self) -> str:
        """'θ0 = … rad wrapped to … rad (the angle is periodic)' when θ0 was wrapped, else ''."""
        if self.theta0_given is None:
            return ""
        return f"θ0 = {self.theta0_given:.6g} rad wrapped to {self.theta0:.6g} rad (the angle is periodic)"

    def wrap_error(self) -> float:
        """How far the wrap's rounding moved θ0 (rad, ≤ ½ ulp of θ0, 1 ulp at ±π; module function
        wrap_error); 0 when θ0 was not wrapped."""
        return 0.0 if self.theta0_given is None else wrap_error(self.theta0_given, self.theta0)

    def on_level(self) -> Scene:
        """The level-road scene with this one's motion: g → g cos β, a(t) → a(t) + g sin β, grade 0.

        A level scene returns itself, so its runs are bit for bit those of a scene without the field.
        """
        if self.grade == 0.0:
            return self
        pendulum, profile = level_equivalent(self.pendulum, self.profile, self.grade)
        return replace(self, pendulum=pendulum, profile=profile, grade=0.0)

    @property
    def wants_tension(self) -> bool:
        """True when the outputs ask for the string tension."""
        return "tension" in self.outputs

    @property
    def wants_stretch(self) -> bool:
        """True when the outputs ask for the string stretch r − l (needs the elastic model)."""
        return "stretch" in self.outputs


def _finite(value: object) -> TypeGuard[float]:
    """True for an int or float (not a bool) that is finite."""
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _check_scene(scene: Scene) -> None:
    """Raise SceneError('<field path>: expected …, got …') for the first field that is wrong."""
    if not isinstance(scene.name, str) or not _NAME_RE.match(scene.name):
        raise SceneError(f"name: expected letters, digits, '_' or '-', got {scene.name!r}")
    if not isinstance(scene.description, str):
        raise SceneError(f"description: expected text, got {scene.description!r}")
    if not _finite(scene.duration) or scene.duration <= 0.0:
        raise SceneError(f"duration: expected a number of seconds > 0, got {scene.duration!r}")
    if not _finite(scene.grade) or not abs(scene.grade) < 0.5 * math.pi:
        raise SceneError(f"grade: expected a number of rad with |grade| < pi/2, got {scene.grade!r}")
    if scene.motion is not None and scene.motion not in MOTIONS:
        raise SceneError(f"motion: expected one of {', '.join(MOTIONS)}, got {_show(scene.motion)}")
    for name in ("theta0", "theta_dot0"):
        if not _finite(getattr(scene, name)):
            raise SceneError(f"pendulum.{name}: expected a finite number, got {getattr(scene, name)!r}")
    if not abs(scene.theta0) <= math.pi:
        raise SceneError(
            f"pendulum.theta0: expected |θ0| ≤ {THETA0_MAX / math.pi:.0f}π rad "
            f"({THETA0_MAX / (2.0 * math.pi):.0f} turns), got {scene.theta0!r}"
        )
    if not _finite(scene.accuracy) or scene.accuracy <= 0.0:
        raise SceneError(f"accuracy.max_angle_error: expected a number of rad > 0, got {scene.accuracy!r}")
    if not isinstance(scene.outputs, tuple) or any(o not in OUTPUTS for o in scene.outputs):
        raise SceneError(f"outputs: expected a list drawn from {', '.join(OUTPUTS)}, got {scene.outputs!r}")
    try:
        scene.sensor.sample_count(scene.duration)
    except ParameterError as err:
        raise SceneError(f"sensor.rate_hz: {err}") from None
    stiff = scene.pendulum.stiffness is not None
    if scene.wants_stretch and not stiff:
        raise SceneError("pendulum.stiffness: expected a value in N/m, since outputs ask for stretch")
    if scene.model is not None and scene.model not in MODELS:
        raise SceneError(f"force.model: expected one of {', '.join(MODELS)}, got {scene.model!r}")
    if scene.method is not None:
        if scene.model is None:
            raise SceneError(f"force.method: expected only with force.model, got {scene.method!r} alone")
        allowed = (CLOSED_FORM_METHOD,) if scene.model in ("exact", "linear") else METHODS
        if scene.method not in allowed:
            raise SceneError(
                f"force.method: expected one of {', '.join(allowed)} for model {scene.model}, "
                f"got {scene.method!r}"
            )
    if scene.model == "elastic" and not stiff:
        raise SceneError("pendulum.stiffness: expected a value in N/m, since force.model is elastic")
    if scene.wants_stretch and scene.model not in (None, "elastic"):
        raise SceneError(f"force.model: expected elastic (outputs ask for stretch), got {scene.model!r}")
    if scene.model in ("exact", "linear"):
        if scene.pendulum.damping != 0.0:
            raise SceneError(
                f"force.model: {scene.model} is undamped only, "
                f"but pendulum.damping is {scene.pendulum.damping!r}"
            )
        if scene.profile.constant_pieces(0.0, scene.duration) is None:
            raise SceneError(
                f"force.model: {scene.model} needs a piecewise-constant acceleration, "
                f"got a varying {scene.profile.kind} profile"
            )


# ---------------------------------------------------------------- reading YAML


class _Fields:
    """Typed reads from one YAML mapping at ``path``; every failure is SceneError('<path>.<key>: …')."""

    def __init__(self, data: object, path: str, allowed: tuple[str, ...]) -> None:
        """Wrap ``data``: it must be a mapping whose keys are all in ``allowed``."""
        where = path or "scene"
        if not isinstance(data, Mapping):
            raise SceneError(f"{where}: expected a mapping of keys to values, got {_show(data)}")
        for key in data:
            if key not in allowed:
                field = f"{path}.{key}" if path else str(key)
                raise SceneError(f"{field}: unknown key (expected one of {', '.join(allowed)})")
        self.data = data
        self.path = path

    def path_of(self, key: str) -> str:
        """Dotted path of ``key``."""
        return f"{self.path}.{key}" if self.path else key

    def has(self, key: str) -> bool:
        """True when ``key`` is present."""
        return key in self.data

    def raw(self, key: str, expected: str) -> object:
        """The value of a required ``key``; SceneError 'missing' when absent."""
        if key not in self.data:
            raise SceneError(f"{self.path_of(key)}: missing (expected {expected})")
        return self.data[key]

    def number(
        self, key: str, default: float | None = None, *, low: float | None = None, strict: bool = False
    ) -> float:
        """A finite number (≥ low, or > low when strict); ``default`` when absent and not None."""
        bound = "" if low is None else f" {'>' if strict else '>='} {low:g}"
        expected = f"a number{bound}"
        if default is not None and key not in self.data:
            return default
        value = self.raw(key, expected)
        if not _finite(value):
            raise SceneError(f"{self.path_of(key)}: expected a finite number{bound}, got {_show(value)}")
        number = float(value)
        if low is not None and (number < low or (strict and number == low)):
            raise SceneError(f"{self.path_of(key)}: expected a number{bound}, got {_show(value)}")
        return number

    def integer(self, key: str, default: int) -> int:
        """An integer ≥ 0 (``default`` when absent)."""
        if key not in self.data:
            return default
        value = self.data[key]
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise SceneError(f"{self.path_of(key)}: expected an integer >= 0, got {_show(value)}")
        return value

    def text(self, key: str, default: str | None = None, *, choices: tuple[str, ...] = ()) -> str:
        """A string (one of ``choices`` when given); ``default`` when absent and not None."""
        expected = f"one of {', '.join(choices)}" if choices else "text"
        if default is not None and key not in self.data:
            return default
        value = self.raw(key, expected)
        if not isinstance(value, str) or (choices and value not in choices):
            raise SceneError(f"{self.path_of(key)}: expected {expected}, got {_show(value)}")
        return value


def _show(value: object) -> str:
    """Short repr of a YAML value with its type, for error messages."""
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({type(value).__name__})"


_TOP = ("name", "description", "duration", "gravity", "grade", "motion", "pendulum", "acceleration",
        "sensor", "outputs", "accuracy", "force")  # fmt: skip
_PENDULUM = ("length", "mass", "damping", "theta0", "theta_dot0", "stiffness")
_SENSOR = ("rate_hz", "noise_std", "noise_density", "bias", "bias_random_walk", "quantization", "seed",
           "bias_mean", "bias_stddev", "dynamic_bias_stddev", "dynamic_bias_correlation_time",
           "range")  # fmt: skip
# Written to YAML only when set, so a scene without them reads (and is stored in bags) as before.
_SENSOR_OPTIONAL = (
    "bias_mean",
    "bias_stddev",
    "dynamic_bias_stddev",
    "dynamic_bias_correlation_time",
    "range",
)


def _outputs(top: _Fields) -> tuple[str, ...]:
    """outputs: a list from OUTPUTS, no repeats; 'angle' always first whether listed or not."""
    if not top.has("outputs"):
        return ("angle",)
    value = top.data["outputs"]
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise SceneError(f"outputs: expected a list drawn from {', '.join(OUTPUTS)}, got {_show(value)}")
    for i, item in enumerate(value):
        if item not in OUTPUTS:
            raise SceneError(f"outputs[{i}]: expected one of {', '.join(OUTPUTS)}, got {item!r}")
        if item in value[:i]:
            raise SceneError(f"outputs[{i}]: {item!r} is listed twice")
    return tuple(o for o in OUTPUTS if o == "angle" or o in value)


def _sensor(sens: _Fields) -> SensorModel:
    """SensorModel from the sensor mapping; noise_std or noise_density (σ = N·√rate_hz), never both."""
    rate_hz = sens.number("rate_hz", low=0.0, strict=True)
    if sens.has("noise_std") and sens.has("noise_density"):
        raise SceneError("sensor: give noise_std (rad per sample) or noise_density (rad/√Hz), not both")
    noise_std = sens.number("noise_std", 0.0, low=0.0)
    if sens.has("noise_density"):
        density = sens.number("noise_density", low=0.0)
        try:
            check_sensor_field("noise_density", density)
        except ParameterError as err:
            raise _sensor_error(err) from None
        noise_std = noise_std_from_density(density, rate_hz)
        if noise_std > SENSOR_LIMITS["noise_std"][1]:
            top = SENSOR_LIMITS["noise_std"][1] / math.sqrt(rate_hz)
            raise SceneError(
                f"sensor: noise_density must be in [0, {top:.6g}] rad/√Hz at rate_hz {rate_hz:g} "
                f"(σ = N·√rate_hz ≤ {SENSOR_LIMITS['noise_std'][1]:g} rad), got {density!r}"
            )
    try:
        return SensorModel(
            rate_hz=rate_hz,
            noise_std=noise_std,
            bias=sens.number("bias", 0.0),
            bias_random_walk=sens.number("bias_random_walk", 0.0, low=0.0),
            quantization=sens.number("quantization", 0.0, low=0.0),
            seed=sens.integer("seed", 0),
            bias_mean=sens.number("bias_mean", 0.0),
            bias_stddev=sens.number("bias_stddev", 0.0, low=0.0),
            dynamic_bias_stddev=sens.number("dynamic_bias_stddev", 0.0, low=0.0),
            dynamic_bias_correlation_time=sens.number("dynamic_bias_correlation_time", 0.0, low=0.0),
            range=sens.number("range", 0.0, low=0.0),
        )
    except ParameterError as err:
        raise _sensor_error(err) from None


def _sensor_error(err: ParameterError) -> SceneError:
    """SceneError of a SensorModel refusal, the field named by its path: 'sensor.bias_mean must be …'."""
    text = str(err)
    return SceneError(f"sensor.{text[len('sensor ') :]}" if text.startswith("sensor ") else f"sensor: {text}")


_REQUIRED = (
    ("name", "text"), ("description", "text"), ("duration", "a number > 0"),
    ("pendulum", "a mapping with length, ..."), ("acceleration", "a mapping with a 'type'"),
    ("sensor", "a mapping with rate_hz, ..."), ("accuracy", "a mapping with max_angle_error"),
)  # fmt: skip
"""A scene's required top-level keys, with what each expects (docs/scenes.md)."""
_EXPECTED = dict(_REQUIRED)
_START_FROM = "'pendulum-accel scenes step_start > scene.yaml' writes a whole scene to start from"


def _missing_keys(top: _Fields) -> None:
    """SceneError naming every required top-level key ``top`` lacks, when it lacks two or more: a scene
    written from scratch learns them in one run, not one per run. One missing key is left to its own read
    ('<key>: missing (expected …)')."""
    missing = [(key, expected) for key, expected in _REQUIRED if not top.has(key)]
    if len(missing) > 1:
        keys = ", ".join(key for key, _ in missing)
        wants = "; ".join(f"{key}: {expected}" for key, expected in missing)
        raise SceneError(f"{keys}: missing (expected {wants}); {_START_FROM}")


def _parse(data: object, base_dir: Path | None) -> Scene:
    """Scene from a parsed YAML document; SceneError('<field>: …') on the first bad field, or naming every
    missing top-level key at once."""
    top = _Fields(data, "", _TOP)
    _missing_keys(top)
    name = top.text("name")
    description = top.text("description")
    duration = top.number("duration", low=0.0, strict=True)
    gravity = top.number("gravity", STANDARD_GRAVITY, low=0.0, strict=True)
    grade = top.number("grade", 0.0)
    motion = top.text("motion", choices=MOTIONS) if top.has("motion") else None

    pend = _Fields(top.raw("pendulum", _EXPECTED["pendulum"]), "pendulum", _PENDULUM)
    length = pend.number("length", low=0.0, strict=True)
    mass = pend.number("mass", 1.0, low=0.0, strict=True)
    damping = pend.number("damping", 0.0, low=0.0)
    theta0 = pend.number("theta0", 0.0)
    theta_dot0 = pend.number("theta_dot0", 0.0)
    stiffness = pend.number("stiffness", low=0.0, strict=True) if pend.has("stiffness") else None
    pendulum = Pendulum(length, mass=mass, gravity=gravity, damping=damping, stiffness=stiffness)

    accel = top.raw("acceleration", _EXPECTED["acceleration"])
    try:
        # The ignore below: the scene's value goes as it is, so profile_from_dict refuses a non-mapping
        # itself, in its own words with the field's path
        profile = profile_from_dict(accel, base_dir)  # type: ignore[arg-type]
    except ParameterError as err:
        where = f"acceleration.{err.path}" if err.path else "acceleration"
        raise SceneError(f"{where}: {err}") from None

    sensor = _sensor(_Fields(top.raw("sensor", _EXPECTED["sensor"]), "sensor", _SENSOR))
    acc = _Fields(top.raw("accuracy", _EXPECTED["accuracy"]), "accuracy", ("max_angle_error",))
    accuracy = acc.number("max_angle_error", low=0.0, strict=True)

    model: str | None = None
    method: str | None = None
    if top.has("force"):
        force = _Fields(top.data["force"], "force", ("model", "method"))
        model = force.text("model", choices=MODELS)
        if force.has("method"):
            method = force.text("method")
    return Scene(
        name=name,
        description=description,
        duration=duration,
        pendulum=pendulum,
        profile=profile,
        sensor=sensor,
        theta0=theta0,
        theta_dot0=theta_dot0,
        outputs=_outputs(top),
        accuracy=accuracy,
        model=model,
        method=method,
        grade=grade,
        motion=motion,
    )


def scene_from_yaml(text: str, *, label: str = "<scene>", base_dir: Path | None = None) -> Scene:
    """Scene from YAML text; errors read '<label>: <field>: expected …' ('<label>:<line>: …' for bad YAML)."""
    try:
        data = load_scene_data(text)
    except yaml.MarkedYAMLError as err:
        mark = err.problem_mark or err.context_mark
        line = f":{mark.line + 1}" if mark is not None else ""
        problem = err.problem or err.context or "not valid YAML"
        raise SceneError(f"{label}{line}: malformed YAML: {problem}") from None
    except yaml.YAMLError as err:
        raise SceneError(f"{label}: malformed YAML: {str(err).splitlines()[0]}") from None
    try:
        return _parse(data, base_dir)
    except SceneError as err:
        raise SceneError(f"{label}: {err}") from None
    except ParameterError as err:
        # A rule checked inside Pendulum or SensorModel that the field reads above did not catch first.
        raise SceneError(f"{label}: {err}") from None


def scene_path(name_or_path: str | Path) -> Path:
    """The file of a bundled scene name, or ``name_or_path`` itself when it names a file (``~`` expanded: a
    launch argument such as ``scene:=~/my.yaml`` reaches us past the shell unexpanded)."""
    text = str(name_or_path)
    if (
        isinstance(name_or_path, Path)
        or "/" in text
        or text.endswith((".yaml", ".yml"))
        or Path(text).is_file()
    ):
        return Path(name_or_path).expanduser()
    if text not in BUNDLED_SCENE_NAMES and not (SCENES_DIR / f"{text}.yaml").is_file():
        raise SceneError(
            f"no bundled scene named {text!r}; choose one of {', '.join(BUNDLED_SCENE_NAMES)} or give a path"
        )
    return SCENES_DIR / f"{text}.yaml"


def load_scene(name_or_path: str | Path, *, motion: bool = True) -> Scene:
    """Scene from a bundled name (see SCENE_NAMES) or a YAML file path; SceneError naming file and field.

    ``motion`` False: a(t) = 0 in place of its ``acceleration`` (scene_text_without_motion), for a reader
    of everything else (the estimator node: pendulum, sensor, motion key): a day-long log's file is then
    not read and fitted again (seconds) by a process that never uses it."""
    path = scene_path(name_or_path)
    try:
        text = read_text_file(path)
    except FileNotFoundError:
        raise SceneError(f"{path}: scene file not found") from None
    except OSError as err:
        raise SceneError(f"{path}: cannot read scene file ({err.strerror or err})") from None
    except ValueError as err:
        raise SceneError(f"{path}: cannot read scene file ({err})") from None
    light = None if motion else scene_text_without_motion(text)
    scene = scene_from_yaml(text if light is None else light, label=str(path), base_dir=path.parent)
    return _with_source(_named_after_copy(scene, path), path)


def _named_after_copy(scene: Scene, path: Path) -> Scene:
    """``scene`` renamed after its file's stem when it keeps a bundled name but is not that bundled file."""
    bundled = SCENES_DIR / f"{scene.name}.yaml"
    if scene.name not in BUNDLED_SCENE_NAMES or path.resolve() == bundled.resolve():
        return scene
    stem = re.sub(r"[^A-Za-z0-9_-]", "_", path.stem) or "scene"
    if stem == scene.name:
        return scene
    _LOG.warning(
        "%s keeps the bundled scene name %r; naming its runs %r after the file", path, scene.name, stem
    )
    return replace(scene, name=stem)


def _with_source(scene: Scene, path: Path) -> Scene:
    """``scene`` with ``source`` set to ``path``."""
    return replace(scene, source=path)


def list_scenes(names: tuple[str, ...] = SCENE_NAMES) -> tuple[Scene, ...]:
    """The bundled scenes ``names`` (default: the core SCENE_NAMES), in that order."""
    return tuple(load_scene(name) for name in names)


def scene_to_dict(scene: Scene) -> dict[str, object]:
    """The YAML mapping of ``scene`` (a CSV profile is written inline as a table, so it stands alone)."""
    p = scene.pendulum
    pendulum: dict[str, float] = {
        "length": p.length,
        "mass": p.mass,
        "damping": p.damping,
        "theta0": float(scene.theta0),
        "theta_dot0": float(scene.theta_dot0),
    }
    if p.stiffness is not None:
        pendulum["stiffness"] = p.stiffness
    s = scene.sensor
    out: dict[str, object] = {
        "name": scene.name,
        "description": scene.description,
        "duration": float(scene.duration),
        "gravity": p.gravity,
        **({"grade": float(scene.grade)} if scene.grade != 0.0 else {}),
        **({"motion": scene.motion} if scene.motion is not None else {}),
        "pendulum": pendulum,
        "acceleration": _plain(scene.profile.to_dict()),
        "sensor": {
            "rate_hz": s.rate_hz,
            "noise_std": s.noise_std,
            "bias": s.bias,
            "bias_random_walk": s.bias_random_walk,
            "quantization": s.quantization,
            "seed": s.seed,
        }
        | {name: getattr(s, name) for name in _SENSOR_OPTIONAL if getattr(s, name) != 0.0},
        "outputs": list(scene.outputs),
        "accuracy": {"max_angle_error": float(scene.accuracy)},
    }
    if scene.model is not None:
        out["force"] = {"model": scene.model} | ({"method": scene.method} if scene.method else {})
    return out


def _plain(value: object) -> object:
    """``value`` with tuples as lists and numpy scalars as Python numbers, for the YAML dumper."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    item = getattr(value, "item", None)  # a numpy scalar's: its Python number
    return item() if callable(item) else value


def write_scene_file(scene: Scene, directory: Path) -> Path:
    """``directory``/NAME.yaml, a file ``load_scene`` reads back into an equal scene (what the launcher hands
    its nodes). A table profile goes beside it as NAME.accel.csv, the ``csv`` profile's file (write_table_csv,
    read back bit for bit): an hour of a phone's 400 Hz log inline is 100 MB of YAML, past the scene file's
    64 MiB bound."""
    path = directory / f"{scene.name}.yaml"
    profile = scene.profile
    if isinstance(profile, Table) and profile.recipe is None:
        data = directory / f"{scene.name}.accel.csv"
        write_table_csv(profile, data)
        scene = replace(scene, profile=replace(profile, recipe={"type": "csv", "path": data.name}))
    path.write_text(scene_to_yaml(scene), encoding="utf-8")
    return path


def stored_scene_text(scene: Scene) -> str:
    """The scene text a bag stores: scene_to_yaml of ``scene`` with a table a(t) cut to the points its
    [0, duration] run reads (the last point at or before 0 to the first at or after the duration).

    A table is linear between its points and flat beyond its ends, so the cut table gives the same a(t)
    on [0, duration], and a run of the stored scene (analyze --seeds, the player's scene) is the recorded
    one. A 10 s run of a day-long log stored the whole day's table (megabytes a minute of log)."""
    profile = scene.profile
    if isinstance(profile, Table) and profile.recipe is None and len(profile.times) > 2:
        times = profile.times
        first = max(bisect.bisect_right(times, 0.0) - 1, 0)
        last = min(bisect.bisect_left(times, scene.duration), len(times) - 1)
        if last - first + 1 < len(times):
            cut = Table(times[first : last + 1], profile.accels[first : last + 1], origin=profile.origin)
            scene = replace(scene, profile=cut)
    return scene_to_yaml(scene)


def scene_to_yaml(scene: Scene) -> str:
    """YAML text that ``scene_from_yaml`` reads back into an equal scene (the text stored in bags):
    scene_yaml.dump_scene_data of scene_to_dict."""
    return dump_scene_data(scene_to_dict(scene))
