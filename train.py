"""Train a stable-baselines3 agent on an sma-gym env and compare it with the report's controllers.

    python train.py                        # the default: SMATracking-v0, algorithm from hyperparams/
    python train.py --env SMARobust-v0 --algo ppo --timesteps 500000 --n-envs 16 --out runs/robust
    python train.py --quick                # tiny budget, for smoke tests

Hyperparameters live in ``hyperparams/<env id>.toml`` (one table per algorithm, RL Zoo style);
command-line options override them. By default the agent is a residual on the report's
controller (``agents/residual.py``: it corrects VSC3 + FF's duty, or the self-sensing PID's
without a position sensor) and sees history features (``agents/history.py``: averages of
its duty and the position over the wire's thermal time constants); README "Training" gives
the measurements behind these choices. The run folder (named at the end) gets:

* ``best_model.zip`` (best on held-out validation references, by a periodic evaluation),
  ``final_model.zip`` and ``checkpoints/``: ordinary stable-baselines3 zips that
  ``SAC.load`` / ``PPO.load`` open, each with a ``.json`` card (env id and kwargs, history, residual base,
  frame stack; for the best model the step and validation return it was chosen at) that
  ``sma-gym evaluate --policy`` and :func:`agents.policies.load_policy` read;
* ``results.md``: the agent beside the report's controllers (all ten of Table 6.1 on the
  tracking env; PID and VSC3 + FF with and without a sensor on the self-sensing env; PID,
  VSC3, VSC3 + FF, PID + FF over the chapter-7 conditions on the robustness env) on
  references it never trained on (the report's 8 mm step and 0.1 Hz sine), goals checked;
  ``evaluation/``: the harness's tables and plots;
* ``tb/``: TensorBoard logs (``tensorboard --logdir <folder>/tb``).

A run never mixes its files with another run's: a non-empty ``--out`` is refused unless
``--overwrite`` is given (then the previous run's outputs are deleted first), a folder
another run is writing to is refused (``.sma-gym.lock``), every file is written atomically,
and each card records the SHA-256 of its zip (a card that does not match is refused).

The validation references used to pick the best model are drawn from the training
distribution with seeds the training never uses; the final comparison uses the report's
references, which the training distribution never produces exactly.
"""

from __future__ import annotations

import argparse
import datetime
import math
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import tomllib

if TYPE_CHECKING:
    from agents.evaluation import Results

ROOT = Path(__file__).resolve().parent
HYPERPARAMS = ROOT / "hyperparams"
ALGOS = ("sac", "ppo")
VALIDATION_SEED = 10_000
QUICK_TIMESTEPS = 1_500


# --------------------------------------------------------------------------------------
# Configuration
# --------------------------------------------------------------------------------------
def load_hyperparams(env_id: str) -> dict[str, Any]:
    path = HYPERPARAMS / f"{env_id}.toml"
    if not path.exists():
        known = sorted(p.stem for p in HYPERPARAMS.glob("*.toml"))
        raise ValueError(f"--env {env_id!r}: no hyperparameter file {path}; expected one of {known}")
    with path.open("rb") as handle:
        return tomllib.load(handle)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--env", default="SMATracking-v0", help="env id (default SMATracking-v0)")
    p.add_argument("--algo", choices=ALGOS, help="algorithm (default: the hyperparameter file's default_algo)")
    p.add_argument("--timesteps", type=int, help="total environment steps (default: from the hyperparameter file)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--n-envs", type=int, help="parallel envs in the native vector env (default: from the file)")
    p.add_argument("--frame-stack", type=int, help="observations stacked as the agent's history (default: from the file)")
    p.add_argument("--history", choices=("none", "ema"), help="history features (agents/history.py; default: from the file)")
    p.add_argument("--residual", help="base controller the agent corrects, e.g. 'VSC3 + FF', or 'none' (default: from the file)")
    p.add_argument("--out", help="run folder (default runs/<env>-<algo>-<time>); must be new or empty unless --overwrite")
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="allow a non-empty --out: the previous run's outputs there are deleted first (default: refuse a non-empty --out)",
    )
    p.add_argument("--device", default="cpu", help="torch device, e.g. cpu, cuda, cuda:1, mps (default cpu)")
    p.add_argument("--quick", action="store_true", help=f"tiny budget ({QUICK_TIMESTEPS} steps) and a short evaluation, for smoke tests")
    p.add_argument(
        "--threads",
        type=int,
        default=1,
        help="torch intra-op threads (default 1: SAC's small networks gain nothing from more, and torch's default "
        "pool of every core thrashes when anything else runs on the machine)",
    )
    p.add_argument("--no-progress", action="store_true", help="no progress bar or progress lines")
    return p.parse_args(argv)


