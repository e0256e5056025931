"""``bag_recorder``: records the chain's topics, as raw CDR, into a rosbag2 MCAP bag (``bag.writer``).

Only its own chain: relative names and the chain's clock (``<ns>/clock`` in a namespaced chain) resolve
in the recorder's namespace, and of the global /diagnostics it keeps the statuses of nodes in that
namespace (a status is named by its node's full name), so two chains on one domain record apart.
Where tf2_msgs is installed it records the global /tf_static whole (the TF tree is shared: a chain's
frames hang from frames other nodes publish), transient local, as rosbag2 does for a topic whose
publishers all offer it, so the transforms sent before it started are in the bag; without tf2_msgs it
cannot subscribe to the type and says so (the estimator then states its transform in its log).

Subscriptions are raw (no deserialisation) and reliable keep-all, so a slow disk pushes back on the
publishers instead of losing messages. Log time is the message's own stamp by default (simulation
time, as ``pendulum-accel generate`` writes it), so a bag replays on the scene's timeline whatever
the pacing of the recording was. The bag starts at the chain's first angle: a message that arrives
before it (start-up diagnostics, the latched robot_description) is logged at that angle's stamp, its
own header stamp unchanged (rosbag2 logs a transient-local message at its receive time, which is
also no earlier than the recording's start). The first SIGINT/SIGTERM drains the queues, then the bag
is closed.
"""

from __future__ import annotations

import functools
import json
import os
import struct
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from rclpy.clock import Clock
from rclpy.clock_type import ClockType

from pendulum_accel import __version__
from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.metadata import complete_qos
from pendulum_accel.bag.writer import (
    CUSTOM_PLAN,
    CUSTOM_SCENE,
    CUSTOM_VERSION,
    BagWriter,
    Stream,
)
from pendulum_accel.errors import ParameterError
from pendulum_accel.nodes.accounting import CUSTOM_ACCOUNTING
from pendulum_accel.nodes.conversions import bag_qos, message_class, stamp_offset
from pendulum_accel.nodes.parameters import LOG_TIMES, RECORDER
from pendulum_accel.nodes.qos import TOPIC_TF_STATIC, make_subscription, qos_for
from pendulum_accel.nodes.runtime import ChainNode, declare_parameters, run_node, write_summary
from pendulum_accel.nodes.static_tf import TF_MESSAGE, tf_message_type

NODE_NAME = "bag_recorder"
_DRAIN_IDLE = 0.3  # s without any message after a stop request: the queues are empty
_DRAIN_LIMIT = 10.0  # s: close the bag even if messages keep coming
_STAMP = struct.Struct("<iI")  # builtin_interfaces/Time: int32 sec, uint32 nanosec (little-endian CDR)
_STAMP_DTYPE = np.dtype([("sec", "<i4"), ("nanosec", "<u4")])


def stamp_ns(data: bytes, offset: int) -> int:
    """ns = sec · 1e9 + nanosec read from the int32/uint32 pair at ``offset`` of a CDR payload."""
    # struct, not numpy: this runs for every recorded message, where numpy's per-call overhead dominates.
    sec, nanosec = _STAMP.unpack_from(data, offset)
    return int(sec) * 1_000_000_000 + int(nanosec)


def log_times(payloads: Sequence[bytes], offset: int) -> NDArray[np.int64]:
    """ns = sec · 1e9 + nanosec of each CDR payload's int32/uint32 pair at ``offset``: stamp_ns in bulk (each
    payload holds offset + 8 bytes)."""
    pairs = np.frombuffer(b"".join(p[offset : offset + _STAMP.size] for p in payloads), dtype=_STAMP_DTYPE)
    return pairs["sec"].astype(np.int64) * 1_000_000_000 + pairs["nanosec"].astype(np.int64)


