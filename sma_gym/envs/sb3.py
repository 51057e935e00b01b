"""Stable-baselines3 ``VecEnv`` adapter for the native vector env.

>>> import gymnasium, sma_gym
>>> from sma_gym.envs.sb3 import SB3VecEnv
>>> venv = SB3VecEnv(gymnasium.make_vec("sma_gym:SMATracking-v0", num_envs=64,
...                                      vectorization_mode="vector_entry_point"))

The adapter works with every autoreset mode (see :mod:`sma_gym.envs.vector`). SB3 wants
the first observation of the next episode on the step an episode ends, with the last one
in ``infos[i]["terminal_observation"]``: with ``SAME_STEP`` the vector env already does
that; with ``NEXT_STEP`` (the default) or ``DISABLED`` the adapter resets the ended
sub-envs at once through ``reset(options={"reset_mask": ...})``, so Gymnasium vector
wrappers may sit in between, except ``NormalizeObservation``, which resets all sub-envs or
none and takes no ``SAME_STEP`` env (refused when the adapter is made: SB3's
``VecNormalize`` on top of the adapter normalises instead).

It also does what SB3's ``Monitor`` does: at the end of an episode ``infos[i]["episode"]``
holds ``{"r": return, "l": length, "t": seconds since the adapter was made}``, so SB3 logs
``rollout/ep_rew_mean`` and ``evaluate_policy`` counts whole episodes without a warning
(``env_is_wrapped(Monitor)`` is true); no ``VecMonitor`` is needed on top.
``infos[i]`` carries the env's per-sub-env ``info`` entries of sub-env i as Python scalars
(the keys of :data:`sma_gym.envs.task.INFO`: ``position_m``, ``reference_m``, ...; the robust
env's ``condition_*``; of the ended episode's last step when it ends) and
``TimeLimit.truncated``; ``reset_infos[i]`` those of its episode's start, as ``DummyVecEnv``.

The sub-envs share one simulator, so ``indices`` are honoured where that is meaningful
(``env_method("reset", indices=...)`` resets only those sub-envs; ``get_attr`` of a
per-sub-env attribute such as ``position_scale_m`` gives each sub-env its own value) and
refused with a clear error where it is not (a method or attribute of the shared env for a
subset); attributes the simulator was built from (``control_period_s``, ...) cannot be set
at all.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.wrappers.vector import DictInfoToList, NormalizeObservation

from sma_gym.extras import extra_error

try:
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env.base_vec_env import VecEnv
except ModuleNotFoundError as err:
    raise extra_error(err, "sma_gym.envs.sb3 (the stable-baselines3 adapter)", "train") from err

_NOT_PER_ENV = ("final_obs", "final_info", "episode")
"""Vector info keys that are no sub-env's own entry (Gymnasium's SAME_STEP records, a wrapper's stats)."""


def _is_per_env(key: str, value: Any, n: int) -> bool:
    """Whether a vector ``info`` entry is one value per sub-env (not a ``_key`` mask, not
    Gymnasium's SAME_STEP records or a wrapper's stats)."""
    return (
        not key.startswith("_")
        and key not in _NOT_PER_ENV
        and isinstance(value, np.ndarray)
        and value.shape[:1] == (n,)
    )


def _per_env(info: dict[str, Any], n: int, which: Any = slice(None)) -> dict[str, list]:
    """The per-sub-env entries of ``info`` for the sub-envs ``which`` (all by default), as lists
    of Python scalars: one conversion per key, not one numpy scalar per key and sub-env."""
    return {k: v[which].tolist() for k, v in info.items() if _is_per_env(k, v, n)}


def _same(a: dict, b: dict) -> bool:
    """Whether two options dicts are equal (one holding arrays compares by identity)."""
    try:
        return bool(a == b)
    except ValueError:
        return a is b


