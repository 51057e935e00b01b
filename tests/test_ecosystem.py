"""Issue 15: the envs fit the tools RL users already run (Gymnasium vector wrappers, batched
and JSON info consumers, SB3 episode logging, the registry, video)."""

import json
import re
import subprocess
import sys
import warnings
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import sma_gym
from sma_gym.envs.sb3 import SB3VecEnv

SINGLE_ACTUATOR_IDS = ("SMATracking-v0", "SMASelfSensing-v0", "SMARobust-v0")
NOISY = {"position_noise_std_m": 1e-5, "resistance_noise_std_ohm": 0.01}


def native(env_id="SMATracking-v0", n=3, **kwargs):
    return gym.make_vec("sma_gym:" + env_id, num_envs=n, vectorization_mode="vector_entry_point", **kwargs)


def run_fresh(code: str) -> str:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    return out.stdout


# --- item 3: autoreset modes, vector observation wrappers, render_mode ---------------------------


def test_native_vector_env_defaults_to_gymnasiums_next_step_autoreset():
    assert native().metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    assert (
        gym.make_vec("CartPole-v1", num_envs=2, vectorization_mode="sync").metadata["autoreset_mode"]
        == AutoresetMode.NEXT_STEP
    )
    with pytest.raises(ValueError, match="autoreset_mode"):
        native(autoreset_mode="Sometimes")


@pytest.mark.parametrize("env_id", ["SMASelfSensing-v0", "SMARobust-v0"])
@pytest.mark.parametrize("mode", list(AutoresetMode))
def test_every_autoreset_mode_matches_gymnasiums_sync_vector_env(env_id, mode):
    n, steps = 3, 12
    kwargs = NOISY if env_id == "SMASelfSensing-v0" else {}
    ours = native(env_id, n, max_episode_steps=steps, autoreset_mode=mode, **kwargs)
    theirs = gym.make_vec(
        "sma_gym:" + env_id,
        num_envs=n,
        vectorization_mode="sync",
        max_episode_steps=steps,
        vector_kwargs={"autoreset_mode": mode},
        **kwargs,
    )
    assert ours.metadata["autoreset_mode"] == theirs.metadata["autoreset_mode"] == mode
    a, _ = ours.reset(seed=3)
    b, _ = theirs.reset(seed=3)
    assert np.array_equal(a, b)
    rng = np.random.default_rng(1)
    ended = 0
    for k in range(3 * steps + 2):
        actions = rng.uniform(-1, 1, size=(n, 1)).astype(np.float32)
        ra, rb = ours.step(actions), theirs.step(actions)
        for x, y in zip(ra[:4], rb[:4]):
            assert np.array_equal(x, y), (mode, k)
        assert np.array_equal(ra[4]["position_m"], rb[4]["position_m"])
        done = ra[2] | ra[3]
        if mode == AutoresetMode.SAME_STEP and done.any():
            assert np.array_equal(ra[4]["_final_obs"], rb[4]["_final_obs"])
            for i in np.flatnonzero(done):
                assert np.array_equal(ra[4]["final_obs"][i], rb[4]["final_obs"][i])
        if mode == AutoresetMode.DISABLED and done.any():
            with pytest.raises(ValueError, match="reset_mask"):
                ours.step(actions)
            a, _ = ours.reset(options={"reset_mask": done})
            b, _ = theirs.reset(options={"reset_mask": done})
            assert np.array_equal(a, b)
        ended += int(done.sum())
    assert ended >= 2 * n


@pytest.mark.parametrize("env_id", sma_gym.ENV_IDS)
def test_a_masked_reset_marks_only_the_reset_sub_envs_info_as_gymnasiums_sync_env_does(env_id):
    """``info["_key"][i]`` says whether sub-env i has an entry: after a masked reset, only the
    reset ones (the native envs marked every sub-env, so a loop that finds its fresh episodes
    by the masks took the running ones for new)."""
    mask = np.array([False, True, False])
    ours, theirs = native(env_id, 3), gym.make_vec("sma_gym:" + env_id, num_envs=3, vectorization_mode="sync")
    for env in (ours, theirs):
        env.reset(seed=0)
        for _ in range(5):
            env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    (a, info_a), (b, info_b) = ours.reset(options={"reset_mask": mask}), theirs.reset(options={"reset_mask": mask})
    assert np.array_equal(a, b)
    assert {k for k in info_b if k.startswith("_")} <= set(info_a)
    for key in (k for k in info_b if k.startswith("_")):
        assert np.array_equal(info_a[key], mask), key
        assert np.array_equal(info_a[key[1:]][mask], info_b[key[1:]][mask]), key
    info_a["_time_s"][0] = True  # each mask its own array, not the caller's
    assert not mask[0] and not ours.reset(options={"reset_mask": mask})[1]["_time_s"][0]
    assert ours.reset()[1]["_time_s"].all()


