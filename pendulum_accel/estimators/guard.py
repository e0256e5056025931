"""Input guard and health state machine for an estimator — ROS-free; the node maps it to /diagnostics.

Each input sample gets a decision:

* ACCEPT — finite θ, t later than the last accepted t;
* DROP   — NaN/inf θ or t (state ERROR), a sample that is not the pendulum's angle by
  ``joint_state_problem`` (no pendulum joint among its names, another frame: state ERROR), or t ≤ last t by
  less than ``reset_jump`` (a small reorder or a duplicate, state WARN);
* RESET  — t jumped back by more than ``reset_jump`` (a looping bag): the estimator must restart
  (state RESET), then the sample is used.

|θ| ≥ ``warn_angle`` is accepted but ill-conditioned (da/dθ = g sec²θ explodes near 90°): state WARN.
|θ| ≥ ``saturation_range`` (the sensor's measurement range, when it has one) is accepted but the
reading is clipped, not measured: state WARN "saturated", counted in ``saturated``.
``check_stale(now)`` (called by the node on a timer) turns the state STALE when no input arrived
for ``stale_after`` seconds. ``report()`` returns the worst state since the previous report, so a
single dropped NaN between two diagnostics publications is still seen. It also measures the input's
rate from its stamps and its angle noise from their third differences, and warns when either is not what
the node was configured with (``rate_hz`` within RATE_TOLERANCE, ``noise_std`` within NOISE_FACTOR).
"""

from __future__ import annotations

import enum
import math
import statistics
from collections import deque
from collections.abc import Sequence
from dataclasses import dataclass

from pendulum_accel.bag.messages import FRAME_ID, PENDULUM_JOINT
from pendulum_accel.errors import ParameterError
from pendulum_accel.estimators.base import MIN_NOISE_STD, Estimate, Estimator
from pendulum_accel.physics.params import require_finite, require_positive
from pendulum_accel.sensor import noise_from_differences

RATE_WINDOW = 64
"""Sample intervals the measured input rate is taken over: 1 / their median, so sporadic losses (up to
half the window) and jitter leave it at the sensor's rate."""

RATE_TOLERANCE = 0.1
"""Relative mismatch of the measured input rate and ``rate_hz`` that warns: diagnostic_updater's
FrequencyStatus default tolerance."""

NOISE_WINDOW = 256
"""Third differences of the last accepted angles the measured angle noise is taken over (its robust
scale has a ~7 % standard error there)."""

NOISE_MIN_DIFFERENCES = 32
"""Third differences before the angle noise is shown (its robust scale has a ~18 % standard error there)."""

NOISE_FACTOR = 2.0
"""Ratio of the measured angle noise to ``noise_std`` (either way) that warns: the published variance's
noise part is then off by 4× or more, far beyond the measurement's own error."""


def frame_problem(frame_id: str, frame: str = FRAME_ID) -> str | None:
    """None when ``frame_id`` is ``frame`` (the chain's, FRAME_ID; a real sensor's angles may carry their
    own, the node's ``joint_frame_id``) or none, else why the message is not the chain's."""
    if frame_id in (frame, ""):
        return None
    return f"frame_id {str(frame_id)[:40]!r}, not {frame!r}"


def joint_state_problem(
    names: Sequence[str] | None,
    frame_id: str | None = None,
    joint: str = PENDULUM_JOINT,
    frame: str = FRAME_ID,
) -> str | None:
    """None when a JointState carries the pendulum's angle, else why not (a phrase): the one rule of the
    estimator node (per message) and of the offline commands (per bag).

    The pendulum's: ``names`` None or empty (a bare angle) or naming ``joint`` among any others (robots
    aggregate their joints in one message: θ is taken by name, the other joints are ignored);
    ``frame_id`` None (not known), none ('') or ``frame``. Joints without the pendulum's are another
    robot's JointState on the topic: which position is θ would be a guess.
    """
    if names and joint not in names:
        shown = ", ".join(repr(str(n)[:40]) for n in list(names)[:3])
        more = f" (+{len(names) - 3} more)" if len(names) > 3 else ""
        return f"names joint(s) {shown}{more}, not {joint!r}"
    return None if frame_id is None else frame_problem(frame_id, frame)


