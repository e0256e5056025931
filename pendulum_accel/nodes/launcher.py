"""Start the chain (simulator, estimator, recorder), each in its own process, and stop it cleanly.

Plain ``subprocess`` (the PyPI ROS wheels have no ``ros2 launch``); no rclpy import here. Start order
and the nodes' wait parameters make sure nothing published is missed: the recorder subscribes first,
the estimator subscribes to the angles once the recorder (by name) listens to its outputs, and the
simulator publishes once both (by name) listen; other subscribers on the graph change nothing.
One time base per run (``time_source``): sim for --fast and for recordings, else wall. Each node
writes its counters at exit; the launcher prints them per topic and fails a run that lost data.
A node that ends by a signal fails the run, except a recorder that had closed its bag when the bag then
reads complete (one WARNING): the recording is what the run was for.
Stop order is the data-flow order (simulator, estimator, recorder), each
asked with one SIGINT (the estimator and recorder drain their queues, the recorder closes the bag),
then SIGKILL after a timeout. Each child also gets SIGTERM from the kernel if the launcher itself
dies (PR_SET_PDEATHSIG), so nothing is ever left running.
"""

from __future__ import annotations

import ctypes
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import FrameType
from typing import TYPE_CHECKING, TypedDict

from pendulum_accel.errors import ParameterError, PendulumAccelError, RosMissingError
from pendulum_accel.nodes.accounting import Accounting
from pendulum_accel.nodes.names import fully_qualified_namespace, publisher_topic_map
from pendulum_accel.nodes.preflight import check_chain
from pendulum_accel.nodes.scheduling import RT_PRIORITY_ENV

if TYPE_CHECKING:
    from pendulum_accel.scene import Scene

_PR_SET_PDEATHSIG = 1
_STOP_TIMEOUT = 15.0  # s a node gets to exit after SIGINT before SIGKILL
_POLL = 0.05  # s
ESTIMATOR_NODE = "accel_estimator"
RECORDER_NODE = "bag_recorder"
BAG_OUTLIVED = (
    "WARNING: recorder ended with {how} after closing its bag; "
    "the bag {path} was verified complete (every chunk CRC checked)"
)
"""The one line a run prints when a signal ended the recorder after a bag that reads complete
(Chain._bag_outlived); {how} is describe_exit's, {path} the bag's."""

ParamValue = bool | int | float | str | list[str]


def _die_with_parent() -> None:
    """In the child, before exec: SIGTERM me when the launcher dies (Linux prctl)."""
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)


def require_rclpy() -> None:
    """RosMissingError, saying how to install it, when rclpy does not import."""
    try:
        import rclpy  # noqa: F401
    except ImportError:
        raise RosMissingError(
            "rclpy is not installed: run `make setup` (it runs `pip install -r requirements-ros.txt` "
            "into .venv) or source a ROS 2 install (source /opt/ros/<distro>/setup.bash)"
        ) from None


def ros_param(name: str, value: ParamValue) -> list[str]:
    """['-p', 'name:=value'] with the value written as YAML (strings quoted, so '1' stays a string)."""
    if isinstance(value, list):
        text = json.dumps([str(v) for v in value])
    elif isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, int | float):
        text = repr(value)
    else:
        text = json.dumps(value)
    return ["-p", f"{name}:={text}"]


class _NodeNames(TypedDict):
    """node_command's namespace and remap rules of a chain's node."""

    namespace: str
    remaps: list[str]


def node_command(
    module: str,
    params: Mapping[str, ParamValue],
    name: str | None = None,
    namespace: str = "",
    remaps: Sequence[str] = (),
) -> list[str]:
    """python -m pendulum_accel.nodes.<module> --ros-args [-r __node:=name] [-r __ns:=/namespace]
    [-r from:=to …] -p k:=v …: what ``ros2 run`` passes for a node name, a namespace and remaps."""
    cmd = [sys.executable, "-m", f"pendulum_accel.nodes.{module}", "--ros-args"]
    if name:
        cmd += ["-r", f"__node:={name}"]
    if fully_qualified_namespace(namespace):
        cmd += ["-r", f"__ns:={fully_qualified_namespace(namespace)}"]
    for rule in remaps:
        cmd += ["-r", rule]
    for key, value in params.items():
        cmd += ros_param(key, value)
    return cmd


def clock_remap(namespace: str) -> list[str]:
    """['/clock:=/ns/clock'] for a namespaced chain (none in the root namespace): every node of the chain then
    publishes, records and follows its own clock, so two chains on one domain keep two timelines apart."""
    ns = namespace.strip("/")
    return [f"/clock:=/{ns}/clock"] if ns else []


