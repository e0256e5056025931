"""The CPU-emulation step (test/cpu_emulation.py): numpy accepts its list and runs at baseline, and
numba compiles for a generic CPU without loading the host's cached code."""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

from test.cpu_emulation import (
    environment,
    numpy_disabled_targets,
    targets_to_disable,
)

_TARGETS = """
import json
from numpy._core import _multiarray_umath as umath
current = {spec["current"] for loops in umath.__cpu_targets_info__.values() for spec in loops.values()}
print(json.dumps(sorted(current)))
"""


def _host_env() -> dict[str, str]:
    """This environment without the emulation's variables (the test may itself run under it)."""
    drop = set(environment())
    return {k: v for k, v in os.environ.items() if k not in drop}


def test_numpy_takes_the_list_and_runs_only_its_baseline() -> None:
    """numpy imports under the list without an ImportWarning (a name it ignores) and every ufunc loop runs
    its baseline target, none AVX-512F, AVX2 or FMA3."""
    umath = importlib.import_module("numpy._core._multiarray_umath")  # numpy's own CPU tables

    assert set(numpy_disabled_targets()).isdisjoint(umath.__cpu_baseline__)
    env = {**_host_env(), **environment()}
    out = subprocess.run(
        [sys.executable, "-W", "error::ImportWarning", "-c", _TARGETS],
        env=env, capture_output=True, text=True, timeout=60, check=True,
    )  # fmt: skip
    current = json.loads(out.stdout)
    assert current and all(t.startswith("baseline(") for t in current), current


def test_blas_takes_its_oldest_kernels() -> None:
    """numpy's and scipy's OpenBLAS both report the SSE-only core under the emulation (OPENBLAS_VERBOSE
    prints the core each library loads)."""
    script = "import numpy as np, scipy.linalg as la; la.solve(np.eye(3), np.ones(3)); np.eye(2) @ np.eye(2)"
    env = {**_host_env(), **environment(), "OPENBLAS_VERBOSE": "2"}
    done = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True, text=True, timeout=60)
    cores = [line for line in done.stderr.splitlines() if line.startswith("Core: ")]
    assert done.returncode == 0 and cores == ["Core: Katmai", "Core: Katmai"], done.stderr


def test_the_list_follows_the_cpu_and_numpys_naming() -> None:
    """numpy 2.x levels on an AVX2 machine without AVX-512: only X86_V3; numpy 1.x names on an AVX-512
    machine: every target above its SSE3 baseline; targets the CPU lacks and baseline ones never."""
    levels = ["X86_V3", "X86_V4", "AVX512_ICL", "AVX512_SPR"]
    assert targets_to_disable(levels, ["X86_V2"], {"X86_V2", "X86_V3"}) == ["X86_V3"]
    old = ["SSSE3", "SSE41", "POPCNT", "SSE42", "AVX", "F16C", "FMA3", "AVX2", "AVX512F", "AVX512_SKX"]
    have = set(old) | {"SSE", "SSE2", "SSE3"}
    assert targets_to_disable(old, ["SSE", "SSE2", "SSE3"], have) == old
    assert targets_to_disable(old, ["SSE", "SSE2", "SSE3"], have - {"AVX512F", "AVX512_SKX"}) == old[:-2]
    above_v3 = targets_to_disable(levels, ["X86_V2", "X86_V3"], set(levels))
    assert above_v3 == ["X86_V4", "AVX512_ICL", "AVX512_SPR"]


_MODULE = """
from numba import njit

@njit(cache=True)
def axpy(x):
    return 1.5 * x + 1.0
"""
_CALL = "import kernel; print(kernel.axpy(2.0)); print(kernel.axpy.inspect_asm(kernel.axpy.signatures[0]))"


def _run_cached(folder: Path, env: dict[str, str]) -> tuple[str, str]:
    """(value and assembly, numba's cache log) of one process that calls the cached kernel."""
    env = {**env, "NUMBA_DEBUG_CACHE": "1", "PYTHONPATH": str(folder)}
    out = subprocess.run(
        [sys.executable, "-c", _CALL],
        cwd=folder,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
        check=True,
    ).stdout.splitlines()
    log = [line for line in out if line.startswith("[cache]")]
    return "\n".join(line for line in out if line not in log), "\n".join(log)


def test_numba_compiles_for_generic_and_never_loads_the_host_cache(tmp_path: Path) -> None:
    """Host run saves its entry; the generic run saves its own (baseline x86-64: no AVX, no FMA) instead of
    loading the host's; each later run loads its own."""
    (tmp_path / "kernel.py").write_text(_MODULE)
    host = _host_env()
    generic = {**host, "NUMBA_CPU_NAME": "generic", "NUMBA_CPU_FEATURES": ""}
    out, log = _run_cached(tmp_path, host)
    assert out.startswith("4.0") and "data saved" in log
    out, log = _run_cached(tmp_path, generic)
    assert out.startswith("4.0") and "data saved" in log and "data loaded" not in log
    asm = out.lower()
    # compiled in this run (numba inspects no cached code): SSE2's mulsd, none of AVX's VEX forms or FMA
    assert "mulsd" in asm and not any(x in asm for x in ("vfmadd", "%ymm", "%zmm", "vmulsd", "vaddsd")), asm
    for env in (host, generic):
        _, log = _run_cached(tmp_path, env)
        assert "data loaded" in log and "data saved" not in log


def test_every_numerics_test_the_makefile_names_exists() -> None:
    """`make pytest-emulated` runs the files NUMERICS_TESTS names: a renamed or deleted one would stop it
    with 'file or directory not found' only in CI, after the whole suite."""
    import re

    root = Path(__file__).resolve().parents[1]
    text = (root / "Makefile").read_text(encoding="utf-8")
    block = re.search(
        r"NUMERICS_TESTS := \$\(addprefix test/test_,\$\(addsuffix \.py, \\\n(.*?)\)\)", text, re.S
    )
    assert block, "NUMERICS_TESTS not found in the Makefile"
    names = block.group(1).replace("\\", " ").split()
    assert len(names) > 20, names
    missing = [n for n in names if not (root / "test" / f"test_{n}.py").is_file()]
    assert missing == [], missing
