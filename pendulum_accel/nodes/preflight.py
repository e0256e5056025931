"""Checks of a chain configuration before any node starts: scene, overrides, names, estimator, output.

Quick (ROS only for rclpy's name validators). The launcher calls :func:`check_chain` first, so a mistake
is one line from the launcher, not three nodes starting, failing each in its own words and leaving an
empty bag behind.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

from pendulum_accel.errors import ParameterError

if TYPE_CHECKING:
    from pendulum_accel.nodes.launcher import ChainConfig
    from pendulum_accel.scene import Scene


def check_chain(config: ChainConfig) -> Scene:
    """The scene the chain runs, its overrides applied; ParameterError/SceneError (one line) for anything
    the nodes would refuse, checked in that order.

    Scene loads and validates with its overrides applied (ranges, whole seeds); the namespace and
    remap rules are names ROS accepts for every node (nodes.names, rcl's rules); the estimator is a
    known method; the bag directory does not exist (or ``overwrite``), and the nearest existing
    directory above it is writable (missing ones are created, as rosbag2 does). (``--rt-priority`` with
    ``--fast`` is refused by the command line, cli.run.chain_config.)
    """
    from pendulum_accel.estimators import ESTIMATORS
    from pendulum_accel.nodes.names import check_chain_names
    from pendulum_accel.overrides import apply_overrides
    from pendulum_accel.scene import load_scene

    scene = apply_overrides(load_scene(config.scene), config.overrides)
    check_chain_names(config.namespace, config.remaps)
    if config.estimator is not None and config.estimator not in ESTIMATORS:
        raise ParameterError(f"unknown estimator {config.estimator!r}; choose one of {', '.join(ESTIMATORS)}")
    if config.record is not None:
        check_output_dir(config.record, overwrite=config.overwrite)
    return scene


def check_output_dir(path: os.PathLike[str] | str, *, overwrite: bool) -> None:
    """ParameterError unless a bag directory can be created at ``path``: the nearest existing directory
    above it writable (the missing ones between are created, as rosbag2 does)."""
    from pathlib import Path

    bag = Path(path)
    if bag.exists() and not overwrite:
        raise ParameterError(f"{bag} exists already; pass --overwrite to replace it")
    if bag.exists() and not bag.is_dir():
        raise ParameterError(f"{bag} is a file, not a bag directory; choose another path")
    # The directories above it are created as rosbag2 creates them (SequentialWriter::open:
    # std::filesystem::create_directories), so the nearest one that exists is the one written in.
    parent = next(above for above in bag.absolute().parents if above.exists())
    if not parent.is_dir():
        raise ParameterError(f"cannot record to {bag}: {parent} is a file, not a directory")
    if not os.access(parent, os.W_OK | os.X_OK) or (bag.is_dir() and not os.access(bag, os.W_OK | os.X_OK)):
        raise ParameterError(f"cannot record to {bag}: {parent} is not writable (read-only or permissions)")
    if _read_only_mount(parent):
        raise ParameterError(f"cannot record to {bag}: {parent} is on a read-only file system")


def _read_only_mount(directory: os.PathLike[str]) -> bool:
    """True when ``directory`` lies on a file system mounted read-only (statvfs ST_RDONLY)."""
    try:
        return bool(os.statvfs(directory).f_flag & os.ST_RDONLY)
    except OSError:
        return False
