"""ROS 2 launch description of the chain: ``ros2 launch pendulum_accel chain.launch.py scene:=step_start``.

Launch arguments: scene, record (a bag directory; empty: no recorder), estimator (method), fast,
time_source (sim or wall; empty: sim with fast or record, else wall, as ``pendulum-accel run``),
namespace, namespace_clock (true: a namespaced chain runs on ``<namespace>/clock``), remap (FROM:=TO
rules for every node, separated by spaces), frame_prefix (of every frame the chain publishes in; auto:
``<namespace>/`` in a namespace, as ``pendulum-accel run``), autostart (false: the managed nodes wait
for ``ros2 lifecycle set``), use_sim_time (true or false for every node, winning over time_source; empty:
time_source decides) and shutdown_on_scene_end (true: the simulator's exit at the scene's end shuts the
launch down, which closes the bag; false: it ends alone, as a robot bringup that includes this file
needs). Every node reads ``config/pendulum_accel.params.yaml`` first; the arguments then override it. The
same start-up rules as the launcher: the simulator publishes once accel_estimator (and bag_recorder,
when recording) subscribe, by name.

Includable: under a bringup's PushRosNamespace the chain's namespace is the pushed one (with
``namespace`` appended, unless absolute), as launch_ros resolves the nodes' namespace, so the clock remap
and the frame prefix follow it too.

Only the standard library is imported at module level; ``launch``, ``launch_ros`` and
``ament_index_python`` inside ``generate_launch_description``, so ``chain_nodes`` (what runs, with
which parameters) can be read without ROS.
"""

from __future__ import annotations

import os
from typing import Any

PACKAGE = "pendulum_accel"
ARGUMENTS: dict[str, tuple[str, str]] = {
    "scene": ("lecture_constant", "bundled scene name or scene YAML path"),
    "record": ("", "record the chain to this bag directory (empty: no recording)"),
    "estimator": ("kalman", "estimation method"),
    "fast": ("false", "true: as fast as possible, on sim time"),
    "time_source": ("", "sim or wall (empty: sim when fast or recording, else wall)"),
    "namespace": ("", "namespace of every node: the chain's relative topics resolve under it"),
    "namespace_clock": (
        "true",
        "true: a namespaced chain publishes and follows <namespace>/clock, not /clock",
    ),
    "remap": (
        "",
        "topic remaps for every node, FROM:=TO separated by spaces (e.g. pendulum/joint_states:=angle)",
    ),
    "frame_prefix": (
        "auto",
        "prepended to every frame the chain publishes in: estimate, truth, markers, Imu, /tf_static "
        "(auto: <namespace>/ in a namespace, else none; empty: none)",
    ),
    "autostart": ("true", "false: the simulator and estimator wait, unconfigured, for ros2 lifecycle set"),
    "use_sim_time": ("", "true or false: every node's use_sim_time, over time_source (empty: time_source)"),
    "shutdown_on_scene_end": (
        "true",
        "true: the scene's end shuts the whole launch down (the bag closes); false: only the simulator ends "
        "(for a bringup that includes this file)",
    ),
}


def _true(text: str) -> bool:
    """A launch argument's boolean: true/1/yes (any case)."""
    return text.strip().lower() in ("true", "1", "yes")


def remappings(namespace: str, namespace_clock: str, remap: str) -> list[tuple[str, str]]:
    """Every node's (from, to) remaps: the user's rules, then ``/clock`` to ``<namespace>/clock`` for a
    namespaced chain unless namespace_clock is false (rcl applies the first matching rule)."""
    from pendulum_accel.nodes.launcher import clock_remap

    rules = remap.split() + (clock_remap(namespace) if _true(namespace_clock) else [])
    pairs = [rule.partition(":=") for rule in rules]
    bad = [
        rule
        for rule, (source, sep, target) in zip(rules, pairs, strict=True)
        if not (sep and source and target)
    ]
    if bad:
        raise ValueError(f"remap {bad[0]!r} must read FROM:=TO")
    return [(source, target) for source, _, target in pairs]


def chain_namespace(pushed: str, namespace: str) -> str:
    """The nodes' namespace as launch_ros resolves it: ``namespace`` when absolute, else ``namespace`` under
    the one a bringup pushed (PushRosNamespace keeps it in the 'ros_namespace' launch configuration)."""
    if namespace.startswith("/"):
        return namespace
    parts = [part for part in (pushed.strip("/"), namespace.strip("/")) if part]
    return "/" + "/".join(parts) if parts else ""


