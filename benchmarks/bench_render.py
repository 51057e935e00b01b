"""Video speed: ``render_mode="rgb_array"`` frames/s over one 1000-step episode.

Renders every step of a ``SMATracking-v0`` episode at 640 x 640, as ``RecordVideo`` does,
and prints frames/s including the env step. As a reference measured in the same run it
renders the same frames with a full redraw of the figure each time (what every frame cost
before the cached background and blitting; the history grows with the episode, so the
reference renders every 20th step to keep the run short) and prints the ratio.

Goal (issue 15): >= 30 frames/s.

It also renders 4 sub-envs of the native vector env (``vectorization_mode=
"vector_entry_point"``) against Gymnasium's ``SyncVectorEnv`` of the same env (one figure
per sub-env there), step included, and prints that ratio: the native env's frames are no
slower (with one figure shared by its sub-envs they were 4x slower, 2026-12-07).

    python benchmarks/bench_render.py [--json] [--steps 1000]
"""

from __future__ import annotations

import argparse
import json
import time

import gymnasium as gym
import numpy as np

import sma_gym  # noqa: F401  (registers the ids)


def frames_per_second(steps: int, every: int = 1, full_redraw: bool = False) -> float:
    """Frames/s of an episode rendered every ``every`` steps (env steps included)."""
    env = gym.make("sma_gym:SMATracking-v0", render_mode="rgb_array", max_episode_steps=steps)
    env.reset(seed=0)
    env.render()  # builds the figure: once per env, not part of the per-frame cost
    renderer = env.unwrapped._renderer
    action = np.array([0.4], dtype=np.float32)
    frames = 0
    start = time.perf_counter()
    for k in range(steps):
        env.step(action)
        if k % every == 0:
            if full_redraw:
                renderer._plot._background = None
            frame = env.render()
            frames += 1
    elapsed = time.perf_counter() - start
    assert frame.shape == (640, 640, 3)
    env.close()
    return frames / elapsed


def vector_frames_per_second(mode: str, steps: int, num_envs: int = 4) -> float:
    """Sub-env frames/s of a vector env rendered every step (steps included)."""
    env = gym.make_vec("sma_gym:SMATracking-v0", num_envs=num_envs, vectorization_mode=mode, render_mode="rgb_array")
    env.reset(seed=0)
    env.render()  # builds the figures
    actions = np.full((num_envs, 1), 0.4, dtype=np.float32)
    start = time.perf_counter()
    for _ in range(steps):
        env.step(actions)
        frames = env.render()
    elapsed = time.perf_counter() - start
    assert len(frames) == num_envs and all(f.shape == (640, 640, 3) for f in frames)
    env.close()
    return steps * num_envs / elapsed


def run(steps: int) -> dict[str, float]:
    fast = frames_per_second(steps)
    reference = frames_per_second(steps, every=20, full_redraw=True)
    native = vector_frames_per_second("vector_entry_point", steps // 5)
    sync = vector_frames_per_second("sync", steps // 5)
    return {
        "frames/s (cached background, blitting)": fast,
        "frames/s (full redraw each frame)": reference,
        "ratio": fast / reference,
        "vector frames/s, native (4 sub-envs)": native,
        "vector frames/s, Gymnasium sync": sync,
        "ratio native / sync": native / sync,
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--steps", type=int, default=1000, help="episode length (default 1000)")
    args = parser.parse_args()
    result = run(args.steps)
    print(json.dumps(result) if args.json else "\n".join(f"{key:40s} {value:10.2f}" for key, value in result.items()))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
