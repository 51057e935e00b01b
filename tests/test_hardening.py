"""Issue 13: nothing hangs, nothing lies, nothing half-written.

One section per item of the issue; each test fails on the code before the fix.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(args: list[str], timeout: float = 300, **kwargs) -> subprocess.CompletedProcess:
    return subprocess.run(args, capture_output=True, text=True, timeout=timeout, **kwargs)


# --- item 3: read-only installs -------------------------------------------------------------


def _read_only_copy(tmp_path: Path) -> Path:
    """A copy of the package that numba cannot cache into, even when the tests run as root."""
    site = tmp_path / "site"
    shutil.copytree(ROOT / "sma_gym", site / "sma_gym", ignore=shutil.ignore_patterns("__pycache__"))
    for folder in [p for p in (site / "sma_gym").rglob("*") if p.is_dir()] + [site / "sma_gym"]:
        # A *file* named __pycache__ defeats os.makedirs whatever the permissions (root ignores
        # mode bits), which is what a read-only directory does for an ordinary user.
        (folder / "__pycache__").write_text("")
    for path in sorted(site.rglob("*"), reverse=True):
        path.chmod(stat.S_IREAD | (stat.S_IEXEC if path.is_dir() else 0))
    return site


def _unwritable_env(site: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(("NUMBA_CACHE", "XDG_"))}
    env.update(
        PYTHONPATH=str(site),
        PYTHONDONTWRITEBYTECODE="1",
        HOME="/dev/null/home",
        XDG_CACHE_HOME="/dev/null/cache",
        NUMBA_CACHE_DIR="/dev/null/numba",
    )
    return env


def test_import_and_help_work_on_a_read_only_install_without_a_cache_dir(tmp_path):
    site = _read_only_copy(tmp_path)
    env = _unwritable_env(site)
    try:
        code = (
            "import sma_gym, sma_gym._jit as j\n"
            f"assert sma_gym.__file__.startswith({str(site)!r}), sma_gym.__file__\n"
            "print(j.caching_available())\n"
            "from sma_gym.physics.resistance import wire_resistance\n"
            "print(wire_resistance(0.0, 1.0, 20.0, 1e-6, 1e-6, 0.0, 0.0, 20.0, 0.1, 1e-8))\n"
        )
        out = _run([sys.executable, "-c", code], env=env, cwd=tmp_path)
        assert out.returncode == 0, out.stderr
        lines = out.stdout.split()
        assert lines[0] == "False" and float(lines[1]) > 0.0
        help_ = _run(
            [sys.executable, "-c", "import sys; from sma_gym.cli import main; sys.exit(main(['--help']))"],
            env=env,
            cwd=tmp_path,
        )
        assert help_.returncode == 0, help_.stderr
        assert "usage: sma-gym" in help_.stdout
    finally:
        for path in tmp_path.rglob("*"):
            path.chmod(stat.S_IRWXU)


# --- item 2: train.py never mixes runs; cards are tied to their zip ---------------------------


def _tiny_model():
    import gymnasium as gym
    from stable_baselines3 import PPO

    env = gym.make("sma_gym:SMATracking-v0")
    return PPO("MlpPolicy", env, n_steps=64, batch_size=64, n_epochs=1, seed=0, device="cpu")


CARD = {
    "format": "sma-gym-policy",
    "algo": "PPO",
    "name": "tiny",
    "env_id": "SMATracking-v0",
    "env_kwargs": {},
    "frame_stack": 1,
}


def test_train_refuses_a_non_empty_out_unless_overwrite_and_says_so_in_help(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / "best_model.zip").write_bytes(b"an older run's model")
    proc = _run([sys.executable, str(ROOT / "train.py"), "--quick", "--no-progress", "--out", str(out)])
    assert proc.returncode == 2, proc.stderr[-2000:]
    assert "not empty" in proc.stderr and "--overwrite" in proc.stderr and str(out) in proc.stderr
    assert sorted(p.name for p in out.iterdir()) == ["best_model.zip"]
    help_ = _run([sys.executable, str(ROOT / "train.py"), "--help"])
    assert "--overwrite" in help_.stdout and "non-empty" in help_.stdout


def test_prepare_out_deletes_a_previous_runs_outputs_only(tmp_path):
    from sma_gym_agents.training import prepare_out

    (tmp_path / "best_model.zip").write_bytes(b"old")
    (tmp_path / "checkpoints").mkdir()
    (tmp_path / "notes.txt").write_text("mine")
    prepare_out(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_cards_carry_the_zip_hash_and_the_loader_refuses_any_mismatch(tmp_path):
    import json

    from sma_gym_agents.trained import load_policy, save_policy

    model = _tiny_model()
    path = save_policy(model, tmp_path / "agent.zip", CARD)
    card_path = tmp_path / "agent.json"
    card = json.loads(card_path.read_text())
    assert len(card["model_sha256"]) == 64
    assert load_policy(path).name == "tiny"
    # Another model written over the zip (a stale card): refused, naming the files.
    path.write_bytes(path.read_bytes() + b"another run")
    with pytest.raises(ValueError, match="SHA-256 mismatch") as err:
        load_policy(path)
    assert str(card_path) in str(err.value)
    save_policy(model, path, CARD)
    cases = {
        "missing": None,
        "malformed": "{not json",
        "a JSON list": json.dumps([card]),
        "unknown env": json.dumps({**json.loads(card_path.read_text()), "env_id": "SMAWarp-v9"}),
        "no hash": json.dumps({k: v for k, v in json.loads(card_path.read_text()).items() if k != "model_sha256"}),
        "binary": b"\x89PNG\r\n\x1a\n\x00\xff",
    }
    good = card_path.read_bytes()
    for case, text in cases.items():
        if text is None:
            card_path.unlink()
        elif isinstance(text, bytes):
            card_path.write_bytes(text)
        else:
            card_path.write_text(text)
        with pytest.raises(ValueError) as err:
            load_policy(path)
        assert str(card_path) in str(err.value), case
        card_path.write_bytes(good)
    assert load_policy(path).env_id == "SMATracking-v0"


# --- item 5: atomic writes and a lock for a busy --out ----------------------------------------


def test_atomic_writes_leave_the_old_file_or_the_new_one(tmp_path):
    from sma_gym._io import atomic_path, write_json

    target = write_json(tmp_path / "a.json", {"v": 1})
    with pytest.raises(KeyboardInterrupt), atomic_path(target) as tmp:
        tmp.write_text('{"v": 2, "half')
        raise KeyboardInterrupt
    assert target.read_text() == '{\n  "v": 1\n}\n'
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.json"]


def test_atomic_writes_give_the_file_the_users_usual_permissions(tmp_path):
    """A temporary file is private (0600); the written file must not stay so (a model or a
    report shared with a group would be unreadable), but get 0666 less the umask."""
    from sma_gym._io import write_text

    old = os.umask(0o022)
    try:
        path = write_text(tmp_path / "r.md", "x")
        plain = tmp_path / "plain.md"
        plain.write_text("x")
    finally:
        os.umask(old)
    assert path.stat().st_mode & 0o777 == plain.stat().st_mode & 0o777 == 0o644


def test_a_busy_out_is_refused_and_a_stale_lock_is_taken_over(tmp_path):
    from sma_gym._io import LOCK_NAME, locked_folder

    with locked_folder(tmp_path / "out"):
        with pytest.raises(ValueError, match="busy") as err:
            with locked_folder(tmp_path / "out"):
                pass
        assert str(os.getpid()) in str(err.value)
    assert not (tmp_path / "out" / LOCK_NAME).exists()
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    (tmp_path / "out" / LOCK_NAME).write_text(f"{dead.pid}\n")
    with locked_folder(tmp_path / "out"):
        assert (tmp_path / "out" / LOCK_NAME).read_text().startswith(str(os.getpid()))


def test_diagnose_into_a_busy_out_exits_2_and_writes_nothing(tmp_path, capsys):
    from sma_gym._io import locked_folder
    from sma_gym.cli import main

    csv = _synth(tmp_path, "s.csv")
    with locked_folder(tmp_path / "d"):
        assert main(["diagnose", str(csv), "--out", str(tmp_path / "d"), "--effects", "sensor_lag"]) == 2
    assert "busy" in capsys.readouterr().err
    assert [p.name for p in (tmp_path / "d").iterdir()] == []


@pytest.mark.parametrize(
    "effects, needle",
    [
        ("", "--effects '': expected a comma-separated subset"),  # was: every effect, silently
        ("sensor_lag,latent_heat,sensor_lag", "sensor_lag given twice"),  # was: fitted twice
        ("sensor_lag,,latent_heat", "--effects '': expected"),
    ],
)
def test_diagnose_refuses_an_empty_or_repeated_effect_and_writes_nothing(
    tmp_path, capsys, monkeypatch, effects, needle
):
    import sma_gym.diagnosis.workflow
    from sma_gym.cli import main

    def no_work(*args, **kwargs):
        raise AssertionError("the diagnosis started with a bad --effects")

    monkeypatch.setattr(sma_gym.diagnosis.workflow, "diagnose", no_work)
    csv = _synth(tmp_path, "s.csv")
    assert main(["diagnose", str(csv), "--out", str(tmp_path / "d"), "--effects", effects]) == 2
    assert needle in capsys.readouterr().err
    assert not (tmp_path / "d").exists()


@pytest.mark.parametrize("threads", ["0", "9", "two"])
def test_diagnose_with_a_bad_thread_count_exits_2_and_writes_nothing(tmp_path, capsys, threads):
    from sma_gym.cli import main

    csv = _synth(tmp_path, "s.csv")
    argv = ["diagnose", str(csv), "--out", str(tmp_path / "d"), "--threads", threads]
    if threads.isdigit():
        assert main(argv) == 2
    else:
        with pytest.raises(SystemExit) as stop:  # argparse refuses it before main runs
            main(argv)
        assert stop.value.code == 2
    err = capsys.readouterr().err
    assert "--threads" in err and threads in err
    assert not (tmp_path / "d").exists()


def _synth(tmp_path: Path, name: str, *extra: str) -> Path:
    from sma_gym.cli import main

    assert main(["synth", "--out", str(tmp_path / name), "--duration", "7", *extra]) == 0
    return tmp_path / name


def test_synths_sidecar_names_a_named_model_so_diagnose_starts_from_it(tmp_path):
    """``synth --model wire-0.5mm`` wrote a sidecar without the model, and ``diagnose`` on the
    file then started from the standard wire; a model file has no name to look up."""
    import json

    from sma_gym.cli import _sidecar_model
    from sma_gym.data import load_trace
    from sma_gym.model import load_model

    named = _synth(tmp_path, "named.csv", "--model", "wire-0.5mm")
    assert json.loads((tmp_path / "named.csv.json").read_text())["model"] == "wire-0.5mm"
    assert _sidecar_model([load_trace(named)]) == "wire-0.5mm"
    path = load_model("wire-0.5mm").save(tmp_path / "mine.json")
    unnamed = _synth(tmp_path, "file.csv", "--model", str(path))
    assert "model" not in json.loads((tmp_path / "file.csv.json").read_text())
    assert _sidecar_model([load_trace(unnamed)]) is None
    # The labels say where the model came from and which effects it carried into the data
    # (a file's own warm surroundings was in the data while the labels said "effect": null).
    warm = load_model("wire-0.5mm").with_effect("warm_surroundings", {"gain_k_j": 0.1}).save(tmp_path / "w.json")
    _synth(tmp_path, "warm.csv", "--model", str(warm), "--no-electrical")
    labels = json.loads((tmp_path / "warm.labels.json").read_text())
    assert labels["effect"] is None and labels["model_source"] == str(warm) and labels["electrical"] is False
    assert labels["model_effects"]["warm_surroundings"]["parameters"]["gain_k_j"] == 0.1


def test_synth_refuses_to_overwrite_any_of_its_outputs(tmp_path, capsys):
    from sma_gym.cli import main

    csv = _synth(tmp_path, "s.csv")
    outputs = (csv, tmp_path / "s.csv.json", tmp_path / "s.labels.json")
    for existing in outputs:
        # Only this one of the three outputs exists (e.g. a sidecar written by hand).
        for p in outputs:
            p.unlink(missing_ok=True)
        existing.write_text("mine")
        assert main(["synth", "--out", str(csv), "--duration", "7", "--seed", "1"]) == 2
        err = capsys.readouterr().err
        assert "--overwrite" in err and str(existing) in err
        assert existing.read_text() == "mine"
        assert sorted(tmp_path.iterdir()) == [existing]
    assert main(["synth", "--out", str(csv), "--duration", "7", "--seed", "1", "--overwrite"]) == 0
    assert all(p.read_text() != "mine" for p in outputs)


# --- item 6: every argument checked before any work --------------------------------------------


@pytest.mark.parametrize("args, needle", [(["--device", "bogus"], "--device"), (["--seed", "-1"], "--seed")])
def test_train_bad_device_or_seed_exit_2_and_leave_nothing(tmp_path, args, needle):
    out = tmp_path / "run"
    proc = _run([sys.executable, str(ROOT / "train.py"), "--quick", "--no-progress", "--out", str(out), *args])
    assert proc.returncode == 2 and needle in proc.stderr and "Traceback" not in proc.stderr
    assert not out.exists()


def _unwritable_out(tmp_path: Path) -> Path:
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    return blocker / "out"  # a folder below a file can never be created, even by root


@pytest.mark.parametrize(
    "command",
    [
        ["diagnose", "{csv}", "--effects", "sensor_lag"],
        ["evaluate", "--experiments", "8", "--baselines", "PID", "--seeds", "1"],
        ["fidelity", "--quick"],
    ],
)
def test_commands_check_out_before_the_work(tmp_path, capsys, monkeypatch, command):
    import sma_gym.diagnosis.workflow
    import sma_gym_agents.commands
    import sma_gym_agents.report_targets
    from sma_gym.cli import main

    def no_work(*args, **kwargs):
        raise AssertionError("the work started before --out was checked")

    monkeypatch.setattr(sma_gym.diagnosis.workflow, "diagnose", no_work)
    monkeypatch.setattr(sma_gym_agents.commands, "evaluate", no_work)
    monkeypatch.setattr(sma_gym_agents.report_targets, "main", no_work)
    csv = _synth(tmp_path, "s.csv") if "{csv}" in command else None
    argv = [str(csv) if a == "{csv}" else a for a in command] + ["--out", str(_unwritable_out(tmp_path))]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "--out" in err and "a-file" in err


def test_evaluate_into_an_earlier_report_needs_overwrite_and_then_drops_its_stale_figures(
    tmp_path, capsys, monkeypatch
):
    """--overwrite removes the earlier report's files that this run does not write (those the
    earlier run listed), never a file of the user's by a name pattern (chapter7_*.png took a
    user's photo), and only once this run is done: an interrupt leaves the earlier report
    whole (it used to be deleted before the work, and a stop left a lone figure)."""
    import sma_gym_agents.commands
    from sma_gym._io import output_list
    from sma_gym.cli import main

    writes = {"names": ["evaluation.md", "evaluation.json", "fig6_5_step_feedforward.png", "chapter7_fan_sine.png"]}

    def fake_evaluate(out, *args):
        for name in writes["names"]:
            (Path(out) / name).write_text("new")
        if writes.get("interrupt"):
            raise KeyboardInterrupt
        return 0

    monkeypatch.setattr(sma_gym_agents.commands, "evaluate", fake_evaluate)
    out = tmp_path / "ev"
    out.mkdir()
    (out / "my_notes.md").write_text("keep")
    (out / "chapter7_my_photo.png").write_text("keep")
    argv = ["evaluate", "--experiments", "6.1", "--baselines", "PID", "--seeds", "1", "--out", str(out)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "not empty" in err and "--overwrite" in err
    assert main([*argv, "--overwrite"]) == 0
    first = sorted(p.name for p in out.iterdir())
    assert first == sorted([*writes["names"], "my_notes.md", "chapter7_my_photo.png", output_list("evaluate")])
    writes.update(names=["evaluation.md", "fig6_2_step.png"], interrupt=True)
    assert main([*argv, "--overwrite"]) == 130
    assert sorted(p.name for p in out.iterdir()) == first  # as it was: no staging folder, no lock
    writes.update(interrupt=False)
    assert main([*argv, "--overwrite"]) == 0
    assert sorted(p.name for p in out.iterdir()) == sorted(
        ["evaluation.md", "fig6_2_step.png", "my_notes.md", "chapter7_my_photo.png", output_list("evaluate")]
    )
    assert (out / "chapter7_my_photo.png").read_text() == "keep"


def test_evaluate_checks_policies_and_experiments_before_the_work(tmp_path, capsys, monkeypatch):
    import sma_gym_agents.commands
    from sma_gym.cli import main

    monkeypatch.setattr(
        sma_gym_agents.commands, "evaluate", lambda *a, **k: (_ for _ in ()).throw(AssertionError("work"))
    )
    assert main(["evaluate", "--experiments", "6.1,warp"]) == 2
    assert "warp" in capsys.readouterr().err
    (tmp_path / "m.zip").write_bytes(b"PK")
    assert main(["evaluate", "--experiments", "8", "--policy", str(tmp_path / "m.zip")]) == 2
    assert "m.json" in capsys.readouterr().err


# --- item 7: actions of the wrong shape or type ---------------------------------------------------


@pytest.mark.parametrize(
    "action", [np.zeros(2, np.float32), "0.5", np.zeros((1, 1), np.float32), np.zeros(0), [True], None]
)
def test_single_env_rejects_wrong_actions_naming_the_shape(action):
    import gymnasium as gym

    env = gym.make("sma_gym:SMATracking-v0")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"shape \(1,\)"):
        env.step(action)


@pytest.mark.parametrize("action", [np.zeros(1, np.float32), np.zeros(1, np.float64), 0.25, np.float32(0.1), [0.5]])
def test_single_env_accepts_what_checkers_send(action):
    import gymnasium as gym

    env = gym.make("sma_gym:SMATracking-v0")
    env.reset(seed=0)
    env.step(action)


@pytest.mark.parametrize("action", [np.zeros(3, np.float32), "0.5", np.zeros((1, 4), np.float32), np.zeros(0)])
def test_multiplexed_env_rejects_wrong_actions_naming_the_shape(action):
    import gymnasium as gym

    env = gym.make("sma_gym:SMAMultiplexed-v0", n_actuators=4)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"shape \(4,\)"):
        env.step(action)
    env.step(np.zeros(4, np.float32))


# --- item 4: every reference field validated, at make and at reset ---------------------------------


BAD_REFERENCES = [
    ({"kind": "sine", "phase_rad": float("inf")}, "phase_rad"),
    ({"kind": "sine", "phase_rad": float("nan")}, "phase_rad"),
    ({"kind": "sine", "offset_m": 0.009, "amplitude_m": 0.003}, "offset_m \\+ amplitude_m"),
    ({"kind": "random", "times_s": [0.0, 1.0], "levels_m": [0.0, float("nan")]}, r"levels_m\[1\]"),
    ({"kind": "random", "times_s": [0.0, 1.0], "levels_m": [0.0, 1e9]}, r"levels_m\[1\]"),
    ({"kind": "random", "times_s": [0.0, float("inf")], "levels_m": [0.0, 0.001]}, r"times_s\[1\]"),
    ({"kind": "step", "level1_m": -0.001}, "level1_m"),
    ({"kind": "step", "t1_s": float("nan")}, "t1_s"),
    ({"kind": "step", "level1_m": "high"}, "level1_m"),
    ({"kind": "ramp", "d1_s": float("inf")}, "d1_s"),
    # A subnormal duration passed "> 0" and made the ramp's rate inf and the observation NaN.
    ({"kind": "ramp", "t1_s": 0.0, "level1_m": 0.005, "d1_s": 1e-320}, "d1_s"),
]


def test_a_reference_object_is_checked_as_its_dict_would_be():
    """A Reference passed as the option skipped every check: NaN and infinite levels gave a
    NaN observation and reward, and a 1 m level was accepted."""
    import gymnasium as gym

    from sma_gym.envs.references import STEP, Reference, report_step

    env = gym.make("sma_gym:SMATracking-v0")
    for params, field in (([0.0, np.nan, np.inf, 0.0], "level1_m"), ([0.5, 1.0, np.inf, 1.0], "level1_m")):
        with pytest.raises(ValueError, match=field):
            env.reset(seed=0, options={"reference": Reference(STEP, np.array(params))})
    obs, _ = env.reset(seed=0, options={"reference": report_step()})
    assert np.isfinite(obs).all()


@pytest.mark.parametrize("reference, field", BAD_REFERENCES)
def test_bad_references_are_refused_at_make_and_at_reset(reference, field):
    import gymnasium as gym

    with pytest.raises(ValueError, match=field) as err:
        gym.make("sma_gym:SMATracking-v0", reference=reference)
    assert "expected" in str(err.value)
    env = gym.make("sma_gym:SMATracking-v0")
    with pytest.raises(ValueError, match=field):
        env.reset(seed=0, options={"reference": reference})


# --- item 9: SB3VecEnv honours indices -------------------------------------------------------------


def test_sb3_vec_env_honours_indices_and_refuses_fixed_attributes():
    import gymnasium as gym

    from sma_gym.envs.sb3 import SB3VecEnv

    venv = SB3VecEnv(gym.make_vec("sma_gym:SMATracking-v0", num_envs=3, vectorization_mode="vector_entry_point"))
    venv.seed(0)
    venv.reset()
    for _ in range(5):
        venv.step(np.ones((3, 1), np.float32))
    steps = venv.venv.unwrapped._steps.copy()
    result = venv.env_method("reset", indices=[0])
    assert len(result) == 1 and result[0][0].shape == venv.observation_space.shape
    assert list(venv.venv.unwrapped._steps) == [0, steps[1], steps[2]]
    with pytest.raises(ValueError, match="control_period_s"):
        venv.set_attr("control_period_s", 0.01)
    assert venv.get_attr("control_period_s")[0] == venv.venv.unwrapped.sim.control_period_s
    with pytest.raises(ValueError, match="share one simulator"):
        venv.set_attr("max_episode_steps", 10, indices=[1])
    venv.set_attr("max_episode_steps", 10)
    with pytest.raises(ValueError, match="indices"):
        venv.env_method("reset", indices=[7])


# --- item 8: synth validates its options up front ----------------------------------------------------


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--sample-period", "0"], "--sample-period"),
        (["--sample-period", "-1"], "--sample-period"),
        (["--sample-period", "1e-6"], "--sample-period"),
        (["--sample-period", "100"], "--sample-period"),
        (["--sample-period", "0.05", "--duration", "3"], "samples"),
        (["--position-noise", "1"], "--position-noise"),
        (["--resistance-noise", "-1"], "--resistance-noise"),
        (["--duration", "inf"], "--duration"),
        (["--duration", "1e6"], "--duration"),
        (["--seed", "-1"], "--seed"),
        (["--actuator-seed", "-1"], "--actuator-seed"),
        (["--form", "uniform"], "--form"),  # a form without an effect was silently ignored
        (["--position-noise", "-1e-6"], "--position-noise = -1e-06"),  # was "expected one argument"
        # Its first step came 4.8 s in: a file of rest in which a diagnosis found "no missing effect".
        (["--duration", "5"], "the wire is driven for 0.18 s only"),
        (["--out", " "], "--out ' ': empty, expected a .csv file name"),  # named '.'
    ],
)
def test_synth_rejects_out_of_range_options_and_writes_nothing(tmp_path, capsys, args, needle):
    from sma_gym.cli import main

    assert main(["synth", "--out", str(tmp_path / "s.csv"), *args]) == 2
    assert needle in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_ends_a_command_with_a_line_not_a_traceback(tmp_path, capsys, monkeypatch):
    import sma_gym.diagnosis.synth
    from sma_gym.cli import main

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(sma_gym.diagnosis.synth, "write", interrupted)
    assert main(["synth", "--out", str(tmp_path / "s.csv"), "--duration", "7"]) == 130
    assert capsys.readouterr().err == "sma-gym synth: interrupted\n"
    assert list(tmp_path.iterdir()) == []


def test_sigterm_ends_a_command_like_ctrl_c_and_leaves_no_folder_nor_lock(tmp_path):
    """``timeout`` or a cluster scheduler stops a job with SIGTERM, whose default action ran
    no cleanup: a diagnosis killed that way left its ``--out`` holding only the lock (found by
    a new user). Now the command says so, exits 143 and removes the empty folder."""
    import signal
    import time

    from sma_gym._io import LOCK_NAME
    from sma_gym.cli import main

    assert main(["synth", "--out", str(tmp_path / "fit.csv"), "--duration", "10"]) == 0
    out = tmp_path / "out"
    proc = subprocess.Popen(
        [sys.executable, "-m", "sma_gym", "diagnose", str(tmp_path / "fit.csv"), "--out", str(out), "--threads", "1"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 120
        while not (out / LOCK_NAME).exists() and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert (out / LOCK_NAME).exists(), "the diagnosis never took its --out"
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    finally:
        proc.kill()
    assert proc.returncode == 143, err
    assert err.rstrip().endswith("sma-gym diagnose: terminated") and "Traceback" not in err
    assert not out.exists()


def test_a_sigterm_that_lands_inside_a_callback_from_c_is_sent_again():
    """Python drops an exception raised inside a ctypes callback; numba's compiler runs
    such callbacks while it loads a cached kernel, and one diagnosis in six stopped there
    ran to its end with exit code 0."""
    import ctypes
    import signal
    import time

    from sma_gym._io import Terminated, sigterm_as_interrupt

    @ctypes.CFUNCTYPE(None)
    def from_c() -> None:
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.01)  # the handler runs here, inside the callback, and its exception is dropped

    before = signal.getsignal(signal.SIGTERM), sys.unraisablehook
    started = time.monotonic()
    with pytest.raises(Terminated), sigterm_as_interrupt():
        from_c()
        time.sleep(10)  # the signal sent again ends this
    assert time.monotonic() - started < 5
    assert (signal.getsignal(signal.SIGTERM), sys.unraisablehook) == before


def test_an_object_half_built_when_sigterm_lands_is_released_without_noise():
    """CI, a cold numba cache: SIGTERM landed inside llvmlite's ``PipelineTuningOptions()``
    before its pointer was set; its ``__del__`` then failed ("no attribute
    '_as_parameter_'") and Python printed that traceback after "sma-gym diagnose:
    terminated". The stop's frames are now released inside the block, their debris unprinted."""
    import gc
    import signal
    import time

    from sma_gym._io import Terminated, sigterm_as_interrupt

    class HalfBuilt:
        def __init__(self) -> None:
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(1)  # the handler raises here, before the handle is set
            self.handle = 1

        def __del__(self) -> None:
            del self.handle  # as llvmlite's ObjectRef.detach: AttributeError when half-built

    printed: list = []
    hook = sys.unraisablehook
    sys.unraisablehook = printed.append
    try:
        with pytest.raises(Terminated) as stop, sigterm_as_interrupt():
            HalfBuilt()
        del stop
        gc.collect()
    finally:
        sys.unraisablehook = hook
    assert printed == []


def test_an_error_a_lost_sigterm_causes_leaves_as_the_stop_and_nothing_is_sent_after():
    """A SIGTERM lost in numba's callback left its compiler half done, and it raised
    "RuntimeError: no compiled object yet" (a traceback, exit 1) before the signal could be
    sent again. An error that leaves the block after a lost stop is that stop; the resend
    still pending is cancelled, not delivered to whatever handler comes after the block."""
    import ctypes
    import signal
    import time

    from sma_gym._io import Terminated, sigterm_as_interrupt

    @ctypes.CFUNCTYPE(None)
    def from_c() -> None:
        signal.raise_signal(signal.SIGTERM)  # to this thread: the handler runs here, its exception dropped

    after: list[int] = []
    before = signal.signal(signal.SIGTERM, lambda signum, frame: after.append(signum))
    try:
        with pytest.raises(Terminated) as stop, sigterm_as_interrupt():
            from_c()
            raise RuntimeError("no compiled object yet")  # at once, before the resend
        assert isinstance(stop.value.__cause__, RuntimeError)
        time.sleep(0.3)
        assert after == []
    finally:
        signal.signal(signal.SIGTERM, before)


def test_a_sigterm_lost_in_a_callback_at_the_end_of_the_block_still_stops():
    import ctypes
    import signal

    from sma_gym._io import Terminated, sigterm_as_interrupt

    @ctypes.CFUNCTYPE(None)
    def from_c() -> None:
        signal.raise_signal(signal.SIGTERM)  # the handler's exception is dropped here

    with pytest.raises(Terminated), sigterm_as_interrupt():
        from_c()  # and the block ends before the signal is sent again


@pytest.mark.parametrize("error", [RuntimeError, AttributeError, ValueError])
def test_any_error_raised_while_handling_a_stop_leaves_as_the_stop(error):
    import signal

    from sma_gym._io import Terminated, sigterm_as_interrupt

    with pytest.raises(Terminated), sigterm_as_interrupt():
        try:
            signal.raise_signal(signal.SIGTERM)
        except Terminated as err:
            raise error("a library's own error for the stop") from err
    with pytest.raises(error), sigterm_as_interrupt():
        raise error("no stop behind it")


def test_a_closed_stdout_ends_a_command_without_a_traceback(tmp_path, capsys, monkeypatch):
    """``sma-gym diagnose ... | head`` printed a BrokenPipeError traceback once ``head`` had
    read its lines; now the shell's code for SIGPIPE and nothing on stderr."""
    import sma_gym.diagnosis.synth
    from sma_gym.cli import main

    def closed(*args, **kwargs):
        raise BrokenPipeError(32, "Broken pipe")

    monkeypatch.setattr(sma_gym.diagnosis.synth, "write", closed)
    assert main(["synth", "--out", str(tmp_path / "s.csv"), "--duration", "7"]) == 141
    assert capsys.readouterr().err == ""
    assert list(tmp_path.iterdir()) == []


def test_sigterm_ends_train_py_like_ctrl_c(tmp_path, capsys, monkeypatch):
    import sma_gym_agents.training.run as run_module
    from sma_gym._io import Terminated
    from sma_gym_agents.training.cli import main

    def terminated(run, out, **kwargs):
        raise Terminated("signal 15")

    monkeypatch.setattr(run_module, "train_and_compare", terminated)
    assert main(["--quick", "--no-progress", "--out", str(tmp_path / "never")]) == 143
    assert capsys.readouterr().err.strip() == "train.py: terminated"


def test_synth_actuator_seed_gives_another_run_of_the_same_actuator(tmp_path):
    """``--seed`` alone draws another actuator (the README's held-out file of the same wire was
    then another wire: its diagnosis came back "unexplained"); ``--actuator-seed K`` keeps the
    actuator of ``--seed K`` and changes only the run."""
    import json

    def labels(name: str) -> dict:
        return json.loads((tmp_path / f"{name}.labels.json").read_text())

    _synth(tmp_path, "fit.csv")
    _synth(tmp_path, "other.csv", "--seed", "1")
    _synth(tmp_path, "held.csv", "--seed", "1", "--actuator-seed", "0")
    fit, other, held = labels("fit"), labels("other"), labels("held")
    assert held["perturbation"] == fit["perturbation"] != other["perturbation"]
    assert (fit["actuator_seed"], other["actuator_seed"], held["actuator_seed"]) == (0, 1, 0)
    assert (
        (tmp_path / "held.csv").read_text()
        != (tmp_path / "other.csv").read_text()
        != (tmp_path / "fit.csv").read_text()
    )


@pytest.mark.parametrize("name", ["labels.json", "trace.txt", "trace"])
def test_synth_writes_only_csv_files(tmp_path, capsys, name):
    from sma_gym.cli import main

    assert main(["synth", "--out", str(tmp_path / name), "--duration", "7"]) == 2
    assert "expected a .csv file name" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


# --- item 10: loader and file gaps ------------------------------------------------------------------


def _csv_text(rows: int = 40) -> str:
    lines = ["t,duty,position"] + [f"{k * 1e-3:.3f},{0.3 if k > 10 else 0.0},{1e-5 * k:.6g}" for k in range(rows)]
    return "\n".join(lines) + "\n"


def test_measured_files_accept_a_bom_and_trailing_blank_lines(tmp_path):
    from sma_gym.data import load_trace

    f = tmp_path / "excel.csv"
    f.write_bytes(b"\xef\xbb\xbf" + _csv_text().encode() + b"\n\n \n")
    assert len(load_trace(f).t) == 40


def test_files_too_short_for_a_diagnosis_are_refused_at_load(tmp_path, capsys):
    from sma_gym.cli import main

    f = tmp_path / "short.csv"
    f.write_text(_csv_text(5))
    assert main(["diagnose", str(f), "--out", str(tmp_path / "d")]) == 2
    err = capsys.readouterr().err
    assert "short.csv" in err and "at least 20" in err
    assert not (tmp_path / "d").exists()


def test_binary_directories_lists_and_endless_files_name_the_file(tmp_path):
    from sma_gym.data import MeasuredDataError, load_trace
    from sma_gym.model import load_model

    f = tmp_path / "ok.csv"
    f.write_text(_csv_text())
    side = tmp_path / "ok.csv.json"
    side.write_bytes(b"\x00\xff\xfe binary")
    with pytest.raises(MeasuredDataError, match="not UTF-8") as err:
        load_trace(f)
    assert str(side) in str(err.value)
    side.unlink()
    side.mkdir()
    with pytest.raises(MeasuredDataError, match="folder"):
        load_trace(f)
    model = tmp_path / "model.json"
    model.write_bytes(b"\x89PNG\r\n\x1a\n\xff")
    with pytest.raises(ValueError, match="not UTF-8") as err:
        load_model(str(model))
    assert str(model) in str(err.value)
    with pytest.raises(ValueError, match="folder"):
        load_model(str(tmp_path))
    model.write_text('{"format": "sma-gym-model", "version": 1, "effects": ["sensor_lag"]}')
    with pytest.raises(ValueError, match="'effects' is a JSON list") as err:
        load_model(str(model))
    assert str(model) in str(err.value)
    if os.path.exists("/dev/zero"):
        with pytest.raises(ValueError, match="larger than"):
            load_model("/dev/zero")


def test_a_faster_controller_is_replayed_with_the_mean_of_its_commands():
    """A file logged with a 2 kHz controller (every other command off) is decimated to the
    model's 1 kHz steps with each kept row holding the mean duty: the nominal model then
    replays it within 0.01 mm (keeping every other command, it saw twice the power and was
    4.9 mm off on a 4.6 mm stroke)."""
    from sma_gym import ModelConfig, Simulator
    from sma_gym.data import MeasuredTrace
    from sma_gym.diagnosis import fitting
    from sma_gym.diagnosis.workflow import _decimated

    model, dt = ModelConfig(), 5e-4
    t = np.arange(24_000) * dt
    level = np.where((t % 6.0 < 3.0) & (t >= 1.0), 0.12, 0.0)
    duty = np.where(np.arange(t.size) % 2 == 0, 2.0 * level, 0.0)
    rec = Simulator([model], control_period_s=dt).run(duty[:, None], record=("position_m",))
    trace = MeasuredTrace(path="fast.csv", t=t, duty=duty, position=np.r_[0.0, rec["position_m"][:-1, 0]])
    said: list[str] = []
    data = fitting.prepare(_decimated(trace, 1e-3, said.append), 1e-3)
    assert "duty is averaged" in said[0]
    sim = fitting.simulate([model], [0.0], data, 1e-3)["position"][:, 0]
    assert np.sqrt(np.mean((sim - data.outputs["position"]) ** 2)) < 1e-5
    assert trace.position.max() > 4e-3


def test_diagnose_shows_progress_and_decimates_oversampled_files(tmp_path, capsys):
    from sma_gym.data import load_trace
    from sma_gym.diagnosis.workflow import _decimated

    csv = _synth(tmp_path, "s.csv")
    trace = load_trace(csv)
    dense = type(trace)(path="dense.csv", t=np.linspace(0, 5, 50_001), duty=np.zeros(50_001), position=np.zeros(50_001))
    said: list[str] = []
    small = _decimated(dense, 1e-3, said.append)
    assert len(small.t) <= 5_001 and "keeping every 10th" in said[0]
    long = type(trace)(path="long.csv", t=np.arange(0, 4000.0, 0.25), duty=np.zeros(16000), position=np.zeros(16000))
    with pytest.raises(
        ValueError, match=r"at most 1800 s .* \(or is the time in milliseconds\? its median step is 0.25 s\)"
    ):
        _decimated(long, 1e-3, said.append)
    from sma_gym.cli import main

    assert main(["diagnose", str(csv), "--out", str(tmp_path / "d"), "--effects", "sensor_lag"]) == 0
    err = capsys.readouterr().err
    assert "candidate 1/2: nominal refit" in err and "candidate 2/2: sensor_lag" in err


# --- item 1 (validation): physically meaningless models are refused; every step is bounded ---------------


def test_every_preset_is_valid_and_meaningless_wires_are_refused_with_field_value_and_reason():
    from sma_gym.params import preset, preset_names

    for name in preset_names():
        preset(name)
    base = preset("standard")
    cases = {
        "wire.length_m": 1e-5,  # the issue's hang
        "wire.diameter_m": 0.3,  # mm for m
        "wire.specific_heat_j_kg_k": 0.8374,  # J/(g K), Table 5.1's erratum
        "wire.youngs_modulus_austenite_pa": 83.0,  # GPa for Pa
        "wire.density_kg_m3": 6.5,  # g/cm^3
        "wire.resistivity_martensite_ohm_m": 97.1,  # uohm cm
        "convection.h0_w_m2_k": 1e9,
        "driver.supply_voltage_v": 1000.0,
        "mechanism.moving_mass_kg": 1e-9,
        "mechanism.spring_stiffness_n_m": 1e9,
        "sensors.position_noise_std_m": 1.0,
    }
    for key, value in cases.items():
        with pytest.raises(ValueError) as err:
            base.with_changes(**{key: value})
        text = str(err.value)
        field = key.split(".")[1]
        assert field in text and repr(value) in text and "expected a value in" in text, text
        assert text.count(":") >= 2, f"no physical reason in {text!r}"
    with pytest.raises(ValueError, match="rest stress"):
        base.with_changes(**{"wire.diameter_m": 25e-6, "mechanism.spring_preload_n": 5.0})


_STEP_WORKER = r"""
import json, sys, time
import gymnasium as gym
import numpy as np
import sma_gym

env = gym.make("sma_gym:SMATracking-v0")
env.reset(seed=0)
env.step(np.zeros(1, np.float32))
print("ready", flush=True)
for line in sys.stdin:
    try:
        env = gym.make("sma_gym:SMATracking-v0", model=line.strip())
    except ValueError as err:
        print(json.dumps({"refused": str(err)}), flush=True)
        continue
    env.reset(seed=0)
    worst = 0.0
    for a in (1.0, 1.0, 1.0, 1.0, -1.0, 0.0):
        start = time.perf_counter()
        env.step(np.array([a], np.float32))
        worst = max(worst, time.perf_counter() - start)
    print(json.dumps({"worst_step_s": worst}), flush=True)
"""


class _StepWorker:
    """One compiled process that makes an env per model file and steps it; a hang is a failure."""

    def __init__(self) -> None:
        env = {**os.environ, "PYTHONUNBUFFERED": "1"}
        self.proc = subprocess.Popen(
            [sys.executable, "-c", _STEP_WORKER],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env=env,
        )
        assert self.readline(240.0) == "ready"

    def readline(self, timeout: float) -> str:
        import selectors

        with selectors.DefaultSelector() as sel:
            sel.register(self.proc.stdout, selectors.EVENT_READ)
            if not sel.select(timeout):
                self.proc.kill()
                pytest.fail(f"no answer within {timeout} s: a step hangs")
        line = self.proc.stdout.readline()
        if not line:
            pytest.fail(f"the worker died (exit code {self.proc.wait()})")
        return line.strip()

    def ask(self, path: Path, timeout: float = 20.0) -> dict:
        import json

        self.proc.stdin.write(f"{path}\n")
        self.proc.stdin.flush()
        return json.loads(self.readline(timeout))

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait(timeout=30)
        # Left open, its pipe is closed by the garbage collector, whose ResourceWarning then
        # lands in whichever test runs at that moment (the env checkers' "no warnings" test).
        self.proc.stdout.close()


@pytest.fixture(scope="module")
def step_worker():
    worker = _StepWorker()
    yield worker
    worker.close()


# log10 ranges drawn: each reaches well beyond the validated bounds on both sides.
_DRAWN = {
    "wire.length_m": (-6.0, 2.0),
    "wire.diameter_m": (-6.0, -1.0),
    "wire.density_kg_m3": (1.0, 5.0),
    "wire.specific_heat_j_kg_k": (-1.0, 5.0),
    "wire.youngs_modulus_austenite_pa": (6.0, 13.0),
    "convection.h0_w_m2_k": (-2.0, 6.0),
    "driver.supply_voltage_v": (-2.0, 3.0),
    "mechanism.moving_mass_kg": (-7.0, 3.0),
    "mechanism.spring_stiffness_n_m": (-1.0, 7.0),
}


def _model_strategy():
    """One or two parameters of the standard model, each drawn log-uniformly across and beyond its bounds."""
    from hypothesis import strategies as st

    def values(keys: frozenset) -> st.SearchStrategy:
        return st.fixed_dictionaries({k: st.floats(*_DRAWN[k]).map(lambda e: float(10.0**e)) for k in sorted(keys)})

    return st.frozensets(st.sampled_from(sorted(_DRAWN)), min_size=1, max_size=2).flatmap(values)


def test_models_across_the_bounds_are_refused_or_step_in_bounded_time(tmp_path_factory, step_worker):
    import json

    from hypothesis import HealthCheck, example, given, settings

    from sma_gym.model import ModelConfig

    folder = tmp_path_factory.mktemp("models")
    base = ModelConfig().to_dict()
    outcomes: list[str] = []

    @settings(max_examples=30, deadline=None, database=None, suppress_health_check=list(HealthCheck))
    @given(_model_strategy())
    @example({"wire.length_m": 1e-5})  # the issue's hang
    @example({"wire.length_m": 1e-4})  # the issue's 25 800 degC
    @example({"wire.length_m": 0.01, "wire.diameter_m": 2e-3, "driver.supply_voltage_v": 60.0})  # corners inside
    @example({"wire.length_m": 0.01, "wire.diameter_m": 25e-6, "driver.supply_voltage_v": 60.0})
    def check(changes: dict) -> None:
        data = json.loads(json.dumps(base))
        for key, value in changes.items():
            group, name = key.split(".")
            data["actuator"][group][name] = value
        path = folder / f"model{len(outcomes)}.json"
        path.write_text(json.dumps(data))
        answer = step_worker.ask(path)
        if "refused" in answer:
            outcomes.append("refused")
            return
        outcomes.append("stepped")
        assert answer["worst_step_s"] < 5.0, (changes, answer)

    check()
    print(f"models: {outcomes.count('refused')} refused, {outcomes.count('stepped')} stepped")
    assert "refused" in outcomes and "stepped" in outcomes


# --- from a new user's try of bad input (2026-11-25) ------------------------------------------


def _sha(path: Path) -> str:
    import hashlib

    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_diagnose_never_writes_over_its_inputs_nor_silently_over_an_earlier_report(tmp_path, capsys):
    from sma_gym.cli import main

    a = _synth(tmp_path, "a.csv")
    b = _synth(tmp_path, "b.csv", "--seed", "1")
    out = tmp_path / "d"
    quick = ["--effects", "sensor_lag", "--max-rounds", "1"]
    assert main(["diagnose", str(a), "--out", str(out), *quick]) == 0
    model = out / "corrected_model.json"
    before = {p.name: _sha(p) for p in out.iterdir()}
    # The corrected model passed back as the nominal one, into the same folder: refused even
    # with --overwrite, since the run would replace the file it reads.
    for extra in ([], ["--overwrite"]):
        assert main(["diagnose", str(b), "--model", str(model), "--out", str(out), *quick, *extra]) == 2
        assert "write over its own input" in capsys.readouterr().err
    # A measured file inside --out that shares an output's name is protected the same way.
    clash = out / "diagnosis.json"
    assert main(["diagnose", str(a), "--heldout", str(clash), "--out", str(out), *quick, "--overwrite"]) == 2
    assert {p.name: _sha(p) for p in out.iterdir()} == before
    # An earlier report needs --overwrite, which replaces it and removes its plots of other files.
    assert main(["diagnose", str(b), "--out", str(out), *quick]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert {p.name: _sha(p) for p in out.iterdir()} == before
    assert main(["diagnose", str(b), "--out", str(out), *quick, "--overwrite"]) == 0
    names = {p.name for p in out.iterdir()}
    assert "fit_0_b.png" in names and "fit_0_a.png" not in names, names


def test_diagnose_refuses_unusable_data_before_it_creates_out(tmp_path, capsys):
    from sma_gym.cli import main

    good = _synth(tmp_path, "s.csv")
    short = tmp_path / "short.csv"  # 100 rows but under 1 ms: not one control step
    short.write_text("t,duty,position\n" + "".join(f"{k * 1e-5!r},0.5,0.0\n" for k in range(100)))
    dead = tmp_path / "dead.csv"  # the duty steps, the sensor never moves
    dead.write_text(
        "t,duty,position,resistance\n"
        + "".join(f"{k * 1e-3!r},{0.3 if k > 500 else 0.0},0.0,{'3.75' if k > 500 else ''}\n" for k in range(3000))
    )
    cold = tmp_path / "cold.csv"  # never heated: the position is sensor noise only
    cold.write_text("t,duty,position\n" + "".join(f"{k * 1e-3!r},0.0,{(k % 7) * 1e-6!r}\n" for k in range(3000)))
    late = tmp_path / "late.csv"  # rests, then heats in its last 20 %: the part fitted never heats
    late.write_text(
        "t,duty,position\n"
        + "".join(f"{k * 1e-2!r},{0.2 if k >= 80 else 0.0},{max(k - 80, 0) * 1e-5!r}\n" for k in range(100))
    )
    out = tmp_path / "d"
    cases = [
        ([str(short)], "short.csv: 0.99 ms of data, expected at least 20 control steps"),
        ([str(late)], "late.csv (t < 0.693 s): duty = 0 in every row of the first 70 % of each file"),
        ([str(dead)], "no measured output varies"),
        ([str(cold)], "cold.csv: duty = 0 in every row; expected a trace in which the wire is heated"),
        ([str(good), str(good)], "already given"),
        ([str(good), "--heldout", str(good)], "held-out data must not be fitted"),
    ]
    for files, message in cases:
        assert main(["diagnose", *files, "--out", str(out)]) == 2
        assert message in capsys.readouterr().err
        assert not out.exists()
    assert main(["diagnose", str(good), "--out", ""]) == 2
    assert "--out '': empty, expected a folder" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(
        ["cold.csv", "dead.csv", "late.csv", "s.csv", "s.csv.json", "s.labels.json", "short.csv"]
    )
    # With a held-out file the whole of it is fitted, heating included.
    from sma_gym.data import load_trace
    from sma_gym.diagnosis.workflow import require_diagnosable

    require_diagnosable([load_trace(late)], [load_trace(good)])


def test_a_sidecar_model_is_the_nominal_model_or_refused(tmp_path, capsys, monkeypatch):
    import json

    import sma_gym.diagnosis.workflow
    from sma_gym.cli import main

    used = []

    class Stop(Exception):
        """Raised instead of the work: only the choice of the nominal model is tested."""

    def record(fit, held, nominal, *args, **kwargs):
        used.append(nominal.actuator.name)
        raise Stop

    monkeypatch.setattr(sma_gym.diagnosis.workflow, "diagnose", record)
    csv = _synth(tmp_path, "s.csv")
    side = tmp_path / "s.csv.json"
    conditions = json.loads(side.read_text())
    side.write_text(json.dumps({**conditions, "model": "Flexinol 0.5 mm"}))
    assert main(["diagnose", str(csv), "--out", str(tmp_path / "d")]) == 2
    assert "sidecar 'model' = 'Flexinol 0.5 mm': expected a model name" in capsys.readouterr().err
    # ... unless --model is given, which decides (it was refused all the same; a new user's trial).
    with pytest.raises(Stop):
        main(["diagnose", str(csv), "--out", str(tmp_path / "d"), "--model", "wire-0.2mm"])
    assert "--model 'wire-0.2mm' is used; the sidecars name 'Flexinol 0.5 mm'" in capsys.readouterr().err
    # Two sidecars that name different models: --model decides there too.
    other = _synth(tmp_path, "o.csv", "--seed", "1")
    (tmp_path / "o.csv.json").write_text(json.dumps({**conditions, "model": "wire-0.3mm"}))
    side.write_text(json.dumps({**conditions, "model": "wire-0.5mm"}))
    assert main(["diagnose", str(csv), "--heldout", str(other), "--out", str(tmp_path / "d")]) == 2
    assert "the sidecars name different models" in capsys.readouterr().err
    with pytest.raises(Stop):
        main(["diagnose", str(csv), "--heldout", str(other), "--out", str(tmp_path / "d"), "--model", "wire-0.2mm"])
    used.clear()
    side.write_text(json.dumps({**conditions, "model": "wire-0.5mm"}))
    with pytest.raises(Stop):
        main(["diagnose", str(csv), "--out", str(tmp_path / "d")])
    with pytest.raises(Stop):
        main(["diagnose", str(csv), "--out", str(tmp_path / "d"), "--model", "standard"])
    from sma_gym.model import load_model

    assert used == [load_model("wire-0.5mm").actuator.name, load_model("standard").actuator.name]
    assert not (tmp_path / "d").exists()  # the failed runs left no empty folder


def test_locked_folder_removes_only_the_empty_folders_it_created_on_failure(tmp_path):
    from sma_gym._io import locked_folder

    with pytest.raises(RuntimeError), locked_folder(tmp_path / "new" / "deeper"):
        raise RuntimeError("failed before writing")
    assert not (tmp_path / "new").exists()
    with pytest.raises(RuntimeError), locked_folder(tmp_path / "kept") as folder:
        (folder / "partial.md").write_text("written before the failure")
        raise RuntimeError("failed after writing")
    assert [p.name for p in (tmp_path / "kept").iterdir()] == ["partial.md"]
    (tmp_path / "existing").mkdir()
    with pytest.raises(RuntimeError), locked_folder(tmp_path / "existing"):
        raise RuntimeError("failed")
    assert (tmp_path / "existing").is_dir()  # the user's (empty) folder stays


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--env-kwargs", "control_period_s:"], "control_period_s = ''"),
        (["--env-kwargs", "foo:1"], "unknown env kwargs ['foo']"),
        (["--hyperparams", "gamma:2"], "gamma = 2: expected a number in [0, 1]"),
        (["--hyperparams", "learning_rate:-1"], "learning_rate = -1"),
        (["--timesteps", "-5"], "--quick with --timesteps -5"),
        (["--hyperparams", "ent_coef:bad"], "ent_coef = 'bad': expected a number >= 0, 'auto'"),
        # These crashed in training with a traceback, or trained an agent that never learnt:
        (["--hyperparams", "gradient_steps:abc"], "gradient_steps = 'abc': expected an integer >= 1, or -1"),
        (["--hyperparams", "gradient_steps:0"], "0 would never train"),
        (["--hyperparams", "ent_coef:-1"], "--hyperparams ent_coef: ent_coef = -1: expected a number >= 0"),
        (["--hyperparams", "use_sde:3"], "use_sde = 3: expected true or false"),
        (["--hyperparams", "verbose:2"], "verbose is set by train.py"),  # SB3: "got multiple values"
        (["--hyperparams", "n_timesteps:1.5"], "n_timesteps = 1.5: expected an integer >= 1"),  # was int(1.5)
        (["--hyperparams", "policy_kwargs:dict(net_arch=[0])"], "net_arch = [0]: expected a list of layer sizes"),
        # Only torch's optimiser can check its own keywords: refused when the model is built.
        (
            ["--hyperparams", "policy_kwargs:{'optimizer_kwargs': {'betas': 3}}"],
            "stable-baselines3 refused one of them",
        ),
        (["--env-kwargs", "control_period_s:0.01", "control_period_s:0.02"], "control_period_s: given twice"),
        (["--residual", ""], "--residual '': expected 'none' or a controller's label"),  # ran the file's base
        (["--hyperparams", "learning_rate:abc"], "learning_rate = 'abc': expected a number > 0"),
        (["--hyperparams", "batch_size:abc"], "batch_size = 'abc': expected an integer >= 1"),  # crashed mid-training
        (["--hyperparams", "buffer_size:5000"], "--quick with --hyperparams buffer_size"),  # was silently replaced
        (["--seed", "4294967296"], "--seed 4294967296: expected an integer in [0, 4294967295]"),  # numpy's words
        (["--seeds", "2", "--seed", "4294967295"], "the last seed, 4294967296, is past 4294967295"),
    ],
)
def test_train_refuses_bad_options_and_leaves_no_run_folder(tmp_path, args, needle):
    out = tmp_path / "run"
    proc = _run([sys.executable, str(ROOT / "train.py"), "--quick", "--no-progress", "--out", str(out), *args])
    assert proc.returncode == 2 and needle in proc.stderr and "Traceback" not in proc.stderr, proc.stderr[-2000:]
    assert not out.exists()  # so the corrected command can use the same --out


