"""The result of a simulation: sampled state, car acceleration and, per model, string quantities."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Trajectory:
    """θ(t) (rad), θ'(t) (rad/s) and a(t) (m/s²) at the sample times t (s), plus per-model extras.

    ``tension`` (N) is T = m (l θ'² + g cos θ + a sin θ) for the reduced models, −μ l for the
    multiplier model and k (r − l) for the elastic string; ``stretch`` = r − l (m) and
    ``stretch_rate`` = r' (m/s) exist only for the elastic string; ``multiplier`` μ (N/m) only
    for the Lagrange-multiplier model. ``nfev`` counts right-hand-side evaluations (0 for closed forms).
    """

    t: np.ndarray
    theta: np.ndarray
    theta_dot: np.ndarray
    accel: np.ndarray
    tension: np.ndarray | None
    stretch: np.ndarray | None
    stretch_rate: np.ndarray | None
    multiplier: np.ndarray | None
    model: str
    method: str
    nfev: int

    def columns(self) -> dict[str, np.ndarray]:
        """{'t', 'theta', 'theta_dot', then 'tension', 'stretch', 'stretch_rate' where present}."""
        out = {"t": self.t, "theta": self.theta, "theta_dot": self.theta_dot}
        extras = {"tension": self.tension, "stretch": self.stretch, "stretch_rate": self.stretch_rate}
        out.update({name: values for name, values in extras.items() if values is not None})
        return out