def status_namespace(name: str) -> str:
    """The namespace of the node a DiagnosticStatus name gives, with or without the leading '/'
    ('car1/accel_estimator' and '/car1/accel_estimator' → '/car1'; a name without a '/' in its node part,
    such as diagnostic_updater's 'node: task', is taken as the root namespace '/')."""
    node = name.split(":", 1)[0].strip().strip("/")
    parent = node.rpartition("/")[0]
    return "/" + parent if parent else "/"


def topic_map(asked: Sequence[str], resolved: Sequence[str]) -> dict[str, str]:
    """{role: recorded name} of the chain roles among the ``asked`` topics, each under the name it resolved
    to (namespace and remaps applied): the map the offline commands read a remapped bag by."""
    out: dict[str, str] = {}
    for name, final in zip(asked, resolved, strict=True):
        role = bm.role_of(name)
        if role is not None and name.lstrip("/") == role.lstrip("/"):
            out[role] = final
    return out


def custom_data_for(scene_name: str) -> dict[str, str]:
    """Bag custom_data for a scene: its YAML and the planner's one-line explanation (empty name: none)."""
    if not scene_name:
        return {CUSTOM_VERSION: __version__}
    from pendulum_accel.planner import plan_scene
    from pendulum_accel.scene import load_scene, stored_scene_text

    scene = load_scene(scene_name)
    return {
        CUSTOM_SCENE: stored_scene_text(scene),
        CUSTOM_PLAN: plan_scene(scene).explain(),
        CUSTOM_VERSION: __version__,
    }