def test_resume_refuses_a_folder_that_is_not_a_sweep(tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "data.csv").write_text("t,duty,position\n")
    proc = _run([sys.executable, str(ROOT / "train.py"), "--quick", "--seeds", "2", "--resume", "--out", str(out)])
    assert proc.returncode == 2 and "not a sweep's folder" in proc.stderr and "data.csv" in proc.stderr
    assert sorted(p.name for p in out.iterdir()) == ["data.csv"]


@pytest.mark.parametrize(("group", "name"), [("wire", "length_m"), ("wire", "minor_loop_law"), ("sensors", None)])
def test_a_model_file_without_a_parameter_is_refused_naming_it(tmp_path, group, name):
    """Found by a new user: a file whose ``wire.length_m`` was deleted ran as the standard
    wire's 0.273 m without a word."""
    import gymnasium as gym

    from sma_gym.model import load_model

    data = load_model("bench-0.5mm-ht-datasheet").to_dict()
    if name is None:
        del data["actuator"][group]
    else:
        del data["actuator"][group][name]
    path = tmp_path / "model.json"
    path.write_text(json.dumps(data))
    before = path.read_bytes()
    with pytest.raises(ValueError, match=rf"model\.json.*missing .*{name or group}"):
        gym.make("sma_gym:SMATracking-v0", model=str(path))
    assert path.read_bytes() == before


