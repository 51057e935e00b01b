"""Training speed: the cost of the default ``python train.py`` and of its parts.

1. One SAC gradient step of the default networks (two 256-unit layers, batch 256, one torch
   thread) with torch's default Adam and with its fused kernel, interleaved so that both see
   the same machine load: the median ratio is the figure (``hyperparams/sac.yml`` uses the
   fused kernel).
2. The default run, estimated from two short runs of exactly its configuration (``train.py
   --timesteps 4000`` and ``--timesteps 12000``, no validation in between): the per-step cost
   once SAC learns, times the default budget, plus the warm-up and the evaluation. Printed
   beside the gradient steps' share of it (the gradient step time of part 1 times the number
   of gradient steps), so a slow figure says whether the networks or the envs cost it.

Issue 16's goal: the default run under 10 minutes on 2 cores with nothing else running, and
no more than 2x slower with one other CPU-bound process (run this twice: alone, and beside
e.g. ``python -c "while True: pass"``).

    python benchmarks/bench_training.py [--reps 5] [--skip-run]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SHORT_STEPS = (4000, 12000)
"""The two short runs: the first ends where learning starts (``learning_starts``)."""


def gradient_step_seconds(fused: bool, steps: int = 200) -> float:
    """Seconds per SAC gradient step of the default networks on a 20-dimensional task."""
    import numpy as np
    import torch
    from stable_baselines3 import SAC

    torch.set_num_threads(1)
    env = _stand_in_env()
    kwargs = {"optimizer_kwargs": {"fused": True}} if fused else {}
    model = SAC(
        "MlpPolicy", env, batch_size=256, learning_starts=0, seed=0, policy_kwargs=dict(net_arch=[256, 256], **kwargs)
    )
    model.learn(300)
    np.random.seed(0)
    start = time.perf_counter()
    model.train(gradient_steps=steps, batch_size=256)
    return (time.perf_counter() - start) / steps


def _stand_in_env():
    """A 20-feature, 1-action env with the default env's sizes and no physics: part 1 times
    the networks only."""
    import gymnasium as gym
    import numpy as np

    class StandIn(gym.Env):
        observation_space = gym.spaces.Box(-1.0, 1.0, (20,), np.float32)
        action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

        def reset(self, *, seed=None, options=None):
            super().reset(seed=seed)
            return self.observation_space.sample(), {}

        def step(self, action):
            return self.observation_space.sample(), float(-abs(action[0])), False, False, {}

    return gym.wrappers.TimeLimit(StandIn(), 200)


def short_run(steps: int, folder: Path) -> dict:
    """``train.py`` on the default configuration for ``steps`` steps: its goals.json times."""
    out = folder / f"run-{steps}"
    cmd = [sys.executable, str(ROOT / "train.py"), "--timesteps", str(steps), "--eval-freq", "1000000"]
    cmd += ["--no-progress", "--out", str(out)]
    subprocess.run(cmd, check=True, cwd=ROOT, stdout=subprocess.DEVNULL)
    return json.loads((out / "goals.json").read_text())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=5, help="interleaved repetitions of part 1")
    parser.add_argument("--skip-run", action="store_true", help="part 1 only")
    args = parser.parse_args()

    plain, fused = [], []
    for _ in range(args.reps):
        plain.append(gradient_step_seconds(False))
        fused.append(gradient_step_seconds(True))
    ratio = statistics.median(f / p for f, p in zip(fused, plain))
    print(
        f"SAC gradient step (256x256, batch 256, 1 thread): default Adam {statistics.median(plain) * 1e3:.1f} ms, "
        f"fused {statistics.median(fused) * 1e3:.1f} ms; fused / default = {ratio:.2f} (median of {args.reps})"
    )
    if args.skip_run:
        return 0

    from sma_gym_agents.training.config import load_hyperparams

    table = load_hyperparams("SMATracking-v0")
    total = int(table["n_timesteps"])
    with tempfile.TemporaryDirectory() as tmp:
        a, b = (short_run(n, Path(tmp)) for n in SHORT_STEPS)
    per_step = (b["train_time_s"] - a["train_time_s"]) / (SHORT_STEPS[1] - SHORT_STEPS[0])
    evaluation = b["total_time_s"] - b["train_time_s"]
    estimate = a["train_time_s"] + per_step * (total - SHORT_STEPS[0]) + evaluation
    n_grad = (total - int(table["learning_starts"])) / (int(table["n_envs"]) * int(table["train_freq"]))
    grad_s = n_grad * int(table["gradient_steps"]) * statistics.median(fused)
    print(
        f"default run ({total} steps): about {estimate / 60:.1f} min "
        f"(warm-up {a['train_time_s']:.0f} s, {per_step * 1e3:.2f} ms per step once learning, evaluation "
        f"{evaluation:.0f} s); gradient steps alone {grad_s / 60:.1f} min ({grad_s / estimate:.0%})"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
