"""Agents that scale with n (issue 16): one policy per actuator, shared by the bank."""

from __future__ import annotations

from dataclasses import replace

import gymnasium as gym
import numpy as np
import pytest

import sma_gym  # noqa: F401  (registers the ids)
from sma_gym_agents.bank import CONTEXT_FEATURES, BankAgent, BankView
from sma_gym_agents.card import PolicyCard
from sma_gym_agents.training.config import RunConfig, parse_args
from sma_gym_agents.training.envs import make_vec_env


def bank(n: int, scheme: str = "fixed_slots", steps: int = 20):
    return gym.make(
        "sma_gym:SMAMultiplexed-v0", n_actuators=n, scheme=scheme, control_period_s=0.01, max_episode_steps=steps
    )


def test_bank_view_rows_are_own_features_plus_context_that_does_not_grow_with_n():
    view = BankView("shared_budget")
    env = bank(3, "shared_budget")
    obs, _ = env.reset(seed=0)
    obs, *_ = env.step(np.array([1.0, 0.0, -1.0], dtype=np.float32))  # shares 1, 0.5, 0: scaled by 1/1.5
    rows = view.rows(obs)
    assert rows.shape == (3, 10 + len(CONTEXT_FEATURES)) == (3, BankView.observation_space().shape[0])
    np.testing.assert_array_equal(rows[:, :10], obs.reshape(3, 10))
    np.testing.assert_allclose(rows[:, 10], 3 / 16)
    np.testing.assert_allclose(rows[:, 11], 1.0)  # a shared budget: one actuator may take the cycle
    np.testing.assert_allclose(rows[:, 12], [1 / 3, 2 / 3, 1.0], rtol=1e-5)  # what the others took
    np.testing.assert_allclose(rows[:, 13], 1.0)
    assert BankView("fixed_slots").rows(np.zeros((2, 40)))[0, 11] == pytest.approx(0.25)
    with pytest.raises(ValueError, match="width 25"):
        view.rows(np.zeros(25))


def test_bank_vec_env_gives_each_actuator_its_own_reward_and_ends_the_bank_together():
    venv = make_vec_env("SMAMultiplexed-v0", 2, {"n_actuators": 3, "control_period_s": 0.01}, 1, 0, max_episode_steps=5)
    assert venv.num_envs == 6 and venv.action_space.shape == (1,)
    obs = venv.reset()
    assert obs.shape == (6, 14)
    for _ in range(5):
        obs, rewards, dones, infos = venv.step(np.full((6, 1), 0.5, dtype=np.float32))
        banks = venv.venv.get_attr("actuator_rewards")
        np.testing.assert_allclose(rewards, np.concatenate(banks), rtol=1e-6)
    assert dones.all() and all("terminal_observation" in i and "episode" in i for i in infos)
    assert infos[0]["terminal_observation"].shape == (14,)
    venv.close()
    # A residual bank agent's rows (terminal ones too) carry the base share last.
    venv = make_vec_env(
        "SMAMultiplexed-v0", 2, {"n_actuators": 3, "control_period_s": 0.01}, 1, 0, "none", "PID", 1.0, 5
    )
    assert venv.reset().shape == (6, 15)
    for _ in range(5):
        obs, rewards, dones, infos = venv.step(np.full((6, 1), 0.5, dtype=np.float32))
    assert dones.all() and obs.shape == (6, 15) and infos[4]["terminal_observation"].shape == (15,)
    assert 0.0 <= infos[4]["terminal_observation"][-1] <= 1.0
    venv.close()


def test_train_py_config_trains_the_bank_with_its_wrapper_only():
    run = RunConfig.from_args(
        parse_args(["--env", "SMAMultiplexed-v0", "--env-kwargs", "n_actuators:16", "scheme:shared_budget"])
    )
    assert run.env_kwargs["n_actuators"] == 16 and run.env_kwargs["scheme"] == "shared_budget"
    assert (run.history, run.residual, run.residual_scale, run.frame_stack) == ("none", "VSC3 + FF", 1.0, 1)
    # The file's base grants an overrun shared budget by priority; the card says so, and reads back.
    assert run.residual_allocation == "priority"
    card = run.card(run.agent_name)
    assert card.as_dict()["residual_allocation"] == "priority"
    assert PolicyCard.from_dict(card.as_dict()).residual_allocation == "priority"
    assert "residual_allocation" not in replace(card, residual_allocation="proportional").as_dict()
    with pytest.raises(ValueError, match="residual_allocation = 'greedy'"):
        PolicyCard.from_dict({**card.as_dict(), "residual_allocation": "greedy"})
    with pytest.raises(ValueError, match="residual_allocation = 'greedy'"):
        replace(run, residual_allocation="greedy").checked()
    plain = RunConfig.from_args(parse_args(["--env", "SMAMultiplexed-v0", "--residual", "none"]))
    assert plain.residual is None
    with pytest.raises(ValueError, match="--history none"):
        RunConfig.from_args(parse_args(["--env", "SMAMultiplexed-v0", "--history", "ema"]))
    with pytest.raises(ValueError, match="--residual 'VSC9'"):
        RunConfig.from_args(parse_args(["--env", "SMAMultiplexed-v0", "--residual", "VSC9"]))
    with pytest.raises(ValueError, match="KEY:VALUE"):
        RunConfig.from_args(parse_args(["--env", "SMAMultiplexed-v0", "--env-kwargs", "n_actuators=16"]))


