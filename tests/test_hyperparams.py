"""hyperparams/<algo>.yml: one source of hyperparameters, read by train.py and RL Zoo.

Every entry must resolve to importable callables and valid values (always checked), pass
the zoo's own preprocessing (when rl_zoo3 is installed), and give train.py the agent it
had before the files moved from TOML to the zoo's YAML (same features, same settings).
"""

from __future__ import annotations

import importlib
import inspect
from dataclasses import replace
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
import yaml

import sma_gym  # noqa: F401  (registers the ids, as the zoo's --gym-packages sma_gym does)
from sma_gym_agents.training.config import (
    ALGOS,
    BANK_WRAPPER,
    HISTORY_WRAPPER,
    NOT_FOR_TRAIN_PY,
    RESIDUAL_WRAPPER,
    RunConfig,
    agent_features,
    literal_kwargs,
    parse_args,
)

ROOT = Path(__file__).resolve().parents[1]
FILES = {algo: ROOT / "hyperparams" / f"{algo}.yml" for algo in ALGOS}
ENTRIES = [(algo, env_id) for algo, path in FILES.items() for env_id in yaml.safe_load(path.read_text())]
SINGLE_ENVS = ("SMATracking-v0", "SMASelfSensing-v0", "SMARobust-v0")


def entry(algo: str, env_id: str) -> dict:
    return yaml.safe_load(FILES[algo].read_text())[env_id]


def resolve(dotted: str) -> object:
    """What the zoo's get_wrapper_class / get_class_by_name import for a dotted name."""
    module, _, name = dotted.rpartition(".")
    return getattr(importlib.import_module(module), name)


def zoo_wrap(venv, spec):
    """The zoo's vec_env_wrapper semantics (rl_zoo3.utils.get_wrapper_class): a name or a
    list of names or {name: kwargs}, applied in order as ``cls(venv, **kwargs)``."""
    for item in [] if spec is None else spec if isinstance(spec, list) else [spec]:
        name, kwargs = next(iter(item.items())) if isinstance(item, dict) else (item, {})
        venv = resolve(name)(venv, **(kwargs or {}))
    return venv


def test_one_source_yaml_per_algorithm_covering_every_env():
    assert not list((ROOT / "hyperparams").glob("*.toml"))
    assert sorted(p.name for p in (ROOT / "hyperparams").iterdir()) == ["ppo.yml", "sac.yml"]
    for algo in ALGOS:
        ids = {env for a, env in ENTRIES if a == algo}
        assert set(SINGLE_ENVS) <= ids, algo
    assert ("sac", "SMAMultiplexed-v0") in ENTRIES


