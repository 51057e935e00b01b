"""Residual agents: a learned correction on top of one of the report's controllers.

The agent's action ``a`` in [-1, 1] is a correction to the duty a base controller (by
default the report's best, VSC3 + feedforward; on the self-sensing env its self-sensing
variant, fed by the position estimated from resistance) computes from the same observation::

    duty = clip(base_duty + scale * a, duty range)

and the base duty is appended to what the agent observes. With ``a = 0`` the agent is the
base controller, so training starts from the baseline's performance and only has to learn
what the baseline cannot do (for instance: use the reference preview to heat before a step
and to start cooling before a reversal, which the hysteresis makes slow).

:class:`ResidualStep` holds the base controller for a batch and is used both by the
training wrapper (:func:`make_residual_vec_env`) and by :class:`agents.policies.AgentPolicy`
at evaluation, so both compose actions identically.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnvWrapper


class ResidualStep:
    """Base controller for ``n`` envs and the action composition."""

    def __init__(self, env: Any, base: str, scale: float):
        from agents.policies import ControllerPolicy, SelfSensingPolicy, _env_attr

        # Without a position sensor the base controller is the self-sensing variant (position
        # from resistance through a calibration fitted on the env's own model, §4.2).
        if "position" in tuple(_env_attr(env, "feature_names")):
            self.policy = ControllerPolicy(base, env)
        else:
            self.policy = SelfSensingPolicy(base, env)
        self.scale = float(scale)
        self.lo, self.hi = self.policy.duty_range
        self.k = self.policy.k
        self.base_duty: np.ndarray | None = None

    def observe(self, obs: np.ndarray, starts: np.ndarray) -> np.ndarray:
        """Run the base controller on ``obs`` (once per step) and append its duty."""
        raw = obs[:, : self.k]
        action, _ = self.policy.predict(raw, episode_start=starts)
        self.base_duty = self.lo + (np.asarray(action, dtype=float).reshape(len(obs), -1)[:, 0] + 1.0) * 0.5 * (self.hi - self.lo)
        return np.concatenate([obs, self.base_duty[:, None]], axis=1).astype(np.float32)

    def action(self, agent_action: np.ndarray) -> np.ndarray:
        """Env actions for the agent's corrections (uses the last observed base duty)."""
        a = np.clip(np.asarray(agent_action, dtype=float).reshape(len(self.base_duty), -1)[:, 0], -1.0, 1.0)
        duty = np.clip(self.base_duty + self.scale * a, self.lo, self.hi)
        return (2.0 * (duty - self.lo) / (self.hi - self.lo) - 1.0).astype(np.float32)[:, None]

    @staticmethod
    def observation_space(base: spaces.Box) -> spaces.Box:
        return spaces.Box(
            np.append(base.low, 0.0).astype(np.float32), np.append(base.high, 1.0).astype(np.float32), dtype=np.float32
        )


class ResidualVecEnv(VecEnvWrapper):
    """SB3 VecEnv wrapper (raw sma_gym observations): the agent acts as a residual."""

    def __init__(self, venv, base: str, scale: float):
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
                infos[i]["terminal_observation"] = np.append(infos[i]["terminal_observation"], self.residual.base_duty[i]).astype(np.float32)
        return self.residual.observe(np.asarray(obs, dtype=float), dones), rewards, dones, infos


def make_residual_vec_env(venv, base: str, scale: float) -> ResidualVecEnv:
    return ResidualVecEnv(venv, base, scale)
