"""numba's on-disk cache of the package's compiled kernels: is it cold, and warming it.

The stepping kernels (``physics.kernels``) and the Kalman passes (``estimators.ekf_kernels``) are
compiled by numba on first use and cached on disk (``cache=True``: ``__pycache__`` beside the installed
modules, or ``NUMBA_CACHE_DIR``). A cold cache costs a compile of a minute or more on a small machine:
``pendulum-accel run`` warms it before it starts the nodes, saying so, since the simulator would
otherwise give up waiting for an estimator that is still compiling; ``make setup`` and a colcon
install (setup.py's install step) warm it too.
"""

from __future__ import annotations

import concurrent.futures
import importlib
import multiprocessing
import os
import time
from collections.abc import Callable
from types import ModuleType


def _modules() -> list[ModuleType]:
    """The modules whose kernels are cached (imported here: numba loads with them)."""
    from pendulum_accel.estimators import ekf_kernels
    from pendulum_accel.physics import kernels

    return [kernels, ekf_kernels]


def cached_kernels() -> list[object]:
    """Every numba dispatcher with an on-disk cache in the kernel modules (made, not compiled: a
    ``physics.lazy`` stand-in gives its dispatcher, which compiles on its first call only). Kernels
    inlined into their callers (``inline="always"``) are compiled only there and have no cache entry."""
    from numba.core.registry import CPUDispatcher

    from pendulum_accel.physics.lazy import LazyJit

    found: list[object] = []
    for module in _modules():
        for obj in list(vars(module).values()):
            dispatcher = obj.dispatcher() if isinstance(obj, LazyJit) else obj
            if (
                isinstance(dispatcher, CPUDispatcher)
                and hasattr(getattr(dispatcher, "_cache", None), "_cache_file")
                and dispatcher.targetoptions.get("inline") != "always"
            ):
                found.append(dispatcher)
    return found


def is_cold() -> bool:
    """True when some kernel has nothing usable in numba's cache (it would be compiled on first use): no
    index file, or one numba itself refuses (written for another version of the source, as after an
    upgrade or a `git pull` in an editable install).

    Asks numba's own cache file (``Dispatcher._cache._cache_file._load_index``, which returns {} for a
    missing or stale index); where that layout is not found, the cache is taken as cold: warming a warm
    cache only loads it.
    """
    kernels = cached_kernels()
    for kernel in kernels:
        cache_file = getattr(getattr(kernel, "_cache", None), "_cache_file", None)
        load_index = getattr(cache_file, "_load_index", None)
        if load_index is None or not load_index():
            return True
    return not kernels


# The cache's three independent parts, longest first (docs/benchmarks/constants.md), each a function of no
# arguments that compiles (or loads) its kernels: every kernel has its own cache files, so two processes can
# fill different parts at once.
WARM_PARTS: tuple[tuple[str, str], ...] = (
    ("pendulum_accel.estimators.ekf_kernels", "warm_batch"),  # the offline passes, the longest
    ("pendulum_accel.estimators.ekf_kernels", "warm_live"),
    ("pendulum_accel.physics.kernels", "warm"),
)


def warm_part(module: str, function: str) -> None:
    """Run one part of WARM_PARTS: import ``module`` and call its ``function``()."""
    getattr(importlib.import_module(module), function)()


def warm(say: Callable[[str], None] | None = None) -> float:
    """Compile (or load) every kernel into the cache; the seconds it took. ``say`` is told what is being
    waited for before, and the time after.

    numba compiles on one core; with two or more, the parts of WARM_PARTS compile in two processes of the
    standard library's ProcessPoolExecutor (spawned: a fork would copy this process's numba state), which
    nearly halves the wait on a two-core machine. The compiled code lands in the cache, not here: each
    process loads what it runs when it first runs it.
    """
    if say is not None:
        say(
            "compiling the stepping kernels and the estimators' loops into numba's cache "
            "(once after an install; a minute or two on a small machine)"
        )
    start = time.perf_counter()
    if (os.cpu_count() or 1) < 2:
        for module, function in WARM_PARTS:
            warm_part(module, function)
    else:
        context = multiprocessing.get_context("spawn")
        with concurrent.futures.ProcessPoolExecutor(max_workers=2, mp_context=context) as pool:
            for done in [pool.submit(warm_part, module, function) for module, function in WARM_PARTS]:
                done.result()  # a part's failure is raised here, as it would be in this process
    took = time.perf_counter() - start
    if say is not None:
        say(f"compiled in {took:.0f} s")
    return took


def warm_if_cold(say: Callable[[str], None] | None = None) -> bool:
    """warm() when is_cold(); whether it did."""
    if not is_cold():
        return False
    warm(say)
    return True


if __name__ == "__main__":
    warm(print)
