"""Every sample accounted for: the chain's per-node counters, compared topic by topic (no rclpy).

Each node writes its counters at exit (``summary_file``); the recorder stores them all in the bag
(custom_data ``pendulum_accel.accounting``). ``run`` prints the table below from them and
``info`` checks a bag's estimate stream against them: an angle without an estimate is explained
only by the estimator's own count of warm-up samples and dropped inputs.

The counters name each topic as its node resolved it (a namespace and remaps applied), so a publisher's
count and the recorder's meet under one name whatever it is; a role (the angles, the estimate) is found
through the run's topic map (``roles``: the launcher's, or the one a recording stores), and only without
one by the name's ending (bags of older recorders).
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

    # Any: each node's summary JSON as the node wrote it (counts, flags, names), read by key.
    simulator: Mapping[str, Any] = field(default_factory=dict)
    estimator: Mapping[str, Any] = field(default_factory=dict)
    recorder: Mapping[str, Any] = field(default_factory=dict)
    chain: Mapping[str, Any] = field(default_factory=dict)
    """How the launcher saw the chain end: {"ended": "finished" | "interrupted" | "node died", "died", "how"}
    (chain.json, which the launcher writes before it stops the nodes)."""
    roles: Mapping[str, str] = field(default_factory=dict)
    """{chain role: the topic name it had in this run}: the launcher's map of the publishers' resolved
    names, or a recording's stored map (messages.CUSTOM_TOPICS)."""

    @classmethod
    def from_json(cls, text: str, roles: Mapping[str, str] | None = None) -> Accounting:
        """Accounting from the custom_data JSON ({role: counters}), with the recording's topic map."""
        data = json.loads(text)
        return cls(
            data.get("simulator", {}),
            data.get("estimator", {}),
            data.get("recorder", {}),
            data.get("chain", {}),
            dict(roles or {}),
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

    def name_of(self, role: str | None) -> str | None:
        """The name ``role`` had in this run: the topic map's (``/angles`` after a remap, ``/car1/…`` in a
        namespace), else the counted name that ends with the role; None when neither says."""
        if role is None:
            return None
        if role in self.roles:
            return self.roles[role]
        for counts in (self.recorder.get("written", {}), self.simulator.get("published", {})):
            for name in counts:
                if bm.role_of(str(name)) == role:
                    return str(name)
        return None

    def published(self, topic: str) -> int | None:
        """Messages the chain published on ``topic``'s role (given by its root name, /pendulum/joint_states):
        the estimator's count for its outputs, the simulator's for the others, under whatever name the role
        had in this run."""
        role = bm.role_of(topic)
        if role in (bm.ACCEL_ESTIMATE, bm.IMU_DATA_RAW) and self.estimator:
            return int(self.estimator["estimates"])
        return _count(self.simulator.get("published", {}), self.name_of(role))

    def recorded(self, topic: str) -> int | None:
        """Messages the recorder wrote on ``topic``'s role, under the name the role had in this run."""
        return _count(self.recorder.get("written", {}), self.name_of(bm.role_of(topic)))

    def shown_name(self, topic: str) -> str:
        """The name ``topic``'s role had in this run (``/car1/pendulum/joint_states`` in a namespaced chain,
        ``/angles`` after a remap), else ``topic`` as given."""
        return self.name_of(bm.role_of(topic)) or topic

    def _roleless(self) -> list[str]:
        """Names the simulator counted that no role of the table is known by (a map that misses one): still
        compared with the recorder's count under the same name, so no loss goes unseen."""
        named = {self.name_of(bm.role_of(t)) for t in _TABLE_TOPICS}
        return [str(n) for n in self.simulator.get("published", {}) if n not in named]

    def _compared(self, topic: str) -> tuple[int | None, int | None]:
        """(published, recorded) of a table topic (a root name, by its role) or of a name _roleless gave."""
        if topic in _TABLE_TOPICS:
            return self.published(topic), self.recorded(topic)
        return _count(self.simulator.get("published", {}), topic), _count(
            self.recorder.get("written", {}), topic
        )

    def held_short(self, held: Mapping[str, int]) -> list[str]:
        """'the recorder wrote 7942 /pendulum/joint_states messages, the bag holds 2461', one per topic of
        which the bag (``held``: name -> messages it holds) has fewer than the recorder wrote: messages lost
        after they were written (the file moved or replaced while it was recorded)."""
        written = self.recorder.get("written", {})
        return [
            f"the recorder wrote {int(n)} {name} messages, the bag holds {held.get(name, 0)}"
            for name, n in written.items()
            if held.get(name, 0) < int(n)
        ]

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
        topics = [t for t in _TABLE_TOPICS if self.published(t) is not None or self.recorded(t) is not None]
        rows = [*topics, *self._roleless()]
        w = max([24, *(len(self.shown_name(t)) for t in rows)])
        lines = [f"  {'topic':<{w}} {'published':>9} {'est. in':>8} {'estimated':>9} {'recorded':>9}  notes"]
        for topic in rows:
            published, recorded = self._compared(topic)
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
        for topic in [*_TABLE_TOPICS, *self._roleless()]:
            published, recorded = self._compared(topic)
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
            for topic in [*_TABLE_TOPICS, *self._roleless()]:
                published, recorded = self._compared(topic)
                if published is not None and (recorded or 0) < published:
                    out.append(
                        f"{self.shown_name(topic)}: {published - (recorded or 0)} of {published} not recorded"
                    )
        for topic in self.simulator.get("unacknowledged", []):
            out.append(f"{topic}: a reader did not acknowledge within 10 s")
        return out


_TABLE_TOPICS = tuple(t for t in (*bm.TOPIC_TYPES, bm.TOPIC_IMU) if t != bm.TOPIC_DIAGNOSTICS)
"""The roles the table and the losses compare, by root name (the diagnostics follow the wall clock)."""


# Any: a summary's counts, JSON numbers read back (int() makes them counts).
def _count(counts: Mapping[str, Any], name: str | None) -> int | None:
    """The count ``counts`` (resolved name -> count) holds for ``name``; None if none."""
    return int(counts[name]) if name is not None and name in counts else None


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
