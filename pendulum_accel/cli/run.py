"""``pendulum-accel run [SCENE] --record DIR``: run the live ROS 2 chain on a scene and summarise it."""

from __future__ import annotations

import argparse
import os
import shutil
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from pendulum_accel.errors import ParameterError, PendulumAccelError
from pendulum_accel.overrides import SET_HELP, parse_override

if TYPE_CHECKING:
    from pendulum_accel.nodes.launcher import ChainConfig


def add_chain_arguments(parser: argparse.ArgumentParser) -> None:
    """The chain's options, shared by ``pendulum-accel run`` and ``launch_scripts/chain.py``."""
    parser.add_argument("scene", nargs="?", default=None, help="bundled scene name or scene YAML path")
    parser.add_argument("--record", type=Path, metavar="DIR", help="record the chain to this bag directory")
    parser.add_argument("--overwrite", action="store_true", help="replace an existing bag")
    pace = parser.add_mutually_exclusive_group()
    pace.add_argument(
        "--realtime", dest="realtime", action="store_true", default=True, help="wall-clock pace (default)"
    )
    pace.add_argument(
        "--fast", dest="realtime", action="store_false", help="as fast as possible, graph on /clock"
    )
    parser.add_argument("--estimator", metavar="M", help="estimation method (default: the package default)")
    parser.add_argument(
        "--time-source",
        choices=("sim", "wall"),
        default=None,
        help="time base of every stamp: sim (scene time from 0, /clock published, every node on "
        "use_sim_time) or wall (the ROS system clock at each sample's due time, no /clock); "
        "default sim with --fast or --record, else wall",
    )
    parser.add_argument(
        "--rt-priority",
        type=_priority,
        default=0,
        metavar="N",
        help="real-time runs: SCHED_FIFO priority 1-99 for every node (needs root or CAP_SYS_NICE); "
        "0, the default, keeps normal scheduling",
    )
    parser.add_argument(
        "--network",
        action="store_true",
        help="let the nodes use every network interface (multi-host; sets PENDULUM_ACCEL_NETWORK=1); "
        "by default they bind the loopback interface only",
    )
    parser.add_argument(
        "--namespace",
        default="",
        metavar="NS",
        help="run every node in this namespace (the chain's relative topics resolve under it, so two "
        "chains on one domain stay apart); the chain's clock is NS/clock (see --global-clock), its "
        "diagnostics go to the global /diagnostics under the node's full name",
    )
    parser.add_argument(
        "--global-clock",
        dest="namespace_clock",
        action="store_false",
        help="with --namespace: publish and follow the global /clock instead of NS/clock (one chain per "
        "domain only: two chains would interleave their timelines)",
    )
    parser.add_argument(
        "--frame-prefix",
        default=None,
        metavar="PREFIX",
        help="prepended to the frames of what viewers draw (markers, Imu, /tf_static), as "
        "robot_state_publisher's frame_prefix; default NS/ with --namespace (two chains draw apart), "
        "else none ('' for none)",
    )
    parser.add_argument(
        "--remap",
        dest="remaps",
        action="append",
        default=[],
        metavar="FROM:=TO",
        help="remap a topic for every node, as --ros-args -r FROM:=TO (the bag records the remapped name)",
    )
    parser.add_argument(
        "--set",
        dest="overrides",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help=SET_HELP,
    )


def chain_config(args: argparse.Namespace) -> ChainConfig:
    """ChainConfig from parsed chain arguments."""
    from pendulum_accel.nodes.dds_profile import NETWORK_ENV
    from pendulum_accel.nodes.launcher import ChainConfig
    from pendulum_accel.scene import DEFAULT_SCENE

    if args.rt_priority and not args.realtime:
        # The launcher would quietly run it at normal priority: say so instead.
        raise ParameterError(
            "--rt-priority applies to real-time runs only (as fast as possible, FIFO nodes that never "
            "block would starve the machine); drop --fast or --rt-priority"
        )
    if getattr(args, "network", False):
        os.environ[NETWORK_ENV] = "1"  # inherited by every node the launcher starts
    return ChainConfig(
        scene=args.scene or DEFAULT_SCENE,
        record=args.record,
        overwrite=args.overwrite,
        realtime=args.realtime,
        estimator=args.estimator,
        overrides=dict(parse_override(text) for text in args.overrides),
        rt_priority=args.rt_priority,
        time_source=args.time_source,
        namespace=str(getattr(args, "namespace", "") or ""),
        remaps=list(getattr(args, "remaps", [])),  # checked with rcl's rules by the launcher's preflight
        namespace_clock=bool(getattr(args, "namespace_clock", True)),
        frame_prefix=getattr(args, "frame_prefix", None),
    )


