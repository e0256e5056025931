"""Expensive imports on first use: numba's ``njit`` and whole modules (scipy.signal …).

``lazy_module(name)`` stands for the module ``name`` and imports it on its first attribute read, so a
module that needs scipy.signal in one method does not load it at import time.

numba (with llvmlite, and the scipy it loads) costs about a second of CPU to import, which ``--help``,
``--version`` and a node's ``--help`` do not need. ``njit(**options)`` keeps the Python function in a
:class:`LazyJit`; the first call or attribute read of any LazyJit of a module compiles (or loads from
numba's cache) that module's whole set with ``numba.njit(**options)`` and puts each dispatcher in place
of its LazyJit among the module's globals. Compiled code that calls or passes another kernel of its
module then finds a numba dispatcher there, exactly as under numba's own decorator; code that imported
a LazyJit by name keeps working through it (calls and attributes are forwarded).
"""

from __future__ import annotations

import functools
import importlib
import sys
from collections.abc import Callable
from typing import Any

# Any throughout: numba, untyped, compiles any function; a LazyJit stands for its dispatcher, which
# takes and returns what the compiled function does, and a LazyModule for any module.


class LazyJit:
    """A function to be compiled by ``numba.njit(**options)`` when first used (module doc)."""

    def __init__(self, func: Callable[..., Any], options: dict[str, Any]) -> None:
        """Keep ``func`` and the njit ``options``; compile nothing yet."""
        self.func = func
        self.options = options
        self.compiled: Any = None
        functools.update_wrapper(self, func)

    def dispatcher(self) -> Any:
        """numba's dispatcher of ``func``: this module's LazyJits compiled on the first request."""
        if self.compiled is None:
            _compile_module(self.func.__module__)
        return self.compiled

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        """dispatcher()(*args, **kwargs)."""
        return self.dispatcher()(*args, **kwargs)

    def __getattr__(self, name: str) -> Any:
        """The dispatcher's attribute (signatures, py_func, inspect_asm …)."""
        if name in ("func", "options", "compiled") or name.startswith("__"):
            raise AttributeError(name)
        return getattr(self.dispatcher(), name)


class LazyModule:
    """The module ``name``, imported on the first attribute read (lazy_module)."""

    def __init__(self, name: str) -> None:
        """Remember ``name``; import nothing yet."""
        self._name = name

    def __getattr__(self, attribute: str) -> Any:
        """The module's attribute, importing the module (once: Python caches it) if need be."""
        if attribute.startswith("__"):
            raise AttributeError(attribute)
        return getattr(importlib.import_module(self._name), attribute)


def lazy_module(name: str) -> Any:
    """A stand-in for ``import name`` that imports it on first use (LazyModule)."""
    return LazyModule(name)


def njit(**options: Any) -> Callable[[Callable[..., Any]], LazyJit]:
    """Decorator: ``numba.njit(**options)`` deferred to the first use of the function (module doc)."""

    def wrap(func: Callable[..., Any]) -> LazyJit:
        return LazyJit(func, options)

    return wrap


def _compile_module(module_name: str) -> None:
    """numba.njit every LazyJit among ``module_name``'s globals; each global becomes its dispatcher."""
    numba = importlib.import_module("numba")
    module = sys.modules[module_name]
    for name, value in list(vars(module).items()):
        if isinstance(value, LazyJit) and value.compiled is None:
            value.compiled = numba.njit(**value.options)(value.func)
            setattr(module, name, value.compiled)
