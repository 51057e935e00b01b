"""Bank baselines (issue 16): the report's controllers per actuator on fixed slots, and the
budget and priority allocators on a shared budget; under evaluate_policy and the harness."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import sma_gym  # noqa: F401  (registers the ids)
from sma_gym_agents import evaluation as ev
from sma_gym_agents.bank import BudgetAllocator, FixedSlotBank, PriorityAllocator, bank_policy


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


class Asking(PriorityAllocator):
    """The priority allocator with the controllers' asks set by the test."""

    asks = np.zeros(1)

    def asked_duty(self, observation, episode_start=None):
        return np.array(self.asks, dtype=float)


def bank_obs(env, reference_m, position_m):
    """Bank observations (batch, n * k) with the given measured positions and references."""
    u = env.unwrapped
    names = list(u.feature_names)
    reference_m, position_m = np.atleast_2d(reference_m), np.atleast_2d(position_m)
    obs = np.zeros((*reference_m.shape, len(names)))
    obs[..., names.index("reference")] = reference_m / u.position_scale_m
    obs[..., names.index("position")] = position_m / u.position_scale_m
    return obs.reshape(reference_m.shape[0], -1)


def test_priority_allocator_serves_the_lead_then_the_largest_errors():
    env = make(4, "shared_budget")
    env.reset(seed=0)
    policy = Asking("VSC3 + FF", env)
    u = env.unwrapped
    reference = np.array([[4e-3, 6e-3, 2e-3, 5e-3]])

    def grant(asks, position, start=False):
        policy.asks = np.atleast_2d(asks)
        action, _ = policy.predict(bank_obs(env, reference, position), episode_start=np.array([start]))
        return u.duty_for(action)

    # Asks within the cycle: each gets what it asks, as under the budget allocator.
    np.testing.assert_allclose(grant([0.2, 0.3, 0.0, 0.4], np.zeros(4), True), [[0.2, 0.3, 0.0, 0.4]], atol=1e-6)
    # Overrun: the largest error (actuator 1, 6 mm) leads; then actuator 3 (5 mm) gets the rest.
    np.testing.assert_allclose(grant([0.5, 0.8, 0.1, 0.6], np.zeros(4), True), [[0.0, 0.8, 0.0, 0.2]], atol=1e-6)
    # A lead asking the whole cycle keeps it though another error is now larger.
    np.testing.assert_allclose(grant([1.0, 1.0, 0.0, 1.0], np.zeros(4), True), [[0.0, 1.0, 0.0, 0.0]], atol=1e-6)
    position = np.array([0.0, 3e-3, 0.0, 0.0])  # actuator 1 has 3 mm to go; 3 now has the most (5 mm)
    np.testing.assert_allclose(grant([1.0, 1.0, 0.0, 1.0], position), [[0.0, 1.0, 0.0, 0.0]], atol=1e-6)
    # Near its reference the lead asks less: the lead moves to the largest error asking (3), and stays.
    np.testing.assert_allclose(grant([1.0, 0.3, 0.0, 1.0], position), [[0.0, 0.0, 0.0, 1.0]], atol=1e-6)
    np.testing.assert_allclose(grant([1.0, 1.0, 0.0, 1.0], position), [[0.0, 0.0, 0.0, 1.0]], atol=1e-6)
    # An episode start forgets the lead: the largest error (actuator 1 again, from zero) leads.
    np.testing.assert_allclose(grant([1.0, 1.0, 0.0, 1.0], np.zeros(4), True), [[0.0, 1.0, 0.0, 0.0]], atol=1e-6)


def test_priority_allocator_passes_over_a_lead_that_held_the_cycle_for_its_limit():
    """A wire that cannot reach its reference (beyond the stroke, broken) asks the whole
    cycle forever; it leads for lead_limit_s at a time, not for ever."""
    env = make(3, "shared_budget")
    env.reset(seed=0)
    policy = Asking("PID", env, lead_limit_s=3e-3)  # three control periods
    policy.asks = np.ones((1, 3))
    obs = bank_obs(env, np.array([[20e-3, 4e-3, 2e-3]]), np.zeros((1, 3)))  # actuator 0 can never arrive
    served = []
    for k in range(9):
        action, _ = policy.predict(obs, episode_start=np.array([k == 0]))
        served.append(int(np.argmax(env.unwrapped.duty_for(action)[0])))
    assert served == [0, 0, 0, 1, 1, 1, 0, 0, 0]
    for bad in (0, float("inf"), float("nan"), True, "1"):
        with pytest.raises(ValueError, match=f"lead_limit_s = {bad!r}: expected finite"):
            PriorityAllocator("PID", env, lead_limit_s=bad)


def test_a_lead_that_reached_its_limit_waits_as_long_behind_the_others():
    """One wire that cannot arrive asks the whole cycle and has the largest error; three
    holders ask 0.3 each. Passed over once, the wire was served second (still the largest
    error) and led again the next step: it kept 0.998 of the cycle and the holders were
    served in 4 of 500 steps. Benched as long as it led, it takes half."""
    env = make(4, "shared_budget")
    env.reset(seed=0)
    policy = Asking("PID", env, lead_limit_s=3e-3)  # three control periods
    policy.asks = np.array([[1.0, 0.3, 0.3, 0.3]])
    obs = bank_obs(env, np.array([[20e-3, 3e-3, 2e-3, 1e-3]]), np.zeros((1, 4)))
    duties = []
    for k in range(60):
        action, _ = policy.predict(obs, episode_start=np.array([k == 0]))
        duties.append(env.unwrapped.duty_for(action)[0])
    duties = np.array(duties)
    np.testing.assert_allclose(duties[:3], [[1.0, 0.0, 0.0, 0.0]] * 3, atol=1e-6)  # it leads its limit
    np.testing.assert_allclose(duties[3:6], [[0.1, 0.3, 0.3, 0.3]] * 3, atol=1e-6)  # then waits behind them
    np.testing.assert_allclose(duties[:, 0].mean(), 0.55, atol=1e-6)
    assert np.all((duties[:, 1:] > 0.29).mean(axis=0) == 0.5)


