"""The training loop: stable-baselines3 ``learn`` with validation, checkpoints and progress.

Every model written (checkpoints, the best on validation, the final one) is an ordinary
stable-baselines3 zip with its card (:class:`sma_gym_agents.card.PolicyCard`), each written
atomically with the SHA-256 of its zip (:func:`sma_gym_agents.trained.save_policy`).
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import (
    BaseCallback,
    CallbackList,
    CheckpointCallback,
    EvalCallback,
)

from sma_gym_agents.trained import save_policy
from sma_gym_agents.training.config import RunConfig
from sma_gym_agents.training.envs import (
    make_training_env,
    make_validation_env,
    validation_count,
    validation_references,
)

PROGRESS_EVERY_S = 60.0
"""Seconds between progress lines when there is no terminal for a bar."""


@dataclass(frozen=True)
class TrainingInfo:
    """What the training loop reports besides the models it wrote."""

    train_time_s: float
    validation_references: list[dict[str, Any]]
    timesteps: int = 0
    """Steps trained (PPO completes its last rollout: more than asked)."""


def progress_line(done: int, total: int, elapsed_s: float) -> str:
    """One progress report: steps done, rate and the time left at that rate."""
    rate = done / elapsed_s if elapsed_s > 0 else 0.0
    left = f"about {(total - done) / rate / 60:.1f} min left" if rate > 0 else "time left unknown"
    return f"train.py: {done}/{total} steps ({100 * done / total:.0f} %), {rate:.0f} steps/s, {left}"


class CardedCheckpoints(CheckpointCallback):
    """SB3's checkpoints, each zip written atomically with its card (hash of the zip)."""

    def __init__(self, run: RunConfig, save_freq: int, save_path: str) -> None:
        super().__init__(save_freq=save_freq, save_path=save_path, name_prefix=run.algo)
        self.run = run

    def _on_step(self) -> bool:
        if self.n_calls % self.save_freq == 0:
            path = Path(self._checkpoint_path(extension="zip"))
            save_policy(self.model, path, self.run.card(path.stem, timesteps=self.num_timesteps))
        return True


class SaveBest(BaseCallback):
    """Called by EvalCallback on a new best validation return: zip, then card."""

    def __init__(self, run: RunConfig, path: Path) -> None:
        super().__init__()
        self.run = run
        self.path = path

    def _on_step(self) -> bool:
        card = self.run.card(
            self.run.agent_name, timesteps=self.num_timesteps, validation_return=float(self.parent.best_mean_reward)
        )
        save_policy(self.model, self.path, card)
        return True


class AtomicEvalCallback(EvalCallback):
    """SB3's ``EvalCallback`` whose ``validation/evaluations.npz`` (the record of how
    best_model.zip was chosen) is written whole: SB3 rewrites it in place after every
    validation, so a stop while it wrote left it truncated. SB3 writes a file beside it,
    which is renamed over it."""

    def __init__(self, *args: Any, log_path: str, **kwargs: Any) -> None:
        folder = Path(log_path)
        super().__init__(*args, log_path=str(folder), **kwargs)
        self.log_path = str(folder / ".evaluations.tmp")  # np.savez adds ".npz"
        self._final = folder / "evaluations.npz"

    def _on_step(self) -> bool:
        before = len(self.evaluations_timesteps)
        go_on = super()._on_step()
        if len(self.evaluations_timesteps) > before:
            os.replace(self.log_path + ".npz", self._final)
        return go_on


class ProgressLines(BaseCallback):
    """Progress as plain lines (CI, nohup, cluster logs: a redrawn bar is unreadable there)."""

    def __init__(self, total_steps: int, every_s: float = PROGRESS_EVERY_S) -> None:
        super().__init__()
        self.total_steps = total_steps
        self.every_s = every_s
        self.start = self.last = time.perf_counter()

    def _on_step(self) -> bool:
        now = time.perf_counter()
        if now - self.last >= self.every_s:
            self.last = now
            print(progress_line(self.num_timesteps, self.total_steps, now - self.start), flush=True)
        return True