class GuardState(enum.Enum):
    """Health of the input stream; ``level`` is the diagnostic_msgs/DiagnosticStatus level byte."""

    OK = "OK"
    WARN = "WARN"
    RESET = "RESET"
    ERROR = "ERROR"
    STALE = "STALE"

    @property
    def level(self) -> int:
        """DiagnosticStatus level: OK 0, WARN 1, ERROR 2, STALE 3; RESET is reported as WARN (1)."""
        return {"OK": 0, "WARN": 1, "RESET": 1, "ERROR": 2, "STALE": 3}[self.value]

    @property
    def rank(self) -> int:
        """Severity used to keep the worst state between reports: OK < WARN < RESET < ERROR < STALE."""
        return ("OK", "WARN", "RESET", "ERROR", "STALE").index(self.value)


class Decision(enum.Enum):
    """What the caller does with one sample."""

    ACCEPT = "accept"
    DROP = "drop"
    RESET = "reset"


@dataclass(frozen=True)
class GuardReport:
    """One diagnostic: state, a one-line message, and (key, value) strings for diagnostic_msgs/KeyValue."""

    state: GuardState
    message: str
    values: tuple[tuple[str, str], ...]

    @property
    def level(self) -> int:
        """The DiagnosticStatus level byte of ``state``."""
        return self.state.level