def frame_prefix_of(namespace: str, frame_prefix: str) -> str:
    """The simulator's and estimator's frame_prefix: ``<namespace>/`` for auto (none in the root
    namespace), else the argument as given."""
    from pendulum_accel.nodes.launcher import namespace_frame_prefix

    return namespace_frame_prefix(namespace) if frame_prefix == "auto" else frame_prefix


def chain_nodes(
    scene: str,
    record: str,
    estimator: str,
    fast: str,
    time_source: str,
    autostart: str = "true",
    frame_prefix: str = "",
    use_sim_time: str = "",
    shutdown_on_scene_end: str = "true",
) -> list[dict[str, Any]]:
    """What to run: one {executable, name, parameters} per node, recorder first (if recording); the
    simulator's ``ends_launch``: its exit shuts the launch down."""
    realtime = not _true(fast)
    # frame_prefix set only when not empty (the nodes' default), so a params file's value stays.
    sim_and_estimator: dict[str, Any] = {"autostart": _true(autostart)}
    if frame_prefix:
        sim_and_estimator["frame_prefix"] = frame_prefix
    if use_sim_time.strip().lower() not in ("", "true", "false", "1", "0", "yes", "no"):
        raise ValueError(f"use_sim_time must be true, false or empty, got {use_sim_time!r}")
    # Set only when given: an explicit use_sim_time wins over time_source in every node (runtime.py).
    clock: dict[str, Any] = {"use_sim_time": _true(use_sim_time)} if use_sim_time.strip() else {}
    source = time_source or ("sim" if (not realtime or record) else "wall")
    if source not in ("sim", "wall"):
        raise ValueError(f"time_source must be sim or wall, got {time_source!r}")
    if source == "wall" and not realtime:
        raise ValueError("time_source wall needs real-time pacing (fast:=false)")
    recorder = "bag_recorder" if record else ""
    nodes: list[dict[str, Any]] = []
    if record:
        nodes.append(
            {
                "executable": "bag_recorder",
                "name": "bag_recorder",
                "parameters": {"path": record, "scene": scene, "time_source": source, **clock},
            }
        )
    nodes.append(
        {
            "executable": "accel_estimator",
            "name": "accel_estimator",
            "parameters": {
                "scene": scene,
                "method": estimator,
                "time_source": source,
                "recorder_node": recorder,
                **sim_and_estimator,
                **clock,
            },
        }
    )
    nodes.append(
        {
            "executable": "pendulum_sim",
            "name": "pendulum_sim",
            "parameters": {
                "scene": scene,
                "realtime": realtime,
                "time_source": source,
                "publish_clock": source == "sim",
                "reader_nodes": ["accel_estimator"],
                "recorder_node": recorder,
                **sim_and_estimator,
                **clock,
            },
            # Its exit (the scene's end) shuts the launch down, which closes the bag; not in a bringup.
            "ends_launch": _true(shutdown_on_scene_end),
        }
    )
    return nodes


def generate_launch_description() -> Any:
    """LaunchDescription: the arguments above, then the nodes ``chain_nodes`` picks for their values."""
    from ament_index_python.packages import get_package_share_directory
    from launch import LaunchDescription
    from launch.actions import DeclareLaunchArgument, OpaqueFunction, Shutdown
    from launch.substitutions import LaunchConfiguration
    from launch_ros.actions import Node

    params_file = os.path.join(get_package_share_directory(PACKAGE), "config", f"{PACKAGE}.params.yaml")

    def nodes(context: Any) -> list[Any]:
        """The Node actions for the arguments' values in ``context``."""
        values = {name: LaunchConfiguration(name).perform(context) for name in ARGUMENTS}
        namespace = values.pop("namespace")
        # Where the nodes end up, a bringup's PushRosNamespace included: the clock and frames follow it.
        full = chain_namespace(context.launch_configurations.get("ros_namespace", ""), namespace)
        remaps = remappings(full, values.pop("namespace_clock"), values.pop("remap"))
        values["frame_prefix"] = frame_prefix_of(full, values["frame_prefix"])
        return [
            Node(
                package=PACKAGE,
                executable=spec["executable"],
                name=spec["name"],
                namespace=namespace,
                remappings=remaps,
                parameters=[params_file, spec["parameters"]],
                output="screen",
                on_exit=[Shutdown(reason="scene finished")] if spec.get("ends_launch") else None,
            )
            for spec in chain_nodes(**values)
        ]

    return LaunchDescription(
        [
            DeclareLaunchArgument(name, default_value=default, description=text)
            for name, (default, text) in ARGUMENTS.items()
        ]
        + [OpaqueFunction(function=nodes)]
    )
