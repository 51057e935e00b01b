"""numba's ``njit`` with on-disk caching only where a cache can be written.

``@numba.njit(cache=True)`` looks for a writable cache directory when the
function is *decorated* (``NUMBA_CACHE_DIR``, then the package's own
``__pycache__``, then the user-wide cache such as ``~/.cache/numba``) and raises
``RuntimeError: cannot cache function ...: no locator available`` if there is
none. On a read-only install (system site-packages, a container image, a
read-only home) that made ``import sma_gym`` and even ``sma-gym --help`` fail.

Every compiled function of the package is decorated with :func:`njit` from
this module instead. ``cache=True`` then means "cache if possible": whether a
cache location exists is decided once per process, by asking numba's own
locators for this file, and when none is writable the functions are compiled
in memory (slower first call, identical results).
"""

from __future__ import annotations

import functools
import os
import warnings
from collections.abc import Callable
from typing import Any

import numba

__all__ = ["available_cores", "caching_available", "njit"]


def available_cores() -> int:
    """The cores this process may run on: its CPU affinity (``taskset``, a cgroup's cpuset,
    a batch scheduler's allocation) where the platform reports one, else every core. What
    sizes thread and process pools: ``os.cpu_count()`` counts the machine's cores, so two
    runs under ``taskset -c 0`` would time-share one."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on every platform (macOS, Windows)
        return os.cpu_count() or 1


def _probe() -> None:  # pragma: no cover - never called, only located
    """A function in this package whose cache location numba is asked for."""


@functools.cache
def caching_available() -> bool:
    """True if numba can write a cache for this package's functions.

    Decided once per process with numba's own locator search (the same one
    ``cache=True`` runs), so the answer follows ``NUMBA_CACHE_DIR``, the
    package directory and the user cache directory exactly as numba does.
    """
    try:
        from numba.core.caching import FunctionCache

        FunctionCache(_probe)
    except Exception:
        warnings.warn(
            "sma_gym: no writable numba cache directory (package directory, NUMBA_CACHE_DIR and the "
            "user cache are read-only); compiling without an on-disk cache, so the first step of a "
            "process is slower. Set NUMBA_CACHE_DIR to a writable folder to cache.",
            UserWarning,
            stacklevel=2,
        )
        return False
    return True


def njit(*args: Any, **kwargs: Any) -> Any:
    """``numba.njit`` whose ``cache=True`` falls back to no cache when none is writable.

    Used exactly like ``numba.njit`` (``@njit`` or ``@njit(cache=True, ...)``).
    """
    if args and callable(args[0]) and len(args) == 1 and not kwargs:
        # Bare ``@njit``: no caching requested, nothing to decide.
        return numba.njit(args[0])
    if kwargs.get("cache") and not caching_available():
        kwargs = {**kwargs, "cache": False}
    decorate = numba.njit(*args, **kwargs)
    if not kwargs.get("cache"):
        return decorate

    def cached(func: Callable[..., Any]) -> Any:
        try:
            return decorate(func)
        except RuntimeError as err:
            # A sub-package that is read-only while the probe's directory is not:
            # still better to compile than to fail at import.
            if "no locator available" not in str(err):
                raise
            return numba.njit(*args, **{**kwargs, "cache": False})(func)

    return cached
