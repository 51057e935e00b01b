"""Residual agents: a learned correction on top of one of the report's controllers.

The agent's action ``a`` in [-1, 1] is a correction to the duty a base controller (by
default the report's best, VSC3 + feedforward; on the self-sensing env its self-sensing
variant, fed by the position estimated from resistance) computes from the same observation::

    c    <- c + beta (a - c),  beta = 1 - exp(-control period / filter_s)   (c = 0 at a reset)
    duty = clip(base_duty + scale * c, duty range)

and the base duty is appended to what the agent observes. With ``a = 0`` the agent is the
base controller, so training starts from the baseline's performance and only has to learn
what the baseline cannot do (for instance: use the reference preview to heat before a step
and to start cooling before a reversal, which the hysteresis makes slow).

``filter_s = 0`` (the default, and every agent trained before the filter existed) applies
the correction as it comes (``c = a``). Why a filter: the wire integrates its power over
its thermal time constants (0.3 s heating to seconds cooling), so a correction that changes
faster than about 0.1 s does nothing useful, yet it costs accuracy. SAC's deterministic
policy left to itself moved the duty by about 0.1 from one 10 ms step to the next (the
inputs that change most from step to step are its own last duty and the resistance
reading's validity flag, which that duty switches); each jump heats or cools the wire by a
fraction of a kelvin, and the narrow hysterons turn that into position. On the report's
0.1 Hz sine, ``filter_s = 0.1`` took the step-to-step change from 0.12 to 0.02 and the RMS
error from 0.043 to 0.025 mm (seed 0, 200 000 steps, with the fine error features of
:mod:`sma_gym_agents.history`); without them, over five seeds, the RMS error went from 0.067
to 0.036 mm (interquartile means; docs/training.md "Results over seeds").

:class:`ResidualStep` holds the base controller for a batch and is used both by the
training wrapper (:class:`sma_gym_agents.training.envs.ResidualVecEnv`) and by
:class:`sma_gym_agents.trained.AgentPolicy` at evaluation, so both compose actions identically.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium import spaces

from sma_gym_agents.card import FILTER_S_EXPECTED, is_filter_time_constant
from sma_gym_agents.policies import ControllerPolicy, SelfSensingPolicy, env_attr


class ResidualStep:
    """Base controller for ``n`` envs and the action composition."""

    def __init__(self, env: Any, base: str, scale: float, filter_s: float = 0.0):
        # Without a position sensor the base controller is the self-sensing variant (position
        # from resistance through a calibration fitted on the env's own model, §4.2).
        if "position" in tuple(env_attr(env, "feature_names")):
            self.policy = ControllerPolicy(base, env)
        else:
            self.policy = SelfSensingPolicy(base, env)
        self.scale = float(scale)
        self.filter_s = float(filter_s)
        if not is_filter_time_constant(self.filter_s):
            raise ValueError(f"residual filter_s = {filter_s!r}: expected {FILTER_S_EXPECTED}")
        dt = float(env_attr(env, "control_period_s"))
        self.beta = 1.0 - math.exp(-dt / self.filter_s) if self.filter_s > 0.0 else 1.0
        """Weight of the new correction in the filtered one (1: no filter)."""
        self.correction: np.ndarray | None = None
        """The filtered correction c of each env, in [-1, 1]."""
        self.duty_range = self.policy.duty_range
        self.lo, self.hi = self.duty_range
        self.k = self.policy.k
        self.base_duty: np.ndarray | None = None

    def observe(self, obs: np.ndarray, starts: np.ndarray) -> np.ndarray:
        """Run the base controller on ``obs`` (once per step) and append its duty."""
        raw = obs[:, : self.k]
        if self.correction is None or len(self.correction) != len(obs):
            self.correction = np.zeros(len(obs))
        self.correction[np.asarray(starts, dtype=bool).reshape(-1)] = 0.0
        action, _ = self.policy.predict(raw, episode_start=starts)
        self.base_duty = self.duty_range.duty_for(np.asarray(action, dtype=float).reshape(len(obs), -1)[:, 0])
        return np.concatenate([obs, self.base_duty[:, None]], axis=1).astype(np.float32)

    def action(self, agent_action: np.ndarray) -> np.ndarray:
        """Env actions for the agent's corrections (uses the last observed base duty)."""
        a = np.clip(np.asarray(agent_action, dtype=float).reshape(len(self.base_duty), -1)[:, 0], -1.0, 1.0)
        if self.beta >= 1.0:
            self.correction = a.copy()
        else:
            self.correction += self.beta * (a - self.correction)
        duty = np.clip(self.base_duty + self.scale * self.correction, self.lo, self.hi)
        return self.duty_range.action_for(duty).astype(np.float32)[:, None]

    @staticmethod
    def observation_space(base: spaces.Box) -> spaces.Box:
        return spaces.Box(
            np.append(base.low, 0.0).astype(np.float32), np.append(base.high, 1.0).astype(np.float32), dtype=np.float32
        )
