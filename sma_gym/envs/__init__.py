"""Gymnasium environments of sma-gym, registered when ``sma_gym`` is imported.

================== =========================================================================
id                 task
================== =========================================================================
SMATracking-v0     one actuator tracks a position reference; sees position and resistance
SMASelfSensing-v0  the same without a position sensor: resistance, current, voltage only
SMAMultiplexed-v0  1-16 actuators on one PWM swept at 100-4000 Hz, each with its reference
SMARobust-v0       tracking under randomised chapter-7 conditions (supply, fan, diameter)
================== =========================================================================

Each env's contract (spaces, reward, episode end, ``info``, arguments, version history) is
the docstring of its class: :class:`~sma_gym.envs.single.SMATrackingEnv`,
:class:`~sma_gym.envs.single.SMASelfSensingEnv`, :class:`~sma_gym.envs.single.SMARobustEnv`,
:class:`~sma_gym.envs.multiplexed.SMAMultiplexedEnv` and the vector env
:class:`~sma_gym.envs.vector.SMAVectorEnv` (``help(env.unwrapped)``).

``gymnasium.make("sma_gym:SMATracking-v0")`` works in a fresh interpreter (the ``module:``
prefix imports ``sma_gym``, which registers the ids), and ``env.spec.id`` keeps that form,
so a logged id can be made again anywhere. All four entry points live in
:mod:`sma_gym.envs.sma_gym_envs`, so ``gymnasium.pprint_registry()`` lists the ids together
under ``sma_gym_envs``. Every id also has a native vector env:
``gymnasium.make_vec(id, num_envs=N, vectorization_mode="vector_entry_point")`` (for
``SMAMultiplexed-v0``, N banks: :class:`~sma_gym.envs.multiplexed.SMAMultiplexedVectorEnv`).
"""

from __future__ import annotations

import dataclasses

import gymnasium
from gymnasium.envs.registration import EnvSpec

EPISODE_STEPS = 1000
"""Registered ``max_episode_steps``: 10 s at the default 10 ms control period."""

ENV_IDS = ("SMATracking-v0", "SMASelfSensing-v0", "SMAMultiplexed-v0", "SMARobust-v0")


MODULE = "sma_gym"
"""The module ``gymnasium.make("sma_gym:<id>")`` imports to register the ids."""


class ImportableSpec:
    """Mixin for the envs: ``spec.id`` carries the ``sma_gym:`` module prefix.

    ``gymnasium.make("sma_gym:SMATracking-v0")`` strips the prefix from the spec it stores,
    so a logged ``env.spec.id`` could not be made again in a process that has not imported
    ``sma_gym``. ``gymnasium.make`` and ``make_vec`` resolve ``module:id`` (they import the
    module), so the prefixed id is the one form they take in any process;
    ``gymnasium.spec`` and ``gymnasium.registry`` do not import and take the bare id
    (``env.spec.id.split(":")[-1]``) once ``sma_gym`` is imported. Ids registered by users on our
    entry points are left as they are (their module is unknown here).
    """

    _spec: EnvSpec | None = None

    @property
    def spec(self) -> EnvSpec | None:
        return self._spec

    @spec.setter
    def spec(self, value: EnvSpec | None) -> None:
        if value is not None and value.id in ENV_IDS:
            value = dataclasses.replace(value, id=f"{MODULE}:{value.id}")
        self._spec = value


def register_envs() -> None:
    """Register the four ids (skipping ids already registered, e.g. on a second import)."""
    entry = "sma_gym.envs.sma_gym_envs:"
    specs = (
        ("SMATracking-v0", "SMATrackingEnv", "tracking_vector"),
        ("SMASelfSensing-v0", "SMASelfSensingEnv", "self_sensing_vector"),
        ("SMARobust-v0", "SMARobustEnv", "robust_vector"),
        ("SMAMultiplexed-v0", "SMAMultiplexedEnv", "multiplexed_vector"),
    )
    for env_id, single, vector in specs:
        if env_id in gymnasium.registry:
            continue
        gymnasium.register(
            id=env_id,
            entry_point=entry + single,
            vector_entry_point=None if vector is None else entry + vector,
            max_episode_steps=EPISODE_STEPS,
        )