@pytest.mark.parametrize("env_id", ["SMATracking-v0", "SMAMultiplexed-v0"])
def test_the_ignored_action_of_a_sub_env_that_restarts_may_be_nan_as_in_gymnasiums_sync_env(env_id):
    """NEXT_STEP: the step after an episode ends ignores that sub-env's action (Gymnasium's
    sync env never passes it on), so a policy's NaN there is no error; elsewhere it is."""
    ours = native(env_id, 2, max_episode_steps=2)
    theirs = gym.make_vec("sma_gym:" + env_id, num_envs=2, vectorization_mode="sync", max_episode_steps=2)
    zeros = np.zeros(ours.action_space.shape, dtype=np.float32)
    nan = np.full_like(zeros, np.nan)
    for env in (ours, theirs):
        env.reset(seed=0)
        env.step(zeros)
        *_, truncated, _ = env.step(zeros)
        assert truncated.all()
    (a, ra, *_), (b, rb, *_) = ours.step(nan), theirs.step(nan)
    assert np.array_equal(a, b) and np.array_equal(ra, rb) and not ra.any()
    with pytest.raises(ValueError, match=r"actions\[0.*nan"):
        ours.step(nan)


def test_gymnasiums_vector_observation_wrappers_run_on_the_native_vector_env():
    from gymnasium.wrappers.vector import (
        DtypeObservation,
        FlattenObservation,
        NormalizeObservation,
        TransformObservation,
    )

    venv = native(n=4, max_episode_steps=20)
    venv = NormalizeObservation(venv)
    venv = FlattenObservation(venv)
    venv = DtypeObservation(venv, np.float64)
    venv = TransformObservation(venv, lambda obs: np.clip(obs, -5.0, 5.0), venv.observation_space)
    obs, _ = venv.reset(seed=0)
    assert obs.dtype == np.float64 and obs.shape == venv.observation_space.shape
    for _ in range(45):
        obs, *_ = venv.step(venv.action_space.sample())
        assert np.all(np.isfinite(obs)) and obs.dtype == np.float64
    venv.close()


def test_vector_entry_point_accepts_render_mode_and_renders_each_sub_env():
    venv = native(n=2, render_mode="rgb_array")
    assert venv.render_mode == "rgb_array"
    venv.reset(seed=0)
    first = venv.render()
    for _ in range(30):
        venv.step(np.ones((2, 1), np.float32))
    later = venv.render()
    assert len(later) == 2 and all(f.shape == (640, 640, 3) and f.dtype == np.uint8 for f in later)
    assert not np.array_equal(first[0], later[0])
    with pytest.raises(ValueError, match="render_mode"):
        native(render_mode="human")


def test_sb3_render_tiles_the_native_vector_envs_frames():
    """SB3's ``render()`` (and ``VecVideoRecorder``) tile ``get_images()``; the adapter gave
    ``None`` for each sub-env, so they failed inside SB3's ``tile_images``."""
    venv = SB3VecEnv(native(n=2, render_mode="rgb_array"))
    venv.reset()
    venv.step(np.zeros((2, 1), np.float32))
    assert venv.render().shape == (1280, 640, 3)  # two 640x640 frames, as DummyVecEnv tiles them
    assert SB3VecEnv(native(n=2)).get_images() == [None, None]


@pytest.mark.parametrize("mode", ["sync", "vector_entry_point"])
@pytest.mark.parametrize(("given", "ends_after"), [(None, 1000), (-1, None), (7, 7)])
def test_make_vec_truncates_alike_in_every_vectorization_mode(mode, given, ends_after):
    """As ``gym.make``: ``None`` is the registered 1000 steps, ``-1`` never (the native env
    took ``None`` as never, so the mode decided the episode's length)."""
    venv = gym.make_vec("sma_gym:SMATracking-v0", 1, vectorization_mode=mode, max_episode_steps=given)
    venv.reset(seed=0)
    steps = 0
    while steps < 1100:
        *_, terminated, truncated, _ = venv.step(np.zeros((1, 1), np.float32))
        steps += 1
        if terminated[0] or truncated[0]:
            assert truncated[0] and not terminated[0]
            break
    assert (steps if steps < 1100 else None) == ends_after


def test_an_env_that_has_rendered_can_still_be_copied_and_pickled():
    import copy
    import pickle

    for env in (gym.make("sma_gym:SMATracking-v0", render_mode="rgb_array"), native(n=2, render_mode="rgb_array")):
        env.reset(seed=0)
        env.step(env.action_space.sample())
        env.render()
        twin = copy.deepcopy(env)
        pickle.loads(pickle.dumps(env))  # matplotlib's canvas could not be pickled
        action = env.action_space.sample()
        assert np.array_equal(env.step(action)[0], twin.step(action)[0])
        frame = twin.render()
        assert (frame[0] if isinstance(frame, tuple) else frame).shape == (640, 640, 3)


# --- item 4: info is flat, fixed-shape and JSON-serialisable ------------------------------------------


@pytest.mark.parametrize("env_id", SINGLE_ACTUATOR_IDS)
def test_single_env_info_is_flat_json_with_the_same_keys_at_reset_and_step(env_id):
    env = gym.make("sma_gym:" + env_id)
    _, reset_info = env.reset(seed=0)
    _, _, _, _, step_info = env.step(env.action_space.sample())
    for info in (reset_info, step_info):
        json.dumps(info)
        assert {type(v) for v in info.values()} <= {float, int, bool}, info
    assert set(reset_info) == set(step_info)
    described = env.unwrapped.reference_description()
    assert described["kind"] in ("step", "ramp", "sine", "random")
    assert reset_info["reference_kind"] == ("step", "ramp", "sine", "random").index(described["kind"])


