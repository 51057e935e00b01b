"""train.py end to end on a tiny budget: models, table and plots written, model reloads."""

import json
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def test_train_quick_writes_models_results_and_plots_that_reload(tmp_path):
    out = tmp_path / "run"
    proc = subprocess.run(
        [sys.executable, str(ROOT / "train.py"), "--quick", "--no-progress", "--out", str(out)],
        capture_output=True, text=True, timeout=900, cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert f"run folder: {out}" in proc.stdout
    for name in ("best_model.zip", "best_model.json", "final_model.zip", "results.md", "goals.json", "run.json"):
        assert (out / name).exists(), name
    assert list((out / "checkpoints").glob("*.zip")) and list((out / "checkpoints").glob("*.json"))
    assert list((out / "tb").rglob("events.out.tfevents.*"))
    results = (out / "results.md").read_text()
    assert "| PID | standard |" in results and "| VSC3 + FF | standard |" in results and "## Goals" in results
    assert len(list((out / "evaluation").glob("*.png"))) >= 4
    goals = json.loads((out / "goals.json").read_text())
    assert goals["goals"] and len(goals["validation_references"]) == 4  # --quick validates on four
    # An ordinary SB3 zip: SAC.load opens it; its card says how it observes (history
    # features, residual base) and load_policy rebuilds that to act on the raw env.
    from stable_baselines3 import SAC

    from agents.policies import load_policy

    model = SAC.load(out / "best_model.zip", device="cpu")
    card = json.loads((out / "best_model.json").read_text())
    assert card["history"] == "ema" and card["residual"] == "VSC3 + FF"
    # The card names the step of the best validation return, within the budget.
    assert card["validation_return"] is not None and 0 < card["timesteps"] <= 1500
    env = gym.make("sma_gym:" + card["env_id"], **card["env_kwargs"])
    raw_dim = env.observation_space.shape[0]
    assert model.observation_space.shape[0] > raw_dim
    policy = load_policy(out / "best_model.zip")
    obs, _ = env.reset(seed=0)
    for _ in range(20):
        action, _ = policy.predict(obs, deterministic=True)
        assert env.action_space.contains(np.asarray(action, dtype=np.float32))
        obs, *_ = env.step(action)
    # sma-gym evaluate --policy scores it beside the baselines.
    proc = subprocess.run(
        [sys.executable, "-m", "sma_gym.cli", "evaluate", "--policy", str(out / "best_model.zip"), "--experiments", "6.1",
         "--seeds", "1", "--baselines", "PID", "--json"],
        capture_output=True, text=True, timeout=900, cwd=tmp_path,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    rows = json.loads(proc.stdout)
    assert any(r["policy"] == card["name"] and r["metric"] == "rms_error_m" and np.isfinite(r["value"]) for r in rows)


def test_train_rejects_bad_options():
    proc = subprocess.run([sys.executable, str(ROOT / "train.py"), "--env", "NoSuchEnv-v0"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "NoSuchEnv-v0" in proc.stderr
    proc = subprocess.run([sys.executable, str(ROOT / "train.py"), "--timesteps", "0"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "timesteps" in proc.stderr
    proc = subprocess.run([sys.executable, str(ROOT / "train.py"), "--threads", "0"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2 and "threads" in proc.stderr


def test_progress_lines_report_steps_rate_and_time_left():
    """Without a terminal (CI, nohup, cluster logs) train.py prints these instead of a bar."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("train_script", ROOT / "train.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    line = module.progress_line(50_000, 400_000, 100.0)
    assert line == "train.py: 50000/400000 steps (12 %), 500 steps/s, about 11.7 min left"
    assert "unknown" in module.progress_line(0, 400_000, 0.0)
