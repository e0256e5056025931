"""Fast start-up: ``pendulum-accel --version`` and ``--help`` import none of the expensive libraries.

Checked by what they import (sys.modules in a fresh interpreter), never by a time: the figures
(benchmarks, docs/portability.md) depend on the machine, the imports do not.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys

import pytest

from pendulum_accel import __version__
from pendulum_accel.cli.main import COMMANDS, build_parser

# numpy alone is the yardstick (--version ≤ 3 × `import numpy`); these each cost as much again or more.
EXPENSIVE = ("numpy", "scipy", "numba", "llvmlite", "matplotlib", "pandas", "pyarrow", "rosbags", "mcap",
             "zstandard", "lz4", "yaml", "allantools", "tqdm", "mpmath", "rclpy")  # fmt: skip

_PROBE = """
import contextlib, io, json, sys
from pendulum_accel.cli.main import main
out = io.StringIO()
with contextlib.redirect_stdout(out):
    try:
        code = main(sys.argv[1:])
    except SystemExit as exit:
        code = exit.code
modules = sorted({m.split(".")[0] for m in sys.modules})
print(json.dumps({"code": code, "out": out.getvalue(), "modules": modules}))
"""


def _imports_of(*args: str) -> tuple[int, str, set[str]]:
    """(exit code, stdout, top-level packages imported) of ``pendulum-accel ARGS`` in a fresh interpreter."""
    done = subprocess.run([sys.executable, "-c", _PROBE, *args], capture_output=True, text=True, timeout=60)
    report = json.loads(done.stdout.strip().splitlines()[-1])
    return int(report["code"] or 0), report["out"], set(report["modules"])


@pytest.mark.parametrize("args", [("--version",), ("--help",), ()])
def test_version_and_help_import_nothing_expensive(args: tuple[str, ...]) -> None:
    """--version prints the version, --help (and no command) every command; neither imports EXPENSIVE."""
    code, out, modules = _imports_of(*args)
    assert sorted(modules & set(EXPENSIVE)) == []
    if args == ("--version",):
        assert code == 0 and out.strip() == f"pendulum-accel {__version__}"
    else:
        assert all(name in out for name in COMMANDS)


def test_summaries_are_the_commands_own_help() -> None:
    """The summary main shows without importing a command is the help its module registers."""
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    registered = {action.dest: action.help for action in sub._choices_actions}
    assert registered == {name: summary for name, (_, summary) in COMMANDS.items()}