def test_robust_env_reports_its_condition_as_fixed_numeric_keys():
    env = gym.make("sma_gym:SMARobust-v0")
    keys = None
    for seed in range(6):
        _, info = env.reset(seed=seed)
        condition = env.unwrapped.condition
        assert info["condition_supply_voltage_v"] == condition["supply_voltage_v"]
        assert info["condition_forced_convection"] == (condition["convection"] == "forced")
        found = {k for k in info if k.startswith("condition_")}
        assert keys is None or found == keys
        keys = found
    assert len(keys) == 8


@pytest.mark.parametrize("env_id", SINGLE_ACTUATOR_IDS)
def test_vector_env_info_holds_fixed_shape_numeric_arrays_only(env_id):
    n = 4
    venv = native(env_id, n, reference=("random", "sine"))
    _, reset_info = venv.reset(seed=0)
    _, _, _, _, step_info = venv.step(np.zeros((n, 1), np.float32))
    for info in (reset_info, step_info):
        for key, value in info.items():
            assert isinstance(value, np.ndarray) and value.shape == (n,) and value.dtype != object, key
    assert set(reset_info) == set(step_info)
    assert [d["kind"] for d in venv.unwrapped.reference_description()] == [
        ("step", "ramp", "sine", "random")[k] for k in reset_info["reference_kind"]
    ]


def test_multiplexed_info_has_fixed_shape_entries_and_no_nested_descriptions():
    env = gym.make("sma_gym:SMAMultiplexed-v0", n_actuators=3)
    _, reset_info = env.reset(seed=0)
    _, _, _, _, step_info = env.step(env.action_space.sample())
    assert set(reset_info) == set(step_info)
    for info in (reset_info, step_info):
        for key, value in info.items():
            assert isinstance(value, float) or (
                isinstance(value, np.ndarray) and value.shape == (3,) and value.dtype != object
            ), key
        json.dumps({k: np.asarray(v).tolist() for k, v in info.items()})
    assert len(env.unwrapped.reference_description()) == 3


def test_an_unknown_kwarg_is_a_type_error_in_pythons_words_as_tools_probe_for():
    """TorchRL's ``GymEnv`` makes an env with ``frameskip`` and drops it on a ``TypeError``
    saying "unexpected keyword argument 'frameskip'" (Python's own wording); a plain
    ``ValueError`` stopped it for every id."""
    for env_id in sma_gym.ENV_IDS:
        with pytest.raises(TypeError, match="unexpected keyword argument 'frameskip'") as err:
            gym.make(f"sma_gym:{env_id}", frameskip=4)
        assert isinstance(err.value, ValueError)  # as every other bad kwarg, and as before
        assert "render_mode" in str(err.value)  # what it takes instead


def test_torchrl_gym_env_builds_every_id_and_passes_its_spec_check():
    """TorchRL (in the test extra) builds each id by name, and a batched one."""
    from torchrl.envs import GymEnv
    from torchrl.envs.utils import check_env_specs

    for env_id in sma_gym.ENV_IDS:
        env = GymEnv(f"sma_gym:{env_id}")
        check_env_specs(env)
        assert env.rollout(3)["next", "reward"].shape == (3, 1)
        env.close()
    env = GymEnv("sma_gym:SMATracking-v0", num_envs=4)
    check_env_specs(env)
    env.close()
    # Our native vector env, wrapped: TorchRL takes SAME_STEP (or DISABLED), as docs/training.md says.
    from torchrl.envs import GymWrapper

    vec = native("SMATracking-v0", 4, autoreset_mode="SameStep", max_episode_steps=5)
    env = GymWrapper(vec)
    check_env_specs(env)
    rollout = env.rollout(12, break_when_any_done=False)
    assert rollout["next", "done"].sum() == 8  # each sub-env ended twice and went on
    env.close()


# --- item 5: the SB3 adapter reports episodes -----------------------------------------------------------


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_sb3_adapter_puts_monitor_episode_stats_in_infos(mode):
    steps, n = 15, 3
    venv = SB3VecEnv(native(n=n, max_episode_steps=steps, autoreset_mode=mode))
    venv.seed(0)
    obs = venv.reset()
    returns = np.zeros(n)
    episodes = 0
    for _ in range(2 * steps):
        obs, rewards, dones, infos = venv.step(np.full((n, 1), 0.3, np.float32))
        returns += rewards
        for i in np.flatnonzero(dones):
            assert infos[i]["episode"]["l"] == steps
            assert infos[i]["episode"]["r"] == pytest.approx(returns[i], abs=1e-4)
            assert infos[i]["terminal_observation"].shape == obs.shape[1:]
            returns[i] = 0.0
            episodes += 1
        assert all("episode" not in infos[i] for i in np.flatnonzero(~dones))
    assert episodes == 2 * n