@pytest.mark.parametrize(("algo", "env_id"), ENTRIES)
def test_every_entry_resolves_to_importable_callables_and_valid_values(algo, env_id):
    from stable_baselines3 import PPO, SAC

    hp = entry(algo, env_id)
    gym.spec(env_id)  # registered by plain id, as the zoo looks it up
    # Numbers are numbers: YAML 1.1 reads "2e-6" as a string (the files write 2.0e-6).
    for key in ("n_timesteps", "n_envs", "learning_rate", "gamma", "batch_size"):
        assert isinstance(hp[key], (int, float)) and not isinstance(hp[key], bool), (key, hp[key])
    for key, value in hp.get("env_kwargs", {}).items():
        assert not isinstance(value, str) or key == "reference", (key, value)
    assert "eval_freq" not in hp  # a zoo command-line option: the zoo would pass it to the model
    # Every remaining key is a keyword of the algorithm, as the zoo passes it.
    zoo_keys = {"n_timesteps", "n_envs", "frame_stack", "vec_env_wrapper", "env_kwargs", "policy_kwargs", "normalize"}
    accepted = set(inspect.signature({"sac": SAC, "ppo": PPO}[algo].__init__).parameters)
    assert set(hp) - zoo_keys <= accepted, set(hp) - zoo_keys - accepted
    # policy_kwargs as the zoo evaluates it, and as train.py reads it (literals only).
    assert literal_kwargs(hp["policy_kwargs"], "policy_kwargs") == eval(hp["policy_kwargs"])
    # Wrappers: importable, and callable with the entry's kwargs.
    for item in hp.get("vec_env_wrapper", []):
        name, kwargs = next(iter(item.items())) if isinstance(item, dict) else (item, {})
        cls = resolve(name)
        inspect.signature(cls).bind(object(), **(kwargs or {}))
    # The env accepts the kwargs, and the wrappers stack on a vector env of it as the zoo does.
    from stable_baselines3.common.env_util import make_vec_env

    venv = make_vec_env(lambda **kw: gym.make(env_id, **kw), n_envs=2, seed=0, env_kwargs=hp.get("env_kwargs", {}))
    venv = zoo_wrap(venv, hp.get("vec_env_wrapper"))
    obs = venv.reset()
    # 2 envs, or 2 banks of n actuators, each actuator a sub-env (BankVecEnv)
    assert venv.num_envs == 2 * hp.get("env_kwargs", {}).get("n_actuators", 1) if "Multiplexed" in env_id else 2
    assert obs.shape == (venv.num_envs, *venv.observation_space.shape) and np.all(np.isfinite(obs))
    venv.step(np.zeros((venv.num_envs, *venv.action_space.shape), dtype=np.float32))
    venv.close()


def test_train_py_reads_the_agent_it_had_from_the_toml_files():
    """The values of the former hyperparams/<env>.toml files (same features, same settings;
    the default run's budget halved and Adam's fused kernel since issue 16)."""
    expected = {  # env: (residual, scale, timesteps) for SAC
        "SMATracking-v0": ("VSC3 + FF", 1.0, 200_000),
        "SMASelfSensing-v0": ("PID", 0.5, 1_000_000),
        "SMARobust-v0": ("VSC3 + FF", 0.5, 1_000_000),
    }
    for env_id, (residual, scale, steps) in expected.items():
        run = RunConfig.from_args(parse_args(["--env", env_id]))
        assert (run.algo, run.history, run.residual, run.residual_scale, run.timesteps) == (
            "sac",
            "ema",
            residual,
            scale,
            steps,
        )
        assert (run.n_envs, run.frame_stack, run.eval_freq) == (4, 1, 20_000)
        # The tracking agent's correction is low-passed (chosen over five seeds, docs/training.md).
        assert run.residual_filter_s == (0.1 if env_id == "SMATracking-v0" else 0.0)
        assert run.env_kwargs == {"control_period_s": 0.01, "position_noise_std_m": 2e-6}
        assert run.model_kwargs == {
            "policy": "MlpPolicy",
            "learning_rate": 7.3e-4,
            "buffer_size": 200_000,
            "batch_size": 256,
            "gamma": 0.99,
            "tau": 0.02,
            "train_freq": 4,
            "gradient_steps": 2,
            "learning_starts": 4_000,
            "ent_coef": "auto",
            "policy_kwargs": {"net_arch": [256, 256], "optimizer_kwargs": {"fused": True}},
        }
        ppo = RunConfig.from_args(parse_args(["--env", env_id, "--algo", "ppo"]))
        assert (ppo.timesteps, ppo.n_envs, ppo.eval_freq, ppo.residual_scale) == (3_000_000, 32, 250_000, scale)
        assert ppo.model_kwargs["policy_kwargs"] == {"net_arch": [256, 256], "log_std_init": -1.0}
    assert RunConfig.from_args(parse_args(["--eval-freq", "5000"])).eval_freq == 5000
    for env_id in NOT_FOR_TRAIN_PY:
        with pytest.raises(ValueError, match="RL Zoo"):
            RunConfig.from_args(parse_args(["--env", env_id]))


