"""Baselines for a multiplexed bank (``SMAMultiplexed-v0``), with stable-baselines3's ``predict``.

>>> import gymnasium as gym
>>> from stable_baselines3.common.evaluation import evaluate_policy
>>> from sma_gym_agents.bank import BudgetAllocator
>>> from stable_baselines3.common.monitor import Monitor
>>> env = Monitor(gym.make("sma_gym:SMAMultiplexed-v0", n_actuators=16, scheme="shared_budget", control_period_s=1e-3))
>>> policy = BudgetAllocator("PID", env)
>>> mean_reward, _ = evaluate_policy(policy, env, n_eval_episodes=1)   # doctest: +SKIP

Three policies, each one of the report's controllers (:mod:`sma_gym_agents.controllers`) per
actuator, each on what a real controller of that actuator reads (its measured position, its
reference and rate):

* :class:`FixedSlotBank` (``scheme="fixed_slots"``, Table 9.1's scheme): each controller's
  duty capped at the slot's 1/n.
* :class:`BudgetAllocator` (``scheme="shared_budget"``): each controller asks a duty in
  [0, 1]; **each gets what it asks, and if the asks of one bank sum past the cycle (1),
  every ask is multiplied by 1 / sum** (proportional scaling,
  :func:`sma_gym.electrical.multiplexer.scale_to_budget`, the env's own rule, so the env
  applies exactly the duties the allocator grants).
* :class:`PriorityAllocator` (``scheme="shared_budget"``, ``allocation="priority"``): the
  same asks, but a cycle they overrun goes to one actuator at a time: the *lead* first, up
  to its ask, then the others by tracking error, largest first, until the cycle is used
  (:class:`PriorityAllocator` states the rule and why).

Batches of banks (vector envs) work as in :class:`~sma_gym_agents.policies.ControllerPolicy`;
the budget is shared within each bank, never across banks.

Agents that scale with n (one policy for any bank of 1 to 16): parameter sharing.
:class:`BankView` turns a bank's observation into one row per actuator: that actuator's own
features plus :data:`CONTEXT_FEATURES`, a few bank-level numbers that do not grow with n.
:class:`sma_gym_agents.training.envs.BankVecEnv` makes every actuator of every bank one
sub-env of a stable-baselines3 VecEnv (its own reward, the tracking term of its actuator),
so one SAC policy learns to act for each actuator; :class:`BankAgent` runs such a model on a bank of any size. With a
residual base (:class:`BankResidual`) the model corrects the bank baseline's action for
its actuator instead of choosing the whole duty, as the single-wire agents correct theirs
(:mod:`sma_gym_agents.residual`). Training:
``python train.py --env SMAMultiplexed-v0`` (the hyperparameter file's ``vec_env_wrapper``,
:class:`sma_gym_agents.training.envs.BankVecEnv`: every actuator of every bank one sub-env
of a stable-baselines3 VecEnv, its reward that actuator's own tracking term).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from gymnasium import spaces

from sma_gym.electrical.multiplexer import scale_to_budget
from sma_gym.envs import task
from sma_gym_agents.card import ALLOCATIONS
from sma_gym_agents.controllers import ControllerSpec
from sma_gym_agents.policies import ControllerPolicy, env_attr, episode_starts, require_finite_observation


def _require_scheme(env: Any, scheme: str, policy: str) -> None:
    try:
        actual = env_attr(env, "scheme")
    except ValueError:  # not an sma-gym env, or one without a bank
        actual = None
    if actual is None:
        raise ValueError(f"{policy}: the env has no multiplexed bank (scheme): expected SMAMultiplexed-v0")
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
        _require_scheme(env, "shared_budget", type(self).__name__)
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


class PriorityAllocator(BudgetAllocator):
    """The report's controller ``spec`` per actuator on a shared budget, the cycle granted by priority.

    Each controller asks a duty in [0, 1] as under :class:`BudgetAllocator`. When the asks
    of a bank fit the cycle (sum at most 1), each gets what it asks. When they do not, the
    cycle goes to the actuators one after another, each up to its ask, until it is used up
    (the last one served gets what is left, the rest nothing), in this order:

    1. the *lead*: the actuator served first in the previous step, as long as its controller
       still asks the whole cycle (it has not yet come near its reference) and for at most
       ``lead_limit_s`` in a row;
    2. the others by measured tracking error r - x, largest first.

    When the lead asks less than the whole cycle (or at an episode start), the actuator with
    the largest error among those asking becomes the lead. A lead that reaches the limit is
    *benched* for as long: it cannot lead and is served after every other actuator, so that
    one wire that cannot reach its reference (a weak supply, a broken wire) takes at most
    ``lead_limit_s`` at a time from the others, and then leaves them as long. (Until
    2026-12-07 it was passed over once: still the largest error, it was served second and
    led again the step after, so it kept 0.998 of an overrun cycle and three holders of 0.3
    each got something in 4 of 500 steps.) At 10 V a wire crosses its stroke at full duty in about
    0.2-0.6 s, so the default limit of 1 s does not cut a reachable rise short there (at
    lower supplies it may: the lead then alternates, it is not lost).

    Why: a wire moves only once it has reached its transformation temperature, and every
    watt it gets before that is partly lost to the air. Proportional scaling splits an
    overrun cycle among all that ask, so sixteen actuators asking at once each get a 1/16
    slot, the fixed-slot bank's, and all heat slowly together; serving one to its reference
    at a time moves each in turn. Measured with VSC3 + FF on sixteen independent references
    (the evaluation's bank tracking, 10 V, worst of three seeds): 4.67 mm RMS proportional,
    2.91 mm by this rule (2026-12-06; on an earlier model 4.78, 3.40 by error alone without
    a lead, and 2.94 mm; docs/baselines.md). The holders
    pay: while the lead takes the cycle, an actuator further down the order cools.
    """

    def __init__(
        self,
        spec: ControllerSpec | str,
        env: Any,
        filter_cutoff_hz: float | None = None,
        lead_limit_s: float = 1.0,
    ):
        super().__init__(spec, env, filter_cutoff_hz)
        number = isinstance(lead_limit_s, (int, float, np.integer, np.floating)) and not isinstance(lead_limit_s, bool)
        if not (number and math.isfinite(lead_limit_s) and lead_limit_s >= self.dt):
            raise ValueError(
                f"lead_limit_s = {lead_limit_s!r}: expected finite seconds >= the control period {self.dt}"
            )
        self.name = f"{self.spec.label} (priority allocator)"
        self.lead_limit_steps = max(1, int(round(float(lead_limit_s) / self.dt)))
        self._lead: np.ndarray | None = None
        self._held = np.zeros(0, dtype=int)
        self._benched = np.zeros((0, 0), dtype=int)  # steps each actuator still waits at the back

    def reset(self) -> None:
        super().reset()
        self._lead = None

    def predict(
        self, observation: np.ndarray, state: Any = None, episode_start: Any = None, deterministic: bool = True
    ):
        obs = np.asarray(observation, dtype=float)
        single = obs.ndim == 1
        ask = np.atleast_2d(self.asked_duty(obs, episode_start))
        granted = self.grant(ask, self.tracking_error_m(obs, ask.shape), episode_start)
        action = self.duty_range.action_for(granted).astype(np.float32)
        return (action[0] if single else action), None

    def tracking_error_m(self, observation: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
        """Each actuator's measured tracking error r - x [m], shape ``shape`` = (batch, n)."""
        n_batch, n = shape
        features = np.asarray(observation, dtype=float).reshape(n_batch, n, self.k)
        scale = self._scale(self.position_scale_m, n_batch, n)
        error_m = features[..., self._index["reference"]] * scale - self.position_m(features, scale)
        return np.broadcast_to(error_m, shape)

    def grant(self, ask: np.ndarray, error_m: np.ndarray, episode_start: Any = None) -> np.ndarray:
        """The duties granted for asks (batch, n) in [0, 1] by the rule above; moves the lead
        (call once per step; ``episode_start`` per bank forgets its lead)."""
        ask = np.asarray(ask, dtype=float)
        n_batch = ask.shape[0]
        if self._lead is None or self._lead.shape != (n_batch,) or self._benched.shape != ask.shape:
            self._lead, self._held = np.full(n_batch, -1), np.zeros(n_batch, dtype=int)
            self._benched = np.zeros(ask.shape, dtype=int)
        if episode_start is not None:
            starting = episode_starts(episode_start, n_batch, broadcast=True)
            self._lead[starting] = -1
            self._benched[starting] = 0
        banks = np.arange(n_batch)
        lead = self._lead
        # The lead keeps its place while it asks the whole cycle, up to the limit; a lead that
        # reaches it is benched as long. Else the largest error asking anything and not benched
        # (a benched one only if no other asks).
        full = (lead >= 0) & (ask[banks, np.maximum(lead, 0)] >= 1.0 - 1e-6)
        keep = full & (self._held < self.lead_limit_steps)
        self._benched = np.maximum(self._benched - 1, 0)
        self._benched[banks[full & ~keep], lead[full & ~keep]] = self.lead_limit_steps
        asking = ask > 0.0
        benched = (self._benched > 0) & (asking & (self._benched == 0)).any(axis=1, keepdims=True)
        candidate = np.argmax(np.where(asking & ~benched, error_m, -np.inf), axis=1)
        new = np.where(keep, lead, np.where(asking.any(axis=1), candidate, -1))
        self._held = np.where(keep, self._held + 1, (new >= 0).astype(int))
        self._lead = lead = new
        key = np.array(error_m, dtype=float)
        key[benched] = -np.inf  # served after every other
        key[banks[lead >= 0], lead[lead >= 0]] = np.inf
        order = np.argsort(-key, axis=1, kind="stable")
        asked = np.take_along_axis(ask, order, axis=1)
        before = np.cumsum(asked, axis=1) - asked
        granted = np.empty_like(ask)
        np.put_along_axis(granted, order, np.clip(1.0 - before, 0.0, asked), axis=1)
        return np.where(ask.sum(axis=1, keepdims=True) <= 1.0, ask, granted)


def bank_policy(spec: ControllerSpec | str, env: Any, allocation: str = "proportional") -> ControllerPolicy:
    """The bank baseline for the env's scheme: :class:`FixedSlotBank` on fixed slots; on a
    shared budget :class:`BudgetAllocator` (``allocation="proportional"``) or
    :class:`PriorityAllocator` (``"priority"``). Fixed slots have nothing to allocate, so
    ``allocation`` is checked but changes nothing there."""
    if allocation not in ALLOCATIONS:
        raise ValueError(f"allocation = {allocation!r}: expected one of {ALLOCATIONS}")
    if env_attr(env, "scheme") == "shared_budget":
        return PriorityAllocator(spec, env) if allocation == "priority" else BudgetAllocator(spec, env)
    return FixedSlotBank(spec, env)


# --------------------------------------------------------------------------------------
# Agents that scale with n: one policy per actuator, shared by all
# --------------------------------------------------------------------------------------
MAX_ACTUATORS = 16
"""The multiplexed env's largest bank (its ``n_actuators`` range)."""
BANK_FEATURES = task.FEATURES[task.OBS_POSITION]
"""Each actuator's own features in a bank's observation (the multiplexed env's)."""
CONTEXT_FEATURES = ("bank_size", "duty_cap", "others_duty", "shared_budget")
"""Bank-level features appended to each actuator's own: n / 16; the largest duty one actuator
may get (1/n on fixed slots, 1 on a shared budget); the duty the other actuators were
applied in the last step, summed (fraction of the cycle: what they took of the budget);
1 on a shared budget, 0 on fixed slots. None grows with n."""
_CONTEXT_LOW = np.zeros(len(CONTEXT_FEATURES), dtype=np.float32)
_CONTEXT_HIGH = np.array([1.0, 1.0, float(MAX_ACTUATORS), 1.0], dtype=np.float32)


class BankView:
    """A bank's observation as one row per actuator: own features, then :data:`CONTEXT_FEATURES`."""

    def __init__(self, scheme: str):
        if scheme not in ("fixed_slots", "shared_budget"):
            raise ValueError(f"scheme = {scheme!r}: expected 'fixed_slots' or 'shared_budget'")
        self.scheme = scheme
        self.k = len(BANK_FEATURES)
        self._duty = BANK_FEATURES.index("last_duty")

    @staticmethod
    def observation_space(residual: bool = False) -> spaces.Box:
        """The per-actuator observation space (the same for every n); with ``residual``, one
        more feature last: the share of the actuator's duty range the base grants it (0: off,
        1: the whole slot, or the whole cycle on a shared budget; :class:`BankResidual`)."""
        low, high = task.bounds(task.OBS_POSITION)
        extra = 1 if residual else 0
        return spaces.Box(
            np.concatenate([low, _CONTEXT_LOW, np.zeros(extra)]).astype(np.float32),
            np.concatenate([high, _CONTEXT_HIGH, np.ones(extra)]).astype(np.float32),
            dtype=np.float32,
        )

    def n_of(self, observation: np.ndarray) -> int:
        """The bank size of an observation (its width / the features per actuator)."""
        width = np.shape(observation)[-1]
        if width % self.k or not 1 <= width // self.k <= MAX_ACTUATORS:
            raise ValueError(
                f"bank observation of width {width}: expected n * {self.k} features for n in 1..{MAX_ACTUATORS}"
            )
        return width // self.k

    def rows(self, observation: np.ndarray, base_share: np.ndarray | None = None) -> np.ndarray:
        """(batch * n, k + 4) float32 rows, actuator-major within each bank, for (batch, n * k)
        or (n * k,); with ``base_share`` ((batch, n), :class:`BankResidual`'s) k + 5, that share last."""
        obs = np.asarray(observation, dtype=np.float32)
        n = self.n_of(obs)
        own = obs.reshape(-1, n, self.k)
        duty = own[:, :, self._duty]
        extra = 0 if base_share is None else 1
        context = np.empty(own.shape[:2] + (len(CONTEXT_FEATURES) + extra,), dtype=np.float32)
        shared = self.scheme == "shared_budget"
        context[:, :, 0] = n / MAX_ACTUATORS
        context[:, :, 1] = 1.0 if shared else 1.0 / n
        context[:, :, 2] = duty.sum(axis=1, keepdims=True) - duty
        context[:, :, 3] = 1.0 if shared else 0.0
        if base_share is not None:
            context[:, :, 4] = np.asarray(base_share, dtype=np.float32).reshape(own.shape[:2])
        return np.concatenate([own, context], axis=2).reshape(-1, self.k + context.shape[2])


class BankResidual:
    """A bank baseline whose action each actuator's model corrects (a residual bank agent).

    The base is :func:`bank_policy` (the report's controller ``base`` per actuator on fixed
    slots; on a shared budget under the budget allocator, or the priority allocator with
    ``allocation="priority"``). Corrections are in shares of
    each actuator's duty range, so that one model means the same on a bank of any n::

        share = clip(base_share + scale * a, 0, 1),   a in [-1, 1]

    where a share of 1 is the whole slot (1/n) on fixed slots and the whole cycle on a
    shared budget (the env then scales a bank whose shares sum past 1, as it does any
    action). Under the priority allocator the correction applies to each controller's
    *ask*, and the allocator then grants the corrected asks (``base_share`` is the ask), so
    the allocator keeps deciding who is served. Each actuator's model is trained on its own
    tracking reward; corrections added after the allocation can take more of the cycle for
    their own actuator, and the env's proportional scaling of an overrun then undoes the
    priority: two seeds trained that way scored 3.19 and 2.67 mm against the allocator's
    2.94 mm, five trained on the ask 2.74-2.75 mm (docs/training.md). With ``a = 0`` the agent is the baseline: on a 1/16 slot, where the baseline
    heats at the cap and a wire takes seconds to answer, training starts from there instead
    of from half a slot (docs/training.md). Used by the training wrapper
    (:class:`sma_gym_agents.training.envs.BankVecEnv`) and by :class:`BankAgent`, so both
    compose actions identically.
    """

    def __init__(self, env: Any, base: ControllerSpec | str, scale: float, allocation: str = "proportional"):
        if not 0.0 < float(scale) <= 1.0:
            raise ValueError(f"scale = {scale}: expected a share of the actuator's duty range in (0, 1]")
        self.policy = bank_policy(base, env, allocation)
        self.allocation = allocation
        self.scale = float(scale)
        self.base_share: np.ndarray | None = None
        self._error_m: np.ndarray | None = None
        self._starts: Any = None

    def reset(self) -> None:
        """Forget the base controllers' states (a new episode for every bank)."""
        self.policy.reset()
        self.base_share = None

    def observe(self, observation: np.ndarray, episode_start: Any = None) -> np.ndarray:
        """Run the base policy on (batch, n * k) bank observations (once per step); returns
        and keeps each actuator's base share, shape (batch, n)."""
        obs = np.asarray(observation, dtype=float)
        if isinstance(self.policy, PriorityAllocator):
            ask = np.atleast_2d(self.policy.asked_duty(obs, episode_start))
            self._error_m, self._starts = self.policy.tracking_error_m(obs, ask.shape), episode_start
            self.base_share = ask
            return ask
        action, _ = self.policy.predict(obs, episode_start=episode_start)
        self.base_share = (np.asarray(action, dtype=float) + 1.0) / 2.0
        return self.base_share

    def action(self, agent_action: np.ndarray) -> np.ndarray:
        """Env actions (batch, n) for the model's corrections (batch, n), on the last observed base."""
        if self.base_share is None:
            raise RuntimeError("BankResidual.action before observe: the base policy has not seen the bank")
        a = np.clip(np.asarray(agent_action, dtype=float).reshape(self.base_share.shape), -1.0, 1.0)
        share = np.clip(self.base_share + self.scale * a, 0.0, 1.0)
        if isinstance(self.policy, PriorityAllocator):
            share = self.policy.grant(share, self._error_m, self._starts)
        return (2.0 * share - 1.0).astype(np.float32)


class BankAgent:
    """A per-actuator model (trained on :class:`BankVecEnv`) acting for a whole bank of any n.

    ``predict`` takes a bank's observation (n * 10,) or a batch (batch, n * 10) and returns
    the bank's action (n,) or (batch, n), every actuator's entry from the same model.
    ``residual``: the :class:`BankResidual` the model trained on (its base and scale), or
    None for a model that chooses the whole action.
    """

    def __init__(self, model: Any, scheme: str, name: str = "bank agent", residual: BankResidual | None = None):
        self.model = model
        self.view = BankView(scheme)
        self.name = name
        self.residual = residual

    @classmethod
    def from_policy(cls, agent: Any, env: Any) -> BankAgent:
        """The bank agent that ``agent`` (:func:`sma_gym_agents.trained.load_policy` of a model
        ``train.py`` wrote for ``SMAMultiplexed-v0``) is, acting on ``env``'s banks, with the
        residual base it trained on."""
        scheme = str(agent.env_kwargs.get("scheme", "fixed_slots"))
        env_scheme = str(env_attr(env, "scheme"))
        if env_scheme != scheme:
            # The model would read its duty cap by one scheme while the base and the env ran the other.
            raise ValueError(
                f"{agent.name}: trained on scheme {scheme!r}, but the env runs {env_scheme!r}: expected a bank env "
                f"made with scheme={scheme!r}"
            )
        residual = (
            None
            if agent.residual is None
            else BankResidual(env, agent.residual, agent.residual_scale, agent.residual_allocation)
        )
        return cls(agent.model, scheme, agent.name, residual)

    def reset(self) -> None:
        """A new episode: the model is memoryless; a residual base forgets its controllers' states."""
        if self.residual is not None:
            self.residual.reset()

    def predict(self, observation: Any, state: Any = None, episode_start: Any = None, deterministic: bool = True):
        obs = np.asarray(observation, dtype=np.float32)
        # A network maps NaN to torch's distribution error, which names no feature.
        require_finite_observation(obs, BANK_FEATURES)
        single = obs.ndim == 1
        n = self.view.n_of(obs)
        batch = obs.reshape(-1, obs.shape[-1])
        base = None if self.residual is None else self.residual.observe(batch, episode_start)
        action, _ = self.model.predict(self.view.rows(batch, base), deterministic=deterministic)
        action = np.asarray(action, dtype=np.float32).reshape(-1, n)
        if self.residual is not None:
            action = self.residual.action(action)
        return (action[0] if single else action), None
