"""The base class and the one main loop every node of the chain uses."""

from __future__ import annotations

import gc
import json
import re
import signal
import sys
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from types import FrameType
from typing import Any, TypeAlias

import rclpy
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
from rcl_interfaces.srv import (
    DescribeParameters,
    GetParameters,
    GetParameterTypes,
    ListParameters,
    SetParameters,
    SetParametersAtomically,
)
from rclpy._rclpy_pybind11 import RCLError
from rclpy.duration import Duration
from rclpy.exceptions import ParameterException
from rclpy.executors import Executor, ExternalShutdownException
from rclpy.experimental.events_executor import EventsExecutor
from rclpy.lifecycle import LifecycleNode, LifecycleState, TransitionCallbackReturn
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions
from rclpy.task import Future

from pendulum_accel.errors import ParameterError, PendulumAccelError
from pendulum_accel.nodes.dds_profile import use_package_profile
from pendulum_accel.nodes.parameters import FROM_SCENE, TIME_SOURCES, ParamSpec, ParamValue
from pendulum_accel.nodes.qos import AnyPublisher
from pendulum_accel.nodes.scheduling import apply_rt_priority
from pendulum_accel.nodes.shm_ports import clear_stale_ports

# How often the main thread wakes to run pending signal handlers.
_SIGNAL_POLL_PERIOD = 0.05  # s
_PUBLISH_RETRY_PERIOD = 0.001  # s

# Any: a parameter holds any of ROS 2's value types (bool, int, float, str, their arrays), per name.
AnyParameter: TypeAlias = Parameter[Any]
"""A node parameter of some value type."""

_ACK_SLICE = Duration(seconds=0.2)


# Set once the node being built (run_node's factory) holds input: a subscription whose messages the
# middleware acknowledges at once, or an open bag. A stop signal then waits for the node to exist and
# drain it.
_HOLDING = threading.Event()


class ChainNode(Node):
    """A Node that may end on its own (``finish``), stops gracefully on request, and ``close``s its files."""

    # Any: rclpy's Node keyword arguments, passed through as they are.
    def __init__(self, node_name: str, **kwargs: Any) -> None:
        """Node(node_name, **kwargs) plus the ``finished`` future that ends the spin."""
        super().__init__(node_name, **kwargs)
        self.finished: Future[int] = Future()

    def holds_input(self) -> None:
        """Say, before subscribing or opening a file, that a stop must now drain this node, not drop it.

        A stop signal that comes while the node is still being built (its constructor subscribes as soon as
        its readers are there, and rclpy's first log line alone can take a second on a loaded machine)
        is kept until the node exists, then asked as request_stop: it used to end the process before its
        spin, the angles the middleware had acknowledged never estimated and no counters written."""
        _HOLDING.set()

    def finish(self, code: int = 0) -> None:
        """End the spin of ``run_node`` with exit code ``code`` (idempotent)."""
        if not self.finished.done():
            self.finished.set_result(code)

    def request_stop(self) -> None:
        """First SIGINT/SIGTERM: stop gracefully; this default finishes at once (draining nodes override)."""
        self.finish(0)

    def close(self) -> None:
        """Release files and threads; called once by ``run_node`` whatever ended the spin."""


class ThreadedNode(ChainNode):
    """A ChainNode whose work runs in one daemon thread; a stop request ends the thread, then the spin."""

    # Any: rclpy's LifecycleNode keyword arguments, passed through as they are.
    def __init__(self, node_name: str, **kwargs: Any) -> None:
        """ChainNode(node_name, **kwargs) with the ``_stop`` event its thread watches; no thread yet."""
        super().__init__(node_name, **kwargs)
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def start_thread(self, target: Callable[[], None], name: str) -> None:
        """Start ``target`` in a daemon thread; it should return soon after ``self._stop`` is set."""
        self._thread = threading.Thread(target=target, name=name, daemon=True)
        self._thread.start()

    def request_stop(self) -> None:
        """Stop the thread's work and finish."""
        self._stop.set()
        self.finish(0)

    def close(self) -> None:
        """Stop the thread and wait for it (5 s at most)."""
        self._stop.set()
        if self._thread is not None and self._thread.is_alive():
            self._thread.join(timeout=5.0)


