"""Trained agents: a stable-baselines3 model run on raw env observations as it trained.

:func:`save_policy` writes a model zip and its card (:class:`sma_gym_agents.card.PolicyCard`);
:func:`load_policy` reads both back into an :class:`AgentPolicy`, which rebuilds what the
model saw in training (residual base controller, history features) from the raw
observations the evaluation harness gives it.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import sma_gym  # noqa: F401  (registers the ids)
from sma_gym._io import atomic_path
from sma_gym_agents.card import BANK_ENV_ID, PolicyCard
from sma_gym_agents.history import HistoryFeatures
from sma_gym_agents.policies import episode_starts, require_finite_observation
from sma_gym_agents.residual import ResidualStep


@dataclass
class AgentPolicy:
    """A trained stable-baselines3 model plus what is needed to evaluate it like it trained.

    ``frame_stack`` is the number of stacked observations (SB3's ``VecFrameStack``) the
    model expects; ``predict`` stacks raw observations itself (and passes ones the
    evaluation harness stacked). Like the reference
    controllers, it keeps state between calls (the residual's base controller, the history
    features): pass ``episode_start`` or call :meth:`reset` after ``env.reset()``.
    """

    model: Any
    name: str
    env_id: str
    env_kwargs: dict
    frame_stack: int = 1
    history: str = "none"
    """``"ema"`` or ``"ema+error"``: the model expects :class:`sma_gym_agents.history.HistoryFeatures`
    appended; the policy computes them from the observations it is given, as training did."""
    residual: str | None = None
    """A controller label (e.g. ``"VSC3 + FF"``): the model is a residual on top of it
    (:mod:`sma_gym_agents.residual`); the policy runs that controller, as training did."""
    residual_scale: float = 0.5
    residual_filter_s: float = 0.0
    """Time constant of the low-pass the residual's correction passes [s] (0: none)."""
    residual_allocation: str = "proportional"
    """A bank agent's base on a shared budget (:data:`sma_gym_agents.card.ALLOCATIONS`)."""

    def __post_init__(self) -> None:
        self._features: HistoryFeatures | None = None
        self._residual: ResidualStep | None = None
        self._stacked: np.ndarray | None = None

    def predict(self, observation, state=None, episode_start=None, deterministic=True):
        if self.env_id == BANK_ENV_ID:
            raise ValueError(
                f"{self.name}: a bank model (trained on {BANK_ENV_ID}) sees one actuator's row at a time: "
                "run it on a bank's observations as sma_gym_agents.bank.BankAgent.from_policy(agent, env)"
            )
        obs = np.asarray(observation, dtype=float)
        require_finite_observation(obs, self._feature_names)  # a network maps NaN to a NaN action without a word
        single = obs.ndim == 1
        batch = obs[None, :] if single else obs
        if episode_start is not None:
            starts = episode_starts(episode_start, len(batch))
        else:  # no flags: the first call starts an episode, later calls continue it
            starts = np.full(len(batch), self._features is None and self._residual is None and self._stacked is None)
        if self.residual is not None:
            if self._residual is None:
                self._residual = self._make_residual()
            batch = self._residual.observe(batch, starts)
        if self.history != "none":
            batch = self._with_history(batch, starts)
        if self.frame_stack > 1:
            batch = self._with_stack(batch, starts)
        action, state = self.model.predict(batch, state=state, episode_start=episode_start, deterministic=deterministic)
        if self._residual is not None:
            action = self._residual.action(action)
        return (action[0] if single else action), state

    def _feature_names(self) -> tuple[str, ...]:
        """The raw observation's features of the env the model trained on (built only to name
        a bad observation's feature)."""
        env = gym.make("sma_gym:" + self.env_id, **self.env_kwargs)
        try:
            return tuple(env.unwrapped.feature_names)
        finally:
            env.close()

    def _make_residual(self) -> ResidualStep:
        """The base controller, built on the env the model trained on (its constants)."""
        env = gym.make("sma_gym:" + self.env_id, **self.env_kwargs)
        try:
            return ResidualStep(env, self.residual, self.residual_scale, self.residual_filter_s)
        finally:
            env.close()

    def _with_history(self, batch: np.ndarray, starts: np.ndarray) -> np.ndarray:
        if self._features is None or self._features.n != batch.shape[0]:
            self._features = HistoryFeatures.for_env(batch.shape[0], self.env_id, self.env_kwargs, self.history)
            return self._features.reset(batch)
        out, _ = self._features.update(batch, starts)
        return out

    def _with_stack(self, batch: np.ndarray, starts: np.ndarray) -> np.ndarray:
        """Raw observations stacked as SB3's ``VecFrameStack`` stacked them in training (the
        oldest first, zeros before an episode's first); a batch already stacked (the
        evaluation harness stacks itself) passes as it is."""
        width = batch.shape[1]
        if width * self.frame_stack != int(np.prod(self.model.observation_space.shape)):
            return batch
        if self._stacked is None or self._stacked.shape[0] != batch.shape[0]:
            self._stacked = np.zeros((batch.shape[0], width * self.frame_stack))
            starts = np.ones(batch.shape[0], dtype=bool)
        self._stacked[:, :-width] = self._stacked[:, width:].copy()
        self._stacked[starts, :-width] = 0.0
        self._stacked[:, -width:] = batch
        return self._stacked.copy()

    def reset(self) -> None:
        """Forget the base controller's, the history features' and the stacked frames' state (a new episode)."""
        self._features = None
        self._residual = None
        self._stacked = None

    @classmethod
    def from_card(cls, model: Any, card: PolicyCard, name: str | None = None) -> AgentPolicy:
        """``model`` run as ``card`` says it trained."""
        return cls(
            model=model,
            name=name or card.name,
            env_id=card.env_id,
            env_kwargs=dict(card.env_kwargs),
            frame_stack=card.frame_stack,
            history=card.history,
            residual=card.residual,
            residual_scale=card.residual_scale,
            residual_filter_s=card.residual_filter_s,
            residual_allocation=card.residual_allocation,
        )


def save_policy(model: Any, path: str | Path, card: PolicyCard | Mapping[str, Any]) -> Path:
    """Save ``model`` to ``path`` (a ``.zip``) and then its card, each atomically.

    The card records the SHA-256 of the zip it describes, so a card can never be read as
    describing another run's model (:meth:`PolicyCard.load` checks it). The zip is written
    first: an interrupt between the two leaves a zip whose card is missing or stale, which
    the reader refuses by name, never a card pointing at a model that does not exist.
    ``card`` may also be given as its JSON fields (checked the same way).
    """
    if not isinstance(card, PolicyCard):
        card = PolicyCard.from_dict(card)
    target = Path(path)
    if target.suffix == "":
        target = target.with_suffix(".zip")  # as SB3's save does; load_policy reads <name>.zip
    elif target.suffix != ".zip":
        # "agent.pt" wrote agent.pt, which load_policy refuses, and replaced agent.json, another model's card.
        raise ValueError(
            f"path = {str(path)!r}: expected a .zip (load_policy reads <name>.zip beside its card <name>.json)"
        )
    with atomic_path(target) as tmp:
        model.save(tmp)
    card.save(target)
    return target


def zip_path(path: str | os.PathLike) -> Path:
    """The .zip a policy path names, as stable-baselines3's ``save`` writes it: the path
    itself when it ends in .zip, else ``<path>.zip`` ("runs/x/best_model" names
    runs/x/best_model.zip, "m.v1" names m.v1.zip, not m.zip)."""
    p = Path(path)
    return p if p.suffix == ".zip" else p.with_name(p.name + ".zip")


def load_policy(path: str | Path, name: str | None = None) -> AgentPolicy:
    """Open a model saved by ``train.py`` (``<name>.zip`` with its card ``<name>.json``).

    The card is required and must describe this very zip (see :meth:`PolicyCard.load`).
    """
    if not isinstance(path, (str, os.PathLike)):
        raise ValueError(f"policy = {path!r}: expected the path of a stable-baselines3 .zip written by train.py")
    p = Path(path)
    if p.is_dir():
        raise ValueError(f"policy = {str(path)!r}: a folder; expected a stable-baselines3 .zip written by train.py")
    if p.suffix != ".zip":
        if p.is_file():
            raise ValueError(
                f"policy = {str(path)!r}: not a .zip; expected a stable-baselines3 .zip written by train.py "
                "(e.g. runs/<run>/best_model.zip)"
            )
        p = zip_path(p)
    if not p.is_file():
        raise ValueError(
            f"policy = {str(path)!r}: no such file (expected a stable-baselines3 .zip written by train.py)"
        )
    card = PolicyCard.load(p)
    import stable_baselines3  # after the card's checks: a bad card is refused without loading torch

    try:
        model = getattr(stable_baselines3, card.algo).load(str(p), device="cpu")
    except Exception as err:
        raise ValueError(f"policy = {str(path)!r}: not a {card.algo} model ({err})") from None
    policy = AgentPolicy.from_card(model, card, name or card.name or p.stem)
    if card.env_id != BANK_ENV_ID:
        _require_card_fits_model(policy, str(path))
    else:  # a bank model sees per-actuator rows (sma_gym_agents.bank)
        _require_bank_card_runs(policy, str(path))
    return policy


def _require_bank_card_runs(policy: AgentPolicy, path: str) -> None:
    """Run a bank agent's card once (its bank env with ``env_kwargs``, its residual base, one
    action on a reset observation): a card naming an unknown base controller or a bank the
    model cannot read is refused here, not in chapter 9 after the other chapters ran."""
    from sma_gym_agents.bank import BankAgent

    described = f"env {policy.env_id} with env_kwargs {policy.env_kwargs}, residual {policy.residual!r}"
    try:
        env = gym.make("sma_gym:" + BANK_ENV_ID, **policy.env_kwargs)
        try:
            obs, _ = env.reset(seed=0)
            BankAgent.from_policy(policy, env).predict(obs)
        finally:
            env.close()
    except (TypeError, ValueError) as err:
        raise ValueError(f"policy = {path!r}: its card ({described}) cannot be run: {err}") from None


def _require_card_fits_model(policy: AgentPolicy, path: str) -> None:
    """Build what the card says the model saw (its env with ``env_kwargs``, the residual
    base, history features, frame stack) on one reset observation, and compare its width
    with the model's observation space: a card that does not describe the model is refused
    here, not at the first ``predict`` after minutes of baselines."""
    described = (
        f"env {policy.env_id} with env_kwargs {policy.env_kwargs}, frame_stack {policy.frame_stack}, "
        f"history {policy.history!r}, residual {policy.residual!r}"
    )
    try:
        env = gym.make("sma_gym:" + policy.env_id, **policy.env_kwargs)
        try:
            obs, _ = env.reset(seed=0)
        finally:
            env.close()
        batch = np.asarray(obs, dtype=float)[None, :]
        if policy.frame_stack > 1:
            width = batch.shape[1] * policy.frame_stack
        else:
            starts = np.ones(1, dtype=bool)
            if policy.residual is not None:
                batch = policy._make_residual().observe(batch, starts)
            if policy.history != "none":
                batch = HistoryFeatures.for_env(1, policy.env_id, policy.env_kwargs, policy.history).reset(batch)
            width = batch.shape[1]
    except (TypeError, ValueError) as err:
        raise ValueError(f"policy = {path!r}: its card ({described}) cannot be run: {err}") from None
    shape = tuple(getattr(policy.model.observation_space, "shape", ()) or ())
    if shape != (width,):
        raise ValueError(
            f"policy = {path!r}: the model takes observations of shape {shape}, but its card ({described}) gives "
            f"({width},): the card does not describe this model"
        )
