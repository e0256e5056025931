"""``bag_player``: publishes a bag's messages (raw CDR) with their original timing, under ros2 bag play's
controls.

Options: ``rate`` factor (settable while playing), ``start_paused``, ``loop`` (the stamps jump back at
each pass, which the estimator sees as a reset), ``start_offset``, ``playback_duration`` and
``playback_until``, ``delay`` before each pass, topic include/exclude lists and regular expressions,
and ``clock``: publish /clock from the bag's log time (the recorded /clock, if any, is then not
replayed). Topics are remapped the ROS way, ``--ros-args -r /old:=/new`` (what ``ros2 bag play
--remap`` passes on). Controls, named as rosbag2's player names them but with standard types
(rosbag2_interfaces is not available everywhere):

* ``~/pause``, ``~/resume``, ``~/toggle_paused``, ``~/play_next`` (std_srvs/Trigger);
* ``~/is_paused`` (Trigger: message "true" or "false");
* ``~/set_rate`` / ``~/get_rate``: the ``rate`` parameter (rcl_interfaces SetParameters/GetParameters);
* ``~/burst`` (Trigger) plays ``burst_size`` messages (a parameter; 0: the rest of the bag);
* ``~/seek`` (Trigger) goes to the bag time in the ``seek_time`` parameter, forwards or backwards;
* keys when stdin is a terminal: space pause/resume, → play next, ↑/↓ rate ±0.1 (rosbag2's steps).
"""

from __future__ import annotations

import contextlib
import os
import re
import select
import sys
import termios
import threading
import tty
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import numpy as np
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock
from rclpy.clock_type import ClockType
from rclpy.parameter import Parameter
from std_srvs.srv import Trigger

from pendulum_accel.bag import messages as bm
from pendulum_accel.bag.errors import NotIndexedError
from pendulum_accel.bag.playback import ArrayTimeline, Playback, Taken, Timeline
from pendulum_accel.bag.reader import Bag, read_bag, salvage_note, stored_choice
from pendulum_accel.bag.stream import StreamedBag
from pendulum_accel.errors import ParameterError, PendulumAccelError
from pendulum_accel.nodes.conversions import message_class
from pendulum_accel.nodes.graph import missing_readers, node_names
from pendulum_accel.nodes.parameters import PLAYER
from pendulum_accel.nodes.qos import AnyPublisher, make_publisher, qos_for
from pendulum_accel.nodes.runtime import (
    AnyParameter,
    ThreadedNode,
    acked_within,
    declare_parameters,
    publish_blocking,
    run_node,
)

NODE_NAME = "bag_player"
_ACK_TIMEOUT_S = 10.0
READY_WAIT_S = 5.0
"""s play_next and burst wait for the readers playing waits for before they answer that they are not there:
a message published before a volatile reader matched never reaches it (rosbag2's play_next waits too)."""
RATE_STEP = 0.1
"""↑/↓ change the rate by this much, as rosbag2's keyboard controls do (get_rate() ± 0.1)."""
KEY_PAUSE = b" "
KEY_NEXT = b"\x1b[C"
KEY_FASTER = b"\x1b[A"
KEY_SLOWER = b"\x1b[B"


def select_topics(
    available: Sequence[str],
    topics: Sequence[str],
    include_regex: str,
    exclude_topics: Sequence[str],
    exclude_regex: str,
) -> list[str]:
    """Topics to play, in bag order: in ``topics`` (all when empty) and matching ``include_regex``, not
    in ``exclude_topics`` nor matching ``exclude_regex``; ParameterError for an unknown topic or bad regex."""
    missing = [t for t in topics if t not in available]
    if missing:
        raise ParameterError(f"the bag has no topic {missing[0]} (it has {', '.join(available)})")
    try:
        include = re.compile(include_regex) if include_regex else None
        exclude = re.compile(exclude_regex) if exclude_regex else None
    except re.error as err:
        raise ParameterError(f"bad topic regular expression: {err}") from None
    return [
        t
        for t in available
        if (not topics or t in topics)
        and (include is None or include.search(t))
        and t not in exclude_topics
        and (exclude is None or not exclude.search(t))
    ]