class ManagedNode(ThreadedNode, LifecycleNode):
    """A ThreadedNode that is also a managed node (rclpy.lifecycle): ``configure`` builds what the node
    publishes from its parameters, ``activate`` starts the data flow, ``deactivate`` stops it,
    ``cleanup`` releases what configure built, ``shutdown`` ends the process (exit 0).

    Subclasses implement ``configure`` (raise PendulumAccelError on bad values), ``activate``,
    ``deactivate`` and ``cleanup``. With ``autostart`` (see ``start``), the node configures and
    activates itself at once, so it runs as an unmanaged node would; a bad configuration is then
    the one-line error and exit 2 of any other node.
    """

    def configure(self) -> None:
        """Build the outputs and the model from the parameters (PendulumAccelError when they are bad)."""

    def activate(self) -> None:
        """Start the data flow."""

    def deactivate(self) -> None:
        """Stop the data flow; configure's outputs stay."""

    def cleanup(self) -> None:
        """Release what configure built."""

    def start(self, autostart: bool) -> None:
        """Configure and activate now when ``autostart`` (the configure error, if any, raised as is);
        else wait, unconfigured, for a lifecycle manager (``ros2 lifecycle set``, the services)."""
        self._configure_error: PendulumAccelError | None = None
        if not autostart:
            self.get_logger().info("unconfigured: waiting for the lifecycle transitions (autostart false)")
            return
        if self.trigger_configure() != TransitionCallbackReturn.SUCCESS:
            raise self._configure_error or PendulumAccelError("configure failed")
        if self.trigger_activate() != TransitionCallbackReturn.SUCCESS:
            raise PendulumAccelError("activate failed")

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """configure(); FAILURE (back to unconfigured) with the reason logged when it raises."""
        try:
            self.configure()
        except PendulumAccelError as err:
            self._configure_error = err
            self.get_logger().error(f"configure failed: {err}")
            return TransitionCallbackReturn.FAILURE
        return TransitionCallbackReturn.SUCCESS

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """activate() (after the lifecycle publishers, if any, are enabled)."""
        result = super().on_activate(state)
        self._stop.clear()
        self.activate()
        return result

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """deactivate(), then disable the lifecycle publishers."""
        self.deactivate()
        return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        """cleanup()."""
        self.cleanup()
        return TransitionCallbackReturn.SUCCESS

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Stop the data flow and end the process with exit 0."""
        self.deactivate()
        self.finish(0)
        return TransitionCallbackReturn.SUCCESS

    def stop_thread(self) -> None:
        """Set ``_stop`` and wait for the worker thread (5 s at most); the node stays usable."""
        self._stop.set()
        if (
            self._thread is not None
            and self._thread.is_alive()
            and self._thread is not threading.current_thread()
        ):
            self._thread.join(timeout=5.0)
        self._thread = None


def parameter_descriptor(spec: ParamSpec) -> ParameterDescriptor:
    """ParameterDescriptor of a spec: description, read_only, range (step 0; 1 for integers), choices."""
    limits: dict[str, object] = {}
    if spec.low is not None and spec.high is not None:
        if spec.type == "integer":
            limits["integer_range"] = [
                IntegerRange(from_value=int(spec.low), to_value=int(spec.high), step=1)
            ]
        else:
            limits["floating_point_range"] = [
                FloatingPointRange(from_value=float(spec.low), to_value=float(spec.high), step=0.0)
            ]
    if spec.choices:
        limits["additional_constraints"] = " | ".join(spec.choices)
    return ParameterDescriptor(description=spec.description, read_only=spec.read_only, **limits)


def _typed(spec: ParamSpec, value: ParamValue) -> bool | int | float | str | list[str]:
    """``value`` as the Python type ROS infers ``spec.type`` from (a string array as a list)."""
    if isinstance(value, tuple):
        return list(value)
    if spec.type == "integer":
        return int(value)
    if spec.type == "double":
        return float(value)
    return value


def declare_parameters(
    node: Node,
    specs: Sequence[ParamSpec],
    scene_defaults: Callable[[str], Mapping[str, ParamValue]] | None = None,
) -> dict[str, Any]:  # Any: each value has its parameter's own type (the spec's), read by name
    """Declare every spec on ``node`` in order; {name: value} (a launch override or the default).

    A FROM_SCENE default comes from ``scene_defaults(scene)``, called once with the value of the
    ``scene`` parameter, which the table declares before them.
    """
    # Any: as declare_parameters' result.
    values: dict[str, Any] = {}
    defaults: Mapping[str, ParamValue] | None = None
    for spec in specs:
        default = spec.default
        if default is FROM_SCENE:
            if scene_defaults is None:
                raise ValueError(
                    f"parameter {spec.name} takes its default from the scene: pass scene_defaults"
                )
            if defaults is None:
                defaults = scene_defaults(str(values["scene"]))
            default = defaults[spec.name]
        assert default is not None
        values[spec.name] = node.declare_parameter(
            spec.name, _typed(spec, default), parameter_descriptor(spec)
        ).value
    if "time_source" in values:
        apply_time_source(node, str(values["time_source"]))
    return values


def apply_time_source(node: Node, time_source: str) -> None:
    """use_sim_time = (time_source == 'sim'): every node of a run on the one time base it names, unless
    use_sim_time was given explicitly (a -p rule or a params file): an explicit value wins, and a
    contradiction is said in one line."""
    if time_source not in TIME_SOURCES:
        raise ParameterError(f"time_source must be one of {', '.join(TIME_SOURCES)}, got {time_source!r}")
    wanted = time_source == "sim"
    # rclpy keeps the node's command-line and params-file values here: the only record of an explicit one.
    explicit = getattr(node, "_parameter_overrides", {}).get("use_sim_time")
    if explicit is None:
        node.set_parameters([Parameter("use_sim_time", Parameter.Type.BOOL, wanted)])
    elif bool(explicit.value) != wanted:
        node.get_logger().info(
            f"use_sim_time {str(bool(explicit.value)).lower()} given explicitly: it wins over time_source "
            f"{time_source} (this node's clock is the {'/clock topic' if explicit.value else 'system clock'})"
        )


def write_summary(path: str, counters: Mapping[str, object]) -> None:
    """Write a node's counters as JSON to ``path`` (nothing when empty): the launcher's accounting."""
    if path:
        Path(path).write_text(json.dumps(dict(counters), indent=1, sort_keys=True))


def parameter_values(
    node: Node, names: Sequence[str], changes: Sequence[AnyParameter] = ()
) -> dict[str, Any]:  # Any: each value has its parameter's own type, read by name
    """{name: current value} of ``names`` on ``node``, with ``changes`` (a pending set) on top."""
    values: dict[str, Any] = {name: node.get_parameter(name).value for name in names}  # Any: as returned
    for param in changes:
        if param.name in values:
            values[param.name] = param.value
    return values


def change_result(build: Callable[[], object]) -> SetParametersResult:
    """Accept a parameter change when ``build()`` (what it would make) raises nothing; else say why."""
    try:
        build()
    except PendulumAccelError as err:
        return SetParametersResult(successful=False, reason=str(err))
    except (TypeError, ValueError) as err:
        return SetParametersResult(successful=False, reason=f"invalid value: {err}")
    return SetParametersResult(successful=True)


def publish_blocking(publisher: AnyPublisher, msg: object, stopping: Callable[[], bool]) -> bool:
    """Publish ``msg`` (message or CDR bytes), retrying while the keep-all history is full; False if stopped.

    A reliable keep-all writer refuses a sample when its readers have not acknowledged enough of
    the previous ones: waiting here is the back-pressure that keeps the chain lossless.
    """
    while True:
        try:
            publisher.publish(msg)
            return True
        except Exception:  # rclpy raises RCLError (not exported) when the history is full
            if stopping():
                return False
            time.sleep(_PUBLISH_RETRY_PERIOD)


PARAMETER_SERVICE_TYPES = (
    DescribeParameters,
    GetParameters,
    GetParameterTypes,
    ListParameters,
    SetParameters,
    SetParametersAtomically,
)
"""The services rclpy's ParameterService gives every node (rclpy.parameter_service)."""


