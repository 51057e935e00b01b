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
training wrapper (:class:`sma_gym_agents.training.envs.ResidualVecEnv`) and by
:class:`sma_gym_agents.trained.AgentPolicy` at evaluation, so both compose actions identically.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from sma_gym_agents.policies import ControllerPolicy, SelfSensingPolicy, env_attr


class ResidualStep:
    """Base controller for ``n`` envs and the action composition."""

    def __init__(self, env: Any, base: str, scale: float):
        # Without a position sensor the base controller is the self-sensing variant (position
        # from resistance through a calibration fitted on the env's own model, §4.2).
        if "position" in tuple(env_attr(env, "feature_names")):
            self.policy = ControllerPolicy(base, env)
        else:
            self.policy = SelfSensingPolicy(base, env)
        self.scale = float(scale)
        self.duty_range = self.policy.duty_range
        self.lo, self.hi = self.duty_range
        self.k = self.policy.k
        self.base_duty: np.ndarray | None = None

    def observe(self, obs: np.ndarray, starts: np.ndarray) -> np.ndarray:
        """Run the base controller on ``obs`` (once per step) and append its duty."""
        raw = obs[:, : self.k]
        action, _ = self.policy.predict(raw, episode_start=starts)
        self.base_duty = self.duty_range.duty_for(np.asarray(action, dtype=float).reshape(len(obs), -1)[:, 0])
        return np.concatenate([obs, self.base_duty[:, None]], axis=1).astype(np.float32)

    def action(self, agent_action: np.ndarray) -> np.ndarray:
        """Env actions for the agent's corrections (uses the last observed base duty)."""
        a = np.clip(np.asarray(agent_action, dtype=float).reshape(len(self.base_duty), -1)[:, 0], -1.0, 1.0)
        duty = np.clip(self.base_duty + self.scale * a, self.lo, self.hi)
        return self.duty_range.action_for(duty).astype(np.float32)[:, None]

    @staticmethod
    def observation_space(base: spaces.Box) -> spaces.Box:
        return spaces.Box(
            np.append(base.low, 0.0).astype(np.float32), np.append(base.high, 1.0).astype(np.float32), dtype=np.float32
        )
