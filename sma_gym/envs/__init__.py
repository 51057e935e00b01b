"""Gymnasium environments of sma-gym, registered when ``sma_gym`` is imported.

================== =========================================================================
id                 task
================== =========================================================================
SMATracking-v0     one actuator tracks a position reference; sees position and resistance
SMASelfSensing-v0  the same without a position sensor: resistance, current, voltage only
SMAMultiplexed-v0  1-16 actuators on one PWM swept at 100-4000 Hz, each with its reference
SMARobust-v0       tracking under randomised chapter-7 conditions (supply, fan, diameter)
================== =========================================================================

``gymnasium.make("sma_gym:SMATracking-v0")`` works in a fresh interpreter (the ``module:``
prefix imports ``sma_gym``, which registers the ids). The three single-actuator ids also
have a native vector env: ``gymnasium.make_vec(id, num_envs=N,
vectorization_mode="vector_entry_point")``.
"""

from __future__ import annotations

import gymnasium

EPISODE_STEPS = 1000
"""Registered ``max_episode_steps``: 10 s at the default 10 ms control period."""

ENV_IDS = ("SMATracking-v0", "SMASelfSensing-v0", "SMAMultiplexed-v0", "SMARobust-v0")


def register_envs() -> None:
    specs = (
        ("SMATracking-v0", "sma_gym.envs.single:tracking", "sma_gym.envs.vector:tracking"),
        ("SMASelfSensing-v0", "sma_gym.envs.single:self_sensing", "sma_gym.envs.vector:self_sensing"),
        ("SMARobust-v0", "sma_gym.envs.single:robust", "sma_gym.envs.vector:robust"),
        ("SMAMultiplexed-v0", "sma_gym.envs.multiplexed:SMAMultiplexedEnv", None),
    )
    for env_id, entry, vector_entry in specs:
        if env_id in gymnasium.registry:
            continue
        gymnasium.register(
            id=env_id,
            entry_point=entry,
            vector_entry_point=vector_entry,
            max_episode_steps=EPISODE_STEPS,
        )