def test_model_files_hold_numbers_where_the_model_has_numbers(tmp_path):
    import gymnasium as gym

    from sma_gym.model import ModelConfig

    data = ModelConfig().to_dict()
    for value, kind in (("10", "str"), (True, "bool")):
        data["actuator"]["driver"]["supply_voltage_v"] = value
        with pytest.raises(ValueError, match=rf"driver.supply_voltage_v = .* \(JSON {kind}\): expected a number"):
            ModelConfig.from_dict(data)
    data["actuator"]["driver"]["supply_voltage_v"] = 10
    assert ModelConfig.from_dict(data).actuator.driver.supply_voltage_v == 10
    with pytest.raises(ValueError, match="reference = 5: expected a reference name"):
        gym.make("sma_gym:SMATracking-v0", reference=5)


def test_the_loader_refuses_a_card_that_does_not_describe_its_model(tmp_path):
    import json

    from sma_gym_agents.trained import load_policy, save_policy

    model = _tiny_model()
    path = save_policy(model, tmp_path / "agent.zip", CARD)
    card_path = tmp_path / "agent.json"
    good = json.loads(card_path.read_text())
    cases = {
        "frame_stack": (5, "the card does not describe this model"),
        "history": ("ema", "the card does not describe this model"),
        "residual": ("nope", "cannot be run: controller = 'nope'"),
        "env_kwargs": ({"control_period_s": 0.0}, "cannot be run: control_period_s = 0.0"),
        "version": (99, "version = 99: expected an integer from 1 to 1"),
    }
    for key, (value, message) in cases.items():
        card_path.write_text(json.dumps({**good, key: value}))
        with pytest.raises(ValueError, match=re.escape(message)):
            load_policy(path)
    card_path.write_text(json.dumps(good))
    assert load_policy(path).name == "tiny"


