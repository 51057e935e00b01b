"""Compile (and, where a cache can be written, cache) every compiled path ahead of use.

The simulator core, the PWM variants and the envs' compiled task are numba functions. The
first process after an install compiles them (13-26 s on a 2-core machine, measured with
``sma-gym warmup``) and, when a cache directory is writable (see :mod:`sma_gym._jit`),
stores the machine code so later processes load it in well under a second. ``sma-gym
warmup`` does that first compilation on purpose, for instance in a Dockerfile or a cluster
job's setup step, and says where the cache went.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class WarmUp:
    """What :func:`warm_up` did."""

    seconds: float
    """Wall-clock time of the whole warm-up [s]."""
    cached: bool
    """True when the compiled code was written to (or read from) an on-disk cache."""
    cache_dir: str
    """Where numba keeps the kernel's cache (as its locator chose it), or ``""``."""
    paths: tuple[str, ...]
    """The compiled paths exercised."""


def _cache_dir() -> str:
    """The folder numba's own locator chose for the kernel's cache (``NUMBA_CACHE_DIR``, the
    package's ``__pycache__`` or the user cache, the first writable), or ``""`` without one:
    read from the compiled function, not assumed (a read-only package's cache, in the user
    cache, was reported next to the package; a ``NUMBA_CACHE_DIR`` numba could not use was
    reported as the cache)."""
    from sma_gym._jit import caching_available

    if not caching_available():
        return ""
    from sma_gym.core import kernel

    cache = getattr(kernel._advance, "_cache", None)  # numba's FunctionCache (a NullCache without one)
    return str(getattr(cache, "_cache_path", "") or "")


def warm_up() -> WarmUp:
    """Run every compiled path once: the simulator in both PWM modes, each env id's single
    env and, where it has one, its native vector env."""
    import gymnasium as gym

    from sma_gym.envs import ENV_IDS
    from sma_gym.simulator import Simulator

    started = time.perf_counter()
    paths = []
    for mode in ("averaged", "resolved"):
        Simulator("standard", pwm_mode=mode).run(np.full(5, 0.2), record=("position_m",))
        paths.append(f"Simulator(pwm_mode={mode!r})")
    for env_id in ENV_IDS:
        env = gym.make(f"sma_gym:{env_id}")
        env.reset(seed=0)
        env.step(env.action_space.sample())
        env.close()
        paths.append(env_id)
        if gym.spec(env_id).vector_entry_point is not None:
            vec = gym.make_vec(f"sma_gym:{env_id}", num_envs=2, vectorization_mode="vector_entry_point")
            vec.reset(seed=0)
            vec.step(vec.action_space.sample())
            vec.close()
            paths.append(f"{env_id} (vector)")
    cache_dir = _cache_dir()
    return WarmUp(time.perf_counter() - started, bool(cache_dir), cache_dir, tuple(paths))
