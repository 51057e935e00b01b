"""Entry points of the registered ids (single and vector), all in one module.

Gymnasium's ``pprint_registry`` groups ids without a namespace by the third part of their
entry point's module path, so keeping every entry point here lists the four ids together,
under ``sma_gym_envs``.
"""

from __future__ import annotations

from typing import Any

from sma_gym.envs.multiplexed import SMAMultiplexedEnv
from sma_gym.envs.single import ROBUST, SELF_SENSING, TRACKING, SMAEnv
from sma_gym.envs.vector import SMAVectorEnv

__all__ = [
    "SMAMultiplexedEnv",
    "robust",
    "robust_vector",
    "self_sensing",
    "self_sensing_vector",
    "tracking",
    "tracking_vector",
]


def tracking(**kwargs: Any) -> SMAEnv:
    """Entry point of ``SMATracking-v0``."""
    return SMAEnv(TRACKING, **kwargs)


def self_sensing(**kwargs: Any) -> SMAEnv:
    """Entry point of ``SMASelfSensing-v0``."""
    return SMAEnv(SELF_SENSING, **kwargs)


def robust(**kwargs: Any) -> SMAEnv:
    """Entry point of ``SMARobust-v0``."""
    return SMAEnv(ROBUST, **kwargs)


def tracking_vector(num_envs: int, **kwargs: Any) -> SMAVectorEnv:
    """Vector entry point of ``SMATracking-v0``."""
    return SMAVectorEnv(num_envs, TRACKING, **kwargs)


def self_sensing_vector(num_envs: int, **kwargs: Any) -> SMAVectorEnv:
    """Vector entry point of ``SMASelfSensing-v0``."""
    return SMAVectorEnv(num_envs, SELF_SENSING, **kwargs)


def robust_vector(num_envs: int, **kwargs: Any) -> SMAVectorEnv:
    """Vector entry point of ``SMARobust-v0``."""
    return SMAVectorEnv(num_envs, ROBUST, **kwargs)