def settings(args: argparse.Namespace) -> dict[str, Any]:
    hp = load_hyperparams(args.env)
    algo = args.algo or hp.get("default_algo", "sac")
    if algo not in hp:
        raise ValueError(f"--algo {algo!r}: hyperparams/{args.env}.toml has no [{algo}] table")
    table = dict(hp[algo])
    run = {
        "env_id": args.env,
        "algo": algo,
        "timesteps": int(table.pop("n_timesteps") if args.timesteps is None else args.timesteps),
        "n_envs": int(table.pop("n_envs", 1) if args.n_envs is None else args.n_envs),
        "frame_stack": int(table.pop("frame_stack", 1) if args.frame_stack is None else args.frame_stack),
        "history": args.history or table.pop("history", "none"),
        "residual": (None if args.residual == "none" else args.residual) if args.residual else table.pop("residual", None),
        "residual_scale": float(table.pop("residual_scale", 0.5)),
        "eval_freq": int(table.pop("eval_freq", 20_000)),
        "env_kwargs": dict(table.pop("env_kwargs", {})),
        "seed": args.seed,
        "device": args.device,
        "threads": args.threads,
        "quick": args.quick,
    }
    for key in ("n_timesteps", "n_envs", "frame_stack", "history", "residual", "residual_scale"):
        table.pop(key, None)
    if args.quick:
        run["timesteps"] = QUICK_TIMESTEPS
        run["eval_freq"] = 500
        if algo == "sac":
            table["learning_starts"] = 200
            table["buffer_size"] = 10_000
        else:
            table["n_steps"] = 64
            table["batch_size"] = 64
    if run["seed"] < 0:
        raise ValueError(f"--seed {run['seed']}: expected an integer >= 0 (numpy and torch seeds are unsigned)")
    run["device"] = check_device(run["device"])
    for name, value in (
        ("timesteps", run["timesteps"]), ("n_envs", run["n_envs"]), ("frame_stack", run["frame_stack"]), ("threads", run["threads"])
    ):
        if value < 1:
            raise ValueError(f"--{name.replace('_', '-')} = {value}: expected an integer >= 1")
    if run["frame_stack"] > 1 and (run["history"] != "none" or run["residual"] is not None):
        # The evaluation harness stacks raw env observations; stacking on top of history
        # features or a residual base would be seen differently in training and evaluation.
        raise ValueError(f"--frame-stack {run['frame_stack']} with history or residual: expected --frame-stack 1, or --history none --residual none")
    if run["history"] not in ("none", "ema"):
        raise ValueError(f"history = {run['history']!r}: expected 'none' or 'ema'")
    if run["residual"] is not None:
        from agents.controllers import ALL_SPECS, spec_by_label

        try:
            run["residual"] = spec_by_label(run["residual"]).label
        except ValueError as err:
            raise ValueError(f"--residual {run['residual']!r}: expected 'none' or one of {[c.label for c in ALL_SPECS]}") from err
    if not 0.0 < run["residual_scale"] <= 1.0:
        raise ValueError(f"residual_scale = {run['residual_scale']}: expected a fraction of full duty in (0, 1]")
    run["model_kwargs"] = table
    return run


