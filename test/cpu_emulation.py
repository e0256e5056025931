"""The environment of `make test`'s CPU-emulation step: numpy at its baseline, libm, numba and BLAS without
AVX-512, AVX2 or FMA.

``python -m test.cpu_emulation COMMAND...`` runs COMMAND in that environment (the Makefile's
``pytest-emulated``); without a command it prints the assignments. Four libraries pick their code by
the CPU they run on, and each is switched off its AVX-512, AVX2 and FMA paths its own way:

* numpy: ``NPY_DISABLE_CPU_FEATURES`` lists dispatch targets. numpy ≥ 2.3 dispatches by level (X86_V3 =
  AVX2 + FMA3 + …, X86_V4 = AVX-512, AVX512_ICL, AVX512_SPR) and only warns about a name it does not
  dispatch (``AVX512F AVX2 FMA3`` would be ignored), while naming a baseline feature aborts its import;
  so the list is every dispatch target this CPU has above numpy's baseline: every ufunc then runs its
  baseline loop (X86_V2 for numpy 2.4), the code any x86-64 machine numpy supports runs.
* libm (glibc): its exp/sin/tan/atan… take FMA variants when the CPU has FMA and AVX2;
  ``GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX2,-FMA,-AVX512F`` makes it take the SSE2 ones (names it does not
  know, or features the CPU lacks, are ignored).
* numba: ``NUMBA_CPU_NAME=generic NUMBA_CPU_FEATURES=`` (numba's documented pair; an empty feature list
  is also numba.core.config's default for ``generic``, set here so that a feature list already in the
  environment cannot leak in), so the kernels compile for baseline x86-64. numba's cache index keys each
  entry on (signature, target triple, CPU name, CPU features), so the host-compiled entries are never
  loaded under ``generic``: the step compiles its own once and keeps both (test_cpu_emulation checks it).
* BLAS/LAPACK (the OpenBLAS numpy and scipy each bundle, built DYNAMIC_ARCH): it picks its kernels by CPU
  (Haswell here, SkylakeX on an AVX-512 Intel, …), and a matrix product's rounding follows the kernel;
  ``OPENBLAS_CORETYPE=Prescott`` makes both take their oldest x86-64 kernels (OpenBLAS reports them as
  Katmai: SSE only), which round differently from the host's.
"""

from __future__ import annotations

import importlib
import os
import sys

GLIBC_HWCAPS = "glibc.cpu.hwcaps=-AVX2,-FMA,-AVX512F"
OPENBLAS_CORE = "Prescott"


def numpy_disabled_targets() -> list[str]:
    """numpy's dispatch targets this CPU has above its baseline (inside the emulation numpy reports the
    disabled ones as absent: they are kept from the variable)."""
    umath = importlib.import_module("numpy._core._multiarray_umath")  # numpy's own CPU tables
    have = {t for t, on in umath.__cpu_features__.items() if on}
    have |= set(os.environ.get("NPY_DISABLE_CPU_FEATURES", "").replace(",", " ").split())
    return targets_to_disable(umath.__cpu_dispatch__, umath.__cpu_baseline__, have)


def targets_to_disable(dispatch: list[str], baseline: list[str], have: set[str]) -> list[str]:
    """The dispatch targets in ``have`` (this CPU's) that are not baseline: numpy then runs its baseline
    loops only. A target the CPU lacks is never named (nothing to switch off), a baseline one never (numpy
    aborts its import)."""
    return [t for t in dispatch if t not in set(baseline) and t in have]


def environment() -> dict[str, str]:
    """The variables the emulation step sets (an existing GLIBC_TUNABLES is kept, the hwcaps appended)."""
    tunables = ":".join(x for x in (os.environ.get("GLIBC_TUNABLES", ""), GLIBC_HWCAPS) if x)
    return {
        "NPY_DISABLE_CPU_FEATURES": " ".join(numpy_disabled_targets()),
        "NUMBA_CPU_NAME": "generic",
        "NUMBA_CPU_FEATURES": "",
        "GLIBC_TUNABLES": tunables,
        "OPENBLAS_CORETYPE": OPENBLAS_CORE,
    }


def main(argv: list[str]) -> int:
    """Print the environment, or run argv in it (replacing this process)."""
    env = environment()
    if not argv:
        for name, value in env.items():
            print(f"{name}='{value}'")
        return 0
    print("CPU emulation: " + " ".join(f"{k}='{v}'" for k, v in env.items()), file=sys.stderr)
    os.execvpe(argv[0], argv, {**os.environ, **env})


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