def _priority(text: str) -> int:
    """An int from 0 to 99, else argparse's one-line error."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if not 0 <= value <= 99:
        raise argparse.ArgumentTypeError(f"must be an integer from 0 to 99, got {text!r}")
    return value


def summary_lines(bag_path: Path, estimator: str | None) -> list[str]:
    """Messages per topic, live-estimator error vs truth (bias, RMS, max), plan line and bag path."""
    from pendulum_accel.bag import messages as bm
    from pendulum_accel.bag.reader import read_bag
    from pendulum_accel.bag.writer import CUSTOM_PLAN
    from pendulum_accel.estimators import estimator_line
    from pendulum_accel.recording.analyze import analyze_bag

    bag = read_bag(bag_path)
    width = max([22, *(len(name) for name in bag.topics)])
    lines = ["messages:"] + [f"  {name:<{width}} {info.count:>8}" for name, info in bag.topics.items()]
    if bag.find_topic(bm.JOINT_STATES) is None or bag.find_topic(bm.ACCEL_TRUTH) is None:
        # Remapped away from the chain's names: the bag is whole, the comparison has nothing to go on.
        lines.append("estimate vs truth: not computed (the angles or the truth were remapped to other names)")
        lines.append(f"bag: {bag.path}")
        return lines
    analysis = analyze_bag(bag, estimator=estimator)
    recorded = analysis.recorded
    if recorded is not None and recorded.n:
        lines.append(
            f"estimate vs truth ({analysis.estimator}, live, {recorded.n} estimates): "
            f"bias {recorded.bias:+.5f}, RMS {recorded.rms:.5f}, max {recorded.max_abs:.5f} m/s²"
        )
    if analysis.settling_time is not None:
        s = analysis.settled_stats
        lines.append(
            f"offline {analysis.estimator} after settling ({analysis.settling_time:.3f} s): "
            f"bias {s.bias:+.5f}, RMS {s.rms:.5f}, max {s.max_abs:.5f} m/s²"
        )
    plan = bag.custom_data.get(CUSTOM_PLAN, "plan: (none stored)")
    lines.append(plan if plan.startswith("plan:") else f"plan: {plan}")
    lines.append(estimator_line(analysis.estimator, analysis.motion))
    lines.append(f"bag: {bag.path}")
    return lines


def run(args: argparse.Namespace) -> int:
    """Run the chain until the scene ends (or Ctrl-C), then print the summary from the recorded bag."""
    from pendulum_accel.nodes.launcher import require_rclpy, run_chain

    require_rclpy()
    config = chain_config(args)
    from pendulum_accel.kernel_cache import warm_if_cold

    # A cold cache (the first run after a pip install) would keep the estimator compiling past the
    # simulator's wait for its readers: compile here first, saying what is waited for.
    warm_if_cold(lambda line: print(f"pendulum-accel run: {line}", file=sys.stderr, flush=True))
    existed = config.record is not None and config.record.exists()
    code = run_chain(config)
    if config.record is not None and not existed and _empty_bag(config.record):
        # A chain that failed before its first message leaves no bag to block the next run.
        shutil.rmtree(config.record, ignore_errors=True)
        print(
            f"pendulum-accel run: no message was recorded; removed the empty {config.record}", file=sys.stderr
        )
    if (
        config.record is not None
        and (config.record / "metadata.yaml").exists()
        and not _recorded_by_another(config.record)
    ):
        # Checked before the summary reads it: a bag moved or cut under its recorder may hold too little
        # to summarise, and the run must then end with the WARNING that says so (exit 1), not the summary's
        # error (exit 2).
        problem = _recording_problem(config.record)
        try:
            for line in summary_lines(config.record, config.estimator):
                print(line)
        except PendulumAccelError as err:
            if problem is None:
                raise
            print(f"pendulum-accel run: no summary: {err}", file=sys.stderr)
        if problem is not None:
            print(problem, file=sys.stderr)
        if code == 0 and problem is not None:
            code = 1
    return code


def _recorded_by_another(path: Path) -> bool:
    """True when another process is writing the bag at ``path`` (its lock, bag/lock.py): this run's
    recorder refused to replace it, and the bag there is not this run's to summarise."""
    from pendulum_accel.bag.lock import holder

    try:
        found = holder(path) if path.is_dir() else None
    except PendulumAccelError:
        return False
    return found is not None and found.live and not found.ours


def _recording_problem(path: Path) -> str | None:
    """None when the bag the run recorded reads [complete] as ``info`` checks it (every message the recorder
    says it wrote is in the file, the publishers' counts agree), else the one WARNING line to print: a bag
    moved or replaced under the recorder holds fewer messages than the run reported."""
    from pendulum_accel.bag.reader import read_bag
    from pendulum_accel.cli.info import bag_state

    try:
        state, losses = bag_state(read_bag(path))
    except PendulumAccelError as err:
        state, losses = str(err), []
    if state == "complete":
        return None
    return f"WARNING: the recorded bag {path} is not complete: {'; '.join(losses) or state}"


def _empty_bag(path: Path) -> bool:
    """True when ``path`` is a directory whose bag holds no message (or nothing readable at all)."""
    from pendulum_accel.bag.reader import read_bag
    from pendulum_accel.errors import BagError

    if not path.is_dir() or path.is_symlink():
        return False
    try:
        return read_bag(path).message_count == 0
    except BagError:
        return not any(f.stat().st_size > 64 for f in path.iterdir() if f.is_file())


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``run``: the live chain (simulator, estimator, recorder over DDS) on one scene."""
    parser = subparsers.add_parser(
        "run",
        help="run the live ROS 2 chain on a scene and record it",
        description="Start simulator, estimator and recorder (separate processes over DDS) on a scene, "
        "wait for the scene to end, stop everything and summarise the recording.",
    )
    add_chain_arguments(parser)
    parser.set_defaults(func=run)
