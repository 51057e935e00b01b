"""train.py end to end on a tiny budget: models, table and plots written, model reloads;
the run configuration (:mod:`sma_gym_agents.training`) and the card (:class:`sma_gym_agents.card.PolicyCard`)."""

import json
import math
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest

from sma_gym_agents.card import CARD_SUFFIX, PolicyCard, card_path
from sma_gym_agents.training import RunConfig, parse_args

ROOT = Path(__file__).resolve().parents[1]


def _run(*args: str, cwd: Path | None = None, timeout: float = 900) -> subprocess.CompletedProcess:
    """Run ``python *args`` as a user would (output captured, the exit code not checked)."""
    return subprocess.run(
        [sys.executable, *args], check=False, capture_output=True, text=True, timeout=timeout, cwd=cwd
    )


def test_train_quick_writes_models_results_and_plots_that_reload(tmp_path):
    out = tmp_path / "run"
    proc = _run(str(ROOT / "train.py"), "--quick", "--no-progress", "--out", str(out), cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert f"run folder: {out}" in proc.stdout
    for name in ("best_model.zip", "best_model.json", "final_model.zip", "results.md", "goals.json", "run.json"):
        assert (out / name).exists(), name
    assert list((out / "checkpoints").glob("*.zip")) and list((out / "checkpoints").glob("*.json"))
    assert list((out / "tb").rglob("events.out.tfevents.*"))
    # The record of how best_model.zip was chosen, written whole (SB3 rewrote it in place).
    validation = np.load(out / "validation" / "evaluations.npz")
    assert len(validation["timesteps"]) >= 1 and [p.name for p in (out / "validation").iterdir()] == ["evaluations.npz"]
    results = (out / "results.md").read_text()
    assert "| PID | standard |" in results and "| VSC3 + FF | standard |" in results and "## Goals" in results
    assert len(list((out / "evaluation").glob("*.png"))) >= 4
    goals = json.loads((out / "goals.json").read_text())
    assert goals["goals"] and len(goals["validation_references"]) == 4  # --quick validates on four
    # The code it ran: the model changes between commits under the same env id.
    from sma_gym.provenance import describe, provenance

    assert goals["provenance"] == provenance() and describe(goals["provenance"]) in results
    # An ordinary SB3 zip: SAC.load opens it; its card says how it observes (history
    # features, residual base) and load_policy rebuilds that to act on the raw env.
    from stable_baselines3 import SAC

    from sma_gym_agents.trained import load_policy

    model = SAC.load(out / "best_model.zip", device="cpu")
    card = json.loads((out / "best_model.json").read_text())
    assert card["history"] == "ema" and card["residual"] == "VSC3 + FF" and card["residual_filter_s"] == 0.1
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
    evaluate = ["-m", "sma_gym.cli", "evaluate", "--policy", str(out / "best_model.zip"), "--experiments", "6.1"]
    proc = _run(*evaluate, "--seeds", "1", "--baselines", "PID", "--json", cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr[-3000:]
    rows = json.loads(proc.stdout)
    assert any(r["policy"] == card["name"] and r["metric"] == "rms_error_m" and np.isfinite(r["value"]) for r in rows)


@pytest.mark.parametrize(
    ("option", "named"),
    [(["--env", "NoSuchEnv-v0"], "NoSuchEnv-v0"), (["--timesteps", "0"], "timesteps"), (["--threads", "0"], "threads")],
)
def test_train_rejects_bad_options(option, named):
    proc = _run(str(ROOT / "train.py"), *option, timeout=120)
    assert proc.returncode == 2 and named in proc.stderr


def test_error_features_without_a_position_sensor_are_refused_before_anything_is_written(tmp_path):
    out = tmp_path / "run"
    proc = _run(
        str(ROOT / "train.py"), "--env", "SMASelfSensing-v0", "--history", "ema+error", "--quick", "--out", str(out)
    )
    assert proc.returncode == 2 and "no 'error'" in proc.stderr and "expected history 'ema'" in proc.stderr
    assert not out.exists()


def test_ctrl_c_ends_train_py_with_a_line_not_a_traceback_and_keeps_the_checkpoints(tmp_path, capsys, monkeypatch):
    """Ctrl-C during training printed a KeyboardInterrupt traceback; now one line that says
    what the folder holds and how to go on, and the shell's code for SIGINT."""
    import sma_gym_agents.training.run as run_module
    from sma_gym_agents.training.cli import main

    out = tmp_path / "run"

    def interrupted(run, out, **kwargs):
        (out / "checkpoints").mkdir(parents=True)
        (out / "checkpoints" / "model_1000_steps.zip").write_bytes(b"PK")
        raise KeyboardInterrupt

    monkeypatch.setattr(run_module, "train_and_compare", interrupted)
    assert main(["--quick", "--no-progress", "--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert "Traceback" not in err and "interrupted" in err and str(out) in err and "--overwrite" in err
    assert (out / "checkpoints" / "model_1000_steps.zip").exists()

    def before_any_file(run, out, **kwargs):
        raise KeyboardInterrupt

    def while_scoring(run, out, **kwargs):
        out.mkdir(parents=True)
        (out / "final_model.zip").write_bytes(b"PK")  # training finished; the comparison was running
        raise KeyboardInterrupt

    monkeypatch.setattr(run_module, "train_and_compare", while_scoring)
    assert main(["--quick", "--no-progress", "--out", str(tmp_path / "scored")]) == 130
    err = capsys.readouterr().err
    assert "interrupted while scoring" in err and "no final model" not in err
    assert f"sma-gym evaluate --policy {tmp_path / 'scored' / 'final_model.zip'}" in err

    monkeypatch.setattr(run_module, "train_and_compare", before_any_file)
    assert main(["--quick", "--no-progress", "--out", str(tmp_path / "never")]) == 130
    assert capsys.readouterr().err.strip() == "train.py: interrupted"
    # Stopped in training before its first checkpoint, into a folder that exists (an earlier
    # run's, which --overwrite puts back): it promised "the checkpoints written so far".
    import sma_gym_agents.training.learn as learn_module

    monkeypatch.undo()
    monkeypatch.setattr(learn_module, "train", lambda run, out, **kwargs: before_any_file(run, out))
    earlier = tmp_path / "earlier"
    (earlier / "checkpoints").mkdir(parents=True)
    for name in ("results.md", "best_model.zip", "checkpoints/model_500_steps.zip"):
        (earlier / name).write_text("the earlier run's")
    assert main(["--quick", "--no-progress", "--overwrite", "--out", str(earlier)]) == 130
    err = capsys.readouterr().err
    assert "before the first checkpoint; nothing of this run is kept" in err and "keeps the checkpoints" not in err
    assert (earlier / "checkpoints" / "model_500_steps.zip").read_text() == "the earlier run's"  # put back
    assert not (earlier / ".previous-run").exists()

    def after_a_checkpoint(run, out, **kwargs):
        (out / "checkpoints").mkdir()
        (out / "checkpoints" / "model_500_steps.zip").write_bytes(b"PK")
        raise KeyboardInterrupt

    monkeypatch.setattr(learn_module, "train", after_a_checkpoint)
    assert main(["--quick", "--no-progress", "--out", str(tmp_path / "later")]) == 130
    err = capsys.readouterr().err
    assert f"{tmp_path / 'later'} keeps 1 checkpoint(s) in checkpoints/ but no final model" in err
    # --overwrite stopped after a checkpoint: the earlier run stays set aside, whole, and the
    # message says where (from an audit: it was deleted, and the message promised checkpoints
    # where there were none).
    assert main(["--quick", "--no-progress", "--overwrite", "--out", str(earlier)]) == 130
    err = capsys.readouterr().err
    aside = earlier / ".previous-run"
    assert f"the earlier run it was to replace is kept in {aside}" in err
    assert (aside / "results.md").read_text() == "the earlier run's" and not (earlier / "results.md").exists()

    def validated_only(run, out, **kwargs):
        (out / "best_model.zip").write_bytes(b"PK")
        raise KeyboardInterrupt

    monkeypatch.setattr(learn_module, "train", validated_only)
    assert main(["--quick", "--no-progress", "--out", str(tmp_path / "validated")]) == 130
    assert "keeps best_model.zip but no final model" in capsys.readouterr().err
    monkeypatch.undo()

    def scoring_with_a_best(run, out, **kwargs):
        out.mkdir(parents=True)
        for name in ("best_model.zip", "final_model.zip"):
            (out / name).write_bytes(b"PK")
        raise KeyboardInterrupt

    monkeypatch.setattr(run_module, "train_and_compare", scoring_with_a_best)
    assert main(["--quick", "--no-progress", "--out", str(tmp_path / "best")]) == 130
    # train.py scores best_model.zip: the hint named final_model.zip, another model.
    assert f"sma-gym evaluate --policy {tmp_path / 'best' / 'best_model.zip'}" in capsys.readouterr().err


def test_progress_lines_report_steps_rate_and_time_left():
    """Without a terminal (CI, nohup, cluster logs) train.py prints these instead of a bar."""
    from sma_gym_agents.training.learn import progress_line

    line = progress_line(50_000, 400_000, 100.0)
    assert line == "train.py: 50000/400000 steps (12 %), 500 steps/s, about 11.7 min left"
    assert "unknown" in progress_line(0, 400_000, 0.0)


def test_train_py_is_a_thin_shell_over_agents_training():
    text = (ROOT / "train.py").read_text()
    assert "from sma_gym_agents.training import main" in text and len(text.splitlines()) <= 15


def test_train_settings_come_from_the_hyperparameter_file_and_options_override():
    run = RunConfig.from_args(parse_args([]))
    assert run.algo == "sac" and run.history == "ema" and run.residual == "VSC3 + FF"
    run = RunConfig.from_args(
        parse_args(["--residual", "none", "--history", "none", "--algo", "ppo", "--timesteps", "1000"])
    )
    assert run.residual is None and run.history == "none" and run.timesteps == 1000 and "n_steps" in run.model_kwargs
    with pytest.raises(ValueError, match="residual"):
        RunConfig.from_args(parse_args(["--residual", "LQR"]))
    with pytest.raises(ValueError, match="frame-stack"):
        RunConfig.from_args(parse_args(["--frame-stack", "4"]))
    run = RunConfig.from_args(parse_args(["--frame-stack", "4", "--history", "none", "--residual", "none"]))
    assert run.frame_stack == 4
    # Frozen, and run.json's fields in their old order.
    with pytest.raises(AttributeError):
        run.seed = 1
    assert list(run.as_dict())[:3] == ["env_id", "algo", "timesteps"] and list(run.as_dict())[-1] == "model_kwargs"
    # A lower-case label is normalised to the controller's own spelling.
    assert RunConfig.from_args(parse_args(["--residual", "vsc3 + ff"])).residual == "VSC3 + FF"


@pytest.mark.parametrize("algo", ["sac", "ppo"])
def test_every_keyword_of_the_algorithm_and_its_policy_is_checked_set_by_train_py_or_refused(algo):
    """An SB3 that adds a keyword fails here, instead of train.py passing it on unchecked;
    and no table entry names a keyword SB3 does not have."""
    import inspect

    import stable_baselines3

    from sma_gym_agents.training import keywords as kw

    algo_cls = getattr(stable_baselines3, algo.upper())
    accepted = set(inspect.signature(algo_cls.__init__).parameters) - {"self"}
    others = {*kw.OWN_KEYWORDS, *kw.NOT_FROM_A_FILE[algo], *kw.ZOO_ONLY_KEYS}
    assert accepted <= {*kw.KEYWORDS[algo], *others}
    assert {*kw.KEYWORDS[algo], *kw.OWN_KEYWORDS, *kw.NOT_FROM_A_FILE[algo]} <= accepted
    assert not set(kw.KEYWORDS[algo]) & others
    policy_cls = algo_cls.policy_aliases["MlpPolicy"]
    accepted = set(inspect.signature(policy_cls.__init__).parameters) - {"self"}
    classes = {"activation_fn", "features_extractor_class", "optimizer_class"}  # no literal can name them
    covered = [*kw.POLICY_KEYWORDS[algo], "net_arch", *kw.POLICY_SET_BY_ALGORITHM, *classes]
    assert len(covered) == len(set(covered)) and set(covered) == accepted


def test_the_keywords_forms_are_read_as_sb3_reads_them():
    """Reviewed against SB3 2.9.2's source: what it trains with passes, and reaches it in the
    type it needs (a count written 2.0 crashed at the first update, a list train_freq was
    refused when the model was built); what it refuses, or cannot learn with, is named."""
    from sma_gym_agents.training.keywords import check_model_kwargs

    def here(key: str) -> str:
        return "here"

    good = {
        "sac": [
            ({"ent_coef": "auto"}, None),
            ({"ent_coef": "auto_0.1"}, None),
            ({"ent_coef": 0.0}, None),  # no entropy bonus: an ablation
            ({"gradient_steps": -1}, None),
            ({"gradient_steps": 2.0}, {"gradient_steps": 2}),
            ({"buffer_size": 1e6, "batch_size": 64.0}, {"buffer_size": 1_000_000, "batch_size": 64}),
            ({"train_freq": [1, "episode"]}, {"train_freq": (1, "episode")}),
            ({"train_freq": 4.0}, {"train_freq": 4}),
            ({"target_entropy": -2.0}, None),
            ({"target_entropy": "-2", "ent_coef": "0.1"}, {"target_entropy": -2.0, "ent_coef": 0.1}),  # SB3: float()
            ({"gamma": 0.0}, None),  # a myopic agent
            ({"sde_sample_freq": 0}, None),
            ({"policy_kwargs": {"net_arch": {"pi": [64.0], "qf": [64, 64]}, "n_critics": 3}}, None),
            ({"policy_kwargs": {"net_arch": None, "clip_mean": 0.0}}, None),  # SB3's defaults; 0: no clipping
        ],
        "ppo": [
            ({"ent_coef": 0.0, "target_kl": None, "clip_range_vf": 0.2, "n_epochs": 10.0}, None),
            ({"batch_size": 1, "normalize_advantage": False}, None),
            ({"policy_kwargs": {"net_arch": {"pi": [64], "vf": [64]}, "log_std_init": -1, "ortho_init": False}}, None),
            ({"policy_kwargs": {"net_arch": {"vf": [64]}}}, None),  # PPO: the actor without hidden layers
        ],
    }
    for algo, cases in good.items():
        for case, expected in cases:
            out = check_model_kwargs(case, algo, here)
            assert out == (case if expected is None else expected), (algo, case, out)
            for key, value in (expected or {}).items():
                assert type(out[key]) is type(value), (key, out[key])
    out = check_model_kwargs({"policy_kwargs": {"net_arch": {"pi": [64.0], "qf": [8]}}}, "sac", here)
    assert type(out["policy_kwargs"]["net_arch"]["pi"][0]) is int
    bad = {
        "sac": [
            ({"ent_coef": "auto_-1"}, "ent_coef = 'auto_-1'"),
            ({"ent_coef": "auto_"}, "ent_coef = 'auto_'"),  # SB3: "could not convert string to float"
            ({"ent_coef": "automatic"}, "ent_coef = 'automatic'"),
            ({"ent_coef": -0.1}, "ent_coef = -0.1"),
            ({"gradient_steps": -2}, "gradient_steps = -2"),
            ({"target_entropy": float("nan")}, "target_entropy = nan"),
            ({"optimize_memory_usage": True}, "optimize_memory_usage = True: expected false"),
            ({"clip_range": 0.2}, "'clip_range' is neither a run key"),
            ({"rollout_buffer_class": None}, "'rollout_buffer_class' is neither a run key"),  # PPO's
            ({"seed": 3}, "seed is set by --seed"),
            ({"action_noise": None}, "action_noise takes an object"),
            ({"learning_rate": "3e-4"}, "YAML 1.1 reads 3e-4 as text: write it with a dot and a signed exponent"),
            ({"policy_kwargs": {"net_arch": {"pi": [64], "vf": [64]}}}, "dict(pi=[...], qf=[...])"),
            ({"policy_kwargs": {"net_arch": {"pi": [64]}}}, "dict(pi=[...], qf=[...])"),  # SAC needs both
            ({"policy_kwargs": {"use_sde": True}}, "use_sde is set by the algorithm"),
            ({"policy_kwargs": {"ortho_init": False}}, "'ortho_init' is no literal keyword of SAC's MlpPolicy"),
        ],
        "ppo": [
            ({"ent_coef": "auto"}, "ent_coef = 'auto'"),  # SAC's, not PPO's
            ({"batch_size": 1}, "batch_size = 1 with normalize_advantage: expected batch_size >= 2"),
            ({"max_grad_norm": 0}, "max_grad_norm = 0"),
            ({"normalize_advantage": "yes"}, "normalize_advantage = 'yes': expected true or false"),
            ({"policy_kwargs": {"log_std_init": "x"}}, "log_std_init = 'x': expected a number"),
        ],
    }
    for algo, cases in bad.items():
        for case, message in cases:
            with pytest.raises(ValueError, match="here: ") as err:
                check_model_kwargs(case, algo, here)
            assert message in str(err.value), (algo, case, str(err.value))


def test_a_run_names_the_source_of_a_bad_value_and_refuses_episodic_training_over_several_envs():
    with pytest.raises(ValueError, match=r"^--hyperparams gamma: gamma = 2"):
        RunConfig.from_args(parse_args(["--hyperparams", "gamma:2"]))
    with pytest.raises(ValueError, match=r"^--hyperparams n_timesteps: n_timesteps = '1e6'.*YAML 1.1"):
        RunConfig.from_args(parse_args(["--hyperparams", "n_timesteps:'1e6'"]))
    with pytest.raises(ValueError, match=r"train_freq = \[1, 'episode'\] with 4 envs: .*expected --n-envs 1"):
        RunConfig.from_args(parse_args(["--hyperparams", "train_freq:[1, 'episode']"]))
    run = RunConfig.from_args(parse_args(["--n-envs", "1", "--hyperparams", "train_freq:[1, 'episode']"]))
    assert run.model_kwargs["train_freq"] == (1, "episode")
    with pytest.raises(ValueError, match="repeated keyword"):
        RunConfig.from_args(parse_args(["--hyperparams", "policy_kwargs:dict(net_arch=[64], net_arch=[32])"]))


def test_the_zoos_nested_dict_calls_are_read_and_a_malformed_file_is_named(tmp_path, monkeypatch):
    from sma_gym_agents.training import config
    from sma_gym_agents.training.config import literal_kwargs

    nested = "dict(net_arch=dict(pi=[64], qf=[64]), optimizer_kwargs=dict(fused=True))"
    assert literal_kwargs(nested, "p") == {"net_arch": {"pi": [64], "qf": [64]}, "optimizer_kwargs": {"fused": True}}
    for text in ("dict(**x)", "dict(activation_fn=nn.ReLU)", "[64, 64]"):
        with pytest.raises(ValueError, match="train.py reads dict"):
            literal_kwargs(text, "p")
    monkeypatch.setattr(config, "HYPERPARAMS", tmp_path)
    for text, message in [
        ("SMATracking-v0:\n  gamma: [0.9\n", "sac.yml is not valid YAML"),  # a traceback before
        ("- SMATracking-v0\n", "expected a mapping of env ids"),
        ("SMATracking-v0: 3\n", "sac.yml [SMATracking-v0]: expected a mapping of hyperparameter names"),
        ("SMATracking-v0:\n  n_envs: 4\n", "no n_timesteps"),  # a KeyError traceback before
        ("SMATracking-v0:\n  n_timesteps: 1000\n  env_kwargs: [1]\n", "env_kwargs = [1]: expected a mapping"),
    ]:
        (tmp_path / "sac.yml").write_text(text)
        with pytest.raises(ValueError, match="sac.yml") as err:
            RunConfig.from_args(parse_args([]))
        assert message in str(err.value), str(err.value)


def test_hyperparams_option_overrides_the_file_as_rl_zoos_does():
    base = RunConfig.from_args(parse_args(["--env", "SMAMultiplexed-v0"]))
    run = RunConfig.from_args(
        parse_args(
            [
                "--env",
                "SMAMultiplexed-v0",
                "--hyperparams",
                "gamma:0.999",
                "n_timesteps:5000",
                "policy_kwargs:dict(net_arch=[64, 64])",
                "target_entropy:-2.0",
            ]
        )
    )
    assert run.model_kwargs["gamma"] == 0.999 and base.model_kwargs["gamma"] == 0.99
    assert run.timesteps == 5000 and run.model_kwargs["policy_kwargs"] == {"net_arch": [64, 64]}
    assert run.model_kwargs["target_entropy"] == -2.0 and "target_entropy" not in base.model_kwargs
    assert {k: v for k, v in run.model_kwargs.items() if k not in ("gamma", "policy_kwargs", "target_entropy")} == {
        k: v for k, v in base.model_kwargs.items() if k not in ("gamma", "policy_kwargs")
    }
    with pytest.raises(ValueError, match="--hyperparams gama: 'gama' is neither a run key"):
        RunConfig.from_args(parse_args(["--hyperparams", "gama:0.9"]))
    with pytest.raises(ValueError, match="--hyperparams clip_range"):  # PPO's, not SAC's
        RunConfig.from_args(parse_args(["--hyperparams", "clip_range:0.1"]))
    with pytest.raises(ValueError, match="--hyperparams seed: seed is set by --seed"):
        RunConfig.from_args(parse_args(["--hyperparams", "seed:3"]))
    with pytest.raises(ValueError, match="--env-kwargs"):
        RunConfig.from_args(parse_args(["--hyperparams", "env_kwargs:{}"]))
    with pytest.raises(ValueError, match="KEY:VALUE"):
        RunConfig.from_args(parse_args(["--hyperparams", "gamma=0.9"]))


def test_one_card_type_writes_and_reads_one_suffix(tmp_path):
    """The card saved in training is the card load_policy reads: same type, same file."""
    zip_path = tmp_path / "best_model.zip"
    zip_path.write_bytes(b"a model")
    run = RunConfig.from_args(parse_args(["--quick"]))
    card = run.card(run.agent_name, timesteps=100, validation_return=-3.5)
    assert card.save(zip_path) == card_path(zip_path) == tmp_path / f"best_model{CARD_SUFFIX}"
    loaded = PolicyCard.load(zip_path)
    assert loaded.model_sha256 and loaded == PolicyCard.from_dict(
        {**card.as_dict(), "model_sha256": loaded.model_sha256}
    )
    written = json.loads(card_path(zip_path).read_text())
    assert list(written)[:3] == ["format", "version", "algo"] and "train_time_s" not in written
    assert written["residual"] == "VSC3 + FF" and written["history"] == "ema" and written["validation_return"] == -3.5
    assert written["residual_filter_s"] == 0.1
    with pytest.raises(ValueError, match="env_id"):
        PolicyCard(algo="SAC", env_id="SMAWarp-v9")
    # A card written before the residual's filter existed reads as no filter; a filter is a
    # time constant >= 0 s.
    old = {k: v for k, v in written.items() if k != "residual_filter_s"}
    assert PolicyCard.from_dict(old).residual_filter_s == 0.0
    for bad in (-0.1, float("inf"), "0.1"):
        with pytest.raises(ValueError, match="residual_filter_s = .*time constant >= 0 s"):
            PolicyCard.from_dict({**old, "residual_filter_s": bad})


def test_goal_lines_print_enough_places_to_tell_the_figures_apart():
    """Found by a new user: "met: RMS step below every baseline (agent_mm = 1.063,
    best_baseline_mm = 1.063)", which read as a tie, was 1.06275 against 1.06336."""
    from sma_gym_agents.training.compare import _places_that_tell_apart

    assert _places_that_tell_apart([1.06275, 1.06336]) == 4
    assert _places_that_tell_apart([0.8, 1.2]) == 3
    assert _places_that_tell_apart([0.5, 0.5]) == 3  # equal figures are not spread out
    assert _places_that_tell_apart([1.0, 1.0 + 1e-9]) == 6  # at most six


def test_validation_references_lie_within_the_stroke_of_the_runs_own_actuator(tmp_path):
    """They were drawn within the standard wire's 9.5 mm whatever the model, so training on a
    shorter wire stopped at once ("levels_m[5] = 0.0081: expected a position in [0, 0.008]")."""
    from sma_gym import ModelConfig, preset
    from sma_gym_agents.training.envs import validation_references

    def highest(run: RunConfig) -> float:
        levels = []
        for ref in validation_references(run, 8):
            levels += [v for k, v in ref.items() if k.startswith("level") and isinstance(v, float)]
            levels += list(ref.get("levels_m", []))
            levels += [ref["offset_m"] + ref["amplitude_m"]] if "offset_m" in ref else []
        return max(levels)

    short = preset("standard").with_changes(**{"wire.length_m": 0.2}, name="short")
    ModelConfig(short).save(tmp_path / "short.json")
    run = RunConfig.from_args(parse_args(["--quick", "--env-kwargs", f"model:{tmp_path / 'short.json'}"]))
    assert short.usable_stroke_m < highest(RunConfig.from_args(parse_args(["--quick"])))
    assert 0.8 * short.usable_stroke_m < highest(run) <= short.usable_stroke_m


def test_a_condition_the_agent_did_not_finish_is_its_worst_and_a_baseline_that_did_not_is_no_contender():
    """Python's max keeps a NaN only where it comes first: a robust agent that overheated the
    wire in the second of the chapter-7 conditions (its figure NaN there) met its worst-case
    goal on the others, and a baseline that overheated decided the best baseline only when
    listed first. results.md left such a policy's row out without a word."""
    from sma_gym_agents.evaluation import ENDED_EARLY, Results, _records
    from sma_gym_agents.training.compare import GOALS, ROBUST, Goal, summarise

    figures = {("agent", "a"): 1e-3, ("agent", "b"): math.nan, ("pid", "a"): 2e-3, ("pid", "b"): 2e-3}
    figures |= {("hot", "a"): math.nan, ("hot", "b"): 1e-4}
    value = lambda p, c: figures[(p, c)]  # noqa: E731
    worst = Goal("worst case below the best baseline", "step", over_conditions=True)
    checked = worst.check(value, "agent", ["hot", "pid"], ["a", "b"])
    assert math.isnan(checked["agent_mm"]) and not checked["met"]
    # The baseline that overheated is no contender, wherever it is listed.
    figures[("agent", "b")] = 1.5e-3
    for pool in (["hot", "pid"], ["pid", "hot"]):
        checked = worst.check(value, "agent", pool, ["a", "b"])
        assert checked["best_baseline_mm"] == pytest.approx(2.0) and checked["met"]
    assert math.isnan(worst.check(value, "agent", ["hot"], ["a", "b"])["best_baseline_mm"])

    # results.md names the run that overheated instead of leaving its row out.
    results = Results()
    for policy, condition in (("PID", "standard"), ("PID", "5 V"), ("SAC", "standard")):
        for ref in ("step", "sine"):
            results.records += _records("7", policy, condition, ref, {"rms_error_m": np.array([1e-3])})
    results.records += _records("7", "SAC", "5 V", "step", {ENDED_EARLY: np.array([2.5])})
    results.records += _records("7", "SAC", "5 V", "sine", {"rms_error_m": np.array([1e-3])})
    run = SimpleNamespace(env_id=ROBUST, algo="sac")
    text, goals = summarise(run, results, "SAC", [("standard", ""), ("5 V", "")])
    assert "| SAC | 5 V | overheated at 2.5 s | 1.000 |" in text
    step_goal, sine_goal = (goals[g.name] for g in GOALS[ROBUST])
    assert math.isnan(step_goal["agent_mm"]) and not step_goal["met"]
    assert sine_goal["agent_mm"] == pytest.approx(1.0)
    # The bank's table too.
    from sma_gym_agents.training.compare import BANK

    bank = Results()
    bank.records += _records(
        "9 bank tracking",
        "PID (fixed slots)",
        "16",
        "independent",
        {"rms_error_m": np.array([1e-3]), "energy_j": np.array([2.0])},
    )
    bank.records += _records("9 bank tracking", "SAC", "16", "independent", {ENDED_EARLY: np.array([4.0])})
    text, _ = summarise(SimpleNamespace(env_id=BANK, algo="sac", env_kwargs={}), bank, "SAC", [("16", "")])
    assert "| PID (fixed slots) | 16 | 1.000 | 2.00 |\n| SAC | 16 | overheated at 4.0 s | overheated at 4.0 s |" in text


def test_the_validation_record_is_written_beside_and_renamed_into_place(tmp_path, monkeypatch):
    """From an audit: SB3's EvalCallback rewrote validation/evaluations.npz in place after every
    validation, so a stop while it wrote truncated the record of how best_model.zip was chosen."""
    from stable_baselines3 import SAC
    from stable_baselines3.common.logger import configure
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv

    from sma_gym_agents.training.learn import AtomicEvalCallback

    env = DummyVecEnv([lambda: Monitor(gym.make("sma_gym:SMATracking-v0", max_episode_steps=3))])
    folder = tmp_path / "validation"
    written = []
    savez = np.savez
    monkeypatch.setattr(np, "savez", lambda path, **arrays: (written.append(str(path)), savez(path, **arrays)))
    callback = AtomicEvalCallback(env, n_eval_episodes=1, eval_freq=1, log_path=str(folder), verbose=0)
    model = SAC("MlpPolicy", env, learning_starts=10, device="cpu")
    model.set_logger(configure(None, []))  # learn() sets one
    callback.init_callback(model)
    for _ in range(2):
        callback.on_step()
    assert written and all(Path(p).name.startswith(".evaluations.tmp") for p in written)
    assert [p.name for p in folder.iterdir()] == ["evaluations.npz"]
    assert len(np.load(folder / "evaluations.npz")["timesteps"]) == 2


def test_a_robustness_agent_trained_on_a_model_of_the_users_is_scored_on_it(tmp_path):
    """results.md scored it on the report's wire under chapter 7's conditions, labelled
    "standard", whatever its card's model (a new user's trial)."""
    from types import SimpleNamespace

    import gymnasium as gym
    from stable_baselines3 import PPO

    from sma_gym import preset
    from sma_gym_agents import PolicyCard
    from sma_gym_agents.training.compare import GOALS, ROBUST, compare

    mine = preset("standard").with_changes(**{"mechanism.spring_stiffness_n_m": 180.0}, name="mine-soft-spring")
    env = gym.make("sma_gym:SMARobust-v0", model=mine)
    PPO("MlpPolicy", env, n_steps=64, batch_size=64, n_epochs=1, seed=0, device="cpu").save(tmp_path / "best_model.zip")
    PolicyCard(algo="PPO", env_id=ROBUST, name="mine", env_kwargs={"model": mine}).save(tmp_path / "best_model.zip")
    run = SimpleNamespace(env_id=ROBUST, quick=True, algo="ppo", env_kwargs={"model": mine})
    text, goals = compare(run, tmp_path)
    rows = [line for line in text.splitlines() if line.startswith("| ") and "policy" not in line]
    assert rows and all("| model mine-soft-spring |" in row for row in rows), rows
    assert "scored on that model as given" in text and "standard" not in "".join(rows)
    assert set(goals) == {g.name for g in GOALS[ROBUST]}
