"""``pendulum-accel urdf [SCENE]``: print the URDF of a scene's pendulum (the one the simulator publishes).

``share/pendulum_accel/urdf/pendulum_accel.urdf`` is this command's output for the default scene, installed
for ``robot_state_publisher`` and viewers that load a file (test_urdf checks that the two agree).
"""

from __future__ import annotations

import argparse


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``urdf`` subcommand."""
    parser = subparsers.add_parser(
        "urdf",
        help="print the URDF of a scene's pendulum (what the simulator publishes on robot_description)",
        description=(
            "Print the URDF of SCENE's pendulum (default: the default scene): the car body, the pivot, "
            "pendulum_joint (continuous about +y) and the string and bob sized from the pendulum's length, "
            "with the bob's mass. robot_state_publisher's frame_prefix parameter prefixes its frames."
        ),
    )
    parser.add_argument("scene", nargs="?", default=None, help="bundled scene name or scene YAML path")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Print the URDF."""
    from pendulum_accel.recording.visual import urdf
    from pendulum_accel.scene import DEFAULT_SCENE, load_scene

    pendulum = load_scene(args.scene or DEFAULT_SCENE).pendulum
    print(urdf(pendulum.length, mass=pendulum.mass), end="")
    return 0
