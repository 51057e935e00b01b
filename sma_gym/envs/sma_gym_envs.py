"""Entry points of the registered ids (single and vector), all in one module.

Gymnasium's ``pprint_registry`` groups ids without a namespace by the third part of their
entry point's module path, so keeping every entry point here lists the four ids together,
under ``sma_gym_envs``. The single-actuator and multiplexed entry points are the env
classes themselves (their signatures are the accepted kwargs); the vector entry points
fix the variant of :class:`SMAVectorEnv` and read ``max_episode_steps`` as ``gym.make`` does
(:func:`episode_steps`).
"""

from __future__ import annotations

import numbers
from typing import Any

from sma_gym.envs import EPISODE_STEPS
from sma_gym.envs.multiplexed import SMAMultiplexedEnv, SMAMultiplexedVectorEnv
from sma_gym.envs.single import (
    ROBUST,
    SELF_SENSING,
    TRACKING,
    SMARobustEnv,
    SMASelfSensingEnv,
    SMATrackingEnv,
    Variant,
)
from sma_gym.envs.vector import SMAVectorEnv

__all__ = [
    "SMAMultiplexedEnv",
    "SMARobustEnv",
    "SMASelfSensingEnv",
    "SMATrackingEnv",
    "multiplexed_vector",
    "robust_vector",
    "self_sensing_vector",
    "tracking_vector",
]


def episode_steps(kwargs: dict[str, Any]) -> dict[str, Any]:
    """``kwargs`` with ``max_episode_steps`` as ``gym.make`` reads it, so that ``make_vec``
    truncates alike in every vectorization mode: absent or ``None`` is the registered
    :data:`~sma_gym.envs.EPISODE_STEPS`, ``-1`` is never (the vector classes' ``None``)."""
    steps = kwargs.get("max_episode_steps")
    if steps is None:
        steps = EPISODE_STEPS
    elif not isinstance(steps, numbers.Integral) or isinstance(steps, bool) or (steps < 1 and steps != -1):
        raise ValueError(
            f"max_episode_steps = {steps!r}: expected an integer >= 1, -1 (never truncate) or None "
            f"(the registered {EPISODE_STEPS})"
        )
    elif steps == -1:
        steps = None
    return {**kwargs, "max_episode_steps": steps}


def _vector(num_envs: int, variant: Variant, env_id: str, kwargs: dict[str, Any]) -> SMAVectorEnv:
    kwargs = episode_steps(kwargs)
    if "variant" in kwargs:
        raise ValueError(
            f"variant = {kwargs['variant']!r}: fixed by the id ({env_id} is the {variant.name} variant); "
            "make_vec another id for another variant"
        )
    return SMAVectorEnv(num_envs, variant, **kwargs)


def tracking_vector(num_envs: int, **kwargs: Any) -> SMAVectorEnv:
    """Vector entry point of ``SMATracking-v0``: :class:`SMAVectorEnv` of that variant (same kwargs)."""
    return _vector(num_envs, TRACKING, "SMATracking-v0", kwargs)


def self_sensing_vector(num_envs: int, **kwargs: Any) -> SMAVectorEnv:
    """Vector entry point of ``SMASelfSensing-v0``: :class:`SMAVectorEnv` of that variant (same kwargs)."""
    return _vector(num_envs, SELF_SENSING, "SMASelfSensing-v0", kwargs)


def robust_vector(num_envs: int, **kwargs: Any) -> SMAVectorEnv:
    """Vector entry point of ``SMARobust-v0``: :class:`SMAVectorEnv` of that variant (same kwargs)."""
    return _vector(num_envs, ROBUST, "SMARobust-v0", kwargs)


def multiplexed_vector(num_envs: int, **kwargs: Any) -> SMAMultiplexedVectorEnv:
    """Vector entry point of ``SMAMultiplexed-v0``: :class:`SMAMultiplexedVectorEnv` (num_envs banks, same kwargs)."""
    return SMAMultiplexedVectorEnv(num_envs, **episode_steps(kwargs))
