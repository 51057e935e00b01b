"""What the agent sees and does in training: the env, residual base, history, frame stack.

:func:`make_vec_env` builds the training envs, :func:`make_validation_env` the held-out
validation envs; both wrap them in the same agent view (:func:`agent_view`), the order
:class:`sma_gym_agents.trained.AgentPolicy` rebuilds at evaluation. The two stable-baselines3
wrappers here hold the very objects evaluation uses (:class:`sma_gym_agents.residual.ResidualStep`,
:class:`sma_gym_agents.history.HistoryFeatures`), so training and evaluation compute identically.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import (
    DummyVecEnv,
    VecEnv,
    VecEnvWrapper,
    VecFrameStack,
    VecMonitor,
)

import sma_gym  # noqa: F401  (registers the ids)
from sma_gym.envs import references as refs
from sma_gym.envs.multiplexed import DEFAULT_N_ACTUATORS
from sma_gym.envs.sb3 import SB3VecEnv
from sma_gym_agents.bank import BankResidual, BankView
from sma_gym_agents.history import HistoryFeatures
from sma_gym_agents.policies import env_attr
from sma_gym_agents.residual import ResidualStep
from sma_gym_agents.training.config import BANK_ENV, RunConfig

VALIDATION_SEED = 10_000
"""First seed of the validation references (training draws its references from seeds below)."""


class ResidualVecEnv(VecEnvWrapper):
    """SB3 VecEnv wrapper (raw sma_gym observations): the agent acts as a residual.

    ``base``: the label of the controller whose duty the agent corrects (``"VSC3 + FF"``);
    ``scale``: the largest correction, as a fraction of full duty; ``filter_s``: the time
    constant of the low-pass the correction passes (0: none). RL Zoo's ``vec_env_wrapper``
    calls it as ``ResidualVecEnv(venv, base=..., scale=..., filter_s=...)``.
    """

    def __init__(self, venv: VecEnv, base: str, scale: float = 0.5, filter_s: float = 0.0):
        self.residual = ResidualStep(venv, base, scale, filter_s)
        super().__init__(venv, observation_space=ResidualStep.observation_space(venv.observation_space))

    def reset(self):
        obs = np.asarray(self.venv.reset(), dtype=float)
        self.residual.policy.reset()
        return self.residual.observe(obs, np.ones(self.num_envs, dtype=bool))

    def step_async(self, actions):
        self.venv.step_async(self.residual.action(actions))

    def step_wait(self):
        obs, rewards, dones, infos = self.venv.step_wait()
        for i in np.flatnonzero(dones):
            if "terminal_observation" in infos[i]:
                # The ended episode's last base duty (the controller is not stepped again:
                # its state now belongs to the new episode).
                infos[i]["terminal_observation"] = np.append(
                    infos[i]["terminal_observation"], self.residual.base_duty[i]
                ).astype(np.float32)
        return self.residual.observe(np.asarray(obs, dtype=float), dones), rewards, dones, infos


class HistoryVecEnv(VecEnvWrapper):
    """SB3 VecEnv wrapper appending :class:`HistoryFeatures` to the observations.

    Without ``history`` the features are built for ``venv``'s envs (their feature names
    and control period), with the fine error features if ``error_features``: the form RL
    Zoo's ``vec_env_wrapper`` calls, ``HistoryVecEnv(venv, error_features=...)``.
    """

    def __init__(self, venv: VecEnv, history: HistoryFeatures | None = None, error_features: bool = False):
        if history is None:
            history = HistoryFeatures(
                venv.num_envs,
                tuple(env_attr(venv, "feature_names")),
                float(env_attr(venv, "control_period_s")),
                error_features=error_features,
            )
        if history.n != venv.num_envs:
            raise ValueError(
                f"history features for {history.n} envs: expected {venv.num_envs} (the vector env's num_envs)"
            )
        self.history = history
        super().__init__(venv, observation_space=self.history.observation_space(venv.observation_space))

    def reset(self):
        return self.history.reset(np.asarray(self.venv.reset(), dtype=float))

    def step_wait(self):
        obs, rewards, dones, infos = self.venv.step_wait()
        terminal = {
            int(i): np.asarray(infos[i]["terminal_observation"], dtype=float)
            for i in np.flatnonzero(dones)
            if "terminal_observation" in infos[i]
        }
        out, ended = self.history.update(np.asarray(obs, dtype=float), dones, terminal)
        for i, last in ended.items():
            infos[i]["terminal_observation"] = last
        return out, rewards, dones, infos


class BankVecEnv(VecEnv):
    """Every actuator of every bank as one sub-env of a stable-baselines3 VecEnv.

    ``venv``: a VecEnv of ``SMAMultiplexed-v0`` banks (all of one n and scheme). Sub-env
    ``b * n + j`` is actuator j of bank b: its observation :class:`BankView`'s row, its
    action that actuator's entry of the bank's action, its reward that actuator's own
    tracking term (``actuator_rewards``). A bank's episode ends for all its actuators at once.
    ``base`` (a controller label) and ``scale``: the model corrects that controller's bank
    baseline (:class:`sma_gym_agents.bank.BankResidual`; its share is the row's last feature),
    else it chooses the whole action; ``allocation``: how that baseline grants an overrun
    shared budget (``"proportional"`` or ``"priority"``, :func:`sma_gym_agents.bank.bank_policy`).
    RL Zoo's ``vec_env_wrapper`` calls it as ``BankVecEnv(venv, base=..., scale=...,
    allocation=...)``. ``references``: one list per bank of one reference per actuator,
    given at every reset (fixed validation banks).
    """

    def __init__(
        self,
        venv: Any,
        references: Sequence[Sequence[Any]] | None = None,
        base: str | None = None,
        scale: float = 0.5,
        allocation: str = "proportional",
    ):
        self.venv = venv
        self.n = int(env_attr(venv, "n"))
        self.view = BankView(str(env_attr(venv, "scheme")))
        self.residual = None if base is None else BankResidual(venv, base, scale, allocation)
        if references is not None and (len(references) != venv.num_envs or any(len(r) != self.n for r in references)):
            raise ValueError(
                f"references: expected {venv.num_envs} lists (one per bank) of {self.n} references (one per actuator)"
            )
        self.references = references
        self._actions: np.ndarray | None = None
        self._returns = np.zeros(venv.num_envs * self.n)
        self._lengths = np.zeros(venv.num_envs * self.n, dtype=np.int64)
        super().__init__(
            num_envs=venv.num_envs * self.n,
            observation_space=BankView.observation_space(residual=self.residual is not None),
            action_space=spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32),
        )

    def _rows(self, obs: np.ndarray, starts: np.ndarray) -> np.ndarray:
        if self.residual is None:
            return self.view.rows(obs)
        return self.view.rows(obs, self.residual.observe(obs, starts))

    def reset(self) -> np.ndarray:
        if self.references is not None:
            self.venv.set_options([{"references": list(r)} for r in self.references])
        self._returns[:] = 0.0
        self._lengths[:] = 0
        if self.residual is not None:
            self.residual.reset()
        return self._rows(self.venv.reset(), np.ones(self.venv.num_envs, dtype=bool))

    def step_async(self, actions: np.ndarray) -> None:
        actions = np.asarray(actions, dtype=np.float32).reshape(self.venv.num_envs, self.n)
        if self.residual is not None:
            actions = self.residual.action(actions)
        self.venv.step_async(actions)

    def step_wait(self):
        obs, _, dones, infos = self.venv.step_wait()
        rewards = np.concatenate([np.asarray(r, dtype=float) for r in self.venv.get_attr("actuator_rewards")])
        done = np.repeat(np.asarray(dones, dtype=bool), self.n)
        self._returns += rewards
        self._lengths += 1
        out: list[dict[str, Any]] = []
        for b, info in enumerate(infos):
            terminal = info.get("terminal_observation")
            rows = None
            if terminal is not None:
                # The ended episode's last base share (the base is not stepped again: its
                # state now belongs to the new episode).
                last = None if self.residual is None else self.residual.base_share[b : b + 1]
                rows = self.view.rows(terminal, last)
            for j in range(self.n):
                i = b * self.n + j
                entry: dict[str, Any] = {}
                if dones[b]:
                    entry["TimeLimit.truncated"] = bool(info.get("TimeLimit.truncated", False))
                    if rows is not None:
                        entry["terminal_observation"] = rows[j]
                    entry["episode"] = {"r": float(self._returns[i]), "l": int(self._lengths[i]), "t": 0.0}
                out.append(entry)
        self._returns[done] = 0.0
        self._lengths[done] = 0
        return self._rows(obs, np.asarray(dones, dtype=bool)), rewards.astype(np.float32), done, out

    def close(self) -> None:
        self.venv.close()

    def _banks(self, indices: Any) -> list[int]:
        chosen = range(self.num_envs) if indices is None else [indices] if isinstance(indices, int) else indices
        return [int(i) // self.n for i in chosen]

    def get_attr(self, attr_name: str, indices: Any = None) -> list[Any]:
        values = self.venv.get_attr(attr_name)
        return [values[b] for b in self._banks(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: Any = None) -> None:
        self.venv.set_attr(attr_name, value, sorted(set(self._banks(indices))))

    def env_method(self, method_name: str, *method_args: Any, indices: Any = None, **method_kwargs: Any) -> list[Any]:
        # Called once per bank the indices touch, never on the other banks (a method may act:
        # reset, set_options).
        banks = self._banks(indices)
        touched = sorted(set(banks))
        results = self.venv.env_method(method_name, *method_args, indices=touched, **method_kwargs)
        by_bank = dict(zip(touched, results))
        return [by_bank[b] for b in banks]

    def env_is_wrapped(self, wrapper_class: Any, indices: Any = None) -> list[bool]:
        # Monitor: this class reports each actuator's episodes as a Monitor would ("episode" info).
        from stable_baselines3.common.monitor import Monitor

        return [wrapper_class is Monitor for _ in self._banks(indices)]

    def seed(self, seed: int | None = None) -> Sequence[None | int]:
        return self.venv.seed(seed)


def agent_view(
    venv: VecEnv,
    env_id: str,
    env_kwargs: dict[str, Any],
    frame_stack: int,
    history: str,
    residual: str | None,
    residual_scale: float,
    residual_filter_s: float = 0.0,
) -> VecEnv:
    """What the agent sees and does on top of the env: residual base controller, history
    features, frame stack (the order :class:`sma_gym_agents.trained.AgentPolicy` rebuilds)."""
    if residual is not None:
        venv = ResidualVecEnv(venv, residual, residual_scale, residual_filter_s)
    if history != "none":
        venv = HistoryVecEnv(venv, HistoryFeatures.for_env(venv.num_envs, env_id, env_kwargs, history))
    if frame_stack > 1:
        venv = VecFrameStack(venv, frame_stack)
    return venv


def make_vec_env(
    env_id: str,
    n_envs: int,
    env_kwargs: dict[str, Any],
    frame_stack: int,
    seed: int,
    history: str = "none",
    residual: str | None = None,
    residual_scale: float = 0.5,
    max_episode_steps: int | None = None,
    allocation: str = "proportional",
    residual_filter_s: float = 0.0,
) -> VecEnv:
    """SB3 VecEnv: the native vector env where the id has one, with a monitor and the agent view
    (the multiplexed bank: ``n_envs`` banks, each actuator a sub-env, :class:`BankVecEnv`)."""
    kwargs = dict(env_kwargs)
    if max_episode_steps is not None:
        kwargs["max_episode_steps"] = max_episode_steps
    if env_id == BANK_ENV:
        # BankVecEnv reports each actuator's episodes itself: no VecMonitor below it.
        venv = BankVecEnv(
            DummyVecEnv([lambda: gym.make("sma_gym:" + env_id, **kwargs)] * n_envs),
            base=residual,
            scale=residual_scale,
            allocation=allocation,
        )
        venv.seed(seed)
        return venv
    if gym.spec(env_id).vector_entry_point is not None:
        # The adapter reports episodes itself (as Monitor does): no VecMonitor on top.
        venv = SB3VecEnv(
            gym.make_vec("sma_gym:" + env_id, num_envs=n_envs, vectorization_mode="vector_entry_point", **kwargs)
        )
    else:
        venv = VecMonitor(DummyVecEnv([lambda: gym.make("sma_gym:" + env_id, **kwargs)] * n_envs))
    venv = agent_view(venv, env_id, kwargs, frame_stack, history, residual, residual_scale, residual_filter_s)
    venv.seed(seed)
    return venv


def make_training_env(run: RunConfig) -> VecEnv:
    """The run's training envs (:func:`make_vec_env` with its settings)."""
    return make_vec_env(
        run.env_id,
        run.n_envs,
        run.env_kwargs,
        run.frame_stack,
        run.seed,
        run.history,
        run.residual,
        run.residual_scale,
        allocation=run.residual_allocation,
        residual_filter_s=run.residual_filter_s,
    )