class StreamTimeline:
    """A Timeline over a StreamedBag: the messages of ``topics`` in [first, last], one chunk decoded at a
    time; seeking restarts the chunk-index reader at the target and counts the index exactly."""

    def __init__(self, bag: StreamedBag, topics: Sequence[str], first_ns: int, last_ns: int) -> None:
        """Count the messages in the window (index records only) and put the cursor on the first."""
        self.bag = bag
        self.topics = list(topics)
        self.size = bag.count(self.topics, first_ns, last_ns)
        self._window = (first_ns, last_ns)
        self.first_ns, self.last_ns = first_ns, last_ns
        if self.size:
            head = next(bag.messages(self.topics, first_ns, last_ns))
            self.first_ns = head[1]
        self._iter: Iterator[tuple[str, int, bytes]] = iter(())
        self._next: tuple[str, int, bytes] | None = None
        self.seek(self.first_ns)

    def seek(self, ns: int) -> int:
        """Cursor on the first message at or after ``ns``; its index (messages in [first, ns))."""
        first, last = self._window
        self._iter = self.bag.messages(self.topics, max(ns, first), last)
        self._next = next(self._iter, None)
        return self.bag.count(self.topics, first, ns - 1) if ns > first else 0

    def peek_ns(self) -> int | None:
        """Log time of the message at the cursor."""
        return None if self._next is None else self._next[1]

    def take(self) -> tuple[str, int, bytes]:
        """The message at the cursor; the next one is read (a new chunk decoded when it starts one)."""
        item = self._next
        assert item is not None
        self._next = next(self._iter, None)
        return item


def open_source(path: str) -> StreamedBag | Bag:
    """The bag streamed through its chunk index, or read whole (salvaged) when it has none; ParameterError
    for a bag being recorded (its end is not written yet: a replay would stop short of it)."""
    try:
        return StreamedBag(path)
    except NotIndexedError:
        bag = read_bag(path)
    if bag.recording is not None:
        raise ParameterError(f"{bag.problem}: the player plays it once the recording has ended")
    return bag


def make_timeline(source: StreamedBag | Bag, topics: Sequence[str], first: int, last: int) -> Timeline:
    """The messages of ``topics`` in [first, last] as a Timeline whose take() gives (topic, ns, cdr)."""
    if isinstance(source, StreamedBag):
        return StreamTimeline(source, topics, first, last)
    messages = [(t, ns, data) for t, ns, data in source.iter_raw(list(topics)) if first <= ns <= last]
    return _ListTimeline(messages)


class _ListTimeline(ArrayTimeline):
    """An ArrayTimeline over messages held in memory; take gives the message itself."""

    def __init__(self, messages: list[tuple[str, int, bytes]]) -> None:
        """Cursor on the first of ``messages`` (time-ordered (topic, ns, cdr))."""
        super().__init__(np.array([ns for _, ns, _ in messages], dtype=np.int64))
        self.messages = messages

    # Any: the message (topic, ns, cdr), where ArrayTimeline.take gives an index (a Timeline's own item).
    def take(self) -> Any:
        """The message at the cursor; the cursor moves on."""
        return self.messages[super().take()]


def play_window(
    bag: Bag | StreamedBag, start_offset: float, duration: float, until: float
) -> tuple[int, int]:
    """(first, last) log time (ns) to play: from start + offset, for ``duration`` s and up to ``until`` s
    of bag time (either negative: no limit)."""
    first = bag.start_ns + round(start_offset * 1e9)
    last = bag.end_ns
    if duration >= 0.0:
        last = min(last, first + round(duration * 1e9))
    if until >= 0.0:
        last = min(last, round(until * 1e9))
    return first, last