def test_evaluate_and_bench_bound_their_repeat_counts(capsys, monkeypatch):
    import sma_gym.bench
    import sma_gym_agents.commands
    from sma_gym.cli import main

    def no_work(*args, **kwargs):
        raise AssertionError("a million repeats were accepted")  # fail, do not run for days

    monkeypatch.setattr(sma_gym_agents.commands, "evaluate", no_work)
    monkeypatch.setattr(sma_gym.bench, "run", no_work)
    assert main(["evaluate", "--experiments", "8", "--seeds", "1000000"]) == 2
    assert "--seeds 1000000: expected an integer in [1, 100]" in capsys.readouterr().err
    assert main(["bench", "--repeats", "1000000"]) == 2
    assert "--repeats 1000000: expected an integer in [1, 100]" in capsys.readouterr().err


def test_policy_paths_and_controller_observations_are_named_when_wrong(tmp_path):
    import gymnasium as gym

    from sma_gym_agents import ControllerPolicy
    from sma_gym_agents.trained import load_policy

    (tmp_path / "plain.txt").write_text("not a model")
    with pytest.raises(ValueError, match=r"not a \.zip"):
        load_policy(tmp_path / "plain.txt")
    with pytest.raises(ValueError, match="a folder"):
        load_policy(tmp_path)
    policy = ControllerPolicy("PID", gym.make("sma_gym:SMATracking-v0"))
    k = policy.k
    with pytest.raises(ValueError, match="observation holds NaN at feature"):
        policy.predict(np.full(k, np.nan))
    with pytest.raises(ValueError, match=rf"shape \({k + 1},\)"):
        policy.predict(np.zeros(k + 1))


def test_a_file_of_text_names_the_first_bad_cells_and_counts_the_rest(tmp_path):
    from sma_gym.data import MeasuredDataError, load_trace

    bad = tmp_path / "bad.csv"
    bad.write_text("t,duty,position\n" + "".join(f"{k * 1e-3},x,0\n" for k in range(5000)))
    with pytest.raises(MeasuredDataError) as err:
        load_trace(bad)
    lines = str(err.value).splitlines()
    assert len(lines) < 30 and "4980 more cells that are not numbers" in lines[-1]


def _here(key: str) -> str:
    return "here"


def test_algorithm_fractions_have_their_own_lower_ends():
    from sma_gym_agents.training.keywords import check_model_kwargs

    check_model_kwargs({"gamma": 0.0, "tau": 0.02}, "sac", _here)  # gamma 0: a myopic agent
    check_model_kwargs({"gamma": 0.99, "gae_lambda": 0.0}, "ppo", _here)  # lambda 0: one-step TD
    bad = (("gamma", -0.1), ("tau", 0.0), ("gae_lambda", 1.5), ("gamma", float("nan")), ("tau", True))
    for key, value in bad:
        with pytest.raises(ValueError, match=rf"here: {key} = "):
            check_model_kwargs({key: value}, "ppo" if key == "gae_lambda" else "sac", _here)


def test_algorithm_counts_and_rates_are_checked_whatever_their_type():
    """Strings and fractional counts passed the range checks (only numbers were compared) and
    failed deep in training, with a traceback and a half-written run folder."""
    from sma_gym_agents.training.keywords import check_model_kwargs

    good = {"learning_rate": 3e-4, "batch_size": 256, "buffer_size": 1e6, "n_steps": 64, "learning_starts": 0}
    check_model_kwargs(good, "sac", _here)
    check_model_kwargs({"learning_rate": lambda progress: 1e-3 * progress, "train_freq": [1, "episode"]}, "sac", _here)
    check_model_kwargs({"train_freq": (4, "step")}, "sac", _here)
    bad = [
        ("learning_rate", "abc"),
        ("learning_rate", float("inf")),
        ("batch_size", "abc"),
        ("batch_size", 1.5),
        ("n_epochs", True),
        ("buffer_size", float("nan")),
        ("train_freq", [0, "step"]),
        ("train_freq", [1, "episodes"]),
        ("train_freq", "4"),
        ("learning_starts", -1),
        ("learning_starts", "abc"),
    ]
    for key, value in bad:
        with pytest.raises(ValueError, match=rf"here: {key} = .*expected"):
            check_model_kwargs({key: value}, "ppo" if key == "n_epochs" else "sac", _here)


def test_evaluate_refuses_an_agent_that_no_chosen_experiment_scores(tmp_path, capsys, monkeypatch):
    import sma_gym_agents.commands
    from sma_gym.cli import main
    from sma_gym_agents.trained import save_policy

    monkeypatch.setattr(
        sma_gym_agents.commands, "evaluate", lambda *a, **k: (_ for _ in ()).throw(AssertionError("work"))
    )
    path = save_policy(_tiny_model(), tmp_path / "agent.zip", CARD)  # trained on SMATracking-v0
    assert main(["evaluate", "--experiments", "self-sensing,9", "--policy", str(path)]) == 2
    err = capsys.readouterr().err
    assert "only the experiment(s) 6.1, 7, 8 score" in err and "add 6.1 to --experiments" in err
    with pytest.raises(AssertionError, match="work"):  # a chosen experiment scores it: the work starts
        main(["evaluate", "--experiments", "8", "--policy", str(path)])


# --- from a new user's try of the Python API (2026-11-25, second hunt) ------------------------------


def _sb3_bank(num_envs: int = 3, **kwargs):
    import gymnasium as gym

    from sma_gym.envs.sb3 import SB3VecEnv

    return SB3VecEnv(
        gym.make_vec(
            "sma_gym:SMAMultiplexed-v0",
            num_envs=num_envs,
            vectorization_mode="vector_entry_point",
            max_episode_steps=30,
            **kwargs,
        )
    )


def test_the_bank_vector_env_hands_each_bank_its_own_scale_and_keeps_its_build_settings():
    from stable_baselines3.common.evaluation import evaluate_policy

    from sma_gym_agents import ControllerPolicy

    venv = _sb3_bank(3)
    scales = venv.get_attr("position_scale_m")
    assert len(scales) == 3 and all(np.ndim(s) == 0 for s in scales)  # one number per bank
    mean, _ = evaluate_policy(ControllerPolicy("PID", venv), venv, n_eval_episodes=3)  # was a broadcast error
    assert np.isfinite(mean)
    for name, value in (("control_period_s", 0.1), ("n", 7)):
        with pytest.raises(ValueError, match=rf"set_attr\('{name}'\): fixed when the env is made"):
            venv.set_attr(name, value)


def test_sb3s_set_options_reach_the_native_vector_envs_at_the_next_reset_only():
    import gymnasium as gym

    from sma_gym.envs.sb3 import SB3VecEnv

    venv = SB3VecEnv(gym.make_vec("sma_gym:SMATracking-v0", num_envs=3, vectorization_mode="vector_entry_point"))
    venv.set_options({"reference": "report-sine"})
    venv.reset()
    assert [d["name"] for d in venv.venv.unwrapped.reference_description()] == ["report-sine"] * 3
    venv.set_options([{"reference": "report-step"}, {}, {"reference": "report-step"}])
    venv.seed(4)
    venv.reset()
    names = [d["name"] for d in venv.venv.unwrapped.reference_description()]
    assert names[0] == names[2] == "report-step" and names[1] != "report-step"
    venv.reset()  # options used once, as DummyVecEnv uses them
    assert "report-step" not in [d["name"] for d in venv.venv.unwrapped.reference_description()]
    bank = _sb3_bank(2, n_actuators=2)
    bank.set_options({"references": ["report-step", "report-sine"]})
    bank.reset()
    assert [[d["name"] for d in b] for b in bank.venv.unwrapped.reference_description()] == [
        ["report-step", "report-sine"]
    ] * 2


