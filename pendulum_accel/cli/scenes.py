"""``pendulum-accel scenes [NAME]``: list the bundled scenes, or show one scene's YAML and plan."""

from __future__ import annotations

import argparse
import sys


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the ``scenes`` subcommand."""
    parser = subparsers.add_parser(
        "scenes",
        help="list the bundled scenes (name and description), or show one",
        description=(
            "Without NAME: one line per bundled scene, name and description. With NAME (a bundled name or "
            "a YAML path): the scene as YAML on stdout and the planner's choice on stderr."
        ),
    )
    parser.add_argument("name", nargs="?", metavar="NAME", help="scene to show")
    parser.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Print the table of bundled scenes, or one scene's YAML (stdout) and plan (stderr)."""
    from pendulum_accel.scene import (
        BUNDLED_SCENE_NAMES,
        DEFAULT_SCENE,
        list_scenes,
        load_scene,
        scene_to_yaml,
    )

    if args.name is None:
        scenes = list_scenes(BUNDLED_SCENE_NAMES)
        width = max(len(s.name) for s in scenes)
        for scene in scenes:
            mark = " (default)" if scene.name == DEFAULT_SCENE else ""
            origin = getattr(scene.profile, "origin", "")
            print(f"{scene.name:<{width}}  {scene.description}{mark}" + (f" [{origin}]" if origin else ""))
        return 0
    from pendulum_accel.planner import plan_scene

    scene = load_scene(args.name)
    sys.stdout.write(scene_to_yaml(scene))
    origin = getattr(scene.profile, "origin", "")
    if origin:
        print(f"acceleration: {origin}", file=sys.stderr)
    print(plan_scene(scene).explain(), file=sys.stderr)
    return 0