def test_sb3_adapter_gives_the_same_run_whatever_the_autoreset_mode():
    runs = []
    for mode in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
        venv = SB3VecEnv(native("SMASelfSensing-v0", n=2, max_episode_steps=7, autoreset_mode=mode, **NOISY))
        venv.seed(4)
        trace = [venv.reset()]
        rng = np.random.default_rng(0)
        for _ in range(20):
            obs, rewards, dones, infos = venv.step(rng.uniform(-1, 1, (2, 1)).astype(np.float32))
            trace += [obs, rewards, dones] + [infos[i]["terminal_observation"] for i in np.flatnonzero(dones)]
        runs.append(trace)
    assert all(np.array_equal(x, y) for x, y in zip(*runs)) and len(runs[0]) == len(runs[1])


def test_sb3_logs_ep_rew_mean_and_evaluate_policy_does_not_warn(tmp_path):
    from stable_baselines3 import PPO
    from stable_baselines3.common.evaluation import evaluate_policy
    from stable_baselines3.common.logger import configure

    venv = SB3VecEnv(native(n=4, max_episode_steps=16))
    model = PPO("MlpPolicy", venv, n_steps=32, batch_size=64, n_epochs=1, seed=0, device="cpu")
    model.set_logger(configure(str(tmp_path), ["csv"]))
    model.learn(total_timesteps=128)
    assert len(model.ep_info_buffer) >= 4
    assert "rollout/ep_rew_mean" in (tmp_path / "progress.csv").read_text().splitlines()[0].split(",")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mean, _ = evaluate_policy(model, venv, n_eval_episodes=4)
    assert np.isfinite(mean)


@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_sb3_adapter_passes_the_robust_envs_conditions_and_the_reset_infos_as_dummy_vec_env(mode):
    """Found by an audit: the adapter passed only the base info keys, so a robust episode's
    condition_* (which the README tells users to read) was lost, and reset_infos stayed empty."""
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv

    ours = SB3VecEnv(native("SMARobust-v0", n=2, max_episode_steps=5, autoreset_mode=mode))
    theirs = DummyVecEnv([lambda: Monitor(gym.make("sma_gym:SMARobust-v0", max_episode_steps=5)) for _ in range(2)])
    for venv in (ours, theirs):
        venv.seed(3)
        venv.reset()
    conditions = sorted(k for k in theirs.reset_infos[1] if k.startswith("condition_"))
    assert len(conditions) == 8 and sorted(k for k in ours.reset_infos[1] if k.startswith("condition_")) == conditions
    assert ours.reset_infos[1]["condition_supply_voltage_v"] == theirs.reset_infos[1]["condition_supply_voltage_v"]
    for step in range(6):  # the episodes end at step 5 and start again
        action = np.full((2, 1), 0.2, np.float32)
        (_, _, done_a, infos_a), (_, _, done_b, infos_b) = ours.step(action), theirs.step(action)
        assert np.array_equal(done_a, done_b)
        for key in ("condition_supply_voltage_v", "condition_wire_diameter_m"):
            assert [i[key] for i in infos_a] == pytest.approx([i[key] for i in infos_b]), (step, key)
        if done_a.any():
            assert ours.reset_infos[0]["condition_supply_voltage_v"] == pytest.approx(
                theirs.reset_infos[0]["condition_supply_voltage_v"]
            )


def test_sb3_adapter_over_a_wrapper_without_partial_resets_says_what_to_use_instead():
    """Gymnasium's NormalizeObservation resets all sub-envs or none (and takes no SAME_STEP
    env): the adapter's restart of the one sub-env that ended raised the wrapper's bare error
    at the first such episode end, 100 steps into training; the docs had recommended it. It is
    refused when the adapter is made, naming what to use."""
    from gymnasium.wrappers.vector import NormalizeObservation
    from stable_baselines3.common.vec_env import VecNormalize

    action = np.array([[1.0], [-1.0]], np.float32)  # sub-env 0 overheats alone
    hot = {"overheat_limit_c": 80.0}
    with pytest.raises(ValueError, match=r"NormalizeObservation: .* expected stable_baselines3's VecNormalize"):
        SB3VecEnv(NormalizeObservation(native(n=2, **hot)))
    # What the message proposes runs through episodes that end apart.
    venv = VecNormalize(SB3VecEnv(native(n=2, **hot)))
    venv.reset()
    ended = 0
    for _ in range(200):
        obs, _, dones, _ = venv.step(action)
        assert np.isfinite(obs).all() and not dones[1]
        ended += int(dones[0])
    assert ended >= 2  # it ended, went on and ended again


def test_an_env_made_with_a_model_config_is_made_again_from_its_json_spec():
    """Gymnasium's EnvSpec.to_json writes a ModelConfig as dataclasses.asdict: made again from
    that JSON, load_model refused it ("'format' = None")."""
    from gymnasium.envs.registration import EnvSpec

    model = sma_gym.load_model("standard").with_actuator(**{"driver.supply_voltage_v": 12.0})
    model = model.with_effect("coulomb_friction", {"force_n": 0.5}, form="stribeck")
    env = gym.make("sma_gym:SMATracking-v0", model=model)
    again = gym.make(EnvSpec.from_json(env.spec.to_json()))
    assert again.unwrapped.settings.model == model
    assert np.array_equal(env.reset(seed=1)[0], again.reset(seed=1)[0])
    params = sma_gym.load_model("wire-0.5mm").actuator  # model=ActuatorParams, the other dataclass a user passes
    env = gym.make("sma_gym:SMATracking-v0", model=params)
    assert gym.make(EnvSpec.from_json(env.spec.to_json())).unwrapped.settings.model.actuator == params