@pytest.mark.parametrize("env_id", ["SMATracking-v0", "SMAMultiplexed-v0"])
def test_a_native_vector_env_refuses_a_step_or_a_reference_before_its_first_reset(env_id):
    import gymnasium as gym
    from gymnasium.error import ResetNeeded

    venv = gym.make_vec(
        f"sma_gym:{env_id}", num_envs=2, vectorization_mode="vector_entry_point", position_noise_std_m=1e-5
    )
    with pytest.raises(ResetNeeded, match="never reset"):
        venv.step(venv.action_space.sample())  # ran an episode without a reference; with noise, AttributeError
    with pytest.raises(ResetNeeded, match="call reset"):
        venv.unwrapped.reference_description()
    venv.reset(seed=0, options={"reset_mask": np.array([True, False])})
    with pytest.raises(ResetNeeded, match=r"\[1\] were never reset"):
        venv.step(venv.action_space.sample())
    venv.reset(seed=0)
    venv.step(venv.action_space.sample())


@pytest.mark.parametrize("env_id", ["SMATracking-v0", "SMARobust-v0", "SMAMultiplexed-v0"])
def test_a_single_env_refuses_a_step_before_its_first_reset_without_gymnasiums_wrapper(env_id):
    import gymnasium as gym
    from gymnasium.error import ResetNeeded

    env = gym.make(f"sma_gym:{env_id}").unwrapped  # OrderEnforcing is a wrapper: gone here
    with pytest.raises(ResetNeeded, match="never reset: call reset"):
        env.step(env.action_space.sample())  # ran against a zero reference before
    env.reset(seed=0)
    env.step(env.action_space.sample())


@pytest.mark.parametrize("options", [["reference"], "report-step", 3])
def test_reset_options_that_are_not_a_dict_are_refused_by_name(options):
    import gymnasium as gym

    for env in (
        gym.make("sma_gym:SMATracking-v0"),
        gym.make("sma_gym:SMAMultiplexed-v0"),
        gym.make_vec("sma_gym:SMATracking-v0", num_envs=2, vectorization_mode="vector_entry_point"),
    ):
        with pytest.raises(ValueError, match="reset options = .*expected a dict"):
            env.reset(seed=0, options=options)


def test_a_banks_references_must_be_a_list_of_n_and_not_beside_reference():
    import gymnasium as gym

    env = gym.make("sma_gym:SMAMultiplexed-v0", n_actuators=4)
    with pytest.raises(ValueError, match=r"options\['references'\] = 'step': expected a list of 4"):
        env.reset(seed=0, options={"references": "step"})  # was read as the letters 's', 't', 'e', 'p'
    with pytest.raises(ValueError, match="both 'reference' and 'references'"):
        env.reset(seed=0, options={"reference": "report-step", "references": ["step"] * 4})


def test_numbers_given_as_text_are_refused_not_parsed():
    import gymnasium as gym

    for kwargs in ({"control_period_s": "0.01"}, {"energy_weight": "1"}):
        with pytest.raises(ValueError, match="not a string"):
            gym.make("sma_gym:SMATracking-v0", **kwargs)
    with pytest.raises(ValueError, match="not a string"):
        gym.make("sma_gym:SMARobust-v0", supply_voltage_v="10")


def test_a_ramp_whose_second_segment_starts_before_the_first_ends_is_refused():
    import gymnasium as gym

    env = gym.make("sma_gym:SMATracking-v0")
    spec = {"kind": "ramp", "t1_s": 0.5, "level1_m": 7e-3, "d1_s": 2.0, "t2_s": 1.5, "level2_m": 1e-3}
    with pytest.raises(ValueError, match=r"t2_s = 1.5: expected a time >= t1_s \+ d1_s = 2.5 s"):
        env.reset(seed=0, options={"reference": spec})
    env.reset(seed=0, options={"reference": {**spec, "t2_s": 2.5}})


def test_make_vec_names_the_variant_as_fixed_by_the_id():
    import gymnasium as gym

    with pytest.raises(ValueError, match="variant = 'robust': fixed by the id"):
        gym.make_vec("sma_gym:SMATracking-v0", num_envs=2, vectorization_mode="vector_entry_point", variant="robust")


def test_write_trace_neither_keeps_a_stale_sidecar_nor_overwrites_one_unasked(tmp_path):
    from sma_gym.data import load_trace
    from sma_gym.data.measured import MeasuredTrace, sidecar_write_path, write_trace

    t = np.arange(200) * 1e-3
    with_conditions = MeasuredTrace(
        path="x.csv", t=t, duty=np.full(200, 0.2), position=np.zeros(200), conditions={"supply_voltage_v": 24.0}
    )
    plain = MeasuredTrace(path="x.csv", t=t, duty=np.full(200, 0.2), position=np.zeros(200))
    path = write_trace(tmp_path / "x.csv", with_conditions)
    write_trace(path, plain, overwrite=True)
    assert load_trace(path).conditions == {} and not sidecar_write_path(path).exists()
    # A sidecar of another file's name is a user's file: never replaced without overwrite=True.
    other = tmp_path / "y.csv"
    sidecar_write_path(other).write_text('{"supply_voltage_v": 5.0}')
    with pytest.raises(FileExistsError, match=r"y\.csv\.json exists"):
        write_trace(other, with_conditions)
    assert sidecar_write_path(other).read_text() == '{"supply_voltage_v": 5.0}'
    # <stem>.json would be read back as the sidecar of a trace without conditions.
    (tmp_path / "z.json").write_text('{"supply_voltage_v": 5.0}')
    with pytest.raises(FileExistsError, match="would read it as the sidecar"):
        write_trace(tmp_path / "z.csv", plain)


def test_policies_refuse_an_episode_start_of_the_wrong_length():
    import gymnasium as gym

    from sma_gym_agents import ControllerPolicy

    env = gym.make("sma_gym:SMATracking-v0")
    obs, _ = env.reset(seed=0)
    policy = ControllerPolicy("PID", env)
    batch = np.stack([obs, obs])
    policy.predict(batch, episode_start=np.array([True, True]))
    with pytest.raises(ValueError, match="episode_start has 3 entries: expected 2"):
        policy.predict(batch, episode_start=np.array([True, False, True]))


def test_a_controller_policy_keeps_state_until_reset_as_its_docstring_says():
    import gymnasium as gym

    from sma_gym_agents import ControllerPolicy

    env = gym.make("sma_gym:SMATracking-v0", reference="report-step", max_episode_steps=150)
    policy = ControllerPolicy("PID", env)

    def episode(reset: bool) -> float:
        obs, _ = env.reset(seed=0)
        if reset:
            policy.reset()
        total, done = 0.0, False
        while not done:
            action, _ = policy.predict(obs)
            obs, reward, terminated, truncated, _ = env.step(action)
            total += reward
            done = terminated or truncated
        return total

    first = episode(reset=True)
    assert episode(reset=False) != pytest.approx(first)  # carried over: why the docs say to reset
    assert episode(reset=True) == pytest.approx(first)


def test_a_cards_record_fields_are_checked_like_its_settings():
    from sma_gym_agents.card import PolicyCard

    good = {"algo": "SAC", "env_id": "SMATracking-v0", "seed": 3, "timesteps": 200000, "validation_return": -20.5}
    assert PolicyCard.from_dict(good).seed == 3
    for key, value, expected in (
        ("seed", "abc", "null or an integer"),
        ("timesteps", -5, "an integer >= 0"),
        ("train_time_s", float("nan"), "a time >= 0 s"),
        ("validation_return", "high", "a finite number"),
    ):
        with pytest.raises(
            ValueError, match=rf"card.json: {key} = .*expected null or.*{re.escape(expected.split('or ')[-1])}"
        ):
            PolicyCard.from_dict({**good, key: value}, where="card.json")


def test_a_model_file_with_an_unknown_key_or_a_non_string_name_is_refused(tmp_path):
    """A misspelt "effects" loaded the model without its effects; a number as the name was
    turned into a string."""
    import json

    from sma_gym.model import ModelConfig
    from sma_gym.models import twin_path

    twin = ModelConfig.load(twin_path("bench-0.5mm-ht")).to_dict()
    assert ModelConfig.from_dict(twin).effects  # the shipped twin carries effects
    misspelt = {k: v for k, v in twin.items() if k != "effects"} | {"effect": twin["effects"]}
    path = tmp_path / "twin.json"
    path.write_text(json.dumps(misspelt))
    before = path.read_bytes()
    with pytest.raises(ValueError, match=r"twin.json.*unknown key\(s\) \['effect'\]: expected only"):
        ModelConfig.load(path)
    assert path.read_bytes() == before
    with pytest.raises(ValueError, match=r"actuator parameters.name = 5: expected a string"):
        ModelConfig.from_dict({**twin, "actuator": {**twin["actuator"], "name": 5}})
    with pytest.raises(ValueError, match=r"'notes' = \['a'\]: expected a string"):
        ModelConfig.from_dict({**twin, "notes": ["a"]})


def test_a_controller_on_another_package_env_says_it_needs_an_sma_gym_env():
    """Found by a new user: ``ControllerPolicy("PID", gym.make("CartPole-v1"))`` raised a raw
    AttributeError about ``feature_names``."""
    import gymnasium as gym

    from sma_gym_agents import ControllerPolicy
    from sma_gym_agents.bank import FixedSlotBank

    with pytest.raises(ValueError, match=r"'CartPole-v1' has no 'feature_names': expected an sma-gym env"):
        ControllerPolicy("PID", gym.make("CartPole-v1"))
    with pytest.raises(ValueError, match="expected SMAMultiplexed-v0"):
        FixedSlotBank("PID", gym.make("sma_gym:SMATracking-v0"))


def test_diagnose_notes_what_it_takes_for_granted_that_a_file_contradicts():
    """Found by a user with their own bench: a clamped wire's force was counted as a varying
    output (a confident effect on a flat position), and a file cut mid-run, a logger dropout
    and a reversed position sign were diagnosed without a word."""
    from sma_gym.data.measured import MeasuredTrace
    from sma_gym.diagnosis.workflow import data_notes, require_diagnosable

    t = np.arange(3000) * 1e-3
    duty = np.where(t > 0.5, 0.3, 0.0)
    rise = np.clip(t - 0.6, 0.0, None) * 1e-3
    clamped = MeasuredTrace("clamped.csv", t, duty, np.zeros_like(t), force=0.5 + 8.0 * (duty > 0))
    with pytest.raises(ValueError, match="no measured output varies"):
        require_diagnosable([clamped])
    good = MeasuredTrace("good.csv", t, duty, rise)
    assert data_notes([good]) == []
    mid = MeasuredTrace("mid.csv", t, np.full_like(t, 0.2), rise)
    gap = MeasuredTrace("gap.csv", np.where(t > 1.0, t + 5.0, t), duty, rise)
    flipped = MeasuredTrace("flipped.csv", t, duty, -rise)
    weighed = MeasuredTrace("weighed.csv", t, duty, rise, force=0.5 + rise)
    notes = data_notes([mid, gap, flipped, weighed])
    assert len(notes) == 4, notes
    assert notes[0].startswith("mid.csv: heated from row 1 on, with no rest before it")
    assert notes[1].startswith("gap.csv: no sample for 5 s after t = 1 s")
    assert (
        notes[2].startswith("flipped.csv: the position falls 2.4 mm below its rest once heated") and "sign" in notes[2]
    )
    # A file cut while the wire cools falls from its start: said to have no rest, not a reversed sign.
    cooling = MeasuredTrace("cooling.csv", t, np.full_like(t, 0.05), 10e-3 - rise)
    assert [n.split(":")[0] for n in data_notes([cooling])] == ["cooling.csv"]
    assert "no rest before it" in data_notes([cooling])[0]
    assert notes[3].startswith("weighed.csv: its force column is checked but not compared")


def test_diagnose_refuses_a_held_out_file_that_is_a_link_to_or_copy_of_a_fitted_one(tmp_path, capsys):
    from sma_gym.cli import main

    fit = _synth(tmp_path, "fit.csv")
    linked, copied = tmp_path / "linked.csv", tmp_path / "copied.csv"
    os.link(fit, linked)
    copied.write_bytes(fit.read_bytes())
    for held, how in ((linked, "the same file"), (copied, "the same data")):
        assert main(["diagnose", str(fit), "--heldout", str(held), "--out", str(tmp_path / "d")]) == 2
        assert f"--heldout {str(held)!r}: {how} as fit file" in capsys.readouterr().err
    assert not (tmp_path / "d").exists()


def test_diagnose_never_makes_its_report_a_data_files_sidecar_nor_writes_over_a_users_own_file(tmp_path, capsys):
    from sma_gym.cli import main
    from sma_gym.diagnosis.report import previous_outputs

    out = tmp_path / "X"
    out.mkdir()
    data = out / "diagnosis.csv"
    data.write_bytes(_synth(tmp_path, "run.csv").read_bytes())
    (tmp_path / "run.csv.json").rename(out / "unrelated.json")
    # diagnosis.json would become diagnosis.csv's sidecar (its <stem>.json) from then on.
    assert main(["diagnose", str(data), "--out", str(out)]) == 2
    assert "would then be read as the sidecar of its input" in capsys.readouterr().err
    # A folder with a file of the user's that only looks like a plot of a diagnosis holds no
    # earlier diagnosis; a file where the run would write is never replaced.
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "fit_2_bench_vs_fem.png").write_text("my figure")
    (mine / "diagnosis.md").write_text("my notes")  # an output's name, but no diagnosis.json beside it
    assert previous_outputs(mine) == []
    (mine / "fit_0_run.png").write_text("my other figure")
    run = tmp_path / "run.csv"
    assert main(["diagnose", str(run), "--out", str(mine), "--overwrite"]) == 2
    assert "not written by an earlier diagnosis" in capsys.readouterr().err
    assert (mine / "fit_0_run.png").read_text() == "my other figure"
    (mine / "fit_0_run.png").unlink()
    assert main(["diagnose", str(run), "--out", str(mine), "--overwrite"]) == 2
    assert "diagnosis.md, not written by an earlier diagnosis" in capsys.readouterr().err
    assert (mine / "diagnosis.md").read_text() == "my notes"


def test_an_interrupt_while_a_diagnosis_writes_leaves_the_earlier_set_whole(tmp_path, monkeypatch):
    """Each file was written atomically but the set was not: a Ctrl-C while the plots were
    written left a new plot beside the earlier report (or, in a new folder, a lone plot)."""
    from sma_gym.diagnosis import report

    out = tmp_path / "d"
    out.mkdir()
    record = {"verdict": "none", "gap_before": {}, "gap_after": {}, "outputs": ["diagnosis.md", "fit_0_a.png"]}
    earlier = {"diagnosis.md": "old", "diagnosis.json": json.dumps(record)}
    earlier["fit_0_a.png"] = "old plot"
    for name, text in earlier.items():
        (out / name).write_text(text)

    def interrupted(result, staging, *args, **kwargs):
        (staging / "fit_0_b.png").write_text("new plot")
        raise KeyboardInterrupt

    monkeypatch.setattr(report, "write_report", interrupted)
    with pytest.raises(KeyboardInterrupt):
        report.write_outputs(None, out, [], [], None)
    assert {p.name: p.read_text() for p in out.iterdir()} == earlier  # no staging folder left either
    assert [p.name for p in report.previous_outputs(out)] == ["diagnosis.json", "diagnosis.md", "fit_0_a.png"]