class SB3VecEnv(VecEnv):
    """Wrap a Gymnasium vector env (any autoreset mode) for stable-baselines3, with episode stats."""

    def __init__(self, vector_env: Any):
        if not isinstance(getattr(vector_env, "metadata", None), dict) or not hasattr(vector_env, "num_envs"):
            raise ValueError(
                f"SB3VecEnv({vector_env!r}): expected a Gymnasium vector env, e.g. gymnasium.make_vec(id, num_envs, "
                "vectorization_mode='vector_entry_point') on an sma_gym id"
            )
        mode = vector_env.metadata.get("autoreset_mode")
        if mode not in tuple(AutoresetMode):
            raise ValueError(
                f"vector env metadata['autoreset_mode'] = {mode!r}: expected an AutoresetMode "
                "(use gymnasium.make_vec(..., vectorization_mode='vector_entry_point') on an sma_gym id)"
            )
        layer = vector_env
        while layer is not None:
            if isinstance(layer, NormalizeObservation):
                # It resets all sub-envs or none and takes no SAME_STEP env, while SB3 needs an
                # ended sub-env restarted on the step it ends: it failed there, 100 steps in.
                raise ValueError(
                    "SB3VecEnv over Gymnasium's NormalizeObservation: it cannot restart one sub-env on the step it "
                    "ends, as SB3 needs; expected stable_baselines3's VecNormalize on the adapter instead "
                    "(VecNormalize(SB3VecEnv(vector_env)))"
                )
            if isinstance(layer, DictInfoToList):
                # The adapter reads one info dict of arrays; a list of dicts failed at the first step.
                raise ValueError(
                    "SB3VecEnv over Gymnasium's DictInfoToList: expected the vector env's own info dict of arrays "
                    "(the adapter makes SB3's list of per-sub-env infos itself); leave the wrapper out"
                )
            layer = getattr(layer, "env", None)
        self.venv = vector_env
        self.autoreset_mode = mode
        super().__init__(vector_env.num_envs, vector_env.single_observation_space, vector_env.single_action_space)
        self._actions: np.ndarray | None = None
        self._seed: int | None = None
        self._t_start = time.time()
        self._returns = np.zeros(self.num_envs)
        self._lengths = np.zeros(self.num_envs, dtype=np.int64)

    def reset(self):
        """Reset every sub-env, with the seed of :meth:`seed` and the options of SB3's
        ``set_options`` (both used once, as ``DummyVecEnv`` uses them)."""
        options = list(self._options)
        if all(_same(o, options[0]) for o in options):
            obs, info = self.venv.reset(seed=self._seed, options=dict(options[0]) or None)
            self._set_reset_infos(info, np.ones(self.num_envs, dtype=bool))
        else:
            # Sub-envs with different options: one masked reset per distinct options dict;
            # the last one returns every sub-env's first observation.
            seeds = [None if self._seed is None else self._seed + i for i in range(self.num_envs)]
            todo = np.ones(self.num_envs, dtype=bool)
            while todo.any():
                first = options[int(np.flatnonzero(todo)[0])]
                group = todo & np.array([_same(o, first) for o in options])
                obs, info = self.venv.reset(
                    seed=[s if g else None for s, g in zip(seeds, group)],
                    options={**first, "reset_mask": group},
                )
                self._set_reset_infos(info, group)
                todo &= ~group
        self._seed = None
        self._reset_options()
        self._returns[:] = 0.0
        self._lengths[:] = 0
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self):
        obs, rewards, terminated, truncated, info = self.venv.step(self._actions)
        dones = np.asarray(terminated | truncated)
        self._returns += rewards
        self._lengths += 1
        ended = np.flatnonzero(dones)
        if ended.size and self.autoreset_mode == AutoresetMode.SAME_STEP:
            terminal = info["final_obs"]
            # The next episode's start, where an env gives it apart (its info is the ended one's last step).
            self._set_reset_infos(info, dones)
            final = info["final_info"]
            info = {
                **info,
                **{
                    k: np.where(dones.reshape((-1,) + (1,) * (v.ndim - 1)), final[k], v)
                    for k, v in info.items()
                    if k in final and _is_per_env(k, v, self.num_envs)
                },
            }
        elif ended.size:
            terminal = obs
            obs = obs.copy()
            restarted, start = self.venv.reset(options={"reset_mask": dones})
            obs[ended] = restarted[ended]
            self._set_reset_infos(start, dones)
        values = _per_env(info, self.num_envs)
        infos: list[dict[str, Any]] = [{k: v[i] for k, v in values.items()} for i in range(self.num_envs)]
        for i in ended:
            infos[i]["terminal_observation"] = terminal[i]
            infos[i]["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            infos[i]["episode"] = {
                "r": round(float(self._returns[i]), 6),
                "l": int(self._lengths[i]),
                "t": round(time.time() - self._t_start, 6),
            }
        self._returns[ended] = 0.0
        self._lengths[ended] = 0
        return obs, rewards.astype(np.float32), dones, infos

    def _set_reset_infos(self, info: dict[str, Any], which: np.ndarray) -> None:
        chosen = np.flatnonzero(which)
        values = _per_env(info, self.num_envs, chosen)
        for j, i in enumerate(chosen):
            self.reset_infos[i] = {k: v[j] for k, v in values.items()}

    def seed(self, seed: int | None = None):
        self._seed = seed
        return [None if seed is None else seed + i for i in range(self.num_envs)]

    def close(self) -> None:
        self.venv.close()

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        """Entry k is the value of sub-env ``indices[k]`` (its own one for per-sub-env
        attributes: the vector env's ``get_attr``)."""
        values = self.venv.unwrapped.get_attr(attr_name)
        return [values[i] for i in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        """Set an attribute of the shared env: only for all sub-envs, never one the simulator
        was built from (the vector env's ``set_attr`` refuses it)."""
        self._require_all(self._indices(indices), f"set_attr({attr_name!r})")
        env = self.venv.unwrapped
        env.set_attr(attr_name, [value] * env.num_envs)  # one per sub-env: a list value stays one value

    def env_method(self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any) -> list[Any]:
        """Call a method: one result per sub-env in ``indices``, as ``DummyVecEnv`` gives them.
        A method with one result per sub-env (the vector env's ``PER_ENV_METHODS``, such as
        ``reference_description``) and ``reset`` may address a subset; any other method is the
        shared env's, called once for all of them."""
        chosen = self._indices(indices)
        env = self.venv.unwrapped
        if method_name == "reset":
            if method_args or set(method_kwargs) - {"seed", "options"}:
                raise ValueError(
                    f"env_method('reset', {', '.join([*map(repr, method_args), *method_kwargs])}): expected only the "
                    "keywords 'seed' and 'options', as an env's reset takes them"
                )
            return self._reset_some(chosen, method_kwargs.get("seed"), method_kwargs.get("options"))
        if method_name in getattr(env, "PER_ENV_METHODS", ()):
            # Each sub-env's own result (the whole batch's list was given to every sub-env,
            # and a subset was refused).
            results = env.call(method_name, *method_args, **method_kwargs)
            return [results[i] for i in chosen]
        self._require_all(chosen, f"env_method({method_name!r})")
        result = getattr(env, method_name)(*method_args, **method_kwargs)
        return [result] * len(chosen)

    def _reset_some(self, chosen: Sequence[int], seed: int | None, options: dict | None) -> list[Any]:
        """``env_method("reset")``: a new episode in the sub-envs ``chosen`` (each given ``seed``,
        as ``DummyVecEnv`` gives every env the same one), one ``(obs, info)`` per entry as an
        env's reset returns it, and their episode statistics restarted, as ``Monitor.reset``
        restarts them. Through ``reset(options={"reset_mask": ...})``, which every native
        vector env and the Gymnasium wrappers in between take."""
        if options is not None and not isinstance(options, dict):
            raise ValueError(f"env_method('reset', options={options!r}): expected a dict or None")
        mask = np.zeros(self.num_envs, dtype=bool)
        mask[list(chosen)] = True
        seeds = None if seed is None else [seed if m else None for m in mask]
        obs, info = self.venv.reset(seed=seeds, options={**(options or {}), "reset_mask": mask})
        self._set_reset_infos(info, mask)
        self._returns[mask] = 0.0
        self._lengths[mask] = 0
        values = _per_env(info, self.num_envs, list(chosen))
        return [(obs[i].copy(), {k: v[j] for k, v in values.items()}) for j, i in enumerate(chosen)]

    def _require_all(self, chosen: Sequence[int], what: str) -> None:
        if sorted(set(chosen)) != list(range(self.num_envs)):
            raise ValueError(
                f"{what} with indices {list(chosen)}: the {self.num_envs} sub-envs share one simulator, so this "
                "applies to all of them or none; pass indices=None"
            )

    def env_is_wrapped(self, wrapper_class: type, indices: Any = None) -> list[bool]:
        """True only for SB3's ``Monitor``, whose bookkeeping this adapter does."""
        return [issubclass(Monitor, wrapper_class)] * len(self._indices(indices))

    def _indices(self, indices: Any) -> Sequence[int]:
        if indices is None:
            return range(self.num_envs)
        chosen = [indices] if isinstance(indices, (int, np.integer)) else list(indices)
        for i in chosen:
            if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 0 <= i < self.num_envs:
                raise ValueError(f"indices contains {i!r}: expected integers in [0, {self.num_envs - 1}]")
        return [int(i) for i in chosen]

    def get_images(self) -> Sequence[np.ndarray | None]:
        """One frame per sub-env when the vector env renders ``rgb_array`` (SB3's ``render()``
        and ``VecVideoRecorder`` tile them), else ``None`` each, as ``DummyVecEnv`` gives."""
        if self.render_mode != "rgb_array":
            return [None] * self.num_envs
        return list(self.venv.render())
