"""Every sample accounted for: the chain's per-node counters, compared topic by topic (no rclpy).

Each node writes its counters at exit (``summary_file``); the recorder stores them all in the bag
(custom_data ``pendulum_accel.accounting``). ``run`` prints the table below from them and
``info`` checks a bag's estimate stream against them: an angle without an estimate is explained
only by the estimator's own count of warm-up samples and dropped inputs.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from pendulum_accel.bag import messages as bm

CUSTOM_ACCOUNTING = "pendulum_accel.accounting"
"""custom_data key of the chain's accounting: {role: counters} as JSON."""

_EXPLAINED = (
    ("warmup", "estimator warm-up"),
    ("dropped_nonfinite", "dropped non-finite"),
    ("dropped_out_of_order", "dropped out-of-order"),
    ("dropped_wrong_joint", "dropped naming another joint"),
)


@dataclass
class Accounting:
    """The chain's counters: simulator, estimator and recorder summaries (each may be missing)."""

    simulator: Mapping[str, Any] = field(default_factory=dict)
    estimator: Mapping[str, Any] = field(default_factory=dict)
    recorder: Mapping[str, Any] = field(default_factory=dict)
    chain: Mapping[str, Any] = field(default_factory=dict)
    """How the launcher saw the chain end: {"ended": "finished" | "interrupted" | "node died", "died", "how"}
    (chain.json, which the launcher writes before it stops the nodes)."""

    @classmethod
    def from_json(cls, text: str) -> Accounting:
        """Accounting from the custom_data JSON ({role: counters})."""
        data = json.loads(text)
        return cls(
            data.get("simulator", {}),
            data.get("estimator", {}),
            data.get("recorder", {}),
            data.get("chain", {}),
        )

    def ending(self) -> str | None:
        """Why the recording is not the whole run, one phrase; None when the chain ended as planned.

        A node died (the launcher's word, or an expected role that left no counters: a killed node writes
        none), or the run was interrupted before the scene's end.
        """
        if self.chain.get("died"):
            how = self.chain.get("how", "unknown cause")
            return f"the chain stopped because the {self.chain['died']} died ({how})"
        # The launcher writes chain.json, the nodes their counters; role names as the user knows them.
        roles = {"simulator": self.simulator, "estimator": self.estimator, "launcher": self.chain}
        expected = ["launcher" if r == "chain" else r for r in self.recorder.get("expected", [])]
        silent = [r for r in expected if r in roles and not roles[r]]
        if silent:
            return f"the {' and the '.join(silent)} left no counters: died before the recording ended"
        if self.chain.get("ended") == "interrupted":
            return "the run was interrupted before the scene's end"
        return None

    def published(self, topic: str) -> int | None:
        """Messages the chain published on ``topic``'s role (simulator's topics, the estimator's outputs),
        whatever namespace the chain ran in."""
        role = bm.role_of(topic)
        if role in (bm.ACCEL_ESTIMATE, bm.IMU_DATA_RAW) and self.estimator:
            return int(self.estimator["estimates"])
        return _by_role(self.simulator.get("published", {}), role)

    def recorded(self, topic: str) -> int | None:
        """Messages the recorder wrote on ``topic``'s role (the bag holds the resolved names)."""
        return _by_role(self.recorder.get("written", {}), bm.role_of(topic))

    def shown_name(self, topic: str) -> str:
        """The name ``topic``'s role had in this run (``/car1/pendulum/joint_states`` in a namespaced chain):
        the recorder's or the simulator's resolved name for it, else ``topic`` as given."""
        role = bm.role_of(topic)
        for counts in (self.recorder.get("written", {}), self.simulator.get("published", {})):
            for name in counts:
                if role is not None and bm.role_of(name) == role:
                    return str(name)
        return topic

    def explained_without_estimate(self) -> int:
        """Angles the estimator received that rightly have no estimate: warm-up plus dropped inputs."""
        return sum(int(self.estimator.get(key, 0)) for key, _ in _EXPLAINED)

    def reasons(self) -> str:
        """'estimator warm-up 12, dropped non-finite 1' (the non-zero reasons), or ''."""
        return ", ".join(
            f"{text} {int(self.estimator.get(key, 0))}" for key, text in _EXPLAINED if self.estimator.get(key)
        )

    def table(self) -> list[str]:
        """Per topic: published / received by the estimator / estimated / recorded, and why they differ.
        The topic column is as wide as its longest name (24 at least), so a namespaced chain's long names
        keep the count columns aligned under their headers."""
        topics = [
            t
            for t in (*bm.TOPIC_TYPES, bm.TOPIC_IMU)
            if t != bm.TOPIC_DIAGNOSTICS and (self.published(t) is not None or self.recorded(t) is not None)
        ]
        w = max([24, *(len(self.shown_name(t)) for t in topics)])
        lines = [f"  {'topic':<{w}} {'published':>9} {'est. in':>8} {'estimated':>9} {'recorded':>9}  notes"]
        for topic in topics:
            published, recorded = self.published(topic), self.recorded(topic)
            received = estimated = "-"
            notes = []
            if topic == bm.TOPIC_JOINT_STATES and self.estimator:
                received, estimated = str(self.estimator["inputs"]), str(self.estimator["estimates"])
                if self.reasons():
                    notes.append(f"no estimate: {self.reasons()}")
            name = self.shown_name(topic)
            lines.append(
                f"  {name:<{w}} {_text(published):>9} {received:>8} {estimated:>9} {_text(recorded):>9}  "
                + "; ".join(notes)
            )
        return lines

    def unrecorded(self) -> list[str]:
        """What the publishers' counters say the bag lacks, a phrase each (empty: nothing, or no counters)."""
        out: list[str] = []
        angles = self.published(bm.TOPIC_JOINT_STATES)
        if self.estimator and angles is not None and int(self.estimator["inputs"]) < angles:
            out.append(f"the estimator missed {angles - int(self.estimator['inputs'])} of {angles} angles")
        for topic in (*bm.TOPIC_TYPES, bm.TOPIC_IMU):
            published, recorded = self.published(topic), self.recorded(topic)
            if published is not None and recorded is not None and recorded < published:
                out.append(
                    f"{self.shown_name(topic)}: {published - recorded} of {published} published not recorded"
                )
        return out

    @property
    def publishers_counted(self) -> bool:
        """True when the publishers (simulator or estimator) left counters to check the bag against."""
        return bool(self.simulator or self.estimator)

    def losses(self, recording: bool) -> list[str]:
        """Every sample lost or missed, one phrase each (empty: all accounted for)."""
        out: list[str] = []
        angles = self.published(bm.TOPIC_JOINT_STATES)
        if self.estimator and angles is not None and int(self.estimator["inputs"]) < angles:
            out.append(f"the estimator missed {angles - int(self.estimator['inputs'])} of {angles} angles")
        if self.estimator.get("unpublished"):
            out.append(f"{self.estimator['unpublished']} estimates were computed but not published")
        if not self.simulator:
            out.append("the simulator left no counters")
        if not self.estimator:
            out.append("the estimator left no counters")
        if recording:
            if not self.recorder:
                out.append("the recorder left no counters")
            for topic in (*bm.TOPIC_TYPES, bm.TOPIC_IMU):
                published, recorded = self.published(topic), self.recorded(topic)
                if published is not None and (recorded or 0) < published:
                    out.append(
                        f"{self.shown_name(topic)}: {published - (recorded or 0)} of {published} not recorded"
                    )
        for topic in self.simulator.get("unacknowledged", []):
            out.append(f"{topic}: a reader did not acknowledge within 10 s")
        return out


def _by_role(counts: Mapping[str, Any], role: str | None) -> int | None:
    """The count of the topic in ``counts`` (resolved name -> count) that plays ``role``; None if none."""
    for name, value in counts.items():
        if role is not None and bm.role_of(name) == role:
            return int(value)
    return None


def _text(count: int | None) -> str:
    """The count, or '-' when unknown."""
    return "-" if count is None else str(count)


def unexplained_missing(
    angles: int, estimates: int, accounting: Accounting | None, holes_after_first: int
) -> int:
    """Angles in a bag without an estimate that nothing explains.

    With the chain's accounting: angles − estimates − (the estimator's warm-up + dropped inputs).
    Without it (a bag from ``generate`` or an older recorder): the holes after the first estimate
    (leading samples are taken as warm-up, which such a bag cannot tell from a late start).
    """
    if accounting is None or not accounting.estimator:
        return holes_after_first
    return max(angles - estimates - accounting.explained_without_estimate(), 0)
