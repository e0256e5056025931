"""Tolerances from error arguments: what two floating-point code paths may differ by.

Two runs of one scheme whose operations round differently (numpy's SIMD sin against libm's, FMA or
not, another order of additions) each differ from exact arithmetic by about one rounding of the state
per function evaluation, ε·Θ (Θ = max |y|), and the linearised flow carries each such error forward
growing at most like 1 + ωT (ω the fastest rate of the motion, T the span): the two runs differ by at
most twice that sum. The bound is loose by design (rounding errors mostly cancel): it must hold on any
x86-64 CPU and SIMD level, and still be far below what a wrong formula or a wrong step would change.
"""

from __future__ import annotations

import numpy as np

EPS = float(np.finfo(float).eps)


def stepped_atol(evaluations: int, scale: float, growth: float = 1.0) -> float:
    """2 N ε Θ (1 + ωT): two stepped runs of N function evaluations on |y| ≤ Θ, rounded differently."""
    return 2.0 * evaluations * EPS * scale * growth