def namespace_frame_prefix(namespace: str) -> str:
    """'car1/' for the namespace /car1 ('' in the root namespace): the simulator's and estimator's
    frame_prefix for a namespaced chain, so two chains draw in their own frames (robot_state_publisher's
    prefix convention)."""
    ns = namespace.strip("/")
    return f"{ns}/" if ns else ""


@dataclass
class ChainConfig:
    """What to run: scene (+ overrides of its fields), recording, pacing and estimator."""

    scene: str
    record: Path | None = None
    overwrite: bool = False
    realtime: bool = True
    estimator: str | None = None
    overrides: dict[str, float] = field(default_factory=dict)
    estimator_params: dict[str, ParamValue] = field(default_factory=dict)
    simulator_params: dict[str, ParamValue] = field(default_factory=dict)
    rt_priority: int = 0  # SCHED_FIFO priority of every node in a real-time run (0: normal scheduling)
    time_source: str | None = None  # sim or wall; None: sim for --fast and recordings, else wall
    namespace: str = ""  # every node's namespace: the chain's relative topics resolve under it
    remaps: list[str] = field(default_factory=list)  # from:=to rules given to every node
    namespace_clock: bool = True  # a namespaced chain runs on <ns>/clock (false: the global /clock)
    frame_prefix: str | None = None  # the viewers' frame prefix; None: namespace_frame_prefix(namespace)

    @property
    def effective_time_source(self) -> str:
        """The run's time base: the one asked for, else sim when fast or recording, wall otherwise."""
        if self.time_source is not None:
            return self.time_source
        return "sim" if (not self.realtime or self.record is not None) else "wall"


@dataclass
class Child:
    """One started node: its role, command and process."""

    role: str
    command: list[str]
    process: subprocess.Popen[bytes]
    expected_exit: bool = False

    @property
    def pid(self) -> int:
        """Process id."""
        return self.process.pid


def effective_scene_file(config: ChainConfig, scene: Scene, directory: Path) -> str:
    """Scene argument for the nodes: the name, or (with overrides) a file of ``scene``, the overridden
    scene check_chain loaded (scene.write_scene_file)."""
    if not config.overrides:
        return config.scene
    from pendulum_accel.scene import write_scene_file

    return str(write_scene_file(scene, directory))


def describe_exit(code: int | None) -> str:
    """'exit 0', 'exit 2' or 'killed by SIGKILL' for a Popen return code."""
    if code is None:
        return "running"
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit {code}"


