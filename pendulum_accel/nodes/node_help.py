"""``--help`` for every node, printed from its parameter table without importing rclpy.

Each node's console script enters through ``console_main`` and ``python -m pendulum_accel.nodes.X``
through the package's ``__init__`` (see ``answer_module_help``): both look at argv before the node
module, and with it rclpy, is imported, so ``--help`` works where ROS is absent or broken.
"""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable, Sequence

from pendulum_accel.nodes.parameters import NODE_PARAMETERS

NODE_MODULES: dict[str, str] = {
    "pendulum_sim": "simulator_node",
    "accel_estimator": "estimator_node",
    "bag_recorder": "recorder_node",
    "bag_player": "player_node",
}
"""Each node's module in pendulum_accel.nodes, by node name."""

ROLES: dict[str, str] = {
    "pendulum_sim": "simulates a scene; publishes the measured angle, the true acceleration and /clock",
    "accel_estimator": "estimates the car's acceleration from the angle; publishes the estimate, an Imu "
    "and /diagnostics",
    "bag_recorder": "records the chain's topics into a rosbag2 MCAP bag",
    "bag_player": "publishes a bag's messages with their original timing",
}
"""One line per node: what it does."""


def wants_help(args: Sequence[str]) -> bool:
    """True when -h or --help comes before any --ros-args (ROS's own arguments are not ours to read)."""
    ours = list(args)
    if "--ros-args" in ours:
        ours = ours[: ours.index("--ros-args")]
    return "-h" in ours or "--help" in ours


def help_text(node: str) -> str:
    """Usage, role and every parameter of ``node`` (name, type, range, default, description)."""
    lines = [
        f"usage: {node} [--ros-args -p NAME:=VALUE ... --params-file FILE ...]",
        "",
        f"{node}: {ROLES[node]}.",
        "",
        "parameters:",
    ]
    lines += [f"  {spec.help_line()}" for spec in NODE_PARAMETERS[node]]
    return "\n".join(lines)


def console_main(node: str, args: Sequence[str] | None = None) -> int:
    """A node's console script: its help (exit 0) when asked, else the node module's ``main``."""
    argv = list(sys.argv[1:] if args is None else args)
    if wants_help(argv):
        print(help_text(node))
        return 0
    module = importlib.import_module(f"pendulum_accel.nodes.{NODE_MODULES[node]}")
    main: Callable[[Sequence[str] | None], int] = module.main
    return main(args)


def answer_module_help(orig_argv: Sequence[str]) -> None:
    """For ``python -m pendulum_accel.nodes.<module> --help``: print the node's help and exit 0."""
    argv = list(orig_argv)
    if "-m" not in argv:
        return
    at = argv.index("-m")
    if at + 1 >= len(argv):
        return
    module = argv[at + 1].removeprefix("pendulum_accel.nodes.")
    node = next((name for name, mod in NODE_MODULES.items() if mod == module), None)
    if node is not None and argv[at + 1].startswith("pendulum_accel.nodes.") and wants_help(argv[at + 2 :]):
        print(help_text(node))
        raise SystemExit(0)


def pendulum_sim() -> int:
    """Console script ``pendulum_sim``."""
    return console_main("pendulum_sim")


def accel_estimator() -> int:
    """Console script ``accel_estimator``."""
    return console_main("accel_estimator")


def bag_recorder() -> int:
    """Console script ``bag_recorder``."""
    return console_main("bag_recorder")


def bag_player() -> int:
    """Console script ``bag_player``."""
    return console_main("bag_player")
