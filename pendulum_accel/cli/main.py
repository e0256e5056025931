"""Entry point of ``pendulum-accel``: dispatches to one module per subcommand.

Each module in ``COMMANDS`` defines ``register(subparsers)``, which adds its parser and
sets ``func(args) -> int`` as the default.
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

from pendulum_accel import __version__
from pendulum_accel.cli.sweep import attach_negative_values
from pendulum_accel.errors import PendulumAccelError

# Order is the order of ``pendulum-accel --help``.
COMMANDS: tuple[str, ...] = (
    "simulate",
    "scenes",
    "sweep",
    "lecture",
    "animate",
    "info",
    "analyze",
    "allan",
    "export",
    "generate",
    "repair",
    "golden_bags",
    "run",
)


def build_parser() -> argparse.ArgumentParser:
    """Build the top-level parser with every registered subcommand."""
    parser = argparse.ArgumentParser(
        prog="pendulum-accel",
        description="Pendulum accelerometer: simulate, estimate, record and replay.",
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        importlib.import_module(f"pendulum_accel.cli.{name}").register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run one subcommand; a PendulumAccelError becomes a one-line message and exit code 2."""
    parser = build_parser()
    args = parser.parse_args(attach_negative_values(sys.argv[1:] if argv is None else argv))
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except PendulumAccelError as err:
        print(f"pendulum-accel {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:
        return 0


if __name__ == "__main__":
    sys.exit(main())