def test_one_saved_policy_acts_on_banks_of_1_4_and_16(tmp_path):
    from stable_baselines3 import SAC

    venv = make_vec_env(
        "SMAMultiplexed-v0", 1, {"n_actuators": 4, "control_period_s": 0.01}, 1, 0, max_episode_steps=20
    )
    model = SAC("MlpPolicy", venv, learning_starts=20, batch_size=32, policy_kwargs={"net_arch": [16]}, seed=0)
    model.learn(40)
    model.save(tmp_path / "bank.zip")
    venv.close()
    loaded = SAC.load(tmp_path / "bank.zip", device="cpu")
    for scheme in ("fixed_slots", "shared_budget"):
        agent = BankAgent(loaded, scheme)
        for n in (1, 4, 16):
            env = bank(n, scheme)
            obs, _ = env.reset(seed=n)
            action, _ = agent.predict(obs)
            assert action.shape == (n,) and np.all(np.abs(action) <= 1.0)
            env.step(action)
            batch, _ = agent.predict(np.stack([obs, obs]))
            np.testing.assert_allclose(batch[0], action)
            # One model for every actuator: actuator j's action is the model's on its row.
            row_action, _ = loaded.predict(agent.view.rows(obs)[n - 1 : n], deterministic=True)
            assert action[n - 1] == pytest.approx(float(row_action[0, 0]), abs=1e-6)


def test_bank_vec_env_calls_a_method_only_on_the_banks_the_indices_touch():
    from sma_gym_agents.training.envs import BankVecEnv

    class Banks:  # two banks of 3 actuators that record which banks a method ran on
        num_envs = 2
        calls: list[list[int]] = []

        def get_attr(self, name, indices=None):
            return [{"n": 3, "scheme": "fixed_slots"}.get(name)] * 2  # render_mode: None

        def env_method(self, name, *args, indices=None, **kwargs):
            self.calls.append(list(indices))
            return [f"bank {b}" for b in indices]

    inner = Banks()
    venv = BankVecEnv(inner)
    assert venv.env_method("reset", indices=[4, 5]) == ["bank 1", "bank 1"]
    assert venv.env_method("reset", indices=2) == ["bank 0"]
    assert inner.calls == [[1], [0]]
    assert venv.env_method("reset") == ["bank 0"] * 3 + ["bank 1"] * 3 and inner.calls[-1] == [0, 1]


@pytest.mark.parametrize(
    "scheme, allocation",
    [("fixed_slots", "proportional"), ("shared_budget", "proportional"), ("shared_budget", "priority")],
)
def test_a_residual_bank_agent_that_corrects_nothing_is_the_bank_baseline(scheme, allocation):
    from sma_gym_agents.bank import BankResidual, bank_policy

    kwargs = {"n_actuators": 4, "control_period_s": 0.01, "scheme": scheme}
    venv = make_vec_env(
        "SMAMultiplexed-v0", 2, kwargs, 1, 0, residual="VSC3 + FF", residual_scale=1.0, allocation=allocation
    )
    assert venv.observation_space.shape == (15,)
    # The same two banks, seeded as make_vec_env seeds them, under the baseline alone.
    envs = [gym.make("sma_gym:SMAMultiplexed-v0", **kwargs) for _ in range(2)]
    obs = np.stack([env.reset(seed=b)[0] for b, env in enumerate(envs)])
    baseline = bank_policy("VSC3 + FF", envs[0], allocation)
    rows = venv.reset()
    for t in range(40):
        np.testing.assert_array_equal(rows[:, :14], BankView(scheme).rows(obs))
        starts = np.full(2, t == 0)
        # The row's last feature is the baseline's share of the actuator's duty range (under
        # the priority allocator its controller's ask, which the correction changes before
        # the allocation).
        if allocation == "priority":  # predict, in its two halves (a controller steps once per call)
            ask = baseline.asked_duty(obs, starts)
            np.testing.assert_allclose(rows[:, 14], ask.reshape(-1), atol=1e-6)
            action = 2.0 * baseline.grant(ask, baseline.tracking_error_m(obs, ask.shape), starts) - 1.0
        else:
            action, _ = baseline.predict(obs, episode_start=starts)
            np.testing.assert_allclose(rows[:, 14], (action.reshape(-1) + 1) / 2, atol=1e-6)
        obs = np.stack([env.step(a)[0] for env, a in zip(envs, action)])
        rows, *_ = venv.step(np.zeros((8, 1), dtype=np.float32))
    assert rows[:, 14].max() >= 0.4  # the baseline heats: shares that matter were compared
    venv.close()
    # The correction is a share of the duty range, clipped to it.
    residual = BankResidual(envs[0], "VSC3 + FF", 0.5)
    residual.base_share = np.array([[0.0, 0.25, 0.5, 1.0]])
    np.testing.assert_allclose(residual.action(np.array([[1.0, -1.0, 0.5, 1.0]])), [[0.0, -1.0, 0.5, 1.0]])
    with pytest.raises(ValueError, match="scale = 0"):
        BankResidual(envs[0], "VSC3 + FF", 0.0)


