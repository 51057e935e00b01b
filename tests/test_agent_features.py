"""History features and residual agents: what training builds, evaluation rebuilds exactly."""

import math

import gymnasium as gym
import numpy as np
import pytest

import sma_gym  # noqa: F401
from sma_gym_agents.history import DUTY_TIME_CONSTANTS_S, ERROR_SCALE, HistoryFeatures
from sma_gym_agents.policies import ControllerPolicy
from sma_gym_agents.residual import ResidualStep
from sma_gym_agents.trained import AgentPolicy
from sma_gym_agents.training.envs import make_vec_env

KWARGS = {"control_period_s": 0.01}


def test_history_features_are_exponential_averages_of_the_duty():
    names = ("position", "last_duty")
    dt = 0.01
    h = HistoryFeatures(1, names, dt)
    obs = np.array([[0.2, 0.0]])
    h.reset(obs)
    steps = 100
    for _ in range(steps):
        out, _ = h.update(np.array([[0.2, 1.0]]), np.zeros(1, dtype=bool))
    expected = [1.0 - math.exp(-steps * dt / tau) for tau in DUTY_TIME_CONSTANTS_S]
    np.testing.assert_allclose(out[0, 2:5], expected, rtol=1e-5)
    assert out[0, 5] == pytest.approx(0.2)  # signal EMA of a constant signal
    assert out[0, 6] == 0.0  # no change


def test_history_features_restart_with_the_new_episode_and_keep_the_ended_ones():
    h = HistoryFeatures(2, ("position", "last_duty"), 0.01)
    h.reset(np.zeros((2, 2)))
    for _ in range(50):
        h.update(np.array([[0.5, 1.0], [0.5, 1.0]]), np.zeros(2, dtype=bool))
    first_of_next = np.array([[0.0, 0.0], [0.6, 1.0]])
    last_of_ended = np.array([0.5, 1.0])
    out, ended = h.update(first_of_next, np.array([True, False]), {0: last_of_ended})
    # Env 0 restarted: averages start from the new episode's observation.
    np.testing.assert_array_equal(out[0, 2:6], [0.0, 0.0, 0.0, 0.0])
    # Its terminal observation carries the ended episode's history, not the new one's.
    assert np.all(ended[0][2:5] > 0.1) and ended[0][5] > 0.1
    # Env 1 went on: its averages kept growing and the position change is seen.
    assert np.all(out[1, 2:5] > 0.1) and out[1, 6] == pytest.approx(1.0)


def test_error_features_resolve_small_errors_and_average_them_over_a_second():
    names = ("position", "last_duty", "error")
    h = HistoryFeatures(1, names, 0.01, error_features=True)
    assert h.observation_space(gym.spaces.Box(-1.0, 1.0, (3,))).shape == (3 + 5 + 2,)
    out = h.reset(np.array([[0.2, 0.0, 0.0]]))
    assert out.shape == (1, 10) and out[0, -1] == 0.0 and out[0, -2] == 0.0
    for _ in range(100):  # an error of ERROR_SCALE held for 1 s
        out, _ = h.update(np.array([[0.2, 0.0, ERROR_SCALE]]), np.zeros(1, dtype=bool))
    assert out[0, -2] == pytest.approx(math.tanh(1.0), rel=1e-5)
    assert out[0, -1] == pytest.approx(math.tanh(1.0 - math.exp(-1.0)), rel=1e-4)
    # The plain EMA features stay what they were, in the same columns.
    plain = HistoryFeatures(1, names, 0.01)
    plain.reset(np.array([[0.2, 0.0, 0.0]]))
    for _ in range(100):
        ref, _ = plain.update(np.array([[0.2, 0.0, ERROR_SCALE]]), np.zeros(1, dtype=bool))
    np.testing.assert_array_equal(out[0, :8], ref[0])
    # A restart sets the average to the new episode's error.
    out, _ = h.update(np.array([[0.0, 0.0, -ERROR_SCALE]]), np.array([True]), {0: np.array([0.2, 0.0, ERROR_SCALE])})
    assert out[0, -1] == pytest.approx(-math.tanh(1.0), rel=1e-5)
    # Without a position sensor there is no tracking error to refine.
    with pytest.raises(ValueError, match="no 'error'.*expected history 'ema'"):
        HistoryFeatures.for_env(1, "SMASelfSensing-v0", {}, "ema+error")
    with pytest.raises(ValueError, match="history = 'fft'"):
        HistoryFeatures.for_env(1, "SMATracking-v0", {}, "fft")