def test_agent_features_accept_our_wrappers_in_order_only():
    assert agent_features(None) == ("none", None, 0.5, "proportional", 0.0)
    assert agent_features([HISTORY_WRAPPER]) == ("ema", None, 0.5, "proportional", 0.0)
    both = [{RESIDUAL_WRAPPER: {"base": "PID", "scale": 0.3}}, HISTORY_WRAPPER]
    assert agent_features(both) == ("ema", "PID", 0.3, "proportional", 0.0)
    filtered = [{RESIDUAL_WRAPPER: {"base": "PID", "filter_s": 0.1}}, {HISTORY_WRAPPER: {"error_features": True}}]
    assert agent_features(filtered) == ("ema+error", "PID", 0.5, "proportional", 0.1)
    assert agent_features([{HISTORY_WRAPPER: {"error_features": False}}]).history == "ema"
    bank = {"base": "PID", "scale": 1.0, "allocation": "priority"}
    assert agent_features([{BANK_WRAPPER: bank}]) == ("none", "PID", 1.0, "priority", 0.0)
    assert agent_features([BANK_WRAPPER]) == ("none", None, 0.5, "proportional", 0.0)
    with pytest.raises(ValueError, match="allocation = 'greedy'"):
        agent_features([{BANK_WRAPPER: {**bank, "allocation": "greedy"}}])
    with pytest.raises(ValueError, match="base, scale and allocation"):
        agent_features([{BANK_WRAPPER: {"allocation": "priority"}}])
    with pytest.raises(ValueError, match="knows"):
        agent_features([HISTORY_WRAPPER, {RESIDUAL_WRAPPER: {"base": "PID"}}])
    with pytest.raises(ValueError, match="knows"):
        agent_features(["stable_baselines3.common.vec_env.VecNormalize"])
    with pytest.raises(ValueError, match="base"):
        agent_features([{RESIDUAL_WRAPPER: {"scale": 0.3}}])
    with pytest.raises(ValueError, match="base, scale and filter_s"):
        agent_features([{RESIDUAL_WRAPPER: {"base": "PID", "tau": 0.1}}])
    with pytest.raises(ValueError, match="error_features: true/false"):
        agent_features([{HISTORY_WRAPPER: {"error_features": "yes"}}])
    for bad in (-0.1, float("nan")):
        with pytest.raises(ValueError, match="filter_s = .*expected a time constant >= 0 s"):
            replace(RunConfig.from_args(parse_args([])), residual_filter_s=bad).checked()
    with pytest.raises(ValueError, match="policy_kwargs"):
        literal_kwargs("dict(activation_fn=nn.ReLU)", "policy_kwargs")
    assert literal_kwargs("{'net_arch': [64]}", "policy_kwargs") == {"net_arch": [64]}


def test_history_wrapper_built_by_the_zoo_equals_the_one_train_py_builds():
    """HistoryVecEnv(venv) (the zoo's call) reads the features train.py passes explicitly."""
    from stable_baselines3.common.env_util import make_vec_env

    from sma_gym_agents.history import HistoryFeatures
    from sma_gym_agents.training.envs import HistoryVecEnv, ResidualVecEnv

    kwargs = entry("sac", "SMATracking-v0")["env_kwargs"]
    outs = []
    for explicit in (False, True):
        venv = ResidualVecEnv(
            make_vec_env(lambda **kw: gym.make("SMATracking-v0", **kw), n_envs=2, seed=3, env_kwargs=kwargs),
            "VSC3 + FF",
            1.0,
        )
        venv = HistoryVecEnv(venv, HistoryFeatures.for_env(2, "SMATracking-v0", kwargs) if explicit else None)
        obs = [venv.reset()]
        for _ in range(5):
            obs.append(venv.step(np.full((2, 1), 0.1, dtype=np.float32))[0])
        outs.append(np.stack(obs))
        venv.close()
    np.testing.assert_array_equal(outs[0], outs[1])


