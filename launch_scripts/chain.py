#!/usr/bin/env python3
"""Launch the chain for a scene: simulator, estimator and recorder, each in its own process.

    python launch_scripts/chain.py [SCENE] [--record DIR] [--overwrite] [--fast] [--estimator M]
                                   [--set NAME=VALUE ...]

Ctrl-C or SIGTERM stops every node in data-flow order; the bag is closed and valid; nothing is
left running. (Plain Python: the PyPI ROS 2 wheels have no ``ros2 launch``.)
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from pendulum_accel.cli.run import add_chain_arguments, chain_config
from pendulum_accel.errors import PendulumAccelError
from pendulum_accel.nodes.launcher import require_rclpy, run_chain


def main(argv: Sequence[str] | None = None) -> int:
    """Parse the arguments and run the chain; exit code 0 when every node ended well."""
    parser = argparse.ArgumentParser(prog="chain.py", description=__doc__.split("\n\n")[0])
    add_chain_arguments(parser)
    args = parser.parse_args(argv)
    try:
        require_rclpy()
        return run_chain(chain_config(args))
    except PendulumAccelError as err:
        print(f"chain.py: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