def test_vector_seeds_indices_and_reference_fields_of_the_wrong_kind_are_refused_by_name():
    """From an RL user's trial: seed=1.5 gave "'float' object is not iterable", seed="0" was
    read as a list, reset_envs([5]) an IndexError ([-1] reset the last env), a reference
    level given as text ran as a number and True as 1.0 (named so), max_episode_steps=-5 was
    "expected [1, ...]" without -1 or None, and autoreset_mode in the sync mode was an
    unknown kwarg without a way on."""
    v = gym.make_vec("sma_gym:SMATracking-v0", num_envs=2, vectorization_mode="vector_entry_point")
    for seed in (1.5, "0", [0], [0, -1], True):
        with pytest.raises(ValueError, match=r"seed = .*: expected None, an integer >= 0 or a list of 2"):
            v.reset(seed=seed)
    v.reset(seed=[3, None])
    for indices in ([5], [-1], [1.5], [True]):
        with pytest.raises(
            ValueError, match=r"reset_envs indices = .*: expected sub-env indices, integers in \[0, 1\]"
        ):
            v.unwrapped.reset_envs(indices)
    for reference, message in (
        ({"kind": "step", "level1_m": "0.004"}, r"level1_m = '0.004': expected a number, not a string"),
        ({"kind": "step", "level1_m": True}, r"level1_m = True: expected a number, not a boolean"),
        ({"kind": "random", "times_s": ["0", "1"], "levels_m": [1e-3, 2e-3]}, r"times_s\[0\] = '0': .*string"),
        ({"kind": "random", "times_s": "01", "levels_m": [1e-3, 2e-3]}, r"times_s = '01': expected a list"),
    ):
        with pytest.raises(ValueError, match=message):
            gym.make("sma_gym:SMATracking-v0", reference=reference)
    with pytest.raises(ValueError, match=r"max_episode_steps = -5: expected an integer >= 1, -1 \(never truncate\)"):
        gym.make_vec(
            "sma_gym:SMATracking-v0", num_envs=2, vectorization_mode="vector_entry_point", max_episode_steps=-5
        )
    with pytest.raises(ValueError, match=r"vector_kwargs=\{'autoreset_mode'"):
        gym.make_vec("sma_gym:SMATracking-v0", num_envs=2, vectorization_mode="sync", autoreset_mode="SameStep")
    bank = gym.make_vec("sma_gym:SMAMultiplexed-v0", num_envs=2, vectorization_mode="vector_entry_point")
    bank.reset(seed=7)
    assert bank.unwrapped.np_random_seed == 7  # as the single-actuator vector env


def test_a_vector_infos_masks_are_its_own_so_editing_one_changes_no_later_reset():
    """Every mask of every info was one array, the default mask of reset(): a user's code that
    set one entry False made the next reset() skip that sub-env."""
    v = gym.make_vec("sma_gym:SMATracking-v0", num_envs=3, vectorization_mode="vector_entry_point")
    v.reset(seed=0)
    for _ in range(5):
        _, _, _, _, info = v.step(np.ones((3, 1), dtype=np.float32))
    masks = [value for key, value in info.items() if key.startswith("_")]
    assert len({id(m) for m in masks}) == len(masks) > 1
    info["_time_s"][1] = False
    _, _, _, _, later = v.step(np.ones((3, 1), dtype=np.float32))
    assert later["_time_s"].all()
    assert v.reset()[1]["time_s"].tolist() == [0.0, 0.0, 0.0]
    # The multiplexed bank's own vector env: one array for every mask until 2026-12-06.
    bank = gym.make_vec("sma_gym:SMAMultiplexed-v0", num_envs=2, vectorization_mode="vector_entry_point")
    _, info = bank.reset(seed=0)
    masks = [value for key, value in info.items() if key.startswith("_")]
    assert len({id(m) for m in masks}) == len(masks) > 1
    info["_duty"][0] = False
    assert info["_position_m"].all()


def test_numbers_past_floats_range_nesting_and_repeated_keys_in_files_are_refused_by_name(tmp_path):
    """A 400-digit integer in a model file or a kwarg gave a raw OverflowError, a deeply nested
    file a RecursionError, and a key given twice silently took the last value."""
    from sma_gym.model import ModelConfig

    data = ModelConfig().to_dict()
    data["actuator"]["convection"]["h0_w_m2_k"] = 10**400
    (tmp_path / "big.json").write_text(json.dumps(data))
    with pytest.raises(ValueError, match=r"big\.json.*h0_w_m2_k = an integer of about 400 digits"):
        ModelConfig.load(tmp_path / "big.json")
    with pytest.raises(ValueError, match="control_period_s = an integer of about 400 digits"):
        gym.make("sma_gym:SMATracking-v0", control_period_s=10**400)
    (tmp_path / "deep.json").write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(ValueError, match=r"deep\.json.*nested too deeply"):
        ModelConfig.load(tmp_path / "deep.json")
    (tmp_path / "twice.json").write_text('{"format": "sma-gym-model", "format": "sma-gym-model"}')
    with pytest.raises(ValueError, match=r"twice\.json.*'format' appears twice"):
        ModelConfig.load(tmp_path / "twice.json")


def test_an_effect_listed_without_values_in_a_model_file_is_refused_not_switched_off(tmp_path):
    from sma_gym.model import ModelConfig

    data = ModelConfig().to_dict()
    for listed in ({"form": "default"}, {"parameters": {}}, {}):
        data["effects"] = {"transformation_spread": listed}
        (tmp_path / "m.json").write_text(json.dumps(data))
        with pytest.raises(
            ValueError, match=r"m\.json': effect 'transformation_spread' gives no parameter values.*spread_k"
        ):
            ModelConfig.load(tmp_path / "m.json")
    data["effects"] = {"transformation_spread": {"parameters": {"spread_k": 5.0}, "form": "default"}}
    (tmp_path / "m.json").write_text(json.dumps(data))
    assert ModelConfig.load(tmp_path / "m.json").effects.value("transformation_spread", "spread_k") == 5.0


def test_an_effect_with_some_of_its_parameters_is_refused_in_a_file_and_merged_by_with_effect(tmp_path):
    """A new user's trial: a model file whose warm_surroundings gave its time constant only
    loaded with the gain at its off value, 0, and ran as no effect at all (no position
    differed from the model without it); ``with_effect`` with one parameter reset the fitted
    other to its off value, and with ``{}`` was a silent no-op that saved as an effect."""
    from sma_gym.model import ModelConfig

    warm = ModelConfig().with_effect("warm_surroundings", {"gain_k_j": 0.1, "time_constant_s": 20.0}, form="electrical")
    data = warm.to_dict()
    data["effects"]["warm_surroundings"]["parameters"] = {"time_constant_s": 20.0}
    (tmp_path / "partial.json").write_text(json.dumps(data))
    with pytest.raises(ValueError, match=r"partial\.json': effect 'warm_surroundings' leaves out \['gain_k_j'\]"):
        ModelConfig.load(tmp_path / "partial.json")
    # A partial mapping changes what it names and keeps the rest, the form included.
    changed = warm.with_effect("warm_surroundings", {"gain_k_j": 0.2}).effects.get("warm_surroundings")
    assert dict(changed.values) == {"gain_k_j": 0.2, "time_constant_s": 20.0} and changed.form == "electrical"
    assert warm.with_effect("warm_surroundings", {"gain_k_j": 0.2}, "default").effects.form("warm_surroundings") == (
        "default"
    )
    with pytest.raises(ValueError, match=r"with_effect\('sensor_lag', \{\}\): no parameter value given"):
        warm.with_effect("sensor_lag", {})


def test_a_sidecar_condition_is_checked_against_the_range_of_the_parameter_it_sets(tmp_path):
    """The loader accepted a 4 mm wire and a 0 V supply (its own ranges), which the model then
    refused without naming the sidecar."""
    from sma_gym.data import load_trace
    from sma_gym.data.measured import MeasuredDataError
    from sma_gym.params import parameter_bound

    (tmp_path / "r.csv").write_text("t,duty,position\n" + "".join(f"{k * 0.01},0,0\n" for k in range(30)))
    for given, message in (
        (
            {"wire_diameter_m": 0.004},
            r"r\.csv\.json: wire_diameter_m = 0\.004: expected a value in \[2\.5e-05, 0\.002\]",
        ),
        ({"supply_voltage_v": 0}, r"supply_voltage_v = 0: expected a value in \(0, 60\]"),
        ({"supply_voltage_v": True}, "not a boolean"),
        ({"supply_voltage_v": "10"}, "expected a number"),
    ):
        (tmp_path / "r.csv.json").write_text(json.dumps(given))
        with pytest.raises(MeasuredDataError, match=message):
            load_trace(tmp_path / "r.csv")
    assert parameter_bound("wire.diameter_m").upper == 2e-3
    (tmp_path / "r.csv.json").write_text(json.dumps({"supply_voltage_v": 12}))
    assert load_trace(tmp_path / "r.csv").conditions == {"supply_voltage_v": 12.0}


def test_small_options_given_wrong_are_refused_and_a_finished_seed_is_not_called_stopped(tmp_path, capsys):
    from sma_gym.cli import main
    from sma_gym.envs.sb3 import SB3VecEnv
    from sma_gym_agents.training.config import build_parser
    from sma_gym_agents.training.sweep import seed_status

    for empty in ("", ","):  # "" ran all ten controllers, "," none (an empty report)
        assert main(["evaluate", "--baselines", empty, "--experiments", "6.1"]) == 2
        assert "--baselines" in capsys.readouterr().err
    for effect, message in (
        ("transformation_spread:spread_k=5,spread_k=6", "spread_k is given twice"),
        ("none:x=1", "'none' hides no effect"),
    ):
        assert main(["synth", "--out", str(tmp_path / "s.csv"), "--effect", effect]) == 2
        assert message in capsys.readouterr().err
    with pytest.raises(ValueError, match="expected a Gymnasium vector env"):
        SB3VecEnv(None)
    assert build_parser().parse_args(["--env", "sma_gym:SMATracking-v0"]).env == "SMATracking-v0"  # env.spec.id
    (tmp_path / "seed-1").mkdir()
    assert seed_status(-15, tmp_path, 1).startswith("stopped")
    (tmp_path / "seed-1" / "goals.json").write_text("{}")
    assert seed_status(-15, tmp_path, 1) == "finished before the stop (kept)"
    assert seed_status(0, tmp_path, 1) == "done"
    # Ended badly after it wrote its goals, which a run writes last: finished, and counted.
    assert seed_status(1, tmp_path, 1).startswith("finished, then ended with exit 1 (kept")
    (tmp_path / "seed-1" / "goals.json").unlink()
    assert seed_status(1, tmp_path, 1).startswith("FAILED")


def test_overwrite_removes_nothing_of_a_folder_whose_diagnosis_json_is_not_a_diagnosis(tmp_path):
    """A diagnosis.json of the user's made the name patterns of old reports delete their PNGs."""
    from sma_gym.diagnosis.report import previous_outputs

    (tmp_path / "diagnosis.json").write_text('{"x": 1}')
    (tmp_path / "fit_2_photo.png").write_text("mine")
    assert previous_outputs(tmp_path) == []
    (tmp_path / "diagnosis.json").write_text('{"outputs": ["fit_2_photo.png"]}')  # a list alone is no diagnosis
    assert previous_outputs(tmp_path) == []
    (tmp_path / "diagnosis.json").write_text('{"verdict": "none", "gap_before": {}, "gap_after": {}}')
    assert tmp_path / "fit_2_photo.png" in previous_outputs(tmp_path)  # an old report, without its list


def test_synth_replaces_its_three_files_together_or_not_at_all_and_one_run_at_a_time(tmp_path, monkeypatch):
    """An interrupted --overwrite left the new labels beside the old data (the labels are the
    benchmarks' truth), and two runs on one --out both wrote, mixing their files."""
    import os

    import sma_gym.diagnosis.synth as synth
    from sma_gym.model import ModelConfig

    out = tmp_path / "s.csv"
    synth.write(synth.SynthSpec(ModelConfig(), duration_s=3.0, seed=1), out)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert set(before) == {"s.csv", "s.csv.json", "s.labels.json"}

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(synth, "write_trace", interrupted)  # after the labels are staged
    with pytest.raises(KeyboardInterrupt):
        synth.write(synth.SynthSpec(ModelConfig(), duration_s=3.0, seed=2, effect="latent_heat"), out, overwrite=True)
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before  # no staging folder, no lock
    monkeypatch.undo()

    (tmp_path / ".s.labels.json.lock").write_text(f"{os.getpid()}\n")  # another live run holds s.csv
    with pytest.raises(ValueError, match=r"s\.csv.*busy.*\.s\.labels\.json\.lock"):
        synth.write(synth.SynthSpec(ModelConfig(), duration_s=3.0, seed=3), out, overwrite=True)
    (tmp_path / ".s.labels.json.lock").unlink()
    (tmp_path / ".s.labels.json.staging-99999999").mkdir()  # a killed run's, removed by the next
    synth.write(synth.SynthSpec(ModelConfig(), duration_s=3.0, seed=3), out, overwrite=True)
    assert json.loads((tmp_path / "s.labels.json").read_text())["seed"] == 3
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.csv", "s.csv.json", "s.labels.json"]
    # Another CSV name with the same labels file is refused, not mixed (w.csv / w.CSV).
    with pytest.raises(ValueError, match="s.labels.json"):
        synth.write(synth.SynthSpec(ModelConfig(), duration_s=3.0, seed=4), tmp_path / "s.CSV")


def test_each_command_removes_only_its_own_listed_outputs_and_a_folder_in_the_way_changes_nothing(tmp_path, capsys):
    """fidelity --overwrite into a folder holding an evaluation removed the evaluation's files
    (one list for every command); a folder named like an output failed half-way."""
    from sma_gym._io import output_list, staged_outputs

    with staged_outputs(tmp_path, "evaluate") as staging:
        (staging / "evaluation.md").write_text("eval")
    with staged_outputs(tmp_path, "fidelity") as staging:
        (staging / "fig8_efficiency.png").write_text("fid")
    assert "evaluation.md" in capsys.readouterr().err  # named as left alone, not removed
    with staged_outputs(tmp_path, "fidelity") as staging:
        (staging / "fig6_4_holding_duty.png").write_text("fid 2")
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == sorted(
        ["evaluation.md", "fig6_4_holding_duty.png", output_list("evaluate"), output_list("fidelity")]
    )
    (tmp_path / "evaluation.json").mkdir()
    with pytest.raises(ValueError, match="evaluation.json is a folder"):
        with staged_outputs(tmp_path, "evaluate") as staging:
            (staging / "evaluation.md").write_text("new")
            (staging / "evaluation.json").write_text("new")
    assert (tmp_path / "evaluation.md").read_text() == "eval"
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted([*names, "evaluation.json"])


def test_conditions_of_two_files_that_share_a_name_are_both_reported():
    from sma_gym.data.measured import MeasuredTrace
    from sma_gym.diagnosis.workflow import file_labels

    files = [MeasuredTrace(f"{d}/run.csv", np.zeros(1), np.zeros(1), np.zeros(1)) for d in ("a", "b")]
    files.append(MeasuredTrace("c/other.csv", np.zeros(1), np.zeros(1), np.zeros(1)))
    assert file_labels(files) == ["a/run.csv", "b/run.csv", "other.csv"]