@pytest.fixture
def zoo_experiment_manager():
    """rl_zoo3's ``ExperimentManager``, with the zoo's global patch undone afterwards: importing
    rl_zoo3 replaces Gymnasium's ``TimeLimit`` everywhere in the process (``rl_zoo3.gym_patches``,
    which adds ``info["TimeLimit.truncated"]``), and a later test in the same worker compared
    our native vector env's info with a sync env that then carried that key."""
    import gymnasium.envs.registration as registration
    import gymnasium.wrappers as wrappers
    import gymnasium.wrappers.common as common

    modules = (wrappers, common, registration)
    saved = [module.__dict__.get("TimeLimit") for module in modules]  # registration has none
    from rl_zoo3.exp_manager import ExperimentManager

    yield ExperimentManager
    for module, value in zip(modules, saved):
        if value is None:
            module.__dict__.pop("TimeLimit", None)
        else:
            module.TimeLimit = value


def test_the_zoo_preprocesses_every_entry(tmp_path, zoo_experiment_manager):
    """RL Zoo's own reading of our files (rl_zoo3: the zoo extra, which the test extra installs)."""
    ExperimentManager = zoo_experiment_manager

    for algo, env_id in ENTRIES:
        manager = ExperimentManager(
            args=None,
            algo=algo,
            env_id=env_id,
            log_folder=str(tmp_path),
            config=str(FILES[algo]),
            verbose=0,
            seed=0,
        )
        hyperparams, _ = manager.read_hyperparameters()
        kwargs, env_wrapper, callbacks, vec_env_wrapper = manager._preprocess_hyperparams(hyperparams)
        assert env_wrapper is None and callbacks == []
        assert vec_env_wrapper is not None  # the bank's too: BankVecEnv
        assert "eval_freq" not in kwargs and "vec_env_wrapper" not in kwargs and "env_kwargs" not in kwargs
        assert manager.n_envs == entry(algo, env_id)["n_envs"] and manager.frame_stack is None
        assert manager.env_kwargs == entry(algo, env_id).get("env_kwargs", {})
        if env_id == "SMATracking-v0" and algo == "sac":
            manager.vec_env_wrapper = vec_env_wrapper  # as setup_experiment stores it
            venv = manager.create_envs(2, no_log=True)
            # residual base duty + 5 history features on top of the raw observation
            assert venv.observation_space.shape[0] == gym.make(env_id).observation_space.shape[0] + 1 + 5
            # The zoo passes the residual's keyword arguments, the low-pass included.
            from sma_gym_agents.training.envs import ResidualVecEnv

            inner = venv
            while not isinstance(inner, ResidualVecEnv):
                inner = inner.venv
            assert inner.residual.filter_s == 0.1 and 0.0 < inner.residual.beta < 1.0
            venv.close()


def test_the_zoo_trains_our_default_agent_from_our_file(tmp_path):
    """``python -m rl_zoo3.train`` with our conf file, a few hundred steps: the saved model
    sees what train.py's does (raw observation, base duty, five history features)."""
    import subprocess
    import sys

    from stable_baselines3 import SAC

    cmd = [
        sys.executable,
        "-m",
        "rl_zoo3.train",
        "--algo",
        "sac",
        "--env",
        "SMATracking-v0",
        "--gym-packages",
        "sma_gym",
        "--conf-file",
        str(FILES["sac"]),
        "-n",
        "400",
        "--eval-freq",
        "-1",
        "--num-threads",
        "1",
        "--seed",
        "0",
        "-f",
        str(tmp_path),
        "-params",
        "learning_starts:100",
        "buffer_size:1000",
    ]
    proc = subprocess.run(cmd, check=False, capture_output=True, text=True, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    (model_zip,) = tmp_path.glob("sac/SMATracking-v0_*/SMATracking-v0.zip")
    model = SAC.load(model_zip, device="cpu")
    raw = gym.make("SMATracking-v0").observation_space.shape[0]
    assert model.observation_space.shape == (raw + 1 + 5,)
    assert (
        model.batch_size == 256
        and model.tau == 0.02
        and model.gradient_steps == 2
        and list(model.policy.net_arch) == [256, 256]
    )
