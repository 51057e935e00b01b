"""Bank baselines (issue 16): the report's controllers per actuator on fixed slots, and the
budget allocator on a shared budget; both under evaluate_policy and the harness."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import sma_gym  # noqa: F401  (registers the ids)
from sma_gym_agents import evaluation as ev
from sma_gym_agents.bank import BudgetAllocator, FixedSlotBank, bank_policy


def make(n: int, scheme: str, steps: int = 40):
    return gym.make(
        "sma_gym:SMAMultiplexed-v0", n_actuators=n, scheme=scheme, control_period_s=1e-3, max_episode_steps=steps
    )


def test_budget_allocator_gives_each_what_it_asks_and_scales_down_past_the_cycle():
    env = make(4, "shared_budget")
    obs, _ = env.reset(seed=0, options={"references": [{"kind": "step", "t1_s": 0.0, "level1_m": 5e-3}] * 4})
    policy = BudgetAllocator("PID", env)
    asked = policy.asked_duty(obs.copy())
    np.testing.assert_allclose(asked, 1.0)  # every PID far below its reference asks everything
    action, _ = BudgetAllocator("PID", env).predict(obs)
    granted = env.unwrapped.duty_for(action)
    np.testing.assert_allclose(granted, 0.25, rtol=1e-6)  # 4 x 1 scaled by 1 / 4
    # Only actuator 2 asks: it gets the whole cycle (a fixed slot would cap it at 1/4).
    obs, _ = env.reset(
        seed=0,
        options={"references": [{"kind": "step", "t1_s": 0.0, "level1_m": lvl} for lvl in (0.0, 0.0, 5e-3, 0.0)]},
    )
    action, _ = BudgetAllocator("PID", env).predict(obs)
    np.testing.assert_allclose(env.unwrapped.duty_for(action), [0.0, 0.0, 1.0, 0.0], atol=1e-6)
    fixed = make(4, "fixed_slots")
    obs, _ = fixed.reset(seed=0, options={"references": [{"kind": "step", "t1_s": 0.0, "level1_m": 5e-3}] * 4})
    action, _ = FixedSlotBank("PID", fixed).predict(obs)
    np.testing.assert_allclose(fixed.unwrapped.duty_for(action), 0.25, rtol=1e-6)


def test_budget_is_shared_within_each_bank_of_a_batch():
    env = make(2, "shared_budget")
    env.reset(seed=0)
    policy = BudgetAllocator("PID", env)
    obs = np.zeros((3, 20), dtype=np.float32)
    reference = env.unwrapped.feature_names.index("reference")
    obs[:, reference] = obs[:, 10 + reference] = 0.5  # both actuators of every bank far below
    obs[1, 10 + reference] = 0.0  # bank 1: actuator 1 at its reference, asks nothing
    action, _ = policy.predict(obs, episode_start=np.ones(3, dtype=bool))
    duty = env.unwrapped.duty_for(action)
    np.testing.assert_allclose(duty.sum(axis=1), [1.0, 1.0, 1.0], rtol=1e-6)
    np.testing.assert_allclose(duty[1], [1.0, 0.0], atol=1e-6)


@pytest.mark.parametrize("scheme", ["fixed_slots", "shared_budget"])
def test_bank_baselines_run_under_evaluate_policy(scheme):
    from stable_baselines3.common.evaluation import evaluate_policy
    from stable_baselines3.common.monitor import Monitor

    env = Monitor(make(4, scheme))
    policy = bank_policy("VSC3 + FF", env)
    assert isinstance(policy, BudgetAllocator if scheme == "shared_budget" else FixedSlotBank)
    mean, _ = evaluate_policy(policy, env, n_eval_episodes=2)
    assert np.isfinite(mean)


def test_a_bank_baseline_refuses_the_other_scheme():
    with pytest.raises(ValueError, match="expected 'shared_budget'"):
        BudgetAllocator("PID", make(4, "fixed_slots"))
    with pytest.raises(ValueError, match="expected 'fixed_slots'"):
        FixedSlotBank("PID", make(4, "shared_budget"))


def test_bank_baselines_run_in_the_harness_chapter_9_experiments():
    results = ev.Results()
    allocator = ev.bank_entry("PID", "shared_budget")
    ev.run_chapter_9([allocator], results, conditions=[(1, 2000.0, 10.0)])
    assert np.isfinite(
        results.value("9", "PID (budget allocator)", ev.chapter_9_label(1, 2000.0, 10.0), "3 mm step", "rise_time_s")
    )
    shared = ev.bank_step(allocator, n=4, step_time_s=1.0, max_after_s=3.0)
    fixed = ev.bank_step(ev.bank_entry("PID", "fixed_slots"), n=4, step_time_s=1.0, max_after_s=3.0)
    # Four actuators at 10 V: a 1/4 slot is slow, the shared budget lends the idle share.
    assert shared["rise_time_s"] < fixed["half_rise_time_s"]
