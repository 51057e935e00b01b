"""History features for agents: what the hysteresis hides from a single observation.

A single observation does not tell how far the wire has heated into or cooled out of its
15 K hysteresis: the position does not move there. The wire's temperature is, to first
order, a low-pass filter of the electrical power, with time constants from a fraction of
a second (heating) to seconds (cooling). So the history an agent needs is the applied duty
(and the position) filtered at those time constants, not the last few frames (40 ms at
the default control period). :class:`HistoryFeatures` appends exponential moving averages
of the ``last_duty`` feature at 0.3, 1 and 3 s, of the measured position (or resistance,
without a position sensor) at 1 s, and the change of that signal since the last step.

History ``"ema+error"`` (:data:`HISTORIES`) appends two more, for envs with a position sensor:
the tracking error (the env's ``error`` feature, a fraction of the stroke) and its 1 s moving
average, each as ``tanh(e / ERROR_SCALE)``. The env's own feature spans the whole stroke, so
the errors that separate the controllers on the report's sine (0.02-0.08 mm, 0.002-0.008
of the stroke) are a few thousandths next to features of order one, which a network with
the usual initialisation barely resolves; the average gives the agent the integral action
that removes a PID's steady lag. Measured (seed 0, 200 000 steps, docs/training.md): the
agent's mean error on the sine fell from +0.064 to -0.013 mm and its RMS error from 0.076
to 0.043 mm.

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
ERROR_SCALE = 0.005
"""Tracking error (a fraction of the stroke) at which the fine error feature is tanh(1):
about 0.05 mm on the 9.5 mm stroke, the size of the sine errors that separate controllers."""
ERROR_TIME_CONSTANT_S = 1.0
HISTORIES = ("none", "ema", "ema+error")
"""History features an agent may see: none, the EMAs, the EMAs and the fine error features."""


class HistoryFeatures:
    """Stateful feature augmenter for a batch of ``n`` observations."""

    def __init__(self, n: int, feature_names: Sequence[str], dt: float, error_features: bool = False):
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
        self.i_error: int | None = None
        if error_features:
            if "error" not in names:
                raise ValueError(
                    f"history 'ema+error': the env's features {tuple(names)} have no 'error' (a position "
                    "sensor's tracking error); expected history 'ema' for an env without a position sensor"
                )
            self.i_error = names.index("error")
            self.extra += 2
        self.alpha_error = 1.0 - math.exp(-dt / ERROR_TIME_CONSTANT_S)
        self.error_ema = np.zeros(n)

    @classmethod
    def for_env(cls, n: int, env_id: str, env_kwargs: dict, history: str = "ema") -> HistoryFeatures:
        """Features ``history`` (:data:`HISTORIES`, not ``"none"``) for ``n`` copies of the
        registered env ``env_id`` made with ``env_kwargs`` (its feature names and control period)."""
        if history not in HISTORIES[1:]:
            raise ValueError(f"history = {history!r}: expected one of {HISTORIES[1:]}")
        import gymnasium as gym

        import sma_gym  # noqa: F401

        env = gym.make("sma_gym:" + env_id, **{k: v for k, v in env_kwargs.items() if k != "max_episode_steps"})
        try:
            return cls(
                n, env.unwrapped.feature_names, env.unwrapped.control_period_s, error_features=history == "ema+error"
            )
        finally:
            env.close()

    def observation_space(self, base: spaces.Box) -> spaces.Box:
        errors = 0 if self.i_error is None else 2
        low = np.concatenate(
            [base.low, np.zeros(len(DUTY_TIME_CONSTANTS_S)), [base.low[self.i_signal], -1.0], -np.ones(errors)]
        )
        high = np.concatenate(
            [base.high, np.ones(len(DUTY_TIME_CONSTANTS_S)), [base.high[self.i_signal], 1.0], np.ones(errors)]
        )
        return spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)

    def reset(self, obs: np.ndarray, mask: np.ndarray | None = None) -> np.ndarray:
        m = np.ones(self.n, dtype=bool) if mask is None else np.asarray(mask, dtype=bool)
        self.ema[m] = obs[m, self.i_duty][:, None]
        self.signal_ema[m] = obs[m, self.i_signal]
        self.last_signal[m] = obs[m, self.i_signal]
        if self.i_error is not None:
            self.error_ema[m] = obs[m, self.i_error]
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
        if self.i_error is not None:
            self.error_ema += self.alpha_error * (current[:, self.i_error] - self.error_ema)
        out = self._augment(current, change)
        ended = {i: out[i].copy() for i in terminal}
        if np.any(dones):
            out[dones] = self.reset(obs, dones)[dones]
        return out, ended

    def _augment(self, obs: np.ndarray, change: np.ndarray) -> np.ndarray:
        parts = [obs, self.ema, self.signal_ema[:, None], np.clip(10.0 * change, -1.0, 1.0)[:, None]]
        if self.i_error is not None:
            parts += [
                np.tanh(obs[:, self.i_error] / ERROR_SCALE)[:, None],
                np.tanh(self.error_ema / ERROR_SCALE)[:, None],
            ]
        return np.concatenate(parts, axis=1).astype(np.float32)