def test_a_stop_during_the_last_renames_waits_until_they_are_all_done(tmp_path, monkeypatch, request):
    """A Ctrl-C between two of a run's final renames left a new report beside an old figure
    (the verifier simulated it): the renames now happen all or none, the stop after them."""
    import os
    import signal

    from sma_gym._io import signals_deferred, staged_outputs

    # Python's own Ctrl-C handler, whatever an earlier test left; and the signal raised in this
    # thread (os.kill lets the kernel hand it to any thread, e.g. a pytest-xdist worker's I/O
    # thread, and then it can land after the block: one full run found no stop here).
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    request.addfinalizer(lambda: signal.signal(signal.SIGINT, previous))
    done = []
    with pytest.raises(KeyboardInterrupt):
        with signals_deferred():
            signal.raise_signal(signal.SIGINT)
            for k in range(3):
                done.append(k)
        done.append("after")  # never reached: the stop lands as the block ends
    assert done == [0, 1, 2]

    with staged_outputs(tmp_path, "evaluate") as staging:
        for name in ("a.md", "b.png"):
            (staging / name).write_text("old")
    real_replace = os.replace

    def replace_then_stop(src, dst):
        real_replace(src, dst)
        signal.raise_signal(signal.SIGINT)  # a stop after the first rename

    with pytest.raises(KeyboardInterrupt):
        with staged_outputs(tmp_path, "evaluate") as staging:
            for name in ("a.md", "b.png"):
                (staging / name).write_text("new")
            monkeypatch.setattr(os, "replace", replace_then_stop)
    monkeypatch.undo()
    assert {p.name: p.read_text() for p in tmp_path.glob("*.*") if not p.name.startswith(".")} == {
        "a.md": "new",
        "b.png": "new",
    }


def test_a_controller_given_twice_or_a_bad_filter_is_refused_before_anything_runs(tmp_path, capsys):
    """``--baselines PID,pid`` ran the PID twice into one row; ``ControllerPolicy`` took a
    NaN, negative or infinite filter cut-off as "no filter" without a word, a string failed
    only at the first predict, and a number as the controller raised an AttributeError."""
    import gymnasium as gym

    from sma_gym.cli import main
    from sma_gym_agents import ControllerPolicy

    for given in ("PID,PID", "PID, pid", "VSC3 + FF,vsc3+ff"):
        assert main(["evaluate", "--baselines", given, "--experiments", "6.1", "--out", str(tmp_path / "e")]) == 2
        assert "given twice" in capsys.readouterr().err
    assert not (tmp_path / "e").exists()
    env = gym.make("sma_gym:SMATracking-v0")
    for cutoff in (float("nan"), -5.0, float("inf"), "100", True):
        with pytest.raises(ValueError, match=r"filter_cutoff_hz = .*expected"):
            ControllerPolicy("PID", env, filter_cutoff_hz=cutoff)
    for spec in (5, None):
        with pytest.raises(ValueError, match=r"spec = .*expected a controller's label"):
            ControllerPolicy(spec, env)
    assert ControllerPolicy("PID", env, filter_cutoff_hz=0).predict(env.reset(seed=0)[0])[0].shape == (1,)


def test_a_trained_agent_refuses_a_nan_observation_and_an_effect_file_names_its_bad_parameters(tmp_path):
    import gymnasium as gym

    from sma_gym.effects import EffectSet
    from sma_gym_agents import ControllerPolicy
    from sma_gym_agents.trained import load_policy, save_policy

    agent = load_policy(save_policy(_tiny_model(), tmp_path / "agent.zip", CARD))
    obs, _ = gym.make("sma_gym:SMATracking-v0").reset(seed=0)
    obs[2] = np.nan
    with pytest.raises(ValueError, match=r"observation holds NaN at feature 'resistance_valid' \(index 2;"):
        agent.predict(obs)
    batch = np.stack([obs, obs])
    batch[0, 2], batch[1, 0] = 0.0, -np.inf  # a batch: the first bad value's row and column
    with pytest.raises(ValueError, match=r"holds -inf at feature 'position' \(index 1, 0; 2 non-finite"):
        agent.predict(batch)
    controller = ControllerPolicy("PID", gym.make("sma_gym:SMATracking-v0"))
    with pytest.raises(ValueError, match=r"holds -inf at feature 'position'"):
        controller.predict(batch)
    with pytest.raises(ValueError, match=r"effects\['sensor_lag'\]\['parameters'\] = \[1\]: expected a mapping"):
        EffectSet.of({"sensor_lag": {"parameters": [1]}})


def test_overwrite_keeps_the_earlier_run_when_the_new_one_is_refused_at_its_start(tmp_path, capsys):
    """``--overwrite`` deleted the earlier run's results, models and checkpoints, and then the
    algorithm refused a value (here an unknown policy): nothing of either run was left."""
    out = tmp_path / "run"
    earlier = {
        "results.md": "earlier",
        "best_model.zip": "model",
        "checkpoints/ckpt_1.zip": "ckpt",
        "notes.txt": "mine",
    }
    for name, text in earlier.items():
        (out / name).parent.mkdir(parents=True, exist_ok=True)
        (out / name).write_text(text)
    (out / "mine").mkdir()  # the user's empty folder stays too
    argv = ["--quick", "--no-progress", "--overwrite", "--out", str(out), "--hyperparams", "policy:Foo"]
    proc = _run([sys.executable, str(ROOT / "train.py"), *argv])
    assert proc.returncode == 2 and "Foo" in proc.stderr and "Traceback" not in proc.stderr, proc.stderr[-2000:]
    assert {str(p.relative_to(out)) for p in out.rglob("*") if p.is_file()} == set(earlier)
    assert all((out / name).read_text() == text for name, text in earlier.items())
    assert (out / "mine").is_dir() and not (out / ".previous-run").exists()


def test_an_empty_out_is_refused_not_read_as_no_out(capsys, monkeypatch):
    """``--out ''`` trained into ./runs (an empty value read as "not given")."""
    from sma_gym_agents.training import cli

    def no_default(run):  # were the value read as "no --out", the run would go to runs/<run>
        raise AssertionError("--out '' taken for no --out")

    monkeypatch.setattr(cli, "default_out", no_default)
    main = cli.main
    for empty in ("", " "):
        assert main(["--quick", "--no-progress", "--out", empty]) == 2
        assert "--out" in capsys.readouterr().err


def test_a_robust_env_refuses_condition_ranges_that_can_draw_a_wire_it_cannot_run_at_make():
    """Found by an audit: ranges whose draws included an invalid wire were accepted, and the
    first such draw failed a reset, and every reset after it (a refused reset restores the
    generator, so it drew the same condition again): the env was stuck."""
    import sma_gym

    warm = sma_gym.load_model().with_actuator(**{"convection.ambient_temperature_c": 58.0})
    cases = [
        (dict(model=warm, convection="natural"), "ambient_temperature_c = 58.0"),  # shift -3 K: below ambient
        (dict(reference="report-step", spread=3, wire_diameter_m=5e-5), "reference 'report-step'"),
        (dict(wire_diameter_m=(5e-5, 2e-4), reference="report-step"), "wire diameter 0.05 mm"),
    ]
    for kwargs, cause in cases:
        with pytest.raises(ValueError, match="expected ranges whose every draw can") as err:
            gym.make("sma_gym:SMARobust-v0", **kwargs)
        assert cause in str(err.value) and "supply_voltage_v, convection, wire_diameter_m, spread" in str(err.value)
    # Without the spread the same warm wire is always valid, and every reset works.
    env = gym.make("sma_gym:SMARobust-v0", model=warm, convection="natural", spread=0)
    env.reset(seed=0)
    for _ in range(40):
        env.reset()


def test_settings_no_episode_can_run_with_are_refused_at_make():
    """An overheat limit below where the wire starts to move ended every step's episode (a
    training loop reset for ever); a self-sensing model whose pulses at the smallest duty
    are shorter than the settling never read its resistance."""
    import sma_gym

    for env_id in ("SMATracking-v0", "SMAMultiplexed-v0", "SMARobust-v0"):
        with pytest.raises(
            ValueError, match=r"overheat_limit_c = 50.0: the wire of .* starts to contract at 61.1 degC"
        ):
            gym.make(f"sma_gym:{env_id}", overheat_limit_c=50.0)
    gym.make("sma_gym:SMATracking-v0", overheat_limit_c=70.0)
    fast = sma_gym.load_model("forced-convection").with_actuator(**{"driver.pwm_frequency_hz": 1e5})
    with pytest.raises(ValueError, match=r"pwm_frequency_hz = 100000.0 .* expected pwm_frequency_hz at most 1000 Hz"):
        gym.make("sma_gym:SMASelfSensing-v0", model=fast)
    edge = sma_gym.load_model("forced-convection").with_actuator(**{"driver.pwm_frequency_hz": 1000.0})
    gym.make("sma_gym:SMASelfSensing-v0", model=edge)  # 50 us pulses: the kernel reads them
    gym.make("sma_gym:SMATracking-v0", model=fast)  # the position sensor needs no reading of R


def test_integer_arguments_take_numpy_integers_and_nothing_that_int_would_truncate():
    gym.make("sma_gym:SMAMultiplexed-v0", n_actuators=np.int64(3))
    assert gym.make("sma_gym:SMAMultiplexed-v0", n_actuators=np.array(3)).unwrapped.n == 3
    for value in (np.array(2.9), np.array(True), np.array([4]), np.bool_(True), 2.0):
        with pytest.raises(ValueError, match=r"n_actuators = .*expected an integer in \[1, 16\]"):
            gym.make("sma_gym:SMAMultiplexed-v0", n_actuators=value)


def test_a_path_names_a_file_even_when_a_preset_has_its_name_and_old_and_new_expansions_conflict(tmp_path, monkeypatch):
    import json

    from sma_gym.model import load_model

    data = load_model("standard").with_actuator(**{"driver.supply_voltage_v": 20.0}).to_dict()
    monkeypatch.chdir(tmp_path)
    (tmp_path / "standard").write_text(json.dumps(data))
    assert load_model(Path("standard")).actuator.driver.supply_voltage_v == 20.0  # read the 10 V preset
    assert load_model("standard").actuator.driver.supply_voltage_v == 10.0  # a name is the preset
    data["actuator"]["wire"]["thermal_expansion_1_k"] = 5e-6  # beside the two per-phase keys
    (tmp_path / "both.json").write_text(json.dumps(data))
    with pytest.raises(
        ValueError, match=r"thermal_expansion_1_k = 5e-06 beside wire.thermal_expansion_austenite_1_k and wire"
    ):
        load_model("both.json")


def test_an_effect_written_flat_with_a_form_is_told_where_its_parameters_go():
    """It said only "unknown key(s) ['force_n']", though force_n is the effect's parameter."""
    from sma_gym.effects import EffectSet

    with pytest.raises(ValueError, match=r"expected \{'parameters': \{'force_n': \.\.\.\}, 'form': \.\.\.\}"):
        EffectSet.of({"coulomb_friction": {"force_n": 0.5, "form": "stribeck"}})


def test_a_controller_refuses_observations_it_would_misread():
    """From an audit: a PID over VecNormalize read normalised features as positions (a return
    of -82 for -11); a frame-stacked observation was read as four actuators; a bank's policy
    made for 4 actuators took an 8-actuator bank's observation and halved its duties."""
    from gymnasium.wrappers import FlattenObservation, FrameStackObservation, NormalizeObservation
    from stable_baselines3.common.monitor import Monitor
    from stable_baselines3.common.vec_env import DummyVecEnv, VecFrameStack, VecNormalize

    from sma_gym_agents import ControllerPolicy
    from sma_gym_agents.bank import FixedSlotBank

    def tracking():
        return Monitor(gym.make("sma_gym:SMATracking-v0"))

    for env, message in (
        (VecNormalize(DummyVecEnv([tracking])), "pass VecNormalize"),
        (NormalizeObservation(gym.make("sma_gym:SMATracking-v0")), "pass NormalizeObservation"),
        (
            FlattenObservation(FrameStackObservation(gym.make("sma_gym:SMATracking-v0"), 4)),
            r"shape \(40,\) from \(10,\)",
        ),
        (FrameStackObservation(gym.make("sma_gym:SMATracking-v0"), 4), r"shape \(4, 10\) from \(10,\)"),
        (VecFrameStack(DummyVecEnv([tracking]), 4), r"shape \(40,\) from \(10,\)"),
    ):
        with pytest.raises(ValueError, match=rf"PID: .*{message}"):
            ControllerPolicy("PID", env)
    assert ControllerPolicy("PID", VecNormalize(DummyVecEnv([tracking]), norm_obs=False)).width == 10
    policy = ControllerPolicy("PID", gym.make("sma_gym:SMATracking-v0"))
    for obs in (np.zeros(40), np.zeros((0, 10))):
        with pytest.raises(ValueError, match=r"observation of shape"):
            policy.predict(obs)
    bank = FixedSlotBank("PID", gym.make("sma_gym:SMAMultiplexed-v0", n_actuators=4))
    eight, _ = gym.make("sma_gym:SMAMultiplexed-v0", n_actuators=8).reset(seed=0)
    with pytest.raises(ValueError, match=r"expected 40 features per observation, .* \(4 actuator\(s\) x 10\)"):
        bank.predict(eight)


def test_agent_names_never_share_a_baselines_row_or_break_a_table_and_saved_paths_load(tmp_path):
    """A card named "PID" shared the PID baseline's row (the report showed one of the two); a
    '|' or a line break in a name broke the markdown table. save_policy wrote "agent" (no
    .zip) that load_policy could not open, and "agent.pt" replaced agent.json, another
    model's card."""
    from sma_gym_agents.commands import agent_names
    from sma_gym_agents.trained import load_policy, save_policy

    names = agent_names(
        ["a.zip", "b.zip", "c.zip", "d.zip"], ["PID", "VSC3 + FF (self-sensing)", "a|b\nc", "SAC agent"]
    )
    assert names == ["PID [agent]", "VSC3 + FF (self-sensing) [agent]", "a/b c", "SAC agent"]
    assert save_policy(_tiny_model(), tmp_path / "agent", CARD) == tmp_path / "agent.zip"
    assert load_policy(tmp_path / "agent").name
    (tmp_path / "agent.json").write_text((tmp_path / "agent.json").read_text())
    before = (tmp_path / "agent.json").read_bytes()
    with pytest.raises(ValueError, match=r"path = .*agent\.pt.*expected a \.zip"):
        save_policy(_tiny_model(), tmp_path / "agent.pt", CARD)
    assert (tmp_path / "agent.json").read_bytes() == before and not (tmp_path / "agent.pt").exists()
    save_policy(_tiny_model(), tmp_path / "m.v1.zip", CARD)
    assert load_policy(tmp_path / "m.v1").name  # looked for m.zip
    with pytest.raises(ValueError, match=r"policy = None: expected the path"):
        load_policy(None)


def test_files_of_one_name_in_two_folders_each_keep_their_row(tmp_path):
    """``diagnose r1/run.csv r2/run.csv``: the gap per file (diagnosis.md, diagnosis.json) and
    the cross-validation folds were keyed by the file's name, so the second replaced the first."""
    import json

    from sma_gym.cli import main

    for folder, seed in (("r1", "1"), ("r2", "2")):
        (tmp_path / folder).mkdir()
        _synth(tmp_path / folder, "run.csv", "--seed", seed)
    files = [str(tmp_path / "r1" / "run.csv"), str(tmp_path / "r2" / "run.csv")]
    options = ["--max-rounds", "1", "--effects", "sensor_lag", "--threads", "1"]
    assert main(["diagnose", *files, "--out", str(tmp_path / "d"), *options]) == 0
    report = json.loads((tmp_path / "d" / "diagnosis.json").read_text())
    assert sorted(report["gap_by_file"]["nominal"]["fit"]) == sorted(files)
    assert f"Fitted: {files[0]}, {files[1]}." in (tmp_path / "d" / "diagnosis.md").read_text()
    assert main(["diagnose", *files, "--cross-validate", "--out", str(tmp_path / "cv"), *options]) == 0
    folds = json.loads((tmp_path / "cv" / "cross_validation.json").read_text())["folds"]
    assert [f["held_out"] for f in folds] == files and [f["fitted"] for f in folds] == [files[1:], files[:1]]
    # An earlier cross-validation is replaced with --overwrite; a file of the user's that only
    # shares its name never is (any cross_validation.md was taken for an earlier run's).
    again = ["diagnose", *files, "--cross-validate", "--out", str(tmp_path / "cv"), *options]
    assert main([*again, "--overwrite"]) == 0
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "cross_validation.md").write_text("my notes")
    mine = ["diagnose", *files, "--cross-validate", "--out", str(tmp_path / "mine"), *options, "--overwrite"]
    assert main(mine) == 2 and (tmp_path / "mine" / "cross_validation.md").read_text() == "my notes"