class InputGuard:
    """Screens (t, θ) samples and tracks OK/WARN/ERROR/STALE/RESET with counters.

    ``warn_angle`` (rad, default 80°) starts the ill-conditioned warning; ``reset_jump`` (s, default
    1 s) separates a dropped reorder from a reset; ``stale_after`` (s) defaults to 20 sample periods
    but at least 0.5 s. ``now`` arguments are arrival times on any monotonic clock (the node uses
    its steady clock, and check_stale must get the same clock); without them the sample time t is used.
    """

    def __init__(
        self,
        *,
        rate_hz: float = 200.0,
        warn_angle: float = math.radians(80.0),
        reset_jump: float = 1.0,
        stale_after: float | None = None,
        saturation_range: float = 0.0,
        joint: str = PENDULUM_JOINT,
        noise_std: float | None = None,
        joint_frame: str = FRAME_ID,
    ) -> None:
        """Validate the thresholds (saturation_range 0: the sensor has no range); start with no input seen.
        ``joint``: the name a sample must carry, ``joint_frame`` the frame it may carry besides none;
        ``noise_std``: the angle noise the estimator assumes (rad),
        checked against the angles' own (None: not checked)."""
        self.rate_hz = rate_hz
        self._intervals: deque[float] = deque(maxlen=RATE_WINDOW)  # the last accepted samples' Δt
        self.noise_std = noise_std
        self._angles: deque[float] = deque(maxlen=4)  # the last accepted θ, for their third difference
        self._third: deque[float] = deque(maxlen=NOISE_WINDOW)
        self.warn_angle = require_positive("warn_angle", warn_angle)
        self.reset_jump = require_positive("reset_jump", reset_jump)
        self.saturation_range = require_finite("saturation_range", saturation_range)
        if self.saturation_range < 0.0:
            raise ParameterError(f"saturation_range must be >= 0 rad, got {saturation_range!r}")
        self.saturated = 0
        self._stale_after = None if stale_after is None else require_positive("stale_after", stale_after)
        self.accepted = 0
        self.dropped_nonfinite = 0
        self.dropped_out_of_order = 0
        self.dropped_wrong_joint = 0
        self.ignored_joints = 0  # values of other joints in the pendulum's messages, not used
        self.joint = joint
        self.joint_frame = joint_frame
        self.resets = 0
        self.ill_conditioned = 0
        self.last_t: float | None = None
        self.last_theta: float | None = None
        self._last_arrival: float | None = None
        self._first_check: float | None = None
        self._stale_for: float | None = None
        self._worst = GuardState.OK
        self._worst_message = ""

    @property
    def rate_hz(self) -> float:
        """The input rate the estimator was configured for (Hz)."""
        return self._rate_hz

    @rate_hz.setter
    def rate_hz(self, value: float) -> None:
        """Validate it: the rate and stale checks divide by it."""
        self._rate_hz = require_positive("rate_hz", value)

    @property
    def stale_after(self) -> float:
        """The silence (s) that turns the state STALE: as given, else max(0.5, 20 / rate_hz), so it
        follows a rate_hz changed after construction (a node's parameter)."""
        return max(0.5, 20.0 / self._rate_hz) if self._stale_after is None else self._stale_after

    def note(self, state: GuardState, message: str) -> None:
        """Latch ``state`` if it is worse than what was seen since the last report."""
        if state.rank >= self._worst.rank:
            self._worst, self._worst_message = state, message

    def check(
        self,
        t: float,
        theta: float,
        now: float | None = None,
        names: Sequence[str] | None = None,
        frame_id: str | None = None,
    ) -> Decision:
        """ACCEPT, DROP (non-finite, not the pendulum's, reorder, duplicate) or RESET (t back > reset_jump).

        ``names``, ``frame_id``: the sample's joint names and frame (None: not known); a sample that
        ``joint_state_problem`` refuses is dropped and counted in ``dropped_wrong_joint``.
        """
        arrival = now if now is not None else t
        if math.isfinite(arrival):
            self._last_arrival = arrival
            self._stale_for = None
        problem = joint_state_problem(names, frame_id, self.joint, self.joint_frame)
        if problem is not None:
            self.dropped_wrong_joint += 1
            self.note(GuardState.ERROR, f"dropped input: {problem}")
            return Decision.DROP
        if names and len(names) > 1:
            self.ignored_joints += len(names) - 1
        if not (math.isfinite(t) and math.isfinite(theta)):
            self.dropped_nonfinite += 1
            self.note(GuardState.ERROR, f"dropped non-finite input t={t!r}, θ={theta!r}")
            return Decision.DROP
        decision = Decision.ACCEPT
        if self.last_t is not None and t <= self.last_t:
            back = self.last_t - t
            if back <= self.reset_jump:
                self.dropped_out_of_order += 1
                self.note(GuardState.WARN, f"dropped out-of-order sample t={t:.6f} s ({back:.6f} s back)")
                return Decision.DROP
            self.resets += 1
            self.note(GuardState.RESET, f"time jumped back by {back:.3f} s to t={t:.3f} s: estimator reset")
            decision = Decision.RESET
        if abs(theta) >= self.warn_angle:
            self.ill_conditioned += 1
            deg = math.degrees(abs(theta))
            why = "tan θ undefined, angle clamped" if abs(theta) >= math.pi / 2 else "ill-conditioned"
            self.note(GuardState.WARN, f"|θ| = {deg:.1f}° near 90°: {why}")
        if 0.0 < self.saturation_range <= abs(theta):
            self.saturated += 1
            self.note(
                GuardState.WARN,
                f"saturated: θ = {theta:+.4f} rad at the sensor's range ±{self.saturation_range:g} rad "
                f"({self.saturated} samples so far)",
            )
        if decision is Decision.ACCEPT and self.last_t is not None:
            self._intervals.append(t - self.last_t)
        if decision is Decision.RESET:
            self._angles.clear()  # a jump back: no difference across it
        self._angles.append(theta)
        if len(self._angles) == 4:
            a0, a1, a2, a3 = self._angles
            self._third.append(a3 - 3.0 * a2 + 3.0 * a1 - a0)
        self.accepted += 1
        self.last_t, self.last_theta = t, theta
        return decision

    def input_rate(self) -> float | None:
        """1 / median Δt of the last RATE_WINDOW accepted samples, or of those so far (Hz); None before
        two."""
        if not self._intervals:
            return None
        return 1.0 / statistics.median(self._intervals)

    def angle_noise(self) -> float | None:
        """The angle noise σ (rad) of the last NOISE_WINDOW third differences (sensor.noise_from_differences);
        None before NOISE_MIN_DIFFERENCES."""
        if len(self._third) < NOISE_MIN_DIFFERENCES:
            return None
        return noise_from_differences(list(self._third))

    def _check_noise(self, measured: float | None) -> None:
        """WARN when ``measured`` (angle_noise()) over a full window is not noise_std within NOISE_FACTOR
        either way (a measured 0, a quantised angle at rest, says nothing of the noise and is not checked)."""
        if self.noise_std is None or len(self._third) < NOISE_WINDOW:
            return
        assumed = max(self.noise_std, MIN_NOISE_STD)
        if measured and not 1.0 / NOISE_FACTOR <= measured / assumed <= NOISE_FACTOR:
            self.note(
                GuardState.WARN,
                f"angle noise {measured:.3g} rad by the angles' third differences, not noise_std "
                f"{self.noise_std:g} rad: set noise_std (the published variance assumes it)",
            )

    def _check_rate(self, rate: float | None) -> None:
        """WARN when ``rate`` (input_rate()) over a full window is not rate_hz within RATE_TOLERANCE."""
        if len(self._intervals) < RATE_WINDOW:
            return
        if rate is not None and abs(rate / self.rate_hz - 1.0) > RATE_TOLERANCE:
            self.note(
                GuardState.WARN,
                f"input at {rate:.4g} Hz by its stamps, not rate_hz {self.rate_hz:g} Hz: set rate_hz "
                "(the fixed lag's length in samples and the stale limit assume it)",
            )

    def check_stale(self, now: float, last_arrival: float | None = None) -> bool:
        """True (and state STALE) when no input arrived for more than stale_after seconds before ``now``.

        ``last_arrival``: when the latest input arrived, if the caller knows better than the samples
        checked so far (a node working off a backlog took later ones already): staleness is the input's
        silence, not the estimator's."""
        if self._first_check is None:
            self._first_check = now
        arrivals = [a for a in (self._last_arrival, last_arrival) if a is not None]
        since = now - max(arrivals, default=self._first_check)
        if since > self.stale_after:
            self._stale_for = since
            self.note(GuardState.STALE, f"no input for {since:.2f} s (limit {self.stale_after:.2f} s)")
            return True
        return False

    def values(self) -> tuple[tuple[str, str], ...]:
        """Counters and the last sample as (key, value) strings."""
        return self._values(self.input_rate(), self.angle_noise())

    def _values(self, rate: float | None, noise: float | None) -> tuple[tuple[str, str], ...]:
        """values() with input_rate() and angle_noise() taken already (report: one median each)."""

        def fmt(x: float | None) -> str:
            """'none' or x with 6 significant digits."""
            return "none" if x is None else f"{x:.6g}"

        return (
            ("accepted", str(self.accepted)),
            ("dropped_nonfinite", str(self.dropped_nonfinite)),
            ("dropped_out_of_order", str(self.dropped_out_of_order)),
            ("dropped_wrong_joint", str(self.dropped_wrong_joint)),
            ("ignored_joints", str(self.ignored_joints)),
            ("resets", str(self.resets)),
            ("ill_conditioned", str(self.ill_conditioned)),
            ("saturated", str(self.saturated)),
            ("last_t", fmt(self.last_t)),
            ("last_theta", fmt(self.last_theta)),
            ("stale_for_s", fmt(self._stale_for)),
            ("input_rate_hz", fmt(rate)),
            ("angle_noise_rad", fmt(noise)),
        )

    def report(self) -> GuardReport:
        """The worst state since the previous report, then re-arm (check_stale re-raises STALE each tick)."""
        rate, noise = self.input_rate(), self.angle_noise()
        self._check_rate(rate)
        self._check_noise(noise)
        state, message = self._worst, self._worst_message
        if state is GuardState.OK:
            message = f"input normal: {self.accepted} samples accepted"
        report = GuardReport(state, message, self._values(rate, noise))
        self._worst, self._worst_message = GuardState.OK, ""
        return report


