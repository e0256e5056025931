"""Scene fields a node may override by parameter: names, ranges, and how to read/replace them (no ROS)."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, replace

from pendulum_accel.errors import ParameterError
from pendulum_accel.scene import Scene


@dataclass(frozen=True)
class Override:
    """One overridable scene field: parameter ``name``, its type, closed range, unit and accessors."""

    name: str
    kind: type  # float or int
    low: float
    high: float
    unit: str
    description: str
    get: Callable[[Scene], float]
    set: Callable[[Scene, float], Scene]

    def check(self, value: float) -> float:
        """value itself when low ≤ value ≤ high (finite, whole for an int field); else ParameterError."""
        if self.kind is int and math.isfinite(value) and value != int(value):
            # As the scene file refuses it: int(1.5) would silently run another seed than asked for.
            raise ParameterError(f"{self.name} must be an integer, got {value!r}")
        if not (self.low <= value <= self.high):
            raise ParameterError(
                f"{self.name} must be in [{self.low:g}, {self.high:g}] {self.unit}, got {value!r}"
            )
        return value


OVERRIDES: tuple[Override, ...] = (
    Override("length", float, 1e-3, 1e3, "m", "pendulum length l", lambda s: s.pendulum.length,
             lambda s, v: replace(s, pendulum=replace(s.pendulum, length=v))),
    Override("gravity", float, 0.1, 100.0, "m/s²", "gravity g", lambda s: s.pendulum.gravity,
             lambda s, v: replace(s, pendulum=replace(s.pendulum, gravity=v))),
    Override("damping", float, 0.0, 100.0, "1/s", "linear damping c", lambda s: s.pendulum.damping,
             lambda s, v: replace(s, pendulum=replace(s.pendulum, damping=v))),
    Override("noise_std", float, 0.0, 1.0, "rad", "angle sensor noise σ", lambda s: s.sensor.noise_std,
             lambda s, v: replace(s, sensor=replace(s.sensor, noise_std=v))),
    Override("rate_hz", float, 1.0, 100_000.0, "Hz", "angle sensor rate", lambda s: s.sensor.rate_hz,
             lambda s, v: replace(s, sensor=replace(s.sensor, rate_hz=v))),
    Override("seed", int, 0, 2**31 - 1, "", "sensor noise seed", lambda s: s.sensor.seed,
             lambda s, v: replace(s, sensor=replace(s.sensor, seed=int(v)))),
    Override("theta0", float, -math.pi, math.pi, "rad", "initial angle θ(0)", lambda s: s.theta0,
             lambda s, v: replace(s, theta0=v)),
    Override("duration", float, 1e-3, 86_400.0, "s", "scene duration", lambda s: s.duration,
             lambda s, v: replace(s, duration=v)),
)  # fmt: skip
"""Each setter rebuilds the frozen dataclasses with dataclasses.replace, so the scene re-validates."""

OVERRIDE_BY_NAME: dict[str, Override] = {o.name: o for o in OVERRIDES}


SENSOR_DESIGNS: dict[str, dict[str, float]] = {
    # l = 5 cm: ω0 = √(g/l) = 14.0 rad/s (f0 = 2.23 Hz); c = √2 ω0 = 19.8 /s: ζ = c/(2ω0) = 0.71, for which
    # the −3 dB bandwidth of θ/a equals f0. A few cm of damped pendulum, as a real sensor is built.
    "short_damped": {"length": 0.05, "damping": 19.8, "rate_hz": 200.0, "noise_std": 2e-3},
    # l = 1 m: f0 = 0.50 Hz, ζ = 0.008 (it rings for minutes): the lecture's pendulum.
    "teaching": {"length": 1.0, "damping": 0.05, "rate_hz": 100.0, "noise_std": 1e-3},
}
"""The bundled sensor designs as override values (docs/real_motion.md): ``apply_overrides(scene,
SENSOR_DESIGNS[name])`` puts any scene's motion on that design. The real-motion scenes ship in both
(``udds`` in short_damped, ``udds_teaching`` in teaching); on the command line the same is
``--set length=1 --set damping=0.05 --set rate_hz=100 --set noise_std=1e-3``."""


def apply_overrides(scene: Scene, values: Mapping[str, float]) -> Scene:
    """The scene with every field named in ``values`` replaced (range-checked; the scene re-validates)."""
    for name, value in values.items():
        spec = OVERRIDE_BY_NAME.get(name)
        if spec is None:
            raise ParameterError(f"{name} is not an overridable scene field ({', '.join(OVERRIDE_BY_NAME)})")
        if spec.get(scene) == value:
            continue
        scene = spec.set(scene, spec.kind(spec.check(value)))
    return scene


def parse_override(text: str) -> tuple[str, float]:
    """'name=value' → (name, float(value)), else ParameterError naming the text (names: apply_overrides)."""
    name, sep, value = text.partition("=")
    try:
        if not sep or not name:
            raise ValueError
        return name.strip(), float(value)
    except ValueError:
        raise ParameterError(f"--set expects NAME=NUMBER (e.g. duration=5), got {text!r}") from None


SET_HELP = "override a scene field (repeatable): " + ", ".join(
    f"{o.name} [{o.kind(o.low):.6g}, {o.kind(o.high):{'.6g' if o.kind is float else 'd'}}]"
    + (f" {o.unit}" if o.unit else "")
    for o in OVERRIDES
)
"""Help text of the CLI's ``--set NAME=VALUE``: every overridable field with its range and unit."""
