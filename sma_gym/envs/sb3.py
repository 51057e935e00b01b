"""Stable-baselines3 ``VecEnv`` adapter for the native vector env.

>>> import gymnasium, sma_gym
>>> from sma_gym.envs.sb3 import SB3VecEnv
>>> venv = SB3VecEnv(gymnasium.make_vec("sma_gym:SMATracking-v0", num_envs=64,
...                                      vectorization_mode="vector_entry_point"))

SB3 expects same-step autoreset, which is what :class:`~sma_gym.envs.vector.SMAVectorEnv`
does; this adapter only converts the info dict of arrays into SB3's list of dicts and adds
``terminal_observation`` and ``TimeLimit.truncated``.

The sub-envs share one simulator, so ``indices`` are honoured where that is meaningful
(``env_method("reset", indices=...)`` resets only those sub-envs) and refused with a clear
error where it is not (a method or attribute of the shared env for a subset); attributes
the simulator was built from (``control_period_s``, ...) cannot be set at all.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env.base_vec_env import VecEnv

_PER_STEP_INFO = (
    "position_m",
    "position_measured_m",
    "reference_m",
    "temperature_c",
    "electrical_energy_j",
    "power_w",
    "spring_force_n",
    "duty",
    "time_s",
)


class SB3VecEnv(VecEnv):
    """Wrap a same-step-autoreset Gymnasium vector env for stable-baselines3."""

    def __init__(self, vector_env: Any):
        unwrapped = getattr(vector_env, "unwrapped", vector_env)
        if unwrapped.metadata.get("autoreset_mode") != AutoresetMode.SAME_STEP:
            raise ValueError(
                f"vector env autoreset_mode = {unwrapped.metadata.get('autoreset_mode')!r}: expected SAME_STEP "
                "(use gymnasium.make_vec(..., vectorization_mode='vector_entry_point') on an sma_gym id)"
            )
        self.venv = vector_env
        super().__init__(vector_env.num_envs, vector_env.single_observation_space, vector_env.single_action_space)
        self._actions: np.ndarray | None = None
        self._seed: int | None = None

    def reset(self):
        obs, _ = self.venv.reset(seed=self._seed)
        self._seed = None
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self):
        obs, rewards, terminated, truncated, info = self.venv.step(self._actions)
        dones = terminated | truncated
        infos: list[dict[str, Any]] = [
            {k: info[k][i] for k in _PER_STEP_INFO if k in info} for i in range(self.num_envs)
        ]
        if dones.any():
            final = info["final_obs"]
            for i in np.flatnonzero(dones):
                infos[i]["terminal_observation"] = final[i]
                infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
                if "final_info" in info:
                    infos[i]["episode_final"] = {k: v[i] for k, v in info["final_info"].items() if not k.startswith("_")}
        return obs, rewards.astype(np.float32), dones, infos

    def seed(self, seed: int | None = None):
        self._seed = seed
        return [None if seed is None else seed + i for i in range(self.num_envs)]

    def close(self) -> None:
        self.venv.close()

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        value = getattr(self.venv.unwrapped, attr_name)
        return [value] * len(self._indices(indices))

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        """Set an attribute of the shared env: only for all sub-envs, never one the simulator was built from."""
        env = self.venv.unwrapped
        if attr_name in getattr(env, "FIXED_AT_MAKE", ()):
            raise ValueError(
                f"set_attr({attr_name!r}): fixed when the env is made (the simulator was built with it); "
                f"make a new env with {attr_name}=... instead"
            )
        self._require_all(self._indices(indices), f"set_attr({attr_name!r})")
        setattr(env, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any) -> list[Any]:
        """Call a method of the shared env; ``reset`` may address a subset of sub-envs."""
        chosen = self._indices(indices)
        env = self.venv.unwrapped
        if method_name == "reset" and indices is not None:
            if method_args or set(method_kwargs) - {"options"}:
                raise ValueError("env_method('reset', indices=...): only an 'options' keyword is accepted for a subset")
            return env.reset_envs(chosen, options=method_kwargs.get("options"))
        self._require_all(chosen, f"env_method({method_name!r})")
        result = getattr(env, method_name)(*method_args, **method_kwargs)
        return [result] * len(chosen)

    def _require_all(self, chosen: Sequence[int], what: str) -> None:
        if sorted(set(chosen)) != list(range(self.num_envs)):
            raise ValueError(
                f"{what} with indices {list(chosen)}: the {self.num_envs} sub-envs share one simulator, so this "
                "applies to all of them or none; pass indices=None"
            )

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        return [False] * len(self._indices(indices))

    def _indices(self, indices: Any) -> Sequence[int]:
        if indices is None:
            return range(self.num_envs)
        chosen = [indices] if isinstance(indices, (int, np.integer)) else list(indices)
        for i in chosen:
            if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 0 <= i < self.num_envs:
                raise ValueError(f"indices contains {i!r}: expected integers in [0, {self.num_envs - 1}]")
        return [int(i) for i in chosen]

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None] * self.num_envs
