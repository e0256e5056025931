"""Fast start-up: --version, --help and every command's and node's --help import no costly library.

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
from pendulum_accel.nodes.node_help import NODE_MODULES

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


# A command's or node's --help may read the tables it prints from (numpy; rosbags' message types for the
# bag commands and the nodes), but none of the libraries only its work needs.
WORK_ONLY = ("scipy", "numba", "llvmlite", "matplotlib", "pandas", "pyarrow", "allantools", "mpmath", "rclpy")


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_each_command_help_imports_no_work_library(command: str) -> None:
    """`pendulum-accel COMMAND --help` prints its usage (exit 0) without scipy, numba, matplotlib …"""
    code, out, modules = _imports_of(command, "--help")
    assert code == 0 and out.startswith(f"usage: pendulum-accel {command}")
    assert sorted(modules & set(WORK_ONLY)) == []


_NODE_PROBE = """
import contextlib, io, json, sys
from pendulum_accel.nodes import node_help
out = io.StringIO()
with contextlib.redirect_stdout(out):
    code = node_help.console_main(sys.argv[1], ["--help"])
modules = sorted({m.split(".")[0] for m in sys.modules})
print(json.dumps({"code": code, "out": out.getvalue(), "modules": modules}))
"""


@pytest.mark.parametrize("node", sorted(NODE_MODULES))
def test_each_node_help_imports_no_work_library(node: str) -> None:
    """A node's --help prints its parameters (exit 0) without scipy, numba, matplotlib or rclpy."""
    probe = [sys.executable, "-c", _NODE_PROBE, node]
    done = subprocess.run(probe, capture_output=True, text=True, timeout=60)
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert report["code"] == 0 and report["out"].startswith(f"usage: {node}")
    assert sorted(set(report["modules"]) & set(WORK_ONLY)) == []


def test_summaries_are_the_commands_own_help() -> None:
    """The summary main shows without importing a command is the help its module registers."""
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    registered = {action.dest: action.help for action in sub._choices_actions}
    assert registered == {name: summary for name, (_, summary) in COMMANDS.items()}


# Each command with what it requires (never run: the unknown option is refused while parsing).
WELL_FORMED: dict[str, list[str]] = {
    "simulate": [], "scenes": [], "sweep": ["at_rest", "--length", "1"], "lecture": [],
    "animate": ["at_rest", "--out", "a.gif"], "info": ["bag"], "analyze": ["bag"],
    "design": ["--out", "t.csv"], "allan": ["bag"], "export": ["bag", "--out", "dir"],
    "generate": ["at_rest", "--out", "bag"],
    "repair": ["bag"], "urdf": [], "golden-bags": ["dir"], "run": [], "lab": ["check"],
}  # fmt: skip


def test_every_command_has_a_well_formed_call() -> None:
    """WELL_FORMED covers every command, and each call parses."""
    assert sorted(WELL_FORMED) == sorted(COMMANDS)
    for command, args in WELL_FORMED.items():
        assert build_parser(command).parse_args([command, *args]).command == command


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_an_unknown_argument_is_refused_by_the_commands_own_parser(
    command: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """An option a command does not take is refused as argparse refuses a subcommand's missing argument:
    exit 2, the command's own usage and 'pendulum-accel COMMAND: error: unrecognized arguments: …', not
    the top level's usage, which lists no option of the command."""
    from pendulum_accel.cli.main import main

    with pytest.raises(SystemExit) as exit_info:
        main([command, *WELL_FORMED[command], "--no-such-option=1"])
    err = capsys.readouterr().err
    assert exit_info.value.code == 2
    assert err.startswith(f"usage: pendulum-accel {command} ")
    last = err.rstrip().splitlines()[-1]
    assert last == f"pendulum-accel {command}: error: unrecognized arguments: --no-such-option=1"
