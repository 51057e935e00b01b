"""Baselines for a multiplexed bank (``SMAMultiplexed-v0``), with stable-baselines3's ``predict``.

>>> import gymnasium as gym
>>> from stable_baselines3.common.evaluation import evaluate_policy
>>> from sma_gym_agents.bank import BudgetAllocator
>>> env = gym.make("sma_gym:SMAMultiplexed-v0", n_actuators=16, scheme="shared_budget", control_period_s=1e-3)
>>> policy = BudgetAllocator("PID", env)
>>> mean_reward, _ = evaluate_policy(policy, env, n_eval_episodes=1)   # doctest: +SKIP

Two policies, both one of the report's controllers (:mod:`sma_gym_agents.controllers`) per
actuator, each on what a real controller of that actuator reads (its measured position, its
reference and rate):

* :class:`FixedSlotBank` (``scheme="fixed_slots"``, Table 9.1's scheme): each controller's
  duty capped at the slot's 1/n.
* :class:`BudgetAllocator` (``scheme="shared_budget"``): each controller asks a duty in
  [0, 1]; **each gets what it asks, and if the asks of one bank sum past the cycle (1),
  every ask is multiplied by 1 / sum** (proportional scaling,
  :func:`sma_gym.electrical.multiplexer.scale_to_budget`, the env's own rule, so the env
  applies exactly the duties the allocator grants).

Batches of banks (vector envs) work as in :class:`~sma_gym_agents.policies.ControllerPolicy`;
the budget is shared within each bank, never across banks.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sma_gym.electrical.multiplexer import scale_to_budget
from sma_gym_agents.controllers import ControllerSpec
from sma_gym_agents.policies import ControllerPolicy, env_attr


def _require_scheme(env: Any, scheme: str, policy: str) -> None:
    actual = env_attr(env, "scheme")
    if actual != scheme:
        raise ValueError(f"{policy}: env scheme = {actual!r}: expected {scheme!r} (SMAMultiplexed-v0's `scheme`)")


class FixedSlotBank(ControllerPolicy):
    """The report's controller ``spec`` per actuator on fixed 1/n slots (Table 9.1's scheme)."""

    def __init__(self, spec: ControllerSpec | str, env: Any, filter_cutoff_hz: float | None = None):
        super().__init__(spec, env, filter_cutoff_hz)
        _require_scheme(env, "fixed_slots", "FixedSlotBank")
        self.name = f"{self.spec.label} (fixed slots)"


class BudgetAllocator(ControllerPolicy):
    """The report's controller ``spec`` per actuator, sharing one duty budget (see the module docstring)."""

    def __init__(self, spec: ControllerSpec | str, env: Any, filter_cutoff_hz: float | None = None):
        super().__init__(spec, env, filter_cutoff_hz)
        _require_scheme(env, "shared_budget", "BudgetAllocator")
        self.name = f"{self.spec.label} (budget allocator)"

    def asked_duty(self, observation: np.ndarray, episode_start: Any = None) -> np.ndarray:
        """Each controller's ask in [0, 1], shape (batch, n) (or (n,) for one observation)."""
        action, _ = super().predict(observation, episode_start=episode_start)
        return self.duty_range.duty_for(np.asarray(action, dtype=float))

    def predict(
        self, observation: np.ndarray, state: Any = None, episode_start: Any = None, deterministic: bool = True
    ):
        granted = scale_to_budget(self.asked_duty(observation, episode_start))
        return self.duty_range.action_for(granted).astype(np.float32), None


def bank_policy(spec: ControllerSpec | str, env: Any) -> ControllerPolicy:
    """The bank baseline for the env's scheme: :class:`FixedSlotBank` or :class:`BudgetAllocator`."""
    if env_attr(env, "scheme") == "shared_budget":
        return BudgetAllocator(spec, env)
    return FixedSlotBank(spec, env)
