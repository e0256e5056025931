"""Physical parameters of the pendulum, validated once at construction."""

from __future__ import annotations

import math
from dataclasses import dataclass

from pendulum_accel.errors import ParameterError

STANDARD_GRAVITY = 9.80665  # m/s², ISO 80000-3


def require_finite(name: str, value: float | str) -> float:
    """Return ``float(value)`` (a number, or a string float() parses), or raise ParameterError naming it
    when it is NaN, inf or not a number."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ParameterError(f"{name} must be a number, got {value!r}") from None
    if not math.isfinite(number):
        raise ParameterError(f"{name} must be finite, got {number!r}")
    return number


def require_positive(name: str, value: float) -> float:
    """Return ``float(value)`` when finite and > 0, else raise ParameterError naming it."""
    number = require_finite(name, value)
    if number <= 0.0:
        raise ParameterError(f"{name} must be > 0, got {number!r}")
    return number


@dataclass(frozen=True)
class Pendulum:
    """A bob of mass m on a string of rest length l, in gravity g, with linear damping c.

    θ'' = -(g/l) sin θ + (a/l) cos θ - c θ'.
    ``stiffness`` k (N/m) is used only by the elastic-string model, V(r) = ½ k (r - l)².
    """

    length: float
    mass: float = 1.0
    gravity: float = STANDARD_GRAVITY
    damping: float = 0.0
    stiffness: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "length", require_positive("length", self.length))
        object.__setattr__(self, "mass", require_positive("mass", self.mass))
        object.__setattr__(self, "gravity", require_positive("gravity", self.gravity))
        damping = require_finite("damping", self.damping)
        if damping < 0.0:
            raise ParameterError(f"damping must be >= 0, got {damping!r}")
        object.__setattr__(self, "damping", damping)
        if self.stiffness is not None:
            object.__setattr__(self, "stiffness", require_positive("stiffness", self.stiffness))

    def effective_gravity(self, accel: float) -> float:
        """g_eff = √(g² + a²)."""
        return math.hypot(self.gravity, require_finite("acceleration", accel))

    def omega(self, accel: float = 0.0) -> float:
        """Small-oscillation angular frequency, ω² = √(g² + a²)/l."""
        return math.sqrt(self.effective_gravity(accel) / self.length)

    def equilibrium_angle(self, accel: float = 0.0) -> float:
        """θ_eq = atan2(a, g): tan θ_eq = a/g, bob to the rear for a > 0."""
        return math.atan2(require_finite("acceleration", accel), self.gravity)
