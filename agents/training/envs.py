"""What the agent sees and does in training: the env, residual base, history, frame stack.

:func:`make_vec_env` builds the training envs, :func:`make_validation_env` the held-out
validation envs; both wrap them in the same agent view (:func:`agent_view`), the order
:class:`sma_gym_agents.trained.AgentPolicy` rebuilds at evaluation. The two stable-baselines3
wrappers here hold the very objects evaluation uses (:class:`sma_gym_agents.residual.ResidualStep`,
:class:`sma_gym_agents.history.HistoryFeatures`), so training and evaluation compute identically.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.vec_env import (
    DummyVecEnv,
    VecEnv,
    VecEnvWrapper,
    VecFrameStack,
    VecMonitor,
)

import sma_gym  # noqa: F401  (registers the ids)
from sma_gym.envs import references as refs
from sma_gym.envs.sb3 import SB3VecEnv
from sma_gym.params import preset
from sma_gym_agents.history import HistoryFeatures
from sma_gym_agents.policies import env_attr
from sma_gym_agents.residual import ResidualStep
from sma_gym_agents.training.config import RunConfig

VALIDATION_SEED = 10_000
"""First seed of the validation references (training draws its references from seeds below)."""


class ResidualVecEnv(VecEnvWrapper):
    """SB3 VecEnv wrapper (raw sma_gym observations): the agent acts as a residual.

    ``base``: the label of the controller whose duty the agent corrects (``"VSC3 + FF"``);
    ``scale``: the largest correction, as a fraction of full duty. RL Zoo's
    ``vec_env_wrapper`` calls it as ``ResidualVecEnv(venv, base=..., scale=...)``.
    """

    def __init__(self, venv: VecEnv, base: str, scale: float = 0.5):
        self.residual = ResidualStep(venv, base, scale)
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
    and control period): the form RL Zoo's ``vec_env_wrapper`` calls,
    ``HistoryVecEnv(venv)``.
    """

    def __init__(self, venv: VecEnv, history: HistoryFeatures | None = None):
        if history is None:
            history = HistoryFeatures(
                venv.num_envs, tuple(env_attr(venv, "feature_names")), float(env_attr(venv, "control_period_s"))
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


def agent_view(
    venv: VecEnv,
    env_id: str,
    env_kwargs: dict[str, Any],
    frame_stack: int,
    history: str,
    residual: str | None,
    residual_scale: float,
) -> VecEnv:
    """What the agent sees and does on top of the env: residual base controller, history
    features, frame stack (the order :class:`sma_gym_agents.trained.AgentPolicy` rebuilds)."""
    if residual is not None:
        venv = ResidualVecEnv(venv, residual, residual_scale)
    if history == "ema":
        venv = HistoryVecEnv(venv, HistoryFeatures.for_env(venv.num_envs, env_id, env_kwargs))
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
) -> VecEnv:
    """SB3 VecEnv: the native vector env where the id has one, with a monitor and the agent view."""
    kwargs = dict(env_kwargs)
    if max_episode_steps is not None:
        kwargs["max_episode_steps"] = max_episode_steps
    if gym.spec(env_id).vector_entry_point is not None:
        # The adapter reports episodes itself (as Monitor does): no VecMonitor on top.
        venv = SB3VecEnv(
            gym.make_vec("sma_gym:" + env_id, num_envs=n_envs, vectorization_mode="vector_entry_point", **kwargs)
        )
    else:
        venv = VecMonitor(DummyVecEnv([lambda: gym.make("sma_gym:" + env_id, **kwargs)] * n_envs))
    venv = agent_view(venv, env_id, kwargs, frame_stack, history, residual, residual_scale)
    venv.seed(seed)
    return venv


def make_training_env(run: RunConfig) -> VecEnv:
    """The run's training envs (:func:`make_vec_env` with its settings)."""
    return make_vec_env(
        run.env_id, run.n_envs, run.env_kwargs, run.frame_stack, run.seed, run.history, run.residual, run.residual_scale
    )


def validation_references(count: int = 8) -> list[dict[str, Any]]:
    """Held-out references: the training distribution, drawn with seeds training never uses."""
    stroke_m = preset("standard").usable_stroke_m
    out = []
    for k in range(count):
        rng = np.random.default_rng(VALIDATION_SEED + k)
        kind = refs.TRAINING_KINDS[k % len(refs.TRAINING_KINDS)]
        spec = refs.draw(kind, rng, stroke_m).describe()
        spec.pop("name", None)
        out.append(spec)
    return out


def make_validation_env(run: RunConfig, references: list[dict[str, Any]]) -> VecEnv:
    """One env per validation reference, seen through the run's agent view."""
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
    )
    venv.seed(VALIDATION_SEED)
    return venv