def test_priority_allocator_keeps_a_lead_per_bank_of_a_batch():
    env = make(2, "shared_budget")
    env.reset(seed=0)
    policy = Asking("PID", env)
    policy.asks = np.ones((3, 2))
    reference = np.array([[2e-3, 3e-3], [3e-3, 2e-3], [1e-3, 1e-3]])
    action, _ = policy.predict(bank_obs(env, reference, np.zeros((3, 2))), episode_start=np.ones(3, dtype=bool))
    duty = env.unwrapped.duty_for(action)
    np.testing.assert_allclose(duty, [[0.0, 1.0], [1.0, 0.0], [1.0, 0.0]], atol=1e-6)
    # Bank 0 restarts with its errors swapped and takes its new largest; bank 1 keeps its lead.
    reference = np.array([[3e-3, 2e-3], [2e-3, 3e-3], [1e-3, 1e-3]])
    action, _ = policy.predict(bank_obs(env, reference, np.zeros((3, 2))), episode_start=np.array([True, False, False]))
    np.testing.assert_allclose(env.unwrapped.duty_for(action), [[1.0, 0.0], [1.0, 0.0], [1.0, 0.0]], atol=1e-6)


def test_priority_allocator_beats_the_budget_allocator_on_independent_references():
    """Sixteen actuators on one cycle, each its own reference: serving one at a time moves
    each in turn where proportional scaling heats all slowly (4.78 -> 2.94 mm at seed 1)."""
    rms = {
        allocation: ev.bank_tracking(ev.bank_entry("VSC3 + FF", "shared_budget", allocation), 16, "shared_budget", 1)
        for allocation in ("proportional", "priority")
    }
    assert rms["priority"]["rms_error_m"] < 0.75 * rms["proportional"]["rms_error_m"]
    with pytest.raises(ValueError, match="allocation = 'greedy'"):
        bank_policy("PID", make(4, "shared_budget"), "greedy")
    assert isinstance(bank_policy("PID", make(4, "fixed_slots"), "priority"), FixedSlotBank)


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


def test_a_priority_residual_corrects_the_asks_and_the_allocator_still_grants():
    """Under the priority allocator a residual bank agent changes what each controller asks;
    the allocator still decides who is served, so corrections that all ask for more cannot
    split the cycle among everyone (the env's proportional scaling would)."""
    from sma_gym_agents.bank import BankResidual

    env = make(4, "shared_budget")
    levels = (2e-3, 4e-3, 8e-3, 6e-3)
    obs, _ = env.reset(seed=0, options={"references": [{"kind": "step", "t1_s": 0.0, "level1_m": v} for v in levels]})
    residual = BankResidual(env, "VSC3 + FF", 1.0, "priority")
    ask = residual.observe(obs[None], np.array([True]))
    assert ask.shape == (1, 4) and ask.max() > 0.9  # every controller far below asks (almost) everything
    duty = env.unwrapped.duty_for(residual.action(np.ones((1, 4))))
    np.testing.assert_allclose(duty, [[0.0, 0.0, 1.0, 0.0]], atol=1e-6)  # the largest error, 8 mm
    duty = env.unwrapped.duty_for(residual.action(-np.ones((1, 4))))
    np.testing.assert_allclose(duty, 0.0, atol=1e-6)


def test_the_evaluation_report_shows_the_bank_tables_and_bad_bank_entries_are_refused_at_once(tmp_path):
    from sma_gym_agents.report import write_report

    with pytest.raises(ValueError, match="allocation = 'bogus'"):
        ev.bank_entry("VSC3 + FF", "shared_budget", "bogus")
    with pytest.raises(ValueError, match="scheme = 'shared'"):
        ev.bank_entry("VSC3 + FF", "shared")
    with pytest.raises(ValueError, match="PriorityAllocator: env scheme = 'fixed_slots'"):
        PriorityAllocator("PID", make(2, "fixed_slots"))
    with pytest.raises(ValueError, match="no multiplexed bank"):
        PriorityAllocator("PID", gym.make("sma_gym:SMATracking-v0"))
    results = ev.Results()
    entries = [ev.bank_entry("PID", "shared_budget"), ev.bank_entry("PID", "shared_budget", "priority")]
    ev.run_bank_tracking(entries, results, 2, "shared_budget", seeds=(0,))
    write_report(results, tmp_path)
    text = (tmp_path / "evaluation.md").read_text()
    assert "The bank on independent references" in text
    assert "| PID (budget allocator) | 2 actuators, shared budget |" in text
    assert "| PID (priority allocator) | 2 actuators, shared budget |" in text
    # The bank step's table: mean over seeds, the worst in parentheses, "never" for no rise.
    step = {"rise_time_s": [np.inf, np.inf], "half_rise_time_s": [13.9, 13.8], "holders_max_error_m": [5e-6, 1.5e-5]}
    results.records += ev._records("9 bank", "PID (fixed slots)", "16 actuators", "bank step", step)
    write_report(results, tmp_path)
    text = (tmp_path / "evaluation.md").read_text()
    assert "| PID (fixed slots) | 16 actuators | never | 13.850 (13.900) | 0.010 (0.015) |" in text
