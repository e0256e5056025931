"""Where the truth a(t) changes: the rule that splits errors into "steady" and "after a change".

A change is a time t at which |a(t) − a(t − CHANGE_LOOKBACK)| > CHANGE_JUMP, a(t − 1 s) interpolated on
the truth's own samples (held at its first value before it starts). The CHANGE_WINDOW s after a change
count as "after a change", and so does the change's onset: a run of consecutive change samples starts at
the first sample after t − 1 s (t its first change) where a has left a(t − 1 s) by more than
CHANGE_ONSET. Without the onset a ramp's first CHANGE_JUMP/slope seconds (0.11 s of a 1.8 m/s³ ramp),
where an estimator has not yet seen it move, would count as steady. Everything else is steady.

The rule sees a step, a ramp steeper than 0.2 m/s³ and a real drive's accelerating and braking alike,
and it does not fire on the small sample-to-sample wiggle every real trace has (a rule on consecutive
samples would call every sample of a recorded trace a change, leaving no steady state to check).

One rule for ``analyze``, the calibration and seed-spread figures and the real-motion benchmark. No ROS.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

CHANGE_JUMP = 0.2
"""m/s²: |a(t) − a(t − 1 s)| beyond this marks a change of a (about 2 % of g; a car's gentle throttle
change, well above the differentiated speed traces' noise)."""
CHANGE_LOOKBACK = 1.0
"""s: how far back a(t) is compared."""
CHANGE_WINDOW = 2.0
"""s after a change that count as "after a change"."""
CHANGE_ONSET = 0.01
"""m/s²: a change starts where a has moved this far from a(t − 1 s) (a twentieth of CHANGE_JUMP)."""


def change_spans(t_truth: NDArray[np.float64], a_truth: NDArray[np.float64]) -> NDArray[np.float64]:
    """[(start, end)] of the truth's changes: each run of consecutive change samples (|a(t) − a(t − 1 s)| >
    CHANGE_JUMP) from its onset (the first sample after t₀ − 1 s with |a − a(t₀ − 1 s)| > CHANGE_ONSET,
    t₀ the run's first change) to its last change + CHANGE_WINDOW; shape (k, 2), ascending starts."""
    t_truth = np.asarray(t_truth, dtype=np.float64)
    a_truth = np.asarray(a_truth, dtype=np.float64)
    if t_truth.size == 0:
        return np.zeros((0, 2))
    back = np.interp(t_truth - CHANGE_LOOKBACK, t_truth, a_truth)
    idx = np.flatnonzero(np.abs(a_truth - back) > CHANGE_JUMP)
    if idx.size == 0:
        return np.zeros((0, 2))
    cuts = np.flatnonzero(np.diff(idx) > 1) + 1
    firsts, lasts = idx[np.r_[0, cuts]], idx[np.r_[cuts - 1, idx.size - 1]]
    spans = np.empty((firsts.size, 2))
    for k, (first, last) in enumerate(zip(firsts, lasts, strict=True)):
        lo = int(np.searchsorted(t_truth, t_truth[first] - CHANGE_LOOKBACK, side="right"))
        moved = np.flatnonzero(np.abs(a_truth[lo : first + 1] - back[first]) > CHANGE_ONSET)
        spans[k] = (t_truth[lo + int(moved[0])], t_truth[last] + CHANGE_WINDOW)  # first itself has moved
    return spans


def after_change(
    t: NDArray[np.float64], t_truth: NDArray[np.float64], a_truth: NDArray[np.float64]
) -> NDArray[np.bool_]:
    """True at each stamp of ``t`` inside a change of the truth, from its onset to CHANGE_WINDOW s after
    its last change sample (change_spans)."""
    t = np.asarray(t, dtype=np.float64)
    spans = change_spans(t_truth, a_truth)
    if spans.shape[0] == 0:
        return np.zeros(t.size, dtype=bool)
    idx = np.searchsorted(spans[:, 0], t, side="right") - 1
    reach = np.maximum.accumulate(spans[:, 1])  # spans may overlap: the furthest end so far
    return (idx >= 0) & (t <= reach[np.maximum(idx, 0)])


def change_rule() -> str:
    """The rule in one line, for reports: '|a(t) − a(t − 1 s)| > 0.2 m/s² on the truth, from its onset …'."""
    return (
        f"|a(t) − a(t − {CHANGE_LOOKBACK:g} s)| > {CHANGE_JUMP:g} m/s² on the truth, "
        f"from its onset (a moved by {CHANGE_ONSET:g} m/s²) to {CHANGE_WINDOW:g} s after"
    )