def check_device(device: str) -> str:
    """``device`` if torch can train on it here, else a ``ValueError`` naming it."""
    import torch

    try:
        parsed = torch.device(device)
    except (RuntimeError, TypeError) as err:
        raise ValueError(f"--device {device!r}: not a torch device ({err}); expected e.g. cpu, cuda, cuda:0, mps") from None
    available = {
        "cpu": lambda: True,
        "cuda": lambda: torch.cuda.is_available() and (parsed.index is None or parsed.index < torch.cuda.device_count()),
        "mps": lambda: bool(getattr(torch.backends, "mps", None)) and torch.backends.mps.is_available(),
    }
    if parsed.type not in available:
        raise ValueError(f"--device {device!r}: expected cpu, cuda[:N] or mps")
    if not available[parsed.type]():
        raise ValueError(f"--device {device!r}: not available on this machine (use --device cpu)")
    return device


RUN_OUTPUTS = (
    "run.json", "results.md", "goals.json", "best_model.zip", "best_model.json", "final_model.zip",
    "final_model.json", "checkpoints", "evaluation", "validation", "tb",
)
"""What a run writes into its folder: what ``--overwrite`` deletes first, and nothing else."""


def prepare_out(out: Path) -> None:
    """Delete a previous run's outputs from ``out`` (``--overwrite``), so none is mistaken for this run's."""
    import shutil

    for name in RUN_OUTPUTS:
        path = out / name
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        elif path.exists() or path.is_symlink():
            path.unlink()


# --------------------------------------------------------------------------------------
# Environments
# --------------------------------------------------------------------------------------
def make_vec_env(env_id: str, n_envs: int, env_kwargs: dict, frame_stack: int, seed: int, history: str = "none", residual: str | None = None, residual_scale: float = 0.5, max_episode_steps: int | None = None):
    """SB3 VecEnv: the native vector env where the id has one, with a monitor and history."""
    import gymnasium as gym
    from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor

    import sma_gym  # noqa: F401
    from sma_gym.envs.sb3 import SB3VecEnv

    kwargs = dict(env_kwargs)
    if max_episode_steps is not None:
        kwargs["max_episode_steps"] = max_episode_steps
    if gym.spec(env_id).vector_entry_point is not None:
        # The adapter reports episodes itself (as Monitor does): no VecMonitor on top.
        venv = SB3VecEnv(gym.make_vec("sma_gym:" + env_id, num_envs=n_envs, vectorization_mode="vector_entry_point", **kwargs))
    else:
        venv = VecMonitor(DummyVecEnv([lambda: gym.make("sma_gym:" + env_id, **kwargs)] * n_envs))
    venv = _agent_view(venv, env_id, kwargs, frame_stack, history, residual, residual_scale)
    venv.seed(seed)
    return venv


def _agent_view(venv, env_id: str, env_kwargs: dict, frame_stack: int, history: str, residual: str | None, residual_scale: float):
    """What the agent sees and does on top of the env: residual base controller, history
    features, frame stack (the order :class:`agents.policies.AgentPolicy` rebuilds)."""
    from stable_baselines3.common.vec_env import VecFrameStack

    if residual is not None:
        from agents.residual import make_residual_vec_env

        venv = make_residual_vec_env(venv, residual, residual_scale)
    if history == "ema":
        from agents.history import make_history_vec_env

        venv = make_history_vec_env(venv, env_id, env_kwargs)
    if frame_stack > 1:
        venv = VecFrameStack(venv, frame_stack)
    return venv


def validation_references(count: int = 8) -> list[dict]:
    """Held-out references: the training distribution, drawn with seeds training never uses."""
    from sma_gym.envs import references as refs
    from sma_gym.params import preset

    stroke = preset("standard").driver.end_of_travel_m
    out = []
    for k in range(count):
        rng = np.random.default_rng(VALIDATION_SEED + k)
        kind = refs.TRAINING_KINDS[k % len(refs.TRAINING_KINDS)]
        spec = refs.draw(kind, rng, stroke).describe()
        spec.pop("name", None)
        out.append(spec)
    return out


def make_validation_env(run: dict, references: list[dict]):
    import gymnasium as gym
    from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor

    import sma_gym  # noqa: F401

    env_id = run["env_id"]
    fns = [
        (lambda ref=ref: gym.make("sma_gym:" + env_id, **{**run["env_kwargs"], "reference": ref}))
        for ref in references
    ]
    venv = _agent_view(
        VecMonitor(DummyVecEnv(fns)), env_id, run["env_kwargs"], run["frame_stack"], run["history"], run["residual"], run["residual_scale"]
    )
    venv.seed(VALIDATION_SEED)
    return venv