def serve_parameter_requests(node: Node) -> int:
    """Answer every parameter request waiting on ``node``'s parameter services; how many were answered.

    For a callback that must wait inside the executor (a full backlog pushing back on its publisher): the
    EventsExecutor runs one callback at a time, in the order the middleware announced them, so a request
    announced behind thousands of queued messages waits for all of them. Taken here as the executor takes
    them (rclpy.executors.Executor._take_service, the EventsExecutor's HandleServiceReady): take, call,
    send the response; the executor's own take later finds nothing and skips it. Parameter services only:
    a lifecycle transition from inside a subscription's callback could destroy that subscription.
    """
    answered = 0
    for service in list(node.services):
        if service.srv_type not in PARAMETER_SERVICE_TYPES:
            continue
        while True:
            with service.handle:
                taken = service.handle.service_take_request(service.srv_type.Request)
            request, header = taken if taken is not None else (None, None)
            if header is None:
                break
            service.send_response(service.callback(request, service.srv_type.Response()), header)
            answered += 1
    return answered


def acked_within(publisher: AnyPublisher, seconds: float, stopping: Callable[[], bool]) -> bool:
    """True once every matched reader acknowledged all ``publisher`` sent; False after ``seconds`` or once
    ``stopping()``. Waits in short slices: close() gives a node's thread 5 s, and destroying a publisher
    while a thread still waits inside it crashes the process."""
    deadline = time.monotonic() + seconds
    while not publisher.wait_for_all_acked(_ACK_SLICE):
        if stopping() or time.monotonic() >= deadline:
            return False
    return True