@pytest.mark.parametrize("env_id", ["SMATracking-v0", "SMARobust-v0", "SMAMultiplexed-v0"])
def test_the_native_vector_env_answers_call_get_attr_and_set_attr_as_the_sync_env(env_id):
    """Code written against Gymnasium's sync env (``v.call("reference_description")``) failed
    with an AttributeError on the native one (found by a new user)."""
    native = gym.make_vec(f"sma_gym:{env_id}", num_envs=3, vectorization_mode="vector_entry_point")
    sync = gym.make_vec(f"sma_gym:{env_id}", num_envs=3, vectorization_mode="sync")
    native.reset(seed=5)
    sync.reset(seed=5)
    assert native.call("reference_description") == sync.call("reference_description")
    for name in ("position_scale_m", "resistance_scale_ohm", "control_period_s"):
        mine, theirs = native.get_attr(name), sync.get_attr(name)
        assert len(mine) == 3 and np.allclose(np.asarray(mine, float), np.asarray(theirs, float)), name
        assert native.call(name) == mine
    native.set_attr("max_episode_steps", 7)
    native.set_attr("max_episode_steps", [9, 9, 9])
    assert native.get_attr("max_episode_steps") == (9, 9, 9) and native.spec.max_episode_steps == 9
    refused = [
        (("max_episode_steps", [9, 8, 9]), "the values differ between sub-envs"),
        (("max_episode_steps", [9, 9]), "2 values for 3 sub-envs"),
        (("control_period_s", 0.001), "fixed when the env is made"),
        (("position_scale_m", 0.01), "one value per sub-env"),
    ]
    for args, message in refused:
        with pytest.raises(ValueError, match=message):
            native.set_attr(*args)
    with pytest.raises(ValueError, match=r"call\('reset'\): the native vector env runs its sub-envs as one batch"):
        native.call("reset")
    assert native.get_attr("max_episode_steps") == (9, 9, 9)


def test_sb3_get_attr_gives_each_sub_env_its_own_value():
    venv = SB3VecEnv(native("SMARobust-v0", n=3))
    venv.seed(0)
    venv.reset()
    scales = venv.venv.unwrapped.resistance_scale_ohm
    assert len(set(scales.tolist())) == 3
    assert venv.get_attr("resistance_scale_ohm") == list(scales)
    assert venv.get_attr("resistance_scale_ohm", indices=[2])[0] == scales[2]
    assert venv.get_attr("conditions")[1] == venv.venv.unwrapped.conditions[1]
    assert venv.get_attr("control_period_s") == [0.01] * 3


@pytest.mark.parametrize("env_id", ["SMATracking-v0", "SMAMultiplexed-v0"])
def test_sb3_env_method_reset_returns_each_sub_envs_own_start_and_restarts_its_episode_stats(env_id):
    """As ``DummyVecEnv`` over ``Monitor`` (found by an audit): ``env_method("reset")`` gives
    entry k sub-env k's own ``(obs, info)`` with ``indices=None`` too (it gave the whole batch
    n times), resets a subset of the multiplexed bank's vector env (``AttributeError``:
    no ``reset_envs``), and restarts the episode statistics of the sub-envs it resets (an
    episode restarted 3 steps in was reported 8 steps long instead of 5)."""
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv

    kwargs = {"max_episode_steps": 5}
    ours = SB3VecEnv(native(env_id, 2, **kwargs))
    ref = DummyVecEnv([lambda: Monitor(gym.make("sma_gym:" + env_id, **kwargs)) for _ in range(2)])
    action = np.zeros((2, *ours.action_space.shape), np.float32)
    for indices in (None, [1], [0, 1]):
        lengths = {}
        for name, venv in (("ours", ours), ("ref", ref)):
            venv.seed(0)
            venv.reset()
            for _ in range(3):
                venv.step(action)
            out = venv.env_method("reset", indices=indices)
            chosen = [0, 1] if indices is None else indices
            assert len(out) == len(chosen)
            for obs, info in out:
                assert np.shape(obs) == ours.observation_space.shape and isinstance(info, dict)
            if env_id == "SMATracking-v0":
                assert all(isinstance(info["position_m"], float) for _, info in out)
            for _ in range(5):
                _, _, dones, infos = venv.step(action)
                for i in np.flatnonzero(dones):
                    lengths.setdefault((name, int(i)), infos[i]["episode"]["l"])
        assert lengths[("ours", chosen[0])] == lengths[("ref", chosen[0])] == 5
    with pytest.raises(
        ValueError, match=r"env_method\('reset', 'x'\): expected only the keywords 'seed' and 'options'"
    ):
        ours.env_method("reset", "x")


