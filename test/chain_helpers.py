"""Helpers shared by the node and chain tests: start nodes and probes through ``spawn``, read their output."""

from __future__ import annotations

import json
import re
import subprocess
import threading
import time
from collections.abc import Mapping
from typing import Any

from pendulum_accel.nodes.launcher import ParamValue, node_command
from test.conftest import PYTHON, REPO, Spawn

LAUNCHER = str(REPO / "launch_scripts" / "chain.py")
PROBE = str(REPO / "test" / "node_probe.py")


class Output:
    """Collects a process's stdout and stderr lines in background threads (so pipes never fill up)."""

    def __init__(self, proc: subprocess.Popen[str]) -> None:
        """Start one reader thread per pipe."""
        self.proc = proc
        self.lines: list[str] = []
        self._lock = threading.Lock()
        self._threads = [
            threading.Thread(target=self._read, args=(pipe,), daemon=True)
            for pipe in (proc.stdout, proc.stderr)
            if pipe
        ]
        for thread in self._threads:
            thread.start()

    def _read(self, pipe: Any) -> None:
        """Append every line of ``pipe``."""
        for line in pipe:
            with self._lock:
                self.lines.append(line.rstrip("\n"))

    @property
    def text(self) -> str:
        """Everything read so far."""
        with self._lock:
            return "\n".join(self.lines)

    def wait_for(self, pattern: str, timeout: float) -> re.Match[str]:
        """First match of ``pattern`` in the output, waiting up to ``timeout`` s (else AssertionError)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            match = re.search(pattern, self.text)
            if match:
                return match
            if self.proc.poll() is not None:
                for thread in self._threads:
                    thread.join(timeout=2.0)
                match = re.search(pattern, self.text)
                if match:
                    return match
                raise AssertionError(
                    f"process exited ({self.proc.returncode}) before {pattern!r}:\n{self.text}"
                )
            time.sleep(0.05)
        raise AssertionError(f"no {pattern!r} within {timeout} s:\n{self.text}")

    def finish(self, timeout: float) -> int:
        """Wait for the process to exit and for its pipes to close; its return code."""
        code = self.proc.wait(timeout=timeout)
        for thread in self._threads:
            thread.join(timeout=5.0)
        return code


def start_node(spawn: Spawn, module: str, params: Mapping[str, ParamValue]) -> Output:
    """Spawn ``python -m pendulum_accel.nodes.<module> --ros-args -p …`` and collect its output."""
    return Output(spawn(node_command(module, params)))


def run_probe(spawn: Spawn, spec: Mapping[str, Any], timeout: float = 60.0) -> dict[str, Any]:
    """Run test/node_probe.py with ``spec`` and return its JSON result."""
    proc = spawn([PYTHON, PROBE, json.dumps(spec)])
    out, err = proc.communicate(timeout=timeout)
    assert proc.returncode == 0, err
    result: dict[str, Any] = json.loads(out.strip().splitlines()[-1])
    return result


def start_chain(spawn: Spawn, *args: str, env: dict[str, str] | None = None) -> Output:
    """Spawn launch_scripts/chain.py with ``args`` (and ``env`` in place of this process's environment)
    and collect its (and its nodes') output."""
    return Output(spawn([PYTHON, LAUNCHER, *args], env=env))


def child_pids(output: Output) -> dict[str, int]:
    """{role: pid} from the launcher's 'started ROLE (pid N)' lines."""
    return {m.group(1): int(m.group(2)) for m in re.finditer(r"started (\w+) \(pid (\d+)\)", output.text)}
