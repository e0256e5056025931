"""What one lecture result prints: the lecture's formula, the simulated value, their difference.

A result is a list of :class:`Comparison` rows plus free text, and a drawing callback
that :func:`pendulum_accel.lecture.plotting.write_plot` turns into a PNG.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from matplotlib.figure import Figure

# θ_ours = −θ_lecture: printed by every result whose formula involves the sign of θ.
SIGN_NOTE = (
    "sign: the lecture measures θ the other way (θ'' = −(g/l) sin θ − (a/l) cos θ, tan θ' = −a/g); "
    "here θ > 0 swings the bob to the rear, θ'' = −(g/l) sin θ + (a/l) cos θ, so θ_ours = −θ_lecture "
    "and tan θ = a/g"
)


@dataclass(frozen=True)
class Comparison:
    """One checked number: |simulated − lecture| ≤ tolerance is a PASS."""

    quantity: str
    unit: str
    lecture: float
    simulated: float
    tolerance: float
    where: str = ""

    @property
    def difference(self) -> float:
        """difference = simulated − lecture."""
        return self.simulated - self.lecture

    @property
    def passed(self) -> bool:
        """PASS ⇔ |simulated − lecture| ≤ tolerance (NaN never passes)."""
        return math.isfinite(self.difference) and abs(self.difference) <= self.tolerance

    def line(self) -> str:
        """One printed row: ``quantity [unit] where: lecture=… simulated=… diff=… tol=… PASS|FAIL``."""
        where = f" {self.where}" if self.where else ""
        return (
            f"{self.quantity} [{self.unit}]{where}: lecture={self.lecture:.9g} "
            f"simulated={self.simulated:.9g} diff={self.difference:+.3e} tol={self.tolerance:.1e} "
            f"{'PASS' if self.passed else 'FAIL'}"
        )


Drawing = Callable[["Figure"], None]


@dataclass(frozen=True)
class LectureReport:
    """Outcome of one lecture result: formula lines, setup, checked comparisons, notes, plot callback."""

    name: str
    title: str
    formulas: tuple[str, ...]
    setup: str
    comparisons: tuple[Comparison, ...]
    notes: tuple[str, ...] = ()
    draw: Drawing | None = field(default=None, compare=False, repr=False)

    @property
    def passed(self) -> bool:
        """True when every comparison is within its tolerance."""
        return all(c.passed for c in self.comparisons)

    def text(self) -> str:
        """The printed report: title, formulas, setup, one row per comparison, notes, verdict."""
        lines = [f"{self.name}: {self.title}"]
        lines += [f"  lecture:  {f}" for f in self.formulas]
        lines.append(f"  setup:    {self.setup}")
        lines += [f"  check:    {c.line()}" for c in self.comparisons]
        lines += [f"  note:     {n}" for n in self.notes]
        failed = sum(not c.passed for c in self.comparisons)
        verdict = "PASS" if failed == 0 else f"FAIL ({failed} of {len(self.comparisons)} outside tolerance)"
        lines.append(f"  result:   {verdict}")
        return "\n".join(lines)