_RCL_WHERE = re.compile(r",? at /\S+:\d+")


def rcl_error_line(err: Exception) -> str:
    """One line of an RCLError: its message without the C source locations rcl appends
    ("Couldn't parse params file: '--params-file x.yaml'. Error: Error opening YAML file")."""
    text = _RCL_WHERE.sub("", str(err))
    text = text.replace("failed to initialize rcl: ", "")
    return " ".join(text.split())


def check_ros_args(argv: Sequence[str]) -> None:
    """ParameterError (one line) for a ``--params-file`` that is missing or not YAML mapping, or a
    ``-p name:=value`` rule that does not parse, among the --ros-args of ``argv``; checked before rcl
    sees them, because rcl logs its own error line before raising."""
    import yaml

    inside = False
    tokens = list(argv)
    for i, token in enumerate(tokens):
        if token == "--ros-args":
            inside = True
            continue
        if token == "--":
            inside = False
            continue
        if not inside or i + 1 >= len(tokens):
            continue
        value = tokens[i + 1]
        if token == "--params-file":
            try:
                text = Path(value).read_text()
            except (OSError, UnicodeDecodeError) as err:
                raise ParameterError(
                    f"cannot read the parameters file {value}: {getattr(err, 'strerror', None) or err}"
                ) from None
            try:
                data = yaml.safe_load(text)
            except yaml.YAMLError as err:
                where = getattr(err, "problem_mark", None)
                line = f" (line {where.line + 1})" if where is not None else ""
                raise ParameterError(f"parameters file {value} is not valid YAML{line}") from None
            if not isinstance(data, dict):
                raise ParameterError(
                    f"parameters file {value} must map node names to ros__parameters, "
                    f"got {type(data).__name__}"
                )
        elif token in ("-p", "--param"):
            name, sep, text = value.partition(":=")
            if not sep or not name:
                raise ParameterError(f"parameter rule {value!r} must read name:=value")
            try:
                yaml.safe_load(text)
            except yaml.YAMLError:
                raise ParameterError(f"parameter rule {value!r}: the value is not valid YAML") from None