class RecorderNode(ChainNode):
    """Writes every message of the chosen topics to one bag; reports received/written counts on exit."""

    def __init__(self) -> None:
        """Declare parameters, create the bag (BagError if it exists and overwrite is false), subscribe."""
        super().__init__(NODE_NAME)
        values = declare_parameters(self, RECORDER)
        # ``path:=~/bags/run`` reaches a node past the shell unexpanded (no shell expands after ``:=``).
        path = os.path.expanduser(str(values["path"]))
        overwrite = bool(values["overwrite"])
        # Relative names resolve in this node's namespace and through its remaps, as the publishers' do;
        # the bag holds the resolved names.
        asked = [str(t) for t in values["topics"] if t]
        resolved = [self.resolve_topic_name(t) for t in asked]
        topics = list(dict.fromkeys(resolved))
        scene = str(values["scene"])
        self.chain_summaries = [str(f) for f in values["chain_summaries"] if f]
        self.summary_file = str(values["summary_file"])
        self.log_time = str(values["log_time"])
        if not path:
            raise ParameterError("parameter path (the bag directory to create) is required")
        if self.log_time not in LOG_TIMES:
            raise ParameterError(f"log_time must be one of {', '.join(LOG_TIMES)}, got {self.log_time!r}")
        # The type of a chain role, asked or resolved (a remap keeps the role of the name asked for);
        # any other name takes its type from the graph, as `ros2 bag record` does.
        types = {
            name: bm.topic_type(t) or bm.topic_type(name) for t, name in zip(asked, resolved, strict=True)
        }
        unknown = [t for t, msgtype in types.items() if msgtype is None]
        if unknown:
            types.update(self._graph_types(unknown))
        self.types: dict[str, str] = {t: str(msgtype) for t, msgtype in types.items()}
        if TOPIC_TF_STATIC not in topics:
            if tf_message_type() is not None:
                topics.append(TOPIC_TF_STATIC)
                self.types[TOPIC_TF_STATIC] = TF_MESSAGE
            else:
                self.get_logger().info(
                    f"{TOPIC_TF_STATIC} is not recorded: tf2_msgs is not installed (the ROS 2 PyPI wheels "
                    "have none), so its messages cannot be received"
                )
        custom_data = {**custom_data_for(scene), bm.CUSTOM_TOPICS: json.dumps(topic_map(asked, resolved))}
        self.holds_input()
        self.writer = BagWriter(Path(path), overwrite=overwrite, custom_data=custom_data, program=NODE_NAME)
        self.received: dict[str, int] = dict.fromkeys(topics, 0)
        self._offsets = {topic: stamp_offset(self.types[topic]) for topic in topics}
        self._first_stamp_ns: int | None = None
        self.foreign_statuses = 0  # /diagnostics statuses of nodes outside this namespace: not recorded
        # The bag starts at the chain's first angle (its first data sample): what comes before it
        # (diagnostics, the latched robot_description) waits here with its stamp, if it has one.
        angles = self.resolve_topic_name(bm.JOINT_STATES)
        self._start_topic = angles if angles in topics else None
        self._early: list[tuple[str, bytes, int | None]] = []

        # Messages wait here (log times, CDR payloads) until the next flush writes them in one bulk call:
        # a per-message write through rosbags cost more CPU than the rest of the recorder.
        self._pending: dict[str, tuple[list[int], list[bytes]]] = {topic: ([], []) for topic in topics}
        # The fast path (``_receiver``): once the bag has started and a topic is in it, a stamped message of
        # it is only appended here; the next write reads the stamps of all of them at once (log_times).
        self._raw: dict[str, list[bytes]] = {topic: [] for topic in topics}
        self._fast: dict[str, list[bool]] = {topic: [False] for topic in topics}
        self._raw_seen = 0  # fast-path messages counted so far: a change tells the drain that input goes on
        self._last_message = time.monotonic()
        self._stopping_since: float | None = None
        self._closed = False
        for topic in topics:
            make_subscription(
                self, message_class(self.types[topic]), topic, self._receiver(topic), qos_for(topic)
            )
        self.create_timer(0.1, self._tick, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(f"recording {len(topics)} topics to {path}")

    def _graph_types(self, names: Sequence[str], wait: float = 5.0) -> dict[str, str]:
        """{name: type} of topics outside the chain's roles, from the graph (waiting up to ``wait`` s for
        their publishers); ParameterError naming a topic no publisher offers."""
        deadline = time.monotonic() + wait
        while True:
            known = dict(self.get_topic_names_and_types())
            missing = [n for n in names if not known.get(n)]
            if not missing:
                return {n: known[n][0] for n in names}
            if time.monotonic() > deadline:
                raise ParameterError(
                    f"cannot record {missing[0]}: not one of the chain's topics "
                    f"({', '.join(bm.CHAIN_ROLES)}) and no publisher of it within {wait:g} s "
                    "to learn its type"
                )
            time.sleep(0.1)

    def _add_topic(self, topic: str) -> None:
        """Register ``topic`` in the bag with the QoS its publishers offer (the chain's if unknown); history
        and depth, which discovery does not carry, are the chain's when the rest matches."""
        chain = bag_qos(qos_for(topic))
        offered = [
            complete_qos(bag_qos(i.qos_profile), chain) for i in self.get_publishers_info_by_topic(topic)
        ]
        self.writer.add_topic(topic, self.types[topic], offered or [chain])

    def _receiver(self, topic: str) -> Callable[[bytes], None]:
        """The subscription callback of ``topic``: append the CDR to the topic's raw list when its fast path
        is on and the message holds a whole stamp, else ``_on_message``. This runs for every recorded
        message, so it does nothing else: stamps, counts and the drain's clock come in bulk at the next
        write."""
        raw = self._raw[topic].append
        fast = self._fast[topic]
        offset = self._offsets[topic]
        need = (offset or 0) + _STAMP.size
        slow = functools.partial(self._on_message, topic)

        def receive(data: bytes) -> None:
            if fast[0] and len(data) >= need:
                raw(data)
            else:
                slow(data)

        return receive

    def _fast_path_allowed(self, topic: str) -> bool:
        """True when every further message of ``topic`` that holds its stamp is logged at that stamp, as is:
        stamp log times, the bag started, the topic in it, a stamped type, not /diagnostics (filtered)."""
        return (
            self.log_time == "stamp"
            and self._first_stamp_ns is not None
            and self.received[topic] > 0
            and self._offsets[topic] is not None
            and self.types[topic] != bm.DIAGNOSTIC_ARRAY
        )

    def _on_message(self, topic: str, data: bytes) -> None:
        """Write one raw message at its stamp (or receive time); before the first angle, hold it."""
        self._last_message = time.monotonic()
        self._on_message_at(topic, data)
        if not self._closed and self._fast_path_allowed(topic):
            self._fast[topic][0] = True

    def _on_message_at(self, topic: str, data: bytes) -> None:
        """_on_message's body: queue the message at its log time (or hold it before the first angle)."""
        if self._closed:
            return
        if self.types[topic] == bm.DIAGNOSTIC_ARRAY:
            own = self._own_statuses(data)
            if own is None:
                return
            data = own
        if self.received[topic] == 0:
            self._add_topic(topic)
        self.received[topic] += 1
        offset = self._offsets[topic]
        stamped = offset is not None and len(data) >= offset + _STAMP.size
        if self.log_time == "stamp" and self._first_stamp_ns is None:
            stamp = stamp_ns(data, offset) if stamped and offset is not None else None
            starts = stamp is not None and (self._start_topic is None or topic == self._start_topic)
            if not starts:
                # Before the data (diagnostics at start-up, robot_description sent to every new
                # subscriber): logged at the first angle's stamp, so the bag starts with its data.
                self._early.append((topic, data, stamp))
                return
            assert stamp is not None
            self._first_stamp_ns = stamp
            for early_topic, early, early_stamp in self._early:
                self._queue(early_topic, max(stamp, early_stamp or stamp), early)
            self._early = []
            self._queue(topic, stamp, data)
        elif self.log_time == "stamp" and stamped and offset is not None:
            self._queue(topic, stamp_ns(data, offset), data)
        else:  # receive time, or an unstamped message later on: the node's clock, on the run's time base
            self._queue(topic, self.get_clock().now().nanoseconds, data)

    def _own_statuses(self, data: bytes) -> bytes | None:
        """The DiagnosticArray ``data`` with only the statuses of this namespace's nodes (as is when all are),
        None when none is; the others are counted in ``foreign_statuses``."""
        from diagnostic_msgs.msg import DiagnosticArray
        from rclpy.serialization import deserialize_message, serialize_message

        msg = deserialize_message(data, DiagnosticArray)
        namespace = self.get_namespace()
        own = [status for status in msg.status if status_namespace(status.name) == namespace]
        self.foreign_statuses += len(msg.status) - len(own)
        if len(own) == len(msg.status):
            return data
        if not own:
            return None
        msg.status = own
        return bytes(serialize_message(msg))

    def _queue(self, topic: str, log_ns: int, data: bytes) -> None:
        """Buffer one message for the next write at log time ``log_ns`` (clamped at 0)."""
        times, payloads = self._pending[topic]
        times.append(max(log_ns, 0))
        payloads.append(data)

    def _take_raw(self) -> int:
        """Count the fast path's messages as received, queue them at their stamps (clamped at 0); how many."""
        taken = 0
        for topic, raw in self._raw.items():
            if not raw:
                continue
            payloads = raw[:]  # emptied in place: the topic's receiver holds this very list's append
            raw.clear()
            offset = self._offsets[topic]
            assert offset is not None  # only stamped topics take the fast path
            times, queued = self._pending[topic]
            times.extend(np.maximum(log_times(payloads, offset), 0).tolist())
            queued.extend(payloads)
            self.received[topic] += len(payloads)
            taken += len(payloads)
        return taken

    def _write_pending(self) -> None:
        """Write every buffered message, merged by log time, and flush the file (BagWriter.write_sorted)."""
        self._take_raw()
        pending, self._pending = self._pending, {topic: ([], []) for topic in self._pending}
        streams = [
            Stream(topic, np.array(times, dtype=np.int64), payloads)
            for topic, (times, payloads) in pending.items()
            if times
        ]
        if streams:
            self.writer.write_sorted(streams)
        else:
            self.writer.flush()

    def _tick(self) -> None:
        """Write and flush when due (a kill loses at most ~1 s); during a stop, finish once drained."""
        if self._closed:
            return
        seen = sum(len(raw) for raw in self._raw.values()) + sum(self.received.values())
        if seen != self._raw_seen:  # the fast path took messages since the last tick
            self._raw_seen = seen
            self._last_message = time.monotonic()
        if self.writer.flush_due():
            try:
                self._write_pending()
            except OSError as err:
                self._write_failed(err)
                return
        if self._stopping_since is None:
            return
        now = time.monotonic()
        if now - self._last_message > _DRAIN_IDLE or now - self._stopping_since > _DRAIN_LIMIT:
            self.finish(0)

    def _chain_accounting(self) -> dict[str, object]:
        """{role: counters} from the other nodes' summary files (role = the file's stem); missing: absent."""
        out: dict[str, object] = {}
        for name in self.chain_summaries:
            path = Path(name)
            try:
                out[path.stem] = json.loads(path.read_text())
            except (OSError, ValueError) as err:
                self.get_logger().warning(f"no accounting from {path}: {err}")
        return out

    def request_stop(self) -> None:
        """Drain: keep recording until no message came for _DRAIN_IDLE since the later of the last message
        and this request (one deferred while the node was built comes before its first message), then
        finish."""
        self._stopping_since = time.monotonic()
        self._last_message = max(self._last_message, self._stopping_since)

    def _stop_fast_path(self) -> None:
        """Send every later message through _on_message, which drops it once the recorder is closed."""
        for flag in self._fast.values():
            flag[0] = False

    def _write_failed(self, err: OSError) -> None:
        """Disk full or unwritable: one error line, stop, exit 1; what was flushed stays salvageable."""
        self._closed = True
        self._stop_fast_path()
        self.get_logger().error(
            f"cannot write the bag {self.writer.path} ({err.strerror or err}): recording stopped; the bag "
            f"keeps what was flushed before and `pendulum-accel repair {self.writer.path}` makes it readable"
        )
        self.finish(1)

    def close(self) -> None:
        """Close the bag (final metadata.yaml) and report received/written counts per topic."""
        if self._closed:
            return
        self._closed = True
        self._stop_fast_path()
        self._take_raw()
        # The roles whose counters were expected: one missing from the accounting died without closing.
        expected = [Path(name).stem for name in self.chain_summaries]
        own = {
            "received": self.received,
            "written": dict(self.writer.counts),
            "expected": expected,
            "foreign_statuses": self.foreign_statuses,
        }
        now = self.get_clock().now().nanoseconds
        for topic, data, stamp in self._early:  # no angle ever came: log them at their stamp (or the clock)
            self._queue(topic, now if stamp is None else stamp, data)
        self._early = []
        try:
            self._write_pending()
            own["written"] = dict(self.writer.counts)
            accounting = {**self._chain_accounting(), "recorder": own}
            self.writer.custom_data[CUSTOM_ACCOUNTING] = json.dumps(accounting, sort_keys=True)
            written = self.writer.close()
        except OSError as err:
            self._closed = False
            self._write_failed(err)
            return
        write_summary(self.summary_file, own)
        for topic, count in self.received.items():
            print(
                f"{NODE_NAME}: {topic}: received {count}, written {written.get(topic, 0)}",
                flush=True,
            )
        print(f"{NODE_NAME}: bag closed: {self.writer.path}", flush=True)


def main(args: Sequence[str] | None = None) -> int:
    """Console script ``bag_recorder``: record until SIGINT/SIGTERM, then close the bag."""
    return run_node(RecorderNode, NODE_NAME, args)


if __name__ == "__main__":
    raise SystemExit(main())