class Chain:
    """The running chain; ``run()`` blocks until the scene ends, a signal arrives or a node dies."""

    def __init__(self, config: ChainConfig, *, log: bool = True, output: Path | None = None) -> None:
        """Check the configuration (no process is started yet); ``output``: file for the nodes' logs."""
        self._scene = check_chain(config)  # read once: a recorded log's table takes seconds to read
        if config.effective_time_source not in ("sim", "wall"):
            raise ParameterError(f"time source must be sim or wall, got {config.time_source!r}")
        if config.effective_time_source == "wall" and not config.realtime:
            raise ParameterError("--time-source wall needs real-time pacing: --fast runs on sim time")
        self.accounting: Accounting | None = None
        self.config = config
        self.children: list[Child] = []
        self._summaries: Path | None = None  # where the nodes' counters and the chain's ending go
        self.log = log
        self._signalled = 0
        self.output = output

    def _say(self, text: str) -> None:
        """One launcher line on stderr (the nodes' own logs interleave there too)."""
        if self.log:
            print(f"chain: {text}", file=sys.stderr, flush=True)

    def commands(self, scene_arg: str, summaries: Path) -> list[tuple[str, list[str]]]:
        """(role, command) of each node, in start order: recorder (if recording), estimator, simulator.

        Each node writes its counters to ``summaries``/<role>.json; the recorder stores the others' in
        its bag. The waits name the chain's own nodes, so no other subscriber can satisfy them.
        """
        cfg = self.config
        time_source = cfg.effective_time_source
        recorder = RECORDER_NODE if cfg.record is not None else ""
        out: list[tuple[str, list[str]]] = []
        prefix = namespace_frame_prefix(cfg.namespace) if cfg.frame_prefix is None else cfg.frame_prefix
        # Set only when not empty (the nodes' default); a frame_prefix in *_params still wins.
        frames: dict[str, ParamValue] = {"frame_prefix": prefix} if prefix else {}
        if cfg.record is not None:
            rec: dict[str, ParamValue] = {
                "path": str(cfg.record),
                "overwrite": cfg.overwrite,
                "scene": scene_arg,
                "time_source": time_source,
                "chain_summaries": [
                    str(summaries / f"{role}.json") for role in ("simulator", "estimator", "chain")
                ],
                "summary_file": str(summaries / "recorder.json"),
            }
            out.append(("recorder", node_command("recorder_node", rec, **self._names())))
        est: dict[str, ParamValue] = {
            "scene": scene_arg,
            "time_source": time_source,
            "recorder_node": recorder,
            "summary_file": str(summaries / "estimator.json"),
        }
        if cfg.estimator:
            est["method"] = cfg.estimator
        est.update(frames)
        est.update(cfg.estimator_params)
        out.append(("estimator", node_command("estimator_node", est, **self._names())))
        sim: dict[str, ParamValue] = {
            "scene": scene_arg,
            "realtime": cfg.realtime,
            "time_source": time_source,
            "publish_clock": time_source == "sim",
            "reader_nodes": [ESTIMATOR_NODE],
            "recorder_node": recorder,
            "summary_file": str(summaries / "simulator.json"),
            **frames,
        }
        sim.update(cfg.simulator_params)
        out.append(("simulator", node_command("simulator_node", sim, **self._names())))
        return out

    def _names(self) -> _NodeNames:
        """node_command's namespace and remaps for every node of this chain (the user's rules before
        the chain's own clock: rcl applies the first rule that matches, so a user's rule for /clock wins)."""
        cfg = self.config
        own_clock = clock_remap(cfg.namespace) if cfg.namespace_clock else []
        return {"namespace": cfg.namespace, "remaps": [*cfg.remaps, *own_clock]}

    def _start(self, role: str, command: list[str]) -> None:
        """Start one node in its own process group (a terminal's Ctrl-C reaches only the launcher)."""
        env = dict(os.environ)
        env.pop(RT_PRIORITY_ENV, None)
        # The nodes start as ``python -m``, which puts the working directory first on sys.path: a folder
        # named pendulum_accel there (a workspace's src/ after the README's clone) would be imported as
        # a namespace package instead of the installed one. Python >= 3.11 leaves it out with this.
        env["PYTHONSAFEPATH"] = "1"
        if self.config.rt_priority and self.config.realtime:
            # Only paced runs: as fast as possible, FIFO nodes that never block would starve the machine.
            env[RT_PRIORITY_ENV] = str(self.config.rt_priority)
        if self.output is None:
            proc = subprocess.Popen(command, preexec_fn=_die_with_parent, start_new_session=True, env=env)
        else:
            with self.output.open("ab") as sink:
                proc = subprocess.Popen(
                    command,
                    stdout=sink,
                    stderr=subprocess.STDOUT,
                    preexec_fn=_die_with_parent,
                    start_new_session=True,
                    env=env,
                )
        self.children.append(Child(role, command, proc))
        self._say(f"started {role} (pid {proc.pid})")

    def _on_signal(self, signum: int, frame: FrameType | None) -> None:
        """Remember a SIGINT/SIGTERM; run() stops the chain."""
        self._signalled += 1

    def _stop_child(self, child: Child, timeout: float = _STOP_TIMEOUT) -> None:
        """SIGINT, wait up to ``timeout`` s, then SIGKILL; always reaps the process."""
        proc = child.process
        child.expected_exit = True
        if proc.poll() is None:
            try:
                proc.send_signal(signal.SIGINT)
                proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self._say(f"{child.role} did not stop within {timeout:g} s: killing it")
                proc.kill()
            except ProcessLookupError:
                pass
        proc.wait()

    def stop(self) -> None:
        """Stop every child in data-flow order: simulator, estimator, recorder."""
        order = {"simulator": 0, "estimator": 1, "recorder": 2}
        for child in sorted(self.children, key=lambda c: order.get(c.role, 3)):
            self._stop_child(child)

    def child(self, role: str) -> Child | None:
        """The child with this role, if started."""
        return next((c for c in self.children if c.role == role), None)

    def run(self) -> int:
        """Start, wait for the end of the scene (or a signal or a dead node), stop; 0 when all went well."""
        previous = {s: signal.signal(s, self._on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
        try:
            with tempfile.TemporaryDirectory(prefix="pendulum_accel_chain_") as tmp:
                scene_arg = effective_scene_file(self.config, self._scene, Path(tmp))
                self._say(f"time source: {self.config.effective_time_source}")
                self._summaries = Path(tmp)
                for role, command in self.commands(scene_arg, Path(tmp)):
                    self._start(role, command)
                code = self._supervise()
                self.stop()
                return self._account(Path(tmp), code)
        finally:
            self.stop()
            for s, handler in previous.items():
                signal.signal(s, handler)

    def _account(self, summaries: Path, code: int) -> int:
        """Print the per-topic accounting; a finished run that lost or missed data: one WARNING, exit 1."""
        roles: dict[str, dict[str, object]] = {}
        for role in ("simulator", "estimator", "recorder"):
            path = summaries / f"{role}.json"
            if path.exists():
                roles[role] = json.loads(path.read_text())
        self.accounting = Accounting(
            roles.get("simulator", {}),
            roles.get("estimator", {}),
            roles.get("recorder", {}),
            # The counters name the topics as the nodes resolved them: the map finds the roles among them.
            roles=publisher_topic_map(self.config.namespace, self._names()["remaps"]),
        )
        if self.log:
            print("samples (published / received by the estimator / estimated / recorded):", flush=True)
            for line in self.accounting.table():
                print(line, flush=True)
        if code != 0:
            return code
        losses = self.accounting.losses(self.config.record is not None)
        if losses:
            print(f"WARNING: data lost or missed: {'; '.join(losses)}", file=sys.stderr, flush=True)
            return 1
        return 0

    def _ended(self, ended: str, died: str | None = None, how: str | None = None) -> None:
        """Write how the chain ended (chain.json, which the recorder stores with the counters) before the
        nodes are stopped: 'finished' | 'interrupted' | 'node died', and which node and how."""
        if self._summaries is not None:
            ending = {"ended": ended, **({"died": died, "how": how} if died else {})}
            (self._summaries / "chain.json").write_text(json.dumps(ending))

    def _bag_outlived(self, child: Child) -> bool:
        """True when ``child`` is the recorder, a signal ended it after it closed the bag, and the bag reads
        complete: every record framed, every chunk CRC and the data section CRC held (``read_bag``'s
        scan, what ``info`` checks before it says [complete]). Then one WARNING line names the signal.

        The recorder writes its summary (recorder.json) only once the bag's writer has closed it (footer
        and metadata.yaml), so a summary means the bag was finished before the process died: a crash in
        the ROS teardown after that (a rare SIGSEGV in rclpy's destroy_node) costs the recording
        nothing. Without the summary, or when the bag does not verify, it stays a failure.
        """
        code = child.process.returncode
        record = self.config.record
        if child.role != "recorder" or code is None or code >= 0 or record is None or self._summaries is None:
            return False
        if not (self._summaries / "recorder.json").exists():
            return False
        from pendulum_accel.bag.reader import read_bag

        try:
            bag = read_bag(record)
        except (PendulumAccelError, OSError):
            return False
        if bag.problem is not None or not bag.complete:
            return False
        print(BAG_OUTLIVED.format(how=describe_exit(code), path=bag.path), file=sys.stderr, flush=True)
        return True

    def _supervise(self) -> int:
        """Watch the children until the simulator ends, a signal arrives or another child dies."""
        simulator = self.child("simulator")
        assert simulator is not None
        while True:
            if self._signalled:
                self._say("interrupted: stopping the chain")
                self._ended("interrupted")
                self.stop()
                return 130
            code = simulator.process.poll()
            if code is not None:
                simulator.expected_exit = True
                if code != 0:
                    self._say(f"simulator ended with {describe_exit(code)}: stopping the chain")
                    self._ended("node died", "simulator", describe_exit(code))
                    self.stop()
                    return 1
                self._say("scene finished: stopping the chain")
                self._ended("finished")
                self.stop()
                failed = [
                    c
                    for c in self.children
                    if c.process.returncode not in (0, None) and not self._bag_outlived(c)
                ]
                for c in failed:
                    self._say(f"{c.role} ended with {describe_exit(c.process.returncode)}")
                return 1 if failed else 0
            for child in self.children:
                if child is simulator:  # its end, 0 too, is read above: an exit between the two polls is
                    continue  # the scene finishing, not a node dying
                code = child.process.poll()
                if code is not None and not child.expected_exit:
                    self._say(
                        f"{child.role} (pid {child.pid}) died with {describe_exit(code)}: stopping the chain"
                    )
                    child.expected_exit = True
                    self._ended("node died", child.role, describe_exit(code))
                    self.stop()
                    return 1
            time.sleep(_POLL)


def run_chain(config: ChainConfig, *, log: bool = True) -> int:
    """Run the chain to completion (see Chain.run); returns the launcher's exit code."""
    return Chain(config, log=log).run()


def pids_alive(pids: Sequence[int]) -> list[int]:
    """The pids among ``pids`` that still exist and are not zombies (read from /proc)."""
    alive = []
    for pid in pids:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            continue
        except PermissionError:
            pass
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except (OSError, IndexError):
            continue
        if state != "Z":
            alive.append(pid)
    return alive