def test_residual_filter_is_a_first_order_low_pass_restarted_with_each_episode():
    env = gym.make("sma_gym:SMATracking-v0", **KWARGS)
    residual = ResidualStep(env, "VSC3 + FF", 0.5, filter_s=0.1)
    obs, _ = env.reset(seed=0)
    residual.observe(obs[None, :].astype(float), np.array([True]))
    duty_for = env.unwrapped.duty_range.duty_for
    for k in range(1, 31):
        residual.base_duty = np.array([0.2])
        duty = duty_for(residual.action(np.ones((1, 1))))[0, 0]
        assert duty == pytest.approx(0.2 + 0.5 * (1.0 - math.exp(-k * 0.01 / 0.1)), abs=1e-6)
    # A new episode starts from no correction.
    residual.observe(obs[None, :].astype(float), np.array([True]))
    base = residual.base_duty[0]
    assert duty_for(residual.action(np.zeros((1, 1))))[0, 0] == pytest.approx(base, abs=1e-6)
    # filter_s = 0: the correction as it comes.
    plain = ResidualStep(env, "VSC3 + FF", 0.5, filter_s=0.0)
    plain.observe(obs[None, :].astype(float), np.array([True]))
    plain.base_duty = np.array([0.2])
    assert duty_for(plain.action(np.full((1, 1), 0.5)))[0, 0] == pytest.approx(0.45, abs=1e-6)
    for bad in (-0.1, float("nan")):
        with pytest.raises(ValueError, match="filter_s = .*expected a time constant >= 0 s"):
            ResidualStep(env, "VSC3 + FF", 0.5, filter_s=bad)


def test_residual_with_zero_correction_is_exactly_its_base_controller():
    env = gym.make("sma_gym:SMATracking-v0", **KWARGS)
    base = ControllerPolicy("VSC3 + FF", env)
    residual = ResidualStep(env, "VSC3 + FF", 0.5)
    obs, _ = env.reset(seed=3, options={"reference": "step"})
    for t in range(300):
        augmented = residual.observe(obs[None, :].astype(float), np.array([t == 0]))
        expected, _ = base.predict(obs, episode_start=np.array([t == 0]))
        action = residual.action(np.zeros((1, 1)))[0]
        np.testing.assert_allclose(action, expected, atol=1e-6)
        lo, hi = env.unwrapped.duty_range
        assert augmented[0, -1] == pytest.approx(lo + (expected[0] + 1) * 0.5 * (hi - lo), abs=1e-6)
        obs, *_ = env.step(action)
    # A full positive correction adds residual_scale to the duty (before the duty clip).
    residual.base_duty = np.array([0.2])
    assert residual.action(np.ones((1, 1)))[0, 0] == pytest.approx(2 * 0.7 - 1)


def test_residual_base_without_a_position_sensor_is_the_self_sensing_controller():
    env = gym.make("sma_gym:SMASelfSensing-v0")
    residual = ResidualStep(env, "PID", 0.5)
    assert "self-sensing" in residual.policy.name
    obs, _ = env.reset(seed=0)
    augmented = residual.observe(obs[None, :].astype(float), np.array([True]))
    assert augmented.shape == (1, obs.shape[0] + 1) and np.isfinite(augmented).all()


@pytest.mark.parametrize(
    "history,residual,filter_s",
    [("ema", "VSC3 + FF", 0.0), ("ema+error", "VSC3 + FF", 0.1), ("ema", None, 0.0), ("none", "PID", 0.0)],
)
def test_evaluation_policy_sees_exactly_what_training_saw(history, residual, filter_s):
    """AgentPolicy (raw env observations, as the harness gives them) must rebuild the
    training wrappers' features and compose actions identically, across an episode end."""
    from stable_baselines3 import SAC

    venv = make_vec_env(
        "SMATracking-v0",
        2,
        KWARGS,
        1,
        seed=5,
        history=history,
        residual=residual,
        max_episode_steps=120,
        residual_filter_s=filter_s,
    )
    model = SAC("MlpPolicy", venv, seed=0, device="cpu", learning_starts=10**9)
    agent = AgentPolicy(
        model, "agent", "SMATracking-v0", dict(KWARGS), history=history, residual=residual, residual_filter_s=filter_s
    )
    k = len(gym.make("sma_gym:SMATracking-v0", **KWARGS).unwrapped.feature_names)
    obs = venv.reset()
    starts = np.ones(2, dtype=bool)
    checked_restart = False
    for _ in range(300):
        train_action, _ = model.predict(obs, deterministic=True)
        eval_action, _ = agent.predict(obs[:, :k], episode_start=starts)
        if residual is not None:
            # Training passes the agent's correction to the residual wrapper, which composes it.
            # (Composed on a copy of its filter's state: the step below composes it again.)
            step = _residual_wrapper(venv).residual
            saved = step.correction.copy()
            composed = step.action(train_action)
            step.correction = saved
            np.testing.assert_allclose(eval_action, composed, atol=1e-5)
        else:
            np.testing.assert_allclose(eval_action, train_action, atol=1e-5)
        obs, _, dones, _ = venv.step(train_action)
        checked_restart |= bool(dones.any())
        starts = dones
    assert checked_restart


def _residual_wrapper(venv):
    from sma_gym_agents.training.envs import ResidualVecEnv

    while not isinstance(venv, ResidualVecEnv):
        venv = venv.venv
    return venv


def test_the_evaluation_records_only_info_keys_the_envs_define():
    """The harness picks a few ``info`` keys to record; they must be names of the envs' one
    ``INFO`` definition (a renamed key would otherwise fail only at evaluation time)."""
    from sma_gym.envs.task import INFO
    from sma_gym_agents.evaluation import _RECORD

    assert set(_RECORD) <= set(INFO), sorted(set(_RECORD) - set(INFO))
