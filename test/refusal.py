"""The one line a command gives bad input: exit 2, no traceback, a single ``error:`` line naming the cause."""

from __future__ import annotations

import subprocess


def error_line(returncode: int, stderr: str, *words: str) -> str:
    """The single error line of a refused command (exit 2, no traceback), checked to contain ``words``."""
    assert returncode == 2, stderr
    assert "Traceback" not in stderr, stderr
    lines = [line for line in stderr.splitlines() if "error:" in line]
    assert len(lines) == 1, stderr
    for word in words:
        assert word in lines[0], lines[0]
    return lines[0]


def one_line_error(result: subprocess.CompletedProcess[str], *words: str) -> str:
    """error_line of a finished process: its return code and its stderr."""
    return error_line(result.returncode, result.stderr, *words)
