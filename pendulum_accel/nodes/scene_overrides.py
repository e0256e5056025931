"""Scene fields a node may override by parameter: names, ranges, and how to read/replace them (no ROS)."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from pendulum_accel.errors import ParameterError


@dataclass(frozen=True)
class Override:
    """One overridable scene field: parameter ``name``, its type, closed range, unit and accessors."""

    name: str
    kind: type  # float or int
    low: float
    high: float
    unit: str
    description: str
    get: Callable[[Any], float]
    set: Callable[[Any, float], Any]

    def check(self, value: float) -> float:
        """value itself when low ≤ value ≤ high (and finite); ParameterError naming the field otherwise."""
        if not (self.low <= value <= self.high):
            raise ParameterError(
                f"{self.name} must be in [{self.low:g}, {self.high:g}] {self.unit}, got {value!r}"
            )
        return value


def _replace_in(field: str, attr: str) -> Callable[[Any, float], Any]:
    """Setter: scene with scene.<field>.<attr> = v (both frozen dataclasses, so rebuilt and re-validated)."""

    def setter(scene: Any, value: float) -> Any:
        """dataclasses.replace on the nested field, then on the scene."""
        inner = dataclasses.replace(getattr(scene, field), **{attr: value})
        return dataclasses.replace(scene, **{field: inner})

    return setter


def _replace_top(attr: str) -> Callable[[Any, float], Any]:
    """Setter: scene with scene.<attr> = v."""

    def setter(scene: Any, value: float) -> Any:
        """dataclasses.replace on the scene."""
        return dataclasses.replace(scene, **{attr: value})

    return setter


OVERRIDES: tuple[Override, ...] = (
    Override("length", float, 1e-3, 1e3, "m", "pendulum length l", lambda s: s.pendulum.length,
             _replace_in("pendulum", "length")),
    Override("gravity", float, 0.1, 100.0, "m/s²", "gravity g", lambda s: s.pendulum.gravity,
             _replace_in("pendulum", "gravity")),
    Override("damping", float, 0.0, 100.0, "1/s", "linear damping c", lambda s: s.pendulum.damping,
             _replace_in("pendulum", "damping")),
    Override("noise_std", float, 0.0, 1.0, "rad", "angle sensor noise σ", lambda s: s.sensor.noise_std,
             _replace_in("sensor", "noise_std")),
    Override("rate_hz", float, 1.0, 100_000.0, "Hz", "angle sensor rate", lambda s: s.sensor.rate_hz,
             _replace_in("sensor", "rate_hz")),
    Override("seed", int, 0, 2**31 - 1, "", "sensor noise seed", lambda s: s.sensor.seed,
             _replace_in("sensor", "seed")),
    Override("theta0", float, -math.pi, math.pi, "rad", "initial angle θ(0)", lambda s: s.theta0,
             _replace_top("theta0")),
    Override("duration", float, 1e-3, 86_400.0, "s", "scene duration", lambda s: s.duration,
             _replace_top("duration")),
)  # fmt: skip

OVERRIDE_BY_NAME: dict[str, Override] = {o.name: o for o in OVERRIDES}


def apply_overrides(scene: Any, values: Mapping[str, float]) -> Any:
    """The scene with every field named in ``values`` replaced (range-checked; the scene re-validates)."""
    for name, value in values.items():
        spec = OVERRIDE_BY_NAME.get(name)
        if spec is None:
            raise ParameterError(f"{name} is not an overridable scene field ({', '.join(OVERRIDE_BY_NAME)})")
        if spec.get(scene) == value:
            continue
        scene = spec.set(scene, spec.kind(spec.check(value)))
    return scene