def validation_references(run: RunConfig, count: int = 8) -> list[dict[str, Any]]:
    """Held-out references: the training distribution, drawn with seeds training never uses,
    within the stroke of the run's own actuator (the env's position scale, as training draws)."""
    env = gym.make("sma_gym:" + run.env_id, **run.env_kwargs)
    stroke_m = float(env.unwrapped.position_scale_m)
    env.close()
    out = []
    for k in range(count):
        rng = np.random.default_rng(VALIDATION_SEED + k)
        kind = refs.TRAINING_KINDS[k % len(refs.TRAINING_KINDS)]
        spec = refs.draw(kind, rng, stroke_m).describe()
        spec.pop("name", None)
        out.append(spec)
    return out


def validation_count(run: RunConfig) -> int:
    """How many validation references a run draws: 4 (quick) or 8 single-wire episodes; for
    the bank 2 (quick) or 4 banks of n actuators, each actuator its own reference."""
    episodes = 4 if run.quick else 8
    if run.env_id == BANK_ENV:
        return (episodes // 2) * int(run.env_kwargs.get("n_actuators", DEFAULT_N_ACTUATORS))
    return episodes


def make_validation_env(run: RunConfig, references: list[dict[str, Any]]) -> VecEnv:
    """One env per validation reference, seen through the run's agent view (the bank: one
    bank per n references, each actuator its own, the same at every evaluation)."""
    if run.env_id == BANK_ENV:
        n = int(run.env_kwargs.get("n_actuators", DEFAULT_N_ACTUATORS))
        banks = [references[k : k + n] for k in range(0, len(references) - n + 1, n)]
        fns = [lambda: gym.make("sma_gym:" + run.env_id, **run.env_kwargs)] * len(banks)
        venv = BankVecEnv(
            DummyVecEnv(fns),
            references=banks,
            base=run.residual,
            scale=run.residual_scale,
            allocation=run.residual_allocation,
        )
        venv.seed(VALIDATION_SEED)
        return venv
    fns = [
        (lambda ref=ref: gym.make("sma_gym:" + run.env_id, **{**run.env_kwargs, "reference": ref}))
        for ref in references
    ]
    venv = agent_view(
        VecMonitor(DummyVecEnv(fns)),
        run.env_id,
        run.env_kwargs,
        run.frame_stack,
        run.history,
        run.residual,
        run.residual_scale,
        run.residual_filter_s,
    )
    venv.seed(VALIDATION_SEED)
    return venv
