"""History features for agents: what the hysteresis hides from a single observation.

A single observation does not tell how far the wire has heated into or cooled out of its
15 K hysteresis: the position does not move there. The wire's temperature is, to first
order, a low-pass filter of the electrical power, with time constants from a fraction of
a second (heating) to seconds (cooling). So the history an agent needs is the applied duty
(and the position) filtered at those time constants, not the last few frames (40 ms at
the default control period). :class:`HistoryFeatures` appends exponential moving averages
of the ``last_duty`` feature at 0.3, 1 and 3 s, of the measured position (or resistance,
without a position sensor) at 1 s, and the change of that signal since the last step.

The same class serves training (:class:`sma_gym_agents.training.envs.HistoryVecEnv`, a
stable-baselines3 VecEnv wrapper) and evaluation (:class:`sma_gym_agents.trained.AgentPolicy` keeps
one internally), so the agent sees identical features in both.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from gymnasium import spaces

DUTY_TIME_CONSTANTS_S = (0.3, 1.0, 3.0)
SIGNAL_TIME_CONSTANT_S = 1.0


class HistoryFeatures:
    """Stateful feature augmenter for a batch of ``n`` observations."""

    def __init__(self, n: int, feature_names: Sequence[str], dt: float):
        names = list(feature_names)
        self.n = n
        self.base_dim = len(names)
        self.i_duty = names.index("last_duty")
        self.i_signal = names.index("position") if "position" in names else names.index("resistance")
        self.alphas = np.array([1.0 - math.exp(-dt / tau) for tau in DUTY_TIME_CONSTANTS_S])
        self.alpha_signal = 1.0 - math.exp(-dt / SIGNAL_TIME_CONSTANT_S)
        self.ema = np.zeros((n, len(DUTY_TIME_CONSTANTS_S)))
        self.signal_ema = np.zeros(n)
        self.last_signal = np.zeros(n)
        self.extra = len(DUTY_TIME_CONSTANTS_S) + 2

    @classmethod
    def for_env(cls, n: int, env_id: str, env_kwargs: dict) -> HistoryFeatures:
        """Features for ``n`` copies of the registered env ``env_id`` made with ``env_kwargs``
        (its feature names and control period)."""
        import gymnasium as gym

        import sma_gym  # noqa: F401

        env = gym.make("sma_gym:" + env_id, **{k: v for k, v in env_kwargs.items() if k != "max_episode_steps"})
        try:
            return cls(n, env.unwrapped.feature_names, env.unwrapped.control_period_s)
        finally:
            env.close()

    def observation_space(self, base: spaces.Box) -> spaces.Box:
        low = np.concatenate([base.low, np.zeros(len(DUTY_TIME_CONSTANTS_S)), [base.low[self.i_signal], -1.0]])
        high = np.concatenate([base.high, np.ones(len(DUTY_TIME_CONSTANTS_S)), [base.high[self.i_signal], 1.0]])
        return spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)

    def reset(self, obs: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
        m = np.ones(self.n, dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
        self.ema[m] = obs[m, self.i_duty][:, None]
        self.signal_ema[m] = obs[m, self.i_signal]
        self.last_signal[m] = obs[m, self.i_signal]
        return self._augment(obs, np.where(m, 0.0, obs[:, self.i_signal] - self.last_signal))

    def update(
        self, obs: np.ndarray, dones: np.ndarray, terminal: dict[int, np.ndarray] | None = None
    ) -> tuple[np.ndarray, dict[int, np.ndarray]]:
        """Features after a step, and the terminal observations of ended episodes with
        theirs. With same-step resets ``obs`` already holds the next episode's first
        observation where ``dones``; ``terminal`` holds the last one of the ended episode."""
        terminal = terminal or {}
        current = obs.copy()
        for i, last in terminal.items():
            current[i] = last
        self.ema += self.alphas[None, :] * (current[:, self.i_duty][:, None] - self.ema)
        signal = current[:, self.i_signal]
        self.signal_ema += self.alpha_signal * (signal - self.signal_ema)
        change = signal - self.last_signal
        self.last_signal = signal.copy()
        out = self._augment(current, change)
        ended = {i: out[i].copy() for i in terminal}
        if np.any(dones):
            out[dones] = self.reset(obs, dones)[dones]
        return out, ended

    def _augment(self, obs: np.ndarray, change: np.ndarray) -> np.ndarray:
        extra = np.concatenate([self.ema, self.signal_ema[:, None], np.clip(10.0 * change, -1.0, 1.0)[:, None]], axis=1)
        return np.concatenate([obs, extra], axis=1).astype(np.float32)
