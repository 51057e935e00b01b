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

A cached function is also keyed on every source of the compiled code
(:data:`COMPILED_SOURCES`), not only on its own file: numba checks only the file
that defines a function, yet compiles the functions it calls (and the constants
it reads) from other modules into its machine code, so an edit of
``physics/thermal.py`` or ``core/layout.py`` alone left the kernel running the
old physics from its cache, silently (numba issue #1833; its docs list it as a
limitation). See :func:`track_sources`.
"""

from __future__ import annotations

import functools
import hashlib
import os
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numba

__all__ = ["COMPILED_SOURCES", "available_cores", "caching_available", "njit", "sources_digest", "track_sources"]

PACKAGE_DIR = Path(__file__).resolve().parent

COMPILED_SOURCES = (
    "_jit.py",
    "core/kernel.py",
    "core/layout.py",
    "electrical/pwm.py",
    "electrical/sensors.py",
    "envs/references.py",
    "envs/task.py",
    "physics/mechanics.py",
    "physics/resistance.py",
    "physics/thermal.py",
    "physics/transformation.py",
)
"""The package's files whose code or constants compiled functions hold (paths relative to
the package): every module that defines a compiled function, and ``core/layout.py``, whose
constants they read. ``tests/test_architecture.py`` checks the list against the code."""

_TRACKED: dict[Path, tuple[str, ...]] = {}
"""Package directories whose compiled functions are keyed on their sources, and those sources."""


@functools.cache
def sources_digest(root: Path, files: tuple[str, ...]) -> str:
    """A digest of the contents of ``files`` (relative to ``root``), read once per process."""
    digest = hashlib.sha256()
    for name in files:
        digest.update(name.encode())
        digest.update((root / name).read_bytes())
    return digest.hexdigest()


def _tracked_root(py_file: str) -> Path | None:
    path = Path(py_file).resolve()
    return next((root for root in _TRACKED if path.is_relative_to(root)), None)


def _keyed_on_sources(locator: type) -> type:
    """numba's ``locator``, for functions defined under a tracked root only, with the sources'
    digest added to the stamp numba keys the cache on."""

    class SourcesKeyed(locator):
        @classmethod
        def from_function(cls, py_func, py_file):
            if _tracked_root(py_file) is None:
                return None  # numba's own locators take it
            return super().from_function(py_func, py_file)

        def get_source_stamp(self):
            root = _tracked_root(self._py_file)
            return (super().get_source_stamp(), sources_digest(root, _TRACKED[root]))

    SourcesKeyed.__name__ = SourcesKeyed.__qualname__ = f"SourcesKeyed{locator.__name__}"
    return SourcesKeyed


def track_sources(root: Path, files: Sequence[str]) -> bool:
    """Key the cache of every compiled function defined under ``root`` on the contents of
    ``files`` as well: an edit of any of them recompiles them all. Must run before those
    functions are decorated (this module does it for the package at import). False, with a
    warning, where numba's cache internals are not as expected (the cache then works as
    numba's alone)."""
    try:
        from numba.core.caching import CacheImpl

        locators = list(CacheImpl._locator_classes)
        first = locators[0]
        first.from_function, first.get_source_stamp  # noqa: B018 - the two methods overridden
    except (ImportError, AttributeError, IndexError):
        warnings.warn(
            f"sma_gym: numba {numba.__version__}'s cache locators are not as expected; a cached kernel "
            "is keyed on its own file only (delete the numba cache after editing a physics module)",
            UserWarning,
            stacklevel=2,
        )
        return False
    root = Path(root).resolve()
    _TRACKED[root] = tuple(files)
    if not any(getattr(k, "__name__", "").startswith("SourcesKeyed") for k in locators):
        CacheImpl._locator_classes = [*(_keyed_on_sources(k) for k in locators), *locators]
    return True


track_sources(PACKAGE_DIR, COMPILED_SOURCES)


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