def test_the_native_vector_envs_check_what_is_set_after_make_and_their_spec_says_their_limit():
    """Found by an audit: ``render()`` before ``reset()`` failed inside numpy ("cannot
    reshape array of size 0"), as Gymnasium's sync env refuses it; ``set_attr`` took a
    ``max_episode_steps`` of 0 (every step ended every episode) or "10" (a numpy error at
    the next step) and a ``render_mode`` the sub-envs' histories were not built for; SB3's
    adapter over ``DictInfoToList`` failed at the first step; ``spec.max_episode_steps``
    said 1000 whatever was given; and the bank's vector env listed the single bank env's
    arguments for an unknown one."""
    from gymnasium.error import ResetNeeded
    from gymnasium.wrappers.vector import DictInfoToList

    env = native(n=2, render_mode="rgb_array")
    with pytest.raises(ResetNeeded, match=r"sub-envs \[0, 1\] were never reset: call reset\(\) before render\(\)"):
        env.render()
    env.reset(seed=0)
    frames = env.render()
    assert len(frames) == 2 and frames[0].shape[2] == 3  # a reset env without a step draws empty axes
    frame = gym.make("sma_gym:SMATracking-v0", render_mode="rgb_array").unwrapped.render()
    assert frame.dtype == np.uint8  # through unwrapped, before reset: empty axes, not a numpy error
    venv = SB3VecEnv(native("SMATracking-v0", 2))
    for value in (0, "10", 2.5):
        with pytest.raises(ValueError, match=rf"max_episode_steps = {value!r}: expected"):
            venv.set_attr("max_episode_steps", value)
    venv.set_attr("max_episode_steps", 7)
    assert venv.get_attr("max_episode_steps") == [7, 7] and venv.venv.spec.max_episode_steps == 7
    with pytest.raises(ValueError, match=r"set_attr\('render_mode'\): fixed when the env is made"):
        venv.set_attr("render_mode", "rgb_array")
    with pytest.raises(ValueError, match=r"DictInfoToList: expected the vector env's own info dict"):
        SB3VecEnv(DictInfoToList(native(n=2)))
    for env_id in ("SMATracking-v0", "SMAMultiplexed-v0"):
        for steps, spec_steps in ((5, 5), (-1, None)):
            assert native(env_id, 2, max_episode_steps=steps).spec.max_episode_steps == spec_steps
        assert gym.make_vec(native(env_id, 2, max_episode_steps=5).spec).unwrapped.max_episode_steps == 5
    with pytest.raises(ValueError, match=r"'n_actuator'.*expected some of \['num_envs', 'n_actuators'") as err:
        native("SMAMultiplexed-v0", 2, n_actuator=4)
    assert "'max_episode_steps'" in str(err.value) and "'model'" in str(err.value)


# --- item 8: contract slips ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "make",
    [
        lambda: gym.make("sma_gym:SMATracking-v0", colour="red"),
        lambda: gym.make("sma_gym:SMAMultiplexed-v0", colour="red"),
        lambda: native(colour="red"),
    ],
)
def test_unknown_kwargs_raise_value_error_naming_them(make):
    with pytest.raises(ValueError, match="colour"):
        make()


@pytest.mark.parametrize("env_id", sma_gym.ENV_IDS)
def test_the_control_period_cannot_be_changed_after_make_where_it_would_do_nothing(env_id):
    """The simulator steps with the period it was built with: setting the attribute on an env,
    through a wrapper or on a native vector env was accepted and ignored."""
    env = gym.make(f"sma_gym:{env_id}", control_period_s=0.005)
    vec = native(env_id, 2, control_period_s=0.005)
    for set_it in (
        lambda: setattr(env.unwrapped, "control_period_s", 0.001),
        lambda: env.set_wrapper_attr("control_period_s", 0.001),
        lambda: setattr(vec, "control_period_s", 0.001),
    ):
        with pytest.raises(AttributeError, match=r"control_period_s = 0.001: fixed when the env is made"):
            set_it()
    assert env.unwrapped.control_period_s == vec.control_period_s == 0.005
    env.reset(seed=0)
    assert env.step(env.action_space.sample())[-1]["time_s"] == pytest.approx(0.005)


def test_pprint_registry_lists_the_four_ids_in_one_group():
    text = gym.pprint_registry(disable_print=True)
    groups = [block for block in text.split("=====") if any(i in block for i in sma_gym.ENV_IDS)]
    assert len(groups) == 1 and all(i in groups[0] for i in sma_gym.ENV_IDS)


def test_spec_id_is_made_again_in_a_fresh_process_without_importing_sma_gym():
    ids = []
    for env_id in sma_gym.ENV_IDS:
        env = gym.make(env_id)  # registered by `import sma_gym`, no prefix given
        assert env.spec.id == "sma_gym:" + env_id
        ids.append(env.spec.id)
    vector_id = native().spec.id
    code = (
        "import sys, gymnasium as gym\n"
        f"for i in {ids!r}:\n"
        "    env = gym.make(i); env.reset(seed=0); env.step(env.action_space.sample())\n"
        "    assert env.spec.id == i, env.spec.id\n"
        f"v = gym.make_vec({vector_id!r}, num_envs=2, vectorization_mode='vector_entry_point')\n"
        f"assert v.spec.id == {vector_id!r}\n"
        "print('ok')\n"
    )
    assert run_fresh(code).strip() == "ok"