def make_model(run: RunConfig, venv: Any, out: Path) -> Any:
    """The stable-baselines3 model of ``run`` on ``venv``, logging to ``out/tb``."""
    from stable_baselines3 import PPO, SAC

    kwargs = dict(run.model_kwargs)
    policy = kwargs.pop("policy", "MlpPolicy")
    algo_cls = {"sac": SAC, "ppo": PPO}[run.algo]
    try:
        return algo_cls(
            policy, venv, seed=run.seed, device=run.device, tensorboard_log=str(out / "tb"), verbose=0, **kwargs
        )
    except (TypeError, ValueError, AssertionError) as err:
        # What only the algorithm, the policy or torch's optimiser can check (optimizer_kwargs,
        # a batch larger than PPO's rollout): refused as a bad option, before any training.
        raise ValueError(
            f"the hyperparameters of {run.algo.upper()} ({', '.join(sorted(run.model_kwargs))}): stable-baselines3 "
            f"refused one of them: {err}"
        ) from None


def train(run: RunConfig, out: Path, progress: bool = True) -> TrainingInfo:
    """Train ``run`` into ``out``: checkpoints, ``best_model`` (on validation), ``final_model``."""
    import torch

    # Deliberate thread count (see --threads): on a busy 2-core machine torch's default pool
    # made an SB3 run of this env 20x slower than one thread, for the same result.
    torch.set_num_threads(run.threads)
    torch.manual_seed(run.seed)
    venv = make_training_env(run)
    references = validation_references(run, validation_count(run))
    eval_env = make_validation_env(run, references)
    model = make_model(run, venv, out)
    per_env = max(1, run.eval_freq // venv.num_envs)
    best = out / "best_model.zip"
    evaluation = AtomicEvalCallback(
        eval_env,
        n_eval_episodes=eval_env.num_envs,
        eval_freq=per_env,
        # Saved by SaveBest (atomic, with its card) rather than by SB3 (a bare zip).
        callback_on_new_best=SaveBest(run, best),
        log_path=str(out / "validation"),
        deterministic=True,
        verbose=0,
    )
    bar = progress and sys.stdout.isatty()
    items: list[BaseCallback] = [
        evaluation,
        CardedCheckpoints(run, save_freq=per_env * 2, save_path=str(out / "checkpoints")),
    ]
    if progress and not bar:
        items.append(ProgressLines(run.timesteps))
    start = time.perf_counter()
    model.learn(total_timesteps=run.timesteps, callback=CallbackList(items), progress_bar=bar, tb_log_name=run.algo)
    train_s = time.perf_counter() - start
    # What it trained, not what was asked: PPO finishes its last rollout (32 envs x 64 steps).
    trained = int(model.num_timesteps)
    save_policy(model, out / "final_model.zip", run.card("final model", timesteps=trained, train_time_s=train_s))
    _finish_best(run, model, evaluation, best, train_s)
    venv.close()
    eval_env.close()
    return TrainingInfo(train_time_s=train_s, validation_references=references, timesteps=trained)


def _finish_best(run: RunConfig, model: Any, evaluation: AtomicEvalCallback, best: Path, train_s: float) -> None:
    """The best model's final card: the step it was chosen at and the training time."""
    best_at = int(model.num_timesteps)
    saved_best = best.exists()  # only SaveBest writes it: --out was empty or its earlier run set aside (--overwrite)
    if saved_best and evaluation.evaluations_timesteps:
        returns = [float(np.mean(r)) for r in evaluation.evaluations_results]
        best_at = int(evaluation.evaluations_timesteps[int(np.argmax(returns))])  # first maximum, as EvalCallback saves
    validation_return = float(evaluation.best_mean_reward) if evaluation.evaluations_timesteps else None
    card = run.card(run.agent_name, timesteps=best_at, train_time_s=train_s, validation_return=validation_return)
    if saved_best:
        card.save(best)  # the card again, now with the training time; same zip, same hash
    else:  # no evaluation happened (tiny budget): the final model is the best we have
        save_policy(model, best, card)