class PlayerNode(ThreadedNode):
    """Replays one bag into the graph from a publishing thread; services, parameters and keys control it."""

    def __init__(self) -> None:
        """Declare parameters, read the bag (BagError when unreadable), create publishers and services,
        start playing (or wait, paused)."""
        super().__init__(NODE_NAME)
        values = declare_parameters(self, PLAYER)
        # ``path:=~/bags/run`` reaches a node past the shell unexpanded (no shell expands after ``:=``).
        path = os.path.expanduser(str(values["path"]))
        self.loop = bool(values["loop"])
        self.delay = float(values["delay"])
        self.clock = bool(values["clock"])
        self.clock_rate_hz = float(values["clock_rate_hz"])
        self.exit_on_end = bool(values["exit_on_end"])
        self.wait_for_subscribers = int(values["wait_for_subscribers"])
        self.wait_for_recorder = bool(values["wait_for_recorder"])
        namespace = self.get_namespace()
        self.reader_nodes = node_names(values["reader_nodes"], namespace)
        self.recorder_node = node_names([str(values["recorder_node"])], namespace)
        if not path:
            raise ParameterError("parameter path (the bag to play) is required")
        source = open_source(path)
        if isinstance(source, Bag):
            note = salvage_note(source)
            self.get_logger().warning(
                (note + "; " if note else "") + "no chunk index: the bag is read whole into memory"
            )
        available = (
            source.topics
            if isinstance(source, StreamedBag)
            else {name: info.msgtype for name, info in source.topics.items()}
        )
        wanted = select_topics(
            list(available),
            [t for t in values["topics"] if t],
            str(values["topics_regex"]),
            [t for t in values["exclude_topics"] if t],
            str(values["exclude_regex"]),
        )
        if not wanted:
            raise ParameterError(f"no topic of bag {path} is left to play after the topic filters")
        if self.clock:  # the player's own /clock replaces the recorded one (a namespaced chain's too)
            wanted = [t for t in wanted if bm.role_of(t) != bm.TOPIC_CLOCK]
        self._outputs: dict[str, AnyPublisher] = {
            topic: make_publisher(self, message_class(available[topic]), topic, qos_for(topic))
            for topic in wanted
        }
        if self.clock:
            self._outputs[bm.TOPIC_CLOCK] = make_publisher(
                self, message_class(bm.CLOCK), bm.TOPIC_CLOCK, qos_for(bm.TOPIC_CLOCK)
            )
        first, last = play_window(
            source,
            float(values["start_offset"]),
            float(values["playback_duration"]),
            float(values["playback_until"]),
        )
        timeline = make_timeline(source, wanted, first, last)
        if timeline.size == 0:
            raise ParameterError(f"bag {path} has no messages in the chosen time range")
        # The angles the readers wait for: by the recording's topic map (a remapped chain's), else by name.
        choice = source.choice if isinstance(source, Bag) else stored_choice(path)
        self._joint_topic = bm.find_topic(wanted, bm.JOINT_STATES, choice)
        self.playback = Playback(timeline, rate=float(values["rate"]), paused=bool(values["start_paused"]))
        self._clock_origin = timeline.first_ns
        self._last_tick: int | None = None
        self._publish_lock = threading.Lock()
        self._ready = threading.Event()  # set once the readers _wait asks for are there
        self.passes = 0
        self.published = 0
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self._control_services = [
            self.create_service(Trigger, f"~/{name}", handler)
            for name, handler in (
                ("pause", self._srv_pause),
                ("resume", self._srv_resume),
                ("toggle_paused", self._srv_toggle_paused),
                ("is_paused", self._srv_is_paused),
                ("play_next", self._srv_play_next),
                ("burst", self._srv_burst),
                ("seek", self._srv_seek),
            )
        ]
        self._stdin_mode: list[int | list[bytes | int]] | None = None  # termios.tcgetattr's
        if bool(values["keyboard"]) and sys.stdin is not None and sys.stdin.isatty():
            self._start_keyboard()
        self._progress_tty = sys.stderr.isatty()
        period = float(values["progress_period"])
        if period > 0.0:
            self.create_timer(period, self._progress, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.start_thread(self._play, "bag_player")
        self.get_logger().info(
            f"playing {timeline.size} messages of {path} ({', '.join(wanted)}) at rate "
            f"{self.playback.rate:g}"
            + (", looping" if self.loop else "")
            + (", paused" if self.playback.paused else "")
        )

    # -- parameters and services ------------------------------------------------------------------

    def _on_set_parameters(self, params: list[AnyParameter]) -> SetParametersResult:
        """Apply a new ``rate`` at once (~/set_rate); other settable parameters are read when used."""
        for param in params:
            if param.name == "rate":
                try:
                    self.playback.set_rate(float(param.value))
                except PendulumAccelError as err:
                    return SetParametersResult(successful=False, reason=str(err))
                self.get_logger().info(f"rate {self.playback.rate:g}")
        return SetParametersResult(successful=True)

    @staticmethod
    # Any: the services' requests and responses are std_srvs/rosbag2_interfaces classes, which ship no
    # types (as the message packages: see nodes/qos.py AnyPublisher).
    def _reply(response: Any, success: bool, message: str) -> Any:
        """Fill a Trigger response."""
        response.success = success
        response.message = message
        return response

    def _srv_pause(self, request: Any, response: Any) -> Any:
        """~/pause: stop the clock."""
        self.playback.pause()
        return self._reply(response, True, "paused")

    def _srv_resume(self, request: Any, response: Any) -> Any:
        """~/resume: restart the clock where it stopped."""
        self.playback.resume()
        return self._reply(response, True, "playing")

    def _srv_toggle_paused(self, request: Any, response: Any) -> Any:
        """~/toggle_paused: pause if playing, else resume; message: the new state."""
        return self._reply(response, True, "paused" if self.playback.toggle() else "playing")

    def _srv_is_paused(self, request: Any, response: Any) -> Any:
        """~/is_paused: message "true" or "false"."""
        return self._reply(response, True, "true" if self.playback.paused else "false")

    def play_next(self) -> bool:
        """Publish the next message now (only while paused, as rosbag2, and once the readers playing
        waits for are there: up to READY_WAIT_S); True if one was published."""
        if not self._ready.wait(READY_WAIT_S):
            return False
        taken = self.playback.step()
        return taken is not None and self._publish(taken)

    def _not_played(self) -> str:
        """Why play_next published nothing: the readers it waits for, or the state."""
        if not self._ready.is_set():
            return f"waiting for its readers ({self._waiting_for() or 'stopping'})"
        return "not paused, or at the end"

    def _srv_play_next(self, request: Any, response: Any) -> Any:
        """~/play_next: success when a message was published."""
        ok = self.play_next()
        return self._reply(response, ok, "played 1 message" if ok else self._not_played())

    def _srv_burst(self, request: Any, response: Any) -> Any:
        """~/burst: play ``burst_size`` messages (0: to the end) while paused; message: how many."""
        size = int(self.get_parameter("burst_size").value)
        if not self.playback.paused:
            return self._reply(response, False, "burst 0 messages: burst needs the paused state")
        played = 0
        while (size == 0 or played < size) and not self._stop.is_set() and self.play_next():
            played += 1
        self.get_logger().info(f"burst {played} messages")
        if played == 0 and not self._ready.is_set():
            return self._reply(response, False, f"burst 0 messages: {self._not_played()}")
        return self._reply(response, played > 0, f"burst {played} messages")

    def _srv_seek(self, request: Any, response: Any) -> Any:
        """~/seek: go to bag time ``seek_time`` (s); refused (success false) outside the played span."""
        seconds = float(self.get_parameter("seek_time").value)
        ok = self.playback.seek(round(seconds * 1e9))
        if ok:
            self.get_logger().info(f"seek to t={seconds:.3f} s")
            return self._reply(response, True, f"seek to t={seconds:.3f} s")
        first, last = self.playback.first_ns * 1e-9, self.playback.last_ns * 1e-9
        return self._reply(
            response, False, f"refused: t={seconds:.3f} s lies outside the bag's [{first:.3f}, {last:.3f}] s"
        )

    # -- keyboard and progress --------------------------------------------------------------------

    def _start_keyboard(self) -> None:
        """Put the terminal in cbreak mode (restored in close) and read keys in a thread."""
        fd = sys.stdin.fileno()
        self._stdin_mode = termios.tcgetattr(fd)
        tty.setcbreak(fd)
        threading.Thread(target=self._read_keys, args=(fd,), name="bag_player_keys", daemon=True).start()
        self.get_logger().info("keys: space pause/resume, → play next, ↑ rate +0.1, ↓ rate −0.1")

    def _read_keys(self, fd: int) -> None:
        """Thread body: act on each key pressed until stopped."""
        actions: dict[bytes, Callable[[], str]] = {
            KEY_PAUSE: lambda: "paused" if self.playback.toggle() else "playing",
            KEY_NEXT: lambda: "played next" if self.play_next() else "play next: not paused",
            KEY_FASTER: lambda: self._step_rate(+RATE_STEP),
            KEY_SLOWER: lambda: self._step_rate(-RATE_STEP),
        }
        pending = b""
        while not self._stop.is_set():
            ready, _, _ = select.select([fd], [], [], 0.1)
            if not ready:
                continue
            chunk = os.read(fd, 16)
            if not chunk:
                return
            pending += chunk
            while pending:
                key = next((k for k in actions if pending.startswith(k)), None)
                if key is None:
                    if any(k.startswith(pending) for k in actions):
                        break  # the rest of an arrow key's escape sequence is still to come
                    pending = pending[1:]
                    continue
                pending = pending[len(key) :]
                self.get_logger().info(f"key: {actions[key]()}")

    def _step_rate(self, step: float) -> str:
        """Set the ``rate`` parameter to rate + step (refused below its range, as a service call would be)."""
        rate = round(self.playback.rate + step, 6)
        result = self.set_parameters([Parameter("rate", value=rate)])[0]
        return f"rate {self.playback.rate:g}" if result.successful else f"rate unchanged: {result.reason}"

    def progress_line(self) -> str:
        """'[state] bag time t s of end s (i/n messages), rate r', t the position (Playback.position_ns), with
        '; behind by d s' when the schedule ran ahead of it."""
        playback = self.playback
        state = "paused" if playback.paused else "playing"
        schedule, position = playback.bag_now_ns(), playback.position_ns()
        end = playback.last_ns * 1e-9
        behind = (schedule - position) * 1e-9
        # Behind by less than a second of bag time is the pacing's ordinary slack, not worth a word.
        lag = f"; behind by {behind:.3f} s" if behind >= 1.0 and not playback.at_end() else ""
        return (
            f"bag_player [{state}] bag time {position * 1e-9:.3f} s of {end:.3f} s "
            f"({playback.index}/{playback.size} messages), rate {playback.rate:g}{lag}"
        )

    def _progress(self) -> None:
        """Timer: the progress line on stderr, rewritten in place on a terminal."""
        end = "\r" if self._progress_tty else "\n"
        sys.stderr.write(self.progress_line() + end)
        sys.stderr.flush()

    # -- playing ------------------------------------------------------------------------------------

    def _waiting_for(self) -> str:
        """What playing still waits for, '' when nothing: the named readers (reader_nodes on the angles, the
        bag's pendulum/joint_states under any namespace; recorder_node on every topic; by name, since a
        count a stranger could satisfy is not theirs), wait_for_subscribers on the angles and, with
        wait_for_recorder, a subscriber on every published topic."""
        for topic, publisher in self._outputs.items():
            wanted = list(self.recorder_node) + (self.reader_nodes if topic == self._joint_topic else [])
            missing = missing_readers(self, publisher, wanted) if wanted else []
            if missing:
                return f"{topic}: {', '.join(missing)}"
        joint = self._outputs.get(self._joint_topic) if self._joint_topic else None
        if joint is not None and joint.get_subscription_count() < self.wait_for_subscribers:
            return f"{self._joint_topic}: {self.wait_for_subscribers} subscribers"
        if self.wait_for_recorder:
            for topic, publisher in self._outputs.items():
                if publisher.get_subscription_count() < 1:
                    return f"{topic}: a subscriber"
        return ""

    def _wait(self) -> bool:
        """True once nothing is waited for (_waiting_for), then play_next may publish too; False if stopped
        while waiting."""
        while self._waiting_for():
            if self._stop.wait(0.01):
                return False
        self._ready.set()
        return True

    def _publish(self, taken: Taken) -> bool:
        """Publish message ``taken.index``, preceded by /clock on each new tick (1/clock_rate_hz of bag
        time) and after every jump; False if stopped while the readers held it back."""
        topic, ns, data = taken.item
        stopping = self._stop.is_set
        with self._publish_lock:
            if self.clock:
                tick = (
                    int((ns - self._clock_origin) * 1e-9 * self.clock_rate_hz + 1e-9)
                    if self.clock_rate_hz > 0.0
                    else taken.index
                )
                if taken.jumped or tick != self._last_tick:
                    self._last_tick = tick
                    clock = bm.serialize(bm.clock(int(ns)), bm.CLOCK)
                    if not publish_blocking(self._outputs[bm.TOPIC_CLOCK], clock, stopping):
                        return False
            if not publish_blocking(self._outputs[topic], data, stopping):
                return False
            self.published += 1
        return True

    def _play(self) -> None:
        """Thread body: publish each message when due, pass after pass, under the controls."""
        if not self._wait():
            return
        first_pass = True
        while not self._stop.is_set():
            if self.delay > 0.0 and self._stop.wait(self.delay):
                return
            if first_pass:
                self.playback.reanchor()  # the clock starts now, not when the node was built
            else:
                self.playback.restart()
            first_pass = False
            while (taken := self.playback.take_due(self._stop)) is not None:
                if not self._publish(taken):
                    return
            if self._stop.is_set():
                return
            self.passes += 1
            if not self.loop:
                break
        for publisher in self._outputs.values():
            acked_within(publisher, _ACK_TIMEOUT_S, self._stop.is_set)
        self.get_logger().info(f"played {self.published} messages in {self.passes} pass(es)")
        if self.exit_on_end:
            self.finish(0)
            return
        # Staying at the end: a seek (or play_next after one) puts the cursor back inside the bag, and
        # playing goes on from there.
        while not self._stop.is_set():
            if self.playback.at_end():
                self._stop.wait(0.05)
                continue
            while (taken := self.playback.take_due(self._stop)) is not None:
                if not self._publish(taken):
                    return

    def close(self) -> None:
        """Stop the threads and give the terminal its mode back."""
        self._stop.set()
        self.playback.wake()
        super().close()
        if self._stdin_mode is not None:
            with contextlib.suppress(termios.error, OSError):
                termios.tcsetattr(sys.stdin.fileno(), termios.TCSADRAIN, self._stdin_mode)
            self._stdin_mode = None


def main(args: Sequence[str] | None = None) -> int:
    """Console script ``bag_player``: play the bag, then exit (or loop until a signal)."""
    return run_node(PlayerNode, NODE_NAME, args)


if __name__ == "__main__":
    raise SystemExit(main())