def run_node(factory: Callable[[], Node], name: str, args: Sequence[str] | None = None) -> int:
    """Exit code of one node's life: the node's own code, 0 on SIGINT/SIGTERM, 2 on a PendulumAccelError.

    The first SIGINT or SIGTERM asks a ChainNode to stop gracefully (``request_stop``: a recorder
    drains its queues before closing the bag); a second one ends the spin at once. Either way
    ``close()`` runs before the process exits. A first signal while the node is still being built waits
    for it once it holds input (``ChainNode.holds_input``), and ends the start-up at once before that.
    The EventsExecutor, not the default one, because it takes about ten times as many messages per
    second in Python, which the 1 kHz chain needs.
    """
    node: Node | None = None
    executor: Executor | None = None
    code = 0
    stops = 0

    def on_signal(signum: int, frame: FrameType | None) -> None:
        """First signal: request_stop() (once the node exists, if it holds input while built); later: now."""
        nonlocal stops
        stops += 1
        if isinstance(node, ChainNode):
            if stops == 1:
                node.request_stop()
            else:
                node.finish(0)
        elif stops > 1 or not _HOLDING.is_set():  # nothing taken yet (a compile, say): end start-up now
            raise KeyboardInterrupt

    use_package_profile()
    clear_stale_ports()  # a port a killed process left empty would hang this node's start-up
    try:
        check_ros_args(list(args) if args is not None else sys.argv)
        rclpy.init(
            args=list(args) if args is not None else None, signal_handler_options=SignalHandlerOptions.NO
        )
        signal.signal(signal.SIGINT, on_signal)
        signal.signal(signal.SIGTERM, on_signal)
        node = factory()
        if stops and isinstance(node, ChainNode):  # a stop that came while it was built (holds_input)
            node.request_stop()
        # The spinning thread only: it runs every callback. With the DDS threads at FIFO too, they would
        # compete with it, and with every other process, at the same priority.
        priority_problem = apply_rt_priority()
        if priority_problem is not None:
            node.get_logger().warning(priority_problem)
        executor = EventsExecutor()
        executor.add_node(node)
        # Everything built so far (rclpy, numpy, scipy, the plan) lives as long as the process: frozen,
        # the collector stops re-walking it, so a full collection in the message loop takes microseconds,
        # not the milliseconds that showed up as p99 latency spikes.
        gc.freeze()
        if not isinstance(node, ChainNode):
            executor.spin()
        else:
            # Short spins in a loop: between two of them the main thread is back in Python,
            # where signal handlers run (never while the C++ executor holds it).
            while not node.finished.done():
                executor.spin_until_future_complete(node.finished, timeout_sec=_SIGNAL_POLL_PERIOD)
            result = node.finished.result()
            code = result if isinstance(result, int) else 0
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except (PendulumAccelError, ParameterException) as err:
        print(f"{name}: error: {err}", file=sys.stderr, flush=True)
        code = 2
    except RCLError as err:  # a bad --params-file or -p rule: rcl refuses the arguments
        print(f"{name}: error: {rcl_error_line(err)}", file=sys.stderr, flush=True)
        code = 2
    finally:
        if isinstance(node, ChainNode):
            node.close()
        if executor is not None and node is not None:
            # The EventsExecutor holds the node's entities and their event handlers: destroying them while it
            # still does can end the process in SIGSEGV (rclpy#1644, seen here once in ~30 chains). Hand the
            # node back and stop the executor first.
            executor.remove_node(node)
            executor.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return code
