"""Entry point of ``pendulum-accel``: dispatches to one module per subcommand.

Each module in ``COMMANDS`` defines ``register(subparsers)``, which adds its parser and
sets ``func(args) -> int`` as the default. Only the module of the command given is imported (the
others appear in ``--help`` by their one-line summary here), so ``--version`` and ``--help`` import no
numpy, scipy or numba (test_startup.py checks what they import).
"""

from __future__ import annotations

import argparse
import importlib
import os
import re
import signal
import sys
import threading
from collections.abc import Callable, Sequence
from types import FrameType
from typing import cast

from pendulum_accel import __version__
from pendulum_accel.errors import PendulumAccelError

# command → (its module in pendulum_accel.cli, its one-line summary: the help= of its parser, which
# test_startup checks). Order is the order of ``pendulum-accel --help``.
COMMANDS: dict[str, tuple[str, str]] = {
    "simulate": (
        "simulate",
        "simulate a scene (or plain flags) with the planner's model and solver, write a CSV",
    ),
    "scenes": ("scenes", "list the bundled scenes (name and description), or show one"),
    "sweep": ("sweep", "run many variants of a scene at once (lengths, accelerations or noise levels)"),
    "lecture": ("lecture", "reproduce a result of the lecture notes: formula vs simulation, with a plot"),
    "animate": ("animate", "draw the car and the swinging bob from a scene or a bag, as a GIF or MP4"),
    "info": ("info", "summarise a bag: topics, counts, duration, scene and plan"),
    "analyze": ("analyze", "compare a bag's recorded estimate and an offline re-run with its truth"),
    "design": (
        "design",
        "sweep sensor designs over motion profiles and seeds: a table and the accuracy-latency front",
    ),
    "allan": (
        "allan",
        "Allan deviation of the angle and the estimate: white-noise density, bias random walk",
    ),
    "export": ("export", "write a bag's topics as CSV or Parquet tables (pandas)"),
    "generate": (
        "generate",
        "write a bag straight from a scene (every topic a live recording holds), no DDS",
    ),
    "repair": ("repair", "rebuild a damaged bag (killed recorder) from what its MCAP file holds"),
    "urdf": (
        "urdf",
        "print the URDF of a scene's pendulum (what the simulator publishes on robot_description)",
    ),
    "golden-bags": ("golden_bags", "regenerate the small golden bags of the bundled scenes (make bags)"),
    "run": ("run", "run the live ROS 2 chain on a scene and record it"),
    "lab": (
        "lab",
        "the lab: check a student's install; make a class's data and key from a secret (teachers)",
    ),
}


def command_in(argv: Sequence[str]) -> str | None:
    """The subcommand named in argv: its first token that is not an option (the top level has only
    -h/--help and --version, which take no value); None when there is none or it is not a command."""
    first = next((token for token in argv if not token.startswith("-")), None)
    return first if first in COMMANDS else None


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The top-level parser: ``command`` (all when None) registered by its module, the rest by name and
    summary only."""
    parser = argparse.ArgumentParser(
        prog="pendulum-accel",
        description="Pendulum accelerometer: simulate, estimate, record and replay.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module, summary) in COMMANDS.items():
        if command is None or name == command:
            importlib.import_module(f"pendulum_accel.cli.{module}").register(sub)
        else:
            sub.add_parser(name, help=summary)
    return parser


def _command_parser(parser: argparse.ArgumentParser, command: str) -> argparse.ArgumentParser:
    """``command``'s own parser among ``parser``'s subcommands."""
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return cast(argparse.ArgumentParser, sub.choices[command])


def main(argv: Sequence[str] | None = None) -> int:
    """Run one subcommand; a PendulumAccelError becomes a one-line message and exit code 2, Ctrl-C (even
    while the command's modules are still importing) one line and exit code 130."""
    own_process = argv is None  # the console script or python -m: this process is the command's own
    argv = list(sys.argv[1:] if argv is None else argv)
    command = command_in(argv)
    interrupts: list[int] = []
    restore = _note_interrupts(interrupts)
    try:
        return _run(argv, command)
    except KeyboardInterrupt:
        return _interrupted(command, own_process)
    except Exception:
        # Code that checks for signals inside C (matplotlib's Agg converters) can turn the KeyboardInterrupt
        # into an error of its own ("Invalid bounding box"): after a Ctrl-C, still the interrupt.
        if not interrupts:
            raise
        return _interrupted(command, own_process)
    finally:
        restore()


def _note_interrupts(seen: list[int]) -> Callable[[], object]:
    """Make SIGINT raise KeyboardInterrupt as Python's default handler does, noting it in ``seen``; returns
    the call that puts the default back. Outside the main thread, or when a caller has SIGINT handled its
    own way, nothing changes."""
    if (
        threading.current_thread() is not threading.main_thread()
        or signal.getsignal(signal.SIGINT) is not signal.default_int_handler
    ):
        return lambda: None

    def note(signum: int, frame: FrameType | None) -> None:
        """Note the SIGINT, then raise it."""
        seen.append(signum)
        raise KeyboardInterrupt

    signal.signal(signal.SIGINT, note)
    return lambda: signal.signal(signal.SIGINT, signal.default_int_handler)


def _interrupted(command: str | None, own_process: bool) -> int:
    """Say 'pendulum-accel COMMAND: interrupted'; exit 130 (os._exit for the command's own process)."""
    print(f"pendulum-accel {command or ''}: interrupted".replace(" :", ":"), file=sys.stderr)
    if own_process:
        # The command has removed its partial output already; the interpreter's own teardown (numba,
        # llvmlite, matplotlib finalizers) can take seconds on a loaded machine after a long generate.
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(130)
    return 130


_OPTION_AT_HOME = re.compile(r"(--[A-Za-z][\w-]*=)(~[^/]*(?:/.*)?)$", re.DOTALL)


def expand_home_values(argv: Sequence[str]) -> list[str]:
    """argv with ``--opt=~/x`` written ``--opt=$HOME/x`` (``~user/x`` too): os.path.expanduser of the value.

    A shell expands a ``~`` that starts a word (``--record ~/x``) but not one after ``--record=``, so
    without this the same option made a directory named ``~`` when given with an ``=``."""
    out: list[str] = []
    for token in argv:
        match = _OPTION_AT_HOME.match(token)
        out.append(match.group(1) + os.path.expanduser(match.group(2)) if match else token)
    return out


def _run(argv: list[str], command: str | None) -> int:
    """Parse argv (only ``command``'s module imported) and run it; PendulumAccelError → one line, exit 2."""
    if command is None:  # --version, --help, or an unknown command: argparse answers without the modules
        parser = build_parser("")
        args = parser.parse_args(argv)
    else:
        from pendulum_accel.cli.sweep import attach_negative_values

        parser = build_parser(command)
        args, extras = parser.parse_known_args(attach_negative_values(expand_home_values(argv)))
        if extras:  # said by the command's own parser, with its usage (argparse's top level would say it)
            _command_parser(parser, command).error(f"unrecognized arguments: {' '.join(extras)}")
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except PendulumAccelError as err:
        print(f"pendulum-accel {args.command}: error: {err}", file=sys.stderr)
        return 2
    except BrokenPipeError:
        return 0


if __name__ == "__main__":
    sys.exit(main())