# --------------------------------------------------------------------------------------
# Training
# --------------------------------------------------------------------------------------
def card(run: dict, name: str, **extra: Any) -> dict[str, Any]:
    return {
        "format": "sma-gym-policy",
        "version": 1,
        "algo": run["algo"].upper(),
        "name": name,
        "env_id": run["env_id"],
        "env_kwargs": run["env_kwargs"],
        "frame_stack": run["frame_stack"],
        "history": run["history"],
        "residual": run["residual"],
        "residual_scale": run["residual_scale"],
        "seed": run["seed"],
        **extra,
    }


def progress_line(done: int, total: int, elapsed_s: float) -> str:
    """One progress report: steps done, rate and the time left at that rate."""
    rate = done / elapsed_s if elapsed_s > 0 else 0.0
    left = f"about {(total - done) / rate / 60:.1f} min left" if rate > 0 else "time left unknown"
    return f"train.py: {done}/{total} steps ({100 * done / total:.0f} %), {rate:.0f} steps/s, {left}"


def train(run: dict, out: Path, progress: bool = True) -> dict[str, Any]:
    import torch
    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.callbacks import (
        BaseCallback,
        CallbackList,
        CheckpointCallback,
        EvalCallback,
    )

    from agents.policies import save_policy, write_card

    # Deliberate thread count (see --threads): on a busy 2-core machine torch's default pool
    # made an SB3 run of this env 20x slower than one thread, for the same result.
    torch.set_num_threads(run["threads"])
    torch.manual_seed(run["seed"])
    algo_cls = {"sac": SAC, "ppo": PPO}[run["algo"]]
    venv = make_vec_env(
        run["env_id"], run["n_envs"], run["env_kwargs"], run["frame_stack"], run["seed"], run["history"], run["residual"], run["residual_scale"]
    )
    references = validation_references(4 if run["quick"] else 8)
    eval_env = make_validation_env(run, references)
    kwargs = dict(run["model_kwargs"])
    policy = kwargs.pop("policy", "MlpPolicy")
    model = algo_cls(policy, venv, seed=run["seed"], device=run["device"], tensorboard_log=str(out / "tb"), verbose=0, **kwargs)
    per_env = max(1, run["eval_freq"] // run["n_envs"])

    class CardedCheckpoints(CheckpointCallback):
        """SB3's checkpoints, each zip written atomically with its card (hash of the zip)."""

        def _on_step(self) -> bool:
            if self.n_calls % self.save_freq == 0:
                path = Path(self._checkpoint_path(extension="zip"))
                save_policy(self.model, path, card(run, path.stem, timesteps=self.num_timesteps))
            return True

    best = out / "best_model.zip"

    class SaveBest(BaseCallback):
        """Called by EvalCallback on a new best validation return: zip, then card."""

        def _on_step(self) -> bool:
            save_policy(
                self.model, best,
                card(run, f"{run['algo'].upper()} agent", timesteps=self.num_timesteps, validation_return=float(self.parent.best_mean_reward)),
            )
            return True

    evaluation = EvalCallback(
        eval_env,
        n_eval_episodes=len(references),
        eval_freq=per_env,
        # Saved by SaveBest (atomic, with its card) rather than by SB3 (a bare zip).
        callback_on_new_best=SaveBest(),
        log_path=str(out / "validation"),
        deterministic=True,
        verbose=0,
    )
    class ProgressLines(BaseCallback):
        """Progress as plain lines (CI, nohup, cluster logs: a redrawn bar is unreadable there)."""

        def __init__(self, every_s: float = 60.0) -> None:
            super().__init__()
            self.every_s = every_s
            self.start = self.last = time.perf_counter()

        def _on_step(self) -> bool:
            now = time.perf_counter()
            if now - self.last >= self.every_s:
                self.last = now
                print(progress_line(self.num_timesteps, run["timesteps"], now - self.start), flush=True)
            return True

    bar = progress and sys.stdout.isatty()
    items = [evaluation, CardedCheckpoints(save_freq=per_env * 2, save_path=str(out / "checkpoints"), name_prefix=run["algo"])]
    if progress and not bar:
        items.append(ProgressLines())
    callbacks = CallbackList(items)
    start = time.perf_counter()
    model.learn(total_timesteps=run["timesteps"], callback=callbacks, progress_bar=bar, tb_log_name=run["algo"])
    train_s = time.perf_counter() - start
    save_policy(model, out / "final_model.zip", card(run, "final model", timesteps=run["timesteps"], train_time_s=train_s))
    best_at = run["timesteps"]
    saved_best = best.exists()  # only SaveBest writes it: --out was empty or cleared (prepare_out)
    if saved_best and evaluation.evaluations_timesteps:
        returns = [float(np.mean(r)) for r in evaluation.evaluations_results]
        best_at = int(evaluation.evaluations_timesteps[int(np.argmax(returns))])  # first maximum, as EvalCallback saves
    best_card = card(run, f"{run['algo'].upper()} agent", timesteps=best_at, train_time_s=train_s, validation_return=float(evaluation.best_mean_reward) if evaluation.evaluations_timesteps else None)
    if saved_best:
        write_card(best, best_card)  # the card again, now with the training time; same zip, same hash
    else:  # no evaluation happened (tiny budget): the final model is the best we have
        save_policy(model, best, best_card)
    venv.close()
    eval_env.close()
    return {"train_time_s": train_s, "validation_references": references}


# --------------------------------------------------------------------------------------
# Comparison with the baselines
# --------------------------------------------------------------------------------------
def compare(run: dict, out: Path) -> tuple[str, dict[str, Any]]:
    from agents.controllers import ALL_SPECS, PID, VSC3, with_feedforward
    from agents.evaluation import (
        CHAPTER_7_CONDITIONS,
        Results,
        agent_entry,
        baseline,
        run_chapter_7,
        run_table_6_1,
    )
    from agents.policies import load_policy
    from agents.report import write_report

    agent = load_policy(out / "best_model.zip")
    entry = agent_entry(agent)
    seeds = (0,) if run["quick"] else (0, 1, 2)
    results = Results()
    env_id = run["env_id"]
    best = [baseline(PID), baseline(with_feedforward(VSC3))]
    if env_id == "SMASelfSensing-v0":
        sensing = [baseline(PID, True), baseline(with_feedforward(VSC3), True)]
        run_table_6_1(best + sensing + [entry], results, seeds, condition="self-sensing", model="forced-convection")
        conditions = [("self-sensing", "forced-convection")]
    elif env_id == "SMARobust-v0":
        conditions = list(CHAPTER_7_CONDITIONS) if not run["quick"] else [CHAPTER_7_CONDITIONS[0]]
        run_chapter_7(best + [baseline(VSC3), baseline(with_feedforward(PID))] + [entry], results, seeds, conditions)
    else:
        # "Lower RMS than every baseline": all ten configurations of Table 6.1.
        every = best if run["quick"] else [baseline(s) for s in ALL_SPECS]
        run_table_6_1(every + [entry], results, seeds)
        conditions = [("standard", "standard")]
    write_report(results, out / "evaluation")
    return summarise(run, results, agent.name, conditions)


def summarise(run: dict, results: Results, agent: str, conditions: list[tuple[str, str]]) -> tuple[str, dict[str, Any]]:
    experiment = "7" if run["env_id"] == "SMARobust-v0" else "6.1"
    policies = results.distinct(experiment, "policy")

    def get(policy: str, condition: str, ref: str, metric: str, worst: bool = True) -> float:
        try:
            return results.value(experiment, policy, condition, ref, metric, worst=worst)
        except KeyError:
            return math.nan

    lines = [
        f"# {run['algo'].upper()} on {run['env_id']} beside the report's controllers",
        "",
        "References the agent never trained on: the report's 8 mm step and 0.1 Hz, 3 mm sine.",
        "Worst case over seeds; lengths in mm.",
        "",
        "| policy | condition | RMS step | RMS sine | overshoot | steady-state error | energy sine [J] |",
        "|---|---|---|---|---|---|---|",
    ]
    for condition, _ in conditions:
        for p in policies:
            rms_step = get(p, condition, "step", "rms_error_m")
            if math.isnan(rms_step):
                continue
            sse = get(p, condition, "step", "steady_state_error_m")
            lines.append(
                f"| {p} | {condition} | {rms_step * 1e3:.3f} | {get(p, condition, 'sine', 'rms_error_m') * 1e3:.3f} | "
                f"{get(p, condition, 'step', 'overshoot_m') * 1e3:.3f} | {'osc.' if math.isnan(sse) else f'{sse * 1e3:+.3f}'} | "
                f"{get(p, condition, 'sine', 'energy_j', worst=False):.2f} |"
            )
    goals: dict[str, Any] = {}
    baselines = [p for p in policies if p != agent]
    with_sensor = [p for p in baselines if "self-sensing" not in p]
    if run["env_id"] == "SMARobust-v0":
        def worst_over(p: str, ref: str) -> float:
            return max(get(p, c, ref, "rms_error_m") for c, _ in conditions)
        for ref in ("step", "sine"):
            a = worst_over(agent, ref)
            b = min(worst_over(p, ref) for p in baselines)
            goals[f"worst-case RMS {ref} over chapter-7 conditions < best baseline's"] = {"agent_mm": a * 1e3, "best_baseline_mm": b * 1e3, "met": a < b}
    else:
        condition = conditions[0][0]
        for ref in ("step", "sine"):
            a = get(agent, condition, ref, "rms_error_m")
            b = min(get(p, condition, ref, "rms_error_m") for p in with_sensor)
            if run["env_id"] == "SMASelfSensing-v0":
                goals[f"RMS {ref} within 2x of the best baseline with a position sensor"] = {"agent_mm": a * 1e3, "best_baseline_mm": b * 1e3, "met": a <= 2 * b}
            else:
                goals[f"RMS {ref} below every baseline"] = {"agent_mm": a * 1e3, "best_baseline_mm": b * 1e3, "met": a < b}
        if run["env_id"] == "SMATracking-v0":
            a = get(agent, condition, "step", "overshoot_m")
            b = get("VSC3 + FF", condition, "step", "overshoot_m")
            goals["overshoot no larger than VSC3 + FF's"] = {"agent_mm": a * 1e3, "vsc3_ff_mm": b * 1e3, "met": a <= b + 1e-9}
    lines += ["", "## Goals", ""]
    for name, g in goals.items():
        figures = ", ".join(f"{k} = {v:.3f}" for k, v in g.items() if k != "met")
        lines.append(f"- {'met' if g['met'] else 'NOT met'}: {name} ({figures})")
    return "\n".join(lines) + "\n", goals


def main(argv: list[str] | None = None) -> int:
    from sma_gym._io import check_output_folder, locked_folder, write_json, write_text

    try:
        args = parse_args(argv)
        run = settings(args)
        stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
        out = Path(args.out or ROOT / "runs" / f"{run['env_id']}-{run['algo']}-{stamp}")
        # Every argument, --out included, is checked before anything is created.
        check_output_folder(out, must_be_empty=not args.overwrite)
        with locked_folder(out):
            if args.overwrite:
                prepare_out(out)
            write_json(out / "run.json", dict(run), default=str)
            started = time.perf_counter()
            info = train(run, out, progress=not args.no_progress)
            table, goals = compare(run, out)
            total = time.perf_counter() - started
            table += f"\nTraining {info['train_time_s'] / 60:.1f} min, training + evaluation {total / 60:.1f} min ({run['timesteps']} steps, {run['n_envs']} envs, seed {run['seed']}).\n"
            write_text(out / "results.md", table)
            write_json(out / "goals.json", {"goals": goals, "train_time_s": info["train_time_s"], "total_time_s": total, "validation_references": info["validation_references"]})
    except ValueError as err:
        print(f"train.py: error: {err}", file=sys.stderr)
        return 2
    print(table)
    print(f"run folder: {out}")
    return 0

if __name__ == "__main__":
    sys.exit(main())
