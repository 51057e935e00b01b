"""Env speed, measured against Gymnasium's classic-control envs in the same run.

Prints steps/s of ``gymnasium.make("sma_gym:SMATracking-v0")`` and of ``Pendulum-v1`` and
``CartPole-v1`` (all with the wrappers ``gymnasium.make`` adds: TimeLimit, OrderEnforcing,
PassiveEnvChecker), the ratios, and env-steps/s of the native vector env at N = 1024 and
4096. Each figure is the best of several timings interleaved across envs, because the
machine is shared and noisy.

Goals (issue): tracking env / Pendulum-v1 >= 1.0; vector env >= 1e6 env-steps/s at N = 4096.

    python benchmarks/bench_envs.py [--json]
"""

from __future__ import annotations

import argparse
import json
import time

import gymnasium as gym
import numpy as np

import sma_gym  # noqa: F401  (registers the ids)

SINGLE = ("sma_gym:SMATracking-v0", "Pendulum-v1", "CartPole-v1")


def single_rate(env_id: str, steps: int = 20000) -> float:
    env = gym.make(env_id)
    env.reset(seed=0)
    env.action_space.seed(0)
    actions = [env.action_space.sample() for _ in range(256)]
    start = time.perf_counter()
    for k in range(steps):
        _, _, terminated, truncated, _ = env.step(actions[k & 255])
        if terminated or truncated:
            env.reset()
    return steps / (time.perf_counter() - start)


def vector_rate(num_envs: int, steps: int = 150) -> float:
    venv = gym.make_vec("sma_gym:SMATracking-v0", num_envs=num_envs, vectorization_mode="vector_entry_point")
    venv.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = [rng.uniform(-1, 1, size=(num_envs, 1)).astype(np.float32) for _ in range(8)]
    for k in range(10):
        venv.step(actions[k & 7])
    start = time.perf_counter()
    for k in range(steps):
        venv.step(actions[k & 7])
    return num_envs * steps / (time.perf_counter() - start)


def run(repeats: int = 5) -> dict[str, float]:
    best: dict[str, float] = {}
    for env_id in SINGLE:  # warm-up (numba cache load, first calls)
        single_rate(env_id, 500)
    for _ in range(repeats):
        for env_id in SINGLE:
            best[env_id] = max(best.get(env_id, 0.0), single_rate(env_id))
    for n in (1024, 4096):
        best[f"vector N={n}"] = max(vector_rate(n) for _ in range(repeats))
    best["ratio tracking/Pendulum-v1"] = best["sma_gym:SMATracking-v0"] / best["Pendulum-v1"]
    best["ratio tracking/CartPole-v1"] = best["sma_gym:SMATracking-v0"] / best["CartPole-v1"]
    return best


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    result = run(args.repeats)
    if args.json:
        print(json.dumps(result))
        return 0
    for key, value in result.items():
        unit = "" if key.startswith("ratio") else (" env-steps/s" if key.startswith("vector") else " steps/s")
        print(f"{key:32s} {value:14,.2f}{unit}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
