"""The native vector env of SMAMultiplexed-v0 (issue 16): N banks as one simulator, step for
step what N single envs give."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import sma_gym  # noqa: F401  (registers the ids)
from sma_gym.envs.multiplexed import SMAMultiplexedVectorEnv


@pytest.mark.parametrize("scheme", ["fixed_slots", "shared_budget"])
def test_native_bank_vector_env_matches_sync_vector_env_step_for_step(scheme):
    kwargs = dict(n_actuators=3, scheme=scheme, control_period_s=0.01, position_noise_std_m=2e-6)
    native = gym.make_vec(
        "sma_gym:SMAMultiplexed-v0", num_envs=2, vectorization_mode="vector_entry_point", max_episode_steps=7, **kwargs
    )
    sync = gym.make_vec(
        "sma_gym:SMAMultiplexed-v0", num_envs=2, vectorization_mode="sync", max_episode_steps=7, **kwargs
    )
    assert isinstance(native.unwrapped, SMAMultiplexedVectorEnv)
    assert native.observation_space == sync.observation_space and native.action_space == sync.action_space
    a, info_a = native.reset(seed=5)
    b, info_b = sync.reset(seed=5)
    np.testing.assert_array_equal(a, b)
    rng = np.random.default_rng(0)
    for _ in range(16):  # two episode ends (autoreset NEXT_STEP)
        action = rng.uniform(-1, 1, (2, 3)).astype(np.float32)
        out_a = native.step(action)
        out_b = sync.step(action)
        for x, y in zip(out_a[:4], out_b[:4]):
            np.testing.assert_array_equal(x, y)
        assert set(out_a[4]) == set(out_b[4])
        for key, value in out_b[4].items():
            np.testing.assert_array_equal(out_a[4][key], value, err_msg=key)
    native.close()
    sync.close()


def test_native_bank_vector_env_refuses_what_it_does_not_do():
    with pytest.raises(ValueError, match="autoreset_mode"):
        SMAMultiplexedVectorEnv(2, autoreset_mode="SameStep")
    with pytest.raises(ValueError, match="n_actuators"):
        SMAMultiplexedVectorEnv(2, n_actuators=17)
    with pytest.raises(ValueError, match="references"):
        SMAMultiplexedVectorEnv(2, n_actuators=2).reset(options={"references": [None]})