# --- item 2: fast rgb_array rendering without global side effects ----------------------------------------


def test_rgb_array_render_leaves_the_global_backend_and_pyplot_alone():
    code = (
        "import matplotlib\n"
        "matplotlib.use('svg')\n"
        "import matplotlib.pyplot as plt, numpy as np, gymnasium as gym\n"
        "for i, kw in (('SMATracking-v0', {}), ('SMAMultiplexed-v0', {'n_actuators': 3})):\n"
        "    env = gym.make('sma_gym:' + i, render_mode='rgb_array', **kw)\n"
        "    env.reset(seed=0)\n"
        "    frames = [env.render()]\n"
        "    for k in range(300):\n"
        "        env.step(np.ones(env.action_space.shape, np.float32))\n"
        "        if k % 100 == 99:\n"
        "            frames.append(env.render())\n"
        "    assert all(f.shape == (640, 640, 3) and f.dtype == np.uint8 for f in frames)\n"
        "    assert all(not np.array_equal(a, b) for a, b in zip(frames, frames[1:]))\n"
        "    assert frames[-1].std() > 10\n"
        "    env.close()\n"
        "assert matplotlib.get_backend() == 'svg', matplotlib.get_backend()\n"
        "assert plt.get_fignums() == []\n"
        "print('ok')\n"
    )
    assert run_fresh(code).strip() == "ok"


def test_blitted_frame_equals_a_fully_redrawn_one():
    env = gym.make("sma_gym:SMATracking-v0", render_mode="rgb_array")
    env.reset(seed=0)
    for _ in range(200):
        env.step(np.array([0.2], np.float32))
        env.render()  # mostly blitted frames
    blitted = env.render()
    env.unwrapped._renderer._plot._background = None  # forces a full redraw
    assert np.array_equal(blitted, env.render())


def test_warmup_runs_every_compiled_path_and_says_where_the_cache_is(capsys):
    """``sma-gym warmup`` (issue 15 item 7): every env id (and its vector env) and both PWM
    modes are exercised, and the user is told whether and where the machine code is cached."""
    from sma_gym.cli import main
    from sma_gym.envs import ENV_IDS
    from sma_gym.warmup import warm_up

    done = warm_up()
    assert set(ENV_IDS) <= set(done.paths)
    assert "SMATracking-v0 (vector)" in done.paths and "Simulator(pwm_mode='resolved')" in done.paths
    assert done.cached == bool(done.cache_dir)
    if done.cached:  # where numba wrote it, not where it was assumed to be
        assert any(Path(done.cache_dir).glob("kernel._advance-*.nbi"))
    assert main(["warmup"]) == 0
    out = capsys.readouterr().out
    assert f"compiled or loaded {len(done.paths)} paths" in out and ("cached in" in out or "not cached" in out)


@pytest.mark.parametrize("env_id", sma_gym.ENV_IDS)
def test_an_episode_that_ends_on_its_last_step_is_terminated_and_truncated_as_in_gymnasiums_sync_env(env_id):
    """Gymnasium's ``TimeLimit`` truncates at the step limit whatever ``terminated`` says, so a
    wire that overheats on the last step is both; the native envs reported it terminated only
    (a loop that counts time-outs apart from failures saw one fewer)."""
    hot = {"overheat_limit_c": 80.0}
    probe = native(env_id, 1, **hot)
    probe.reset(seed=0)
    full = np.ones(probe.action_space.shape, dtype=np.float32)
    step = 1
    while not probe.step(full)[2][0]:
        step += 1
        assert step < 200, "the wire never overheated at full duty"
    ours = native(env_id, 1, max_episode_steps=step, **hot)
    theirs = gym.make_vec("sma_gym:" + env_id, num_envs=1, vectorization_mode="sync", max_episode_steps=step, **hot)
    for env in (ours, theirs):
        env.reset(seed=0)
        for _ in range(step - 1):
            env.step(full)
    (*_, term_a, trunc_a, _), (*_, term_b, trunc_b, _) = ours.step(full), theirs.step(full)
    assert term_b[0] and trunc_b[0]
    assert np.array_equal(term_a, term_b) and np.array_equal(trunc_a, trunc_b)


@pytest.mark.parametrize("env_id", ["SMATracking-v0", "SMAMultiplexed-v0"])
def test_rendering_a_native_vector_env_without_a_render_mode_warns_and_gives_no_frames_as_the_sync_env(env_id):
    ours = native(env_id, 2)
    theirs = gym.make_vec("sma_gym:" + env_id, num_envs=2, vectorization_mode="sync")
    for env in (ours, theirs):
        env.reset(seed=0)
        with pytest.warns(UserWarning, match="render_mode"):
            assert env.render() == (None, None)


def test_reset_envs_given_one_index_instead_of_a_list_says_so():
    with pytest.raises(
        ValueError, match=r"reset_envs indices = 0: expected a sequence of sub-env indices, e\.g\. \[0\]"
    ):
        native("SMATracking-v0", 2).unwrapped.reset_envs(0)