class GuardedEstimator:
    """InputGuard in front of an Estimator: drops bad input, resets on a jump back, never yields NaN/inf."""

    def __init__(self, estimator: Estimator, guard: InputGuard | None = None) -> None:
        """Wrap ``estimator``; a default InputGuard at the estimator's nominal rate when none is given."""
        self.estimator = estimator
        self.guard = guard if guard is not None else InputGuard(rate_hz=estimator.config.rate_hz)

    def update(
        self,
        t: float,
        theta: float,
        now: float | None = None,
        names: Sequence[str] | None = None,
        frame_id: str | None = None,
    ) -> Estimate | None:
        """Guard the sample (``names``, ``frame_id``: see InputGuard.check), then estimator.update."""
        decision = self.guard.check(t, theta, now, names, frame_id)
        if decision is Decision.DROP:
            return None
        if decision is Decision.RESET:
            self.estimator.reset()
        estimate = self.estimator.update(t, theta)
        if estimate is None:
            return None
        if not (math.isfinite(estimate.a) and math.isfinite(estimate.variance)):
            self.guard.note(GuardState.ERROR, "estimator produced a non-finite value: dropped and reset")
            self.estimator.reset()
            return None
        return estimate

    def reset(self) -> None:
        """Reset the estimator (the guard's counters are kept)."""
        self.estimator.reset()