def test_cli_names_a_write_failure_and_reads_negative_exponents_as_values(tmp_path, monkeypatch, capsys):
    """A full disk gave a traceback (exit 1 either way); ``--position-noise -1e-6`` was taken
    for an option ("expected one argument"), where ``-1e-6`` is a value to check and name;
    an unknown option of a command printed the list of commands' usage."""
    import errno
    import os

    from sma_gym.cli import main
    from sma_gym.data import measured

    def full(path, *args, **kwargs):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(measured, "write_text", full)
    out = tmp_path / "s.csv"
    assert main(["synth", "--out", str(out), "--duration", "7"]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"sma-gym synth: error: {tmp_path}") and err.endswith(": No space left on device\n")
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # nothing half-written
    assert main(["synth", "--out", str(out), "--position-noise", "-1e-6"]) == 2
    assert "--position-noise = -1e-06: expected a value in [0" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["fidelity", "--bogus"])
    assert "usage: sma-gym fidelity" in capsys.readouterr().err


def test_episode_start_takes_booleans_and_refuses_what_numpy_would_read_as_true():
    """``np.asarray(x, dtype=bool)`` read ``"no"``, NaN and 0.5 as True: a controller given
    them reset its state at every step (its integral never built up), without a word."""
    from sma_gym_agents import ControllerPolicy
    from sma_gym_agents.bank import FixedSlotBank

    env = gym.make("sma_gym:SMATracking-v0")
    obs, _ = env.reset(seed=0)
    policy = ControllerPolicy("PID", env)
    for flags in ("no", np.array([np.nan]), np.array([0.5])):
        with pytest.raises(ValueError, match=r"episode_start = .*expected booleans \(or 0 / 1\)"):
            policy.predict(obs, episode_start=flags)
    batch = np.stack([obs, obs])
    with pytest.raises(ValueError, match="episode_start has 1 entries: expected 2"):
        policy.predict(batch, episode_start=np.array([True]))
    first, _ = policy.predict(batch, episode_start=np.array([1, 0]))  # 0 / 1 are read as booleans
    again, _ = policy.predict(batch, episode_start=np.array([True, False]))
    assert first.shape == again.shape == (2, 1)
    bank = FixedSlotBank("PID", gym.make("sma_gym:SMAMultiplexed-v0", n_actuators=2))
    two, _ = gym.make("sma_gym:SMAMultiplexed-v0", n_actuators=2).reset(seed=0)
    bank.predict(two, episode_start=True)  # one flag for the whole bank
    with pytest.raises(ValueError, match="episode_start = "):
        bank.predict(two, episode_start="yes")


def test_a_librarys_error_raised_for_a_ctrl_c_is_reported_as_the_stop(tmp_path, monkeypatch, capsys):
    """matplotlib, interrupted while drawing, raised a ValueError of its own; the command then
    said "error: ..." with exit 2 (bad input) instead of "interrupted", 130 (once in seven)."""
    from sma_gym import cli
    from sma_gym._io import interrupt_behind

    def drawing(*args, **kwargs):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise ValueError("Image size of 0x0 pixels is too small") from None

    monkeypatch.setattr("sma_gym.diagnosis.synth.main", drawing)
    assert cli.main(["synth", "--out", str(tmp_path / "s.csv")]) == 130
    assert capsys.readouterr().err == "sma-gym synth: interrupted\n"
    assert interrupt_behind(ValueError("plain")) is None


def test_calibration_names_missing_real_runs_in_one_line(tmp_path, monkeypatch, capsys):
    """``python -m sma_gym.calibration twin|bench`` without the real runs gave a traceback."""
    from sma_gym.calibration import main

    for folder, needle in ((tmp_path / "none", "expected a folder holding the bench's runs"), (tmp_path, "step01.csv")):
        monkeypatch.setenv("SMA_GYM_REAL_DATA", str(folder))
        with pytest.raises(SystemExit) as stop:
            main(["twin"])
        assert stop.value.code == 2 and needle in capsys.readouterr().err


def test_a_rollout_runs_the_seeds_it_is_given_and_refuses_ones_that_are_no_integers():
    """Found by an audit: a rollout ran ``seeds[0] + i`` whatever followed it (``(0, 7)`` ran
    0 and 1, ``(3, 3, 3)`` three seeds), while the bank experiments of the same ``evaluate``
    ran the seeds as given; ``1.5`` ran as 1."""
    from sma_gym_agents.evaluation import baseline, evaluate, rollout

    entry = baseline("PID")

    def run(seeds):
        return rollout(entry, reference="report-step", seconds=0.3, seeds=seeds)["position_measured_m"]

    both, alone = run((0, 7)), run((7,))
    assert np.array_equal(both[:, 1], alone[:, 0])
    same = run((3, 3))
    assert np.array_equal(same[:, 0], same[:, 1])
    for seeds, message in (((1.5,), r"seed = 1\.5: expected an integer"), ((), r"seeds = \(\)"), (3, r"seeds = 3")):
        with pytest.raises(ValueError, match=message):
            run(seeds)
    with pytest.raises(ValueError, match=r"seed = -1: expected an integer in \[0, 4294967295\]"):
        evaluate(experiments=["6.1"], seeds=[-1])


def test_the_self_sensing_experiment_runs_the_baselines_asked_for_and_refuses_none_before_any_run(monkeypatch):
    """Found by an audit: ``--baselines VSC4`` with the self-sensing experiment ran PID and
    VSC3 + FF fed by resistance and nothing fed by the sensor; VSC4 never ran."""
    from sma_gym_agents import evaluation

    ran = []
    monkeypatch.setattr(evaluation, "run_table_6_1", lambda entries, *a, **k: ran.append([e.name for e in entries]))
    evaluation.evaluate(experiments=["self-sensing"], seeds=[0], baselines=[evaluation.baseline("VSC4")])
    assert ran == [["VSC4 (self-sensing)", "VSC4"]]
    ran.clear()
    evaluation.evaluate(experiments=["self-sensing"], seeds=[0])
    assert ran == [["PID (self-sensing)", "VSC3 + FF (self-sensing)", "PID", "VSC3 + FF"]]
    ran.clear()
    mine = evaluation.PolicyEntry("mine", lambda env: None)
    with pytest.raises(ValueError, match=r"baselines = \['mine'\]: the self-sensing experiment runs the report's"):
        evaluation.evaluate(experiments=["6.1", "self-sensing"], seeds=[0], baselines=[mine])
    assert ran == []  # refused before Table 6.1 ran


def test_a_policy_of_ones_own_runs_alone_and_bank_agents_of_one_bank_share_the_baselines(monkeypatch):
    """Found by an audit: a ``PolicyEntry`` of one's own (kind "baseline" by default) was batched
    beside the report's controllers and saw their columns (it failed on shapes), and two bank
    agents of one scheme, n and model ran and recorded every bank baseline twice."""
    from types import SimpleNamespace

    from sma_gym_agents import evaluation

    pid, mine = evaluation.baseline("PID"), evaluation.PolicyEntry("mine", lambda env: None)
    assert [[e.name for e in g] for g in evaluation.batchable([pid, evaluation.baseline("VSC2"), mine])] == [
        ["PID", "VSC2"],
        ["mine"],
    ]
    pools = []
    for name in ("run_chapter_9", "run_bank_step"):
        monkeypatch.setattr(evaluation, name, lambda *a, **k: None)
    monkeypatch.setattr(evaluation, "run_bank_tracking", lambda pool, *a, **k: pools.append([e.name for e in pool]))
    monkeypatch.setattr(evaluation, "bank_agent_entry", lambda a: evaluation.PolicyEntry(a.name, lambda env: None))
    kwargs = {"scheme": "shared_budget", "n_actuators": 4}
    agents = [
        SimpleNamespace(name=f"agent {k}", env_id=evaluation.BANK_ENV_ID, env_kwargs=dict(kwargs)) for k in range(2)
    ]
    agents.append(
        SimpleNamespace(name="agent 8", env_id=evaluation.BANK_ENV_ID, env_kwargs={**kwargs, "n_actuators": 8})
    )
    evaluation.evaluate(agents, experiments=["9"], seeds=[0])
    baselines = [e.name for e in evaluation.bank_baselines("shared_budget")]
    assert pools == [[*baselines, "agent 0", "agent 1"], [*baselines, "agent 8"]]


def test_short_sines_dotted_model_names_bank_nans_and_json_notes_are_handled(tmp_path, monkeypatch, capsys):
    """Found by an audit: a sine shorter than its scoring window failed with an IndexError
    after it was simulated; two models m.v1 and m.v2 were "given twice" (both read as m.zip);
    a NaN in a bank agent's observation gave torch's distribution error; ``--json`` dropped
    the notes that say why an agent was left out of an experiment."""
    from sma_gym_agents import commands, evaluation
    from sma_gym_agents.bank import BankAgent

    with pytest.raises(ValueError, match=r"sine_seconds = 8\.0: expected more than 11 s"):
        evaluation.run_table_6_1([evaluation.baseline("PID")], evaluation.Results(), seeds=[0], sine_seconds=8.0)
    names = commands.agent_names([str(tmp_path / "m.v1"), str(tmp_path / "m.v2")], ["agent", "agent"])
    assert names == ["agent (m.v1)", "agent (m.v2)"]
    with pytest.raises(ValueError, match=r"given twice"):
        commands.agent_names([str(tmp_path / "m.v1.zip"), str(tmp_path / "m.v1")], ["a", "b"])
    observation = np.zeros(40, np.float32)
    observation[10] = np.nan
    with pytest.raises(ValueError, match=r"observation holds NaN at feature 'position' of block 1"):
        BankAgent(None, "fixed_slots", "bank", None).predict(observation)
    results = evaluation.Results(notes=["agent x was left out of chapter 8"])
    monkeypatch.setattr(commands.evaluation, "evaluate", lambda *a, **k: results)
    assert commands.evaluate(None, [], True, ["6.1"], 1) == 0
    out = capsys.readouterr()
    assert json.loads(out.out) == [] and "note: agent x was left out of chapter 8" in out.err


def test_a_seed_sweeps_iqm_counts_a_seed_that_did_not_finish_as_the_worst_not_as_nan():
    """Found by an audit: one overheated seed of five (NaN in its goals.json) made the IQM and
    its interval NaN and the table said nothing of why."""
    from sma_gym_agents.training.compare import GOALS
    from sma_gym_agents.training.config import RunConfig, parse_args
    from sma_gym_agents.training.sweep import seeds_table, summarise_seeds

    goal = GOALS["SMATracking-v0"][0]
    values = {0: 0.50, 1: 0.55, 2: 0.60, 3: 0.52, 4: float("nan")}
    by_seed = {s: {goal.name: {"agent_mm": v, "best_baseline_mm": 1.0, "met": v < 1.0}} for s, v in values.items()}
    entry = summarise_seeds(by_seed, goals=GOALS["SMATracking-v0"])[goal.name]
    agent = entry["agent_mm"]
    assert agent["iqm"] == pytest.approx(np.mean([0.52, 0.55, 0.60]))  # the middle three: the NaN seed trimmed
    assert agent["ci95"][0] == pytest.approx(0.5, abs=0.05) and agent["ci95"][1] == math.inf
    assert agent["did_not_finish"] == 1 and entry["met"] == 4
    table = seeds_table(RunConfig.from_args(parse_args(["--quick"])), list(values), {goal.name: entry}, [], 60.0, 1)
    assert "nan" not in table and "count as the worst figure, +inf" in table


def test_a_quoted_home_folder_in_a_commands_paths_is_the_home_folder(tmp_path, monkeypatch):
    """``synth --out '~/x/s.csv'`` wrote ./~/x/s.csv and said ~/x/s.csv; ``diagnose '~/...'``
    said the file did not exist, while ``--model '~/...'`` was read from the home folder
    (a new user's trial)."""
    from sma_gym.cli import main

    home, elsewhere = tmp_path / "home", tmp_path / "cwd"
    home.mkdir()
    elsewhere.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.chdir(elsewhere)
    assert main(["synth", "--out", "~/x/s.csv", "--duration", "10"]) == 0
    assert (home / "x" / "s.csv").exists() and not (elsewhere / "~").exists()
    argv = ["diagnose", "~/x/s.csv", "--out", "~/d", "--max-rounds", "1", "--effects", "sensor_lag", "--threads", "1"]
    assert main(argv) == 0
    assert (home / "d" / "diagnosis.json").exists() and not (elsewhere / "~").exists()


def test_diagnose_says_before_the_work_that_it_starts_from_the_default_model_and_whose_conditions_it_uses(
    tmp_path, capsys, monkeypatch
):
    """Files of a 0.25 mm wire at 12 V diagnosed without --model named wrong effects with
    confidence, and the note on the default model came only after an unexplained verdict;
    a sidecar's conditions that replace the model's were said only in the finished report
    (a new user's trial)."""
    import sma_gym.diagnosis.workflow
    from sma_gym.cli import main
    from sma_gym.model import ModelConfig

    monkeypatch.setattr(sma_gym.diagnosis.workflow, "diagnose", lambda *a, **k: (_ for _ in ()).throw(KeyError))
    ModelConfig().with_actuator(**{"wire.diameter_m": 0.25e-3, "driver.supply_voltage_v": 12.0}).save(
        str(tmp_path / "my wire.json")
    )
    assert (
        main(["synth", "--out", str(tmp_path / "w.csv"), "--model", str(tmp_path / "my wire.json"), "--duration", "7"])
        == 0
    )
    # The command synth suggests is one a shell runs as it is (the space was not quoted).
    assert f"sma-gym diagnose {tmp_path / 'w.csv'} --model '{tmp_path / 'my wire.json'}'" in capsys.readouterr().err
    with pytest.raises(KeyError):
        main(["diagnose", str(tmp_path / "w.csv"), "--out", str(tmp_path / "d")])
    err = capsys.readouterr().err
    assert "no --model, and no sidecar names one: the nominal model is the default 'standard'" in err
    assert (
        "w.csv: the sidecar's conditions are used instead of the model's ('standard'): supply_voltage_v = 12 (the model: 10), wire_diameter_m = 0.00025 (the model: 0.0003)"
        in err
    )
    with pytest.raises(KeyError):
        main(
            [
                "diagnose",
                str(tmp_path / "w.csv"),
                "--out",
                str(tmp_path / "d"),
                "--model",
                str(tmp_path / "my wire.json"),
            ]
        )
    err = capsys.readouterr().err
    assert "no --model" not in err and "instead of the model's" not in err


def test_diagnose_without_fit_files_says_heldout_took_them(tmp_path, capsys):
    """``diagnose --heldout held.csv fit.csv`` gave argparse's "the following arguments are
    required: files" (a new user's trial)."""
    from sma_gym.cli import main

    assert main(["diagnose", "--heldout", "held.csv", "fit.csv", "--out", str(tmp_path / "d")]) == 2
    assert "no files to fit: --heldout took every name after it (held.csv fit.csv)" in capsys.readouterr().err
    assert main(["diagnose", "--out", str(tmp_path / "d")]) == 2
    assert "no files to fit; expected the measured files first" in capsys.readouterr().err
    assert main(["diagnose", "--out", str(tmp_path / "d"), "--heldout", "held.csv"]) == 2
    assert "no files to fit; expected" in capsys.readouterr().err  # it took nothing of the user's
    assert not (tmp_path / "d").exists()


def test_synth_says_a_pure_convection_scale_is_the_refits_own_parameter(tmp_path, capsys):
    """``--effect convection_change:scale=1.3`` is labelled as that effect, and diagnose
    answered "none" with the scale in its refit (a new user's trial): synth says why."""
    from sma_gym.cli import main

    for effect, said in (("convection_change:scale=1.3", True), ("convection_change", False)):
        out = tmp_path / f"{said}.csv"
        assert main(["synth", "--out", str(out), "--effect", effect, "--duration", "7"]) == 0
        assert ("is a pure scale of the convection" in capsys.readouterr().err) is said