@pytest.mark.parametrize("env_id", ["SMATracking-v0", "SMAMultiplexed-v0"])
def test_sb3_env_method_gives_each_sub_env_its_own_reference_as_dummy_vec_env(env_id):
    """``env_method("reference_description")`` gave every sub-env the whole batch's list, and
    a subset was refused (a new user's trial); DummyVecEnv gives each its own."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    ours = SB3VecEnv(native(env_id, 3))
    ref = DummyVecEnv([lambda: gym.make("sma_gym:" + env_id) for _ in range(3)])
    for venv in (ours, ref):
        venv.seed(4)
        venv.reset()
    assert ours.env_method("reference_description") == ref.env_method("reference_description")
    assert ours.env_method("reference_description", indices=[2]) == ref.env_method("reference_description", indices=[2])
    assert len(ours.env_method("reference_description", indices=1)) == 1


@pytest.mark.parametrize("env_id", ["SMATracking-v0", "SMAMultiplexed-v0"])
def test_the_settings_an_env_was_made_with_are_read_only_and_its_energy_weight_acts_when_set(env_id):
    """``env.unwrapped.overheat_limit_c = 90`` and SB3's ``set_attr("energy_weight", 5)`` were
    taken and changed nothing (``get_attr`` even gave the new value back; a new user's
    trial): the settings checked together at make now refuse, and the energy weight (a
    reward curriculum) acts from the next step, as an env made with it does."""
    made = gym.make("sma_gym:" + env_id, energy_weight=5.0)
    action = np.ones(made.action_space.shape, np.float32)
    made.reset(seed=0)
    expected = made.step(action)[1]
    single = gym.make("sma_gym:" + env_id)
    single.unwrapped.energy_weight = 5.0
    single.reset(seed=0)
    assert single.step(action)[1] == expected and single.unwrapped.energy_weight == 5.0
    vec = gym.make_vec("sma_gym:" + env_id, num_envs=2, vectorization_mode="vector_entry_point")
    sb3 = SB3VecEnv(gym.make_vec("sma_gym:" + env_id, num_envs=2, vectorization_mode="vector_entry_point"))
    vec.set_attr("energy_weight", 5.0)
    sb3.set_attr("energy_weight", 5.0)
    vec.reset(seed=0)
    sb3.seed(0)
    sb3.reset()
    actions = np.stack([action, action])
    assert vec.step(actions)[1][0] == expected
    assert sb3.step(actions)[1][0] == pytest.approx(expected, rel=1e-6)  # SB3's rewards are float32
    with pytest.raises(ValueError, match=r"energy_weight = -1: expected a value in \[0, 10\]"):
        single.unwrapped.energy_weight = -1
    for name, value in (("overheat_limit_c", 90.0), ("model", "wire-0.5mm"), ("reference", "sine"), ("pwm_mode", "x")):
        with pytest.raises(
            AttributeError, match=rf"{name} = .*fixed when the env is made.*gym.make\(id, {name}=\.\.\.\)"
        ):
            setattr(single.unwrapped, name, value)
        with pytest.raises(ValueError, match="fixed when the env is made"):  # as control_period_s
            vec.set_attr(name, value)
    assert single.unwrapped.overheat_limit_c == made.unwrapped.overheat_limit_c


@pytest.mark.parametrize("env_id", ["SMATracking-v0", "SMAMultiplexed-v0"])
def test_a_step_after_the_episode_terminated_warns_once_per_episode(env_id):
    """As Gymnasium's classic-control envs do; it stepped on silently (a new user's trial)."""
    env = gym.make("sma_gym:" + env_id, overheat_limit_c=80.0).unwrapped
    action = np.ones(env.action_space.shape, np.float32)
    for _ in range(2):
        env.reset(seed=0)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            while not env.step(action)[2]:
                pass
        with pytest.warns(UserWarning, match=r"step\(\) after the episode terminated.*call reset\(\) first"):
            env.step(action)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            env.step(action)  # once per episode


def test_a_reference_asked_for_before_reset_names_the_sub_envs_not_the_actuators():
    """A bank vector env of 2 sub-envs named its 8 actuators (a new user's trial)."""
    from gymnasium.error import ResetNeeded

    for env_id, words in (("SMAMultiplexed-v0", "sub-envs (banks) [0, 1]"), ("SMATracking-v0", "sub-envs [0, 1]")):
        vec = gym.make_vec(f"sma_gym:{env_id}", num_envs=2, vectorization_mode="vector_entry_point")
        with pytest.raises(ResetNeeded, match=re.escape(f"no reference yet for {words}: call reset() first")):
            vec.call("reference_description")


@pytest.mark.parametrize("value", [np.array([0.1]), [0.1], (0.1, 0.2)])
def test_a_number_given_as_an_array_is_refused_as_such_not_as_out_of_range(value):
    """``energy_weight=np.array([0.1])`` was told to be in [0, 10], which it is (a new user's trial)."""
    with pytest.raises(ValueError, match=r"expected a value in \[0, 10\], a single number, not an array or sequence"):
        gym.make("sma_gym:SMATracking-v0", energy_weight=value)