def test_a_saved_residual_bank_agent_runs_its_base_on_any_n(tmp_path):
    from stable_baselines3 import SAC

    from sma_gym_agents.bank import BankResidual, bank_policy

    venv = make_vec_env(
        "SMAMultiplexed-v0", 1, {"n_actuators": 4, "control_period_s": 0.01}, 1, 0, "none", "PID", 1.0, 20
    )
    model = SAC("MlpPolicy", venv, learning_starts=20, batch_size=32, policy_kwargs={"net_arch": [16]}, seed=0)
    model.learn(40)
    venv.close()
    for n in (1, 16):
        env = bank(n)
        obs, _ = env.reset(seed=n)
        agent = BankAgent(model, "fixed_slots", residual=BankResidual(env, "PID", 1.0))
        agent.reset()
        action, _ = agent.predict(obs, episode_start=np.array([True]))
        base, _ = bank_policy("PID", env).predict(obs, episode_start=np.array([True]))
        correction, _ = model.predict(agent.view.rows(obs, (base + 1) / 2), deterministic=True)
        expected = np.clip((base + 1) / 2 + correction.reshape(-1), 0, 1) * 2 - 1
        assert action.shape == (n,)
        np.testing.assert_allclose(action, expected, atol=1e-6)


def test_a_bank_agents_card_is_run_when_loaded_not_after_the_other_chapters(tmp_path):
    """A card naming an unknown residual base, or a bank of 2.5 actuators, loaded without a
    word; ``sma-gym evaluate`` refused it only in chapter 9, after Table 6.1 and chapters 7-8."""
    from stable_baselines3 import SAC

    from sma_gym_agents.trained import load_policy, save_policy

    kwargs = {"n_actuators": 4, "control_period_s": 0.01}
    venv = make_vec_env("SMAMultiplexed-v0", 1, kwargs, 1, 0, max_episode_steps=20)
    model = SAC("MlpPolicy", venv, learning_starts=20, batch_size=32, policy_kwargs={"net_arch": [8]}, seed=0)
    venv.close()
    card = {
        "format": "sma-gym-policy",
        "algo": "SAC",
        "name": "bank",
        "env_id": "SMAMultiplexed-v0",
        "env_kwargs": kwargs,
        "frame_stack": 1,
    }
    assert load_policy(save_policy(model, tmp_path / "ok.zip", card)).env_kwargs == kwargs
    for name, bad, field in (
        ("base", {"residual": "bogus"}, "bogus"),
        # A residual agent's rows carry the base's action: this model was trained without one.
        ("width", {"residual": "VSC3 + FF"}, "observation shape"),
        ("half", {"env_kwargs": {**kwargs, "n_actuators": 2.5}}, "n_actuators"),
    ):
        path = save_policy(model, tmp_path / f"{name}.zip", {**card, **bad})
        with pytest.raises(ValueError, match=f"{name}.zip.*card.*{field}"):
            load_policy(path)


def test_a_bank_agent_runs_only_on_a_bank_of_its_own_scheme(tmp_path):
    """From an audit: a fixed-slots agent ran on a shared-budget env, the model told "duty cap
    1/n, shared 0" while the env and its base shared one budget."""
    from stable_baselines3 import SAC

    from sma_gym_agents.bank import BankAgent
    from sma_gym_agents.trained import load_policy, save_policy

    kwargs = {"n_actuators": 4, "control_period_s": 0.01}
    venv = make_vec_env("SMAMultiplexed-v0", 1, kwargs, 1, 0, max_episode_steps=20)
    model = SAC("MlpPolicy", venv, learning_starts=20, batch_size=32, policy_kwargs={"net_arch": [8]}, seed=0)
    venv.close()
    card = {"format": "sma-gym-policy", "algo": "SAC", "name": "bank", "env_id": "SMAMultiplexed-v0"}
    agent = load_policy(save_policy(model, tmp_path / "fixed.zip", {**card, "env_kwargs": kwargs, "frame_stack": 1}))
    BankAgent.from_policy(agent, gym.make("sma_gym:SMAMultiplexed-v0", n_actuators=8))  # any n, the same scheme
    shared = gym.make("sma_gym:SMAMultiplexed-v0", n_actuators=4, scheme="shared_budget")
    with pytest.raises(ValueError, match=r"trained on scheme 'fixed_slots', but the env runs 'shared_budget'"):
        BankAgent.from_policy(agent, shared)
