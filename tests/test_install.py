"""The lean install and its extras (``pyproject.toml``), and the installed package names.

The lean install is simulated in a subprocess in which the extras' modules cannot be
imported (``sys.modules[name] = None`` makes ``import name`` fail as if it were absent), so
the test runs in this environment, which has everything installed.
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from sma_gym.extras import EXTRA_OF_MODULE, MissingExtraError, missing, require

ROOT = Path(__file__).resolve().parents[1]
LEAN = ("numpy", "numba", "gymnasium")


def _hint(extras: str) -> str:
    """The install command for ``extras``: from this checkout (editable) or from the index."""
    return rf"pip install (torch==\S+ )?(-e )?'[^']*(sma-gym|{re.escape(str(ROOT))})\[{re.escape(extras)}\]'"


def test_the_hint_installs_from_the_checkout_this_package_came_from():
    from sma_gym.extras import install_hint

    hint = install_hint(["scipy"])
    assert re.fullmatch(_hint("diagnose"), hint), hint


def _pyproject() -> dict:
    tomllib = pytest.importorskip("tomllib", reason="tomllib is in the standard library from Python 3.11")
    return tomllib.loads((ROOT / "pyproject.toml").read_text())


def _run_lean(code: str) -> dict:
    """Run ``code`` with every extra's module unimportable; it prints one JSON line last."""
    blocked = sorted(EXTRA_OF_MODULE)
    prelude = f"import sys\nfor _m in {blocked!r}:\n    sys.modules[_m] = None\n"
    done = subprocess.run(
        [sys.executable, "-c", prelude + textwrap.dedent(code)],
        capture_output=True,
        text=True,
        timeout=600,
        cwd=ROOT,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_the_lean_install_needs_only_numpy_numba_and_gymnasium():
    project = _pyproject()["project"]
    names = {d.split(">")[0].split("=")[0].split("<")[0].strip() for d in project["dependencies"]}
    assert names == set(LEAN)
    extras = project["optional-dependencies"]
    assert {"plots", "diagnose", "train", "all", "test"} <= set(extras)
    assert "sma-gym[all,zoo]" in extras["test"], "the tests cover everything: the test extra installs all and the zoo"
    # Every module the code guards with an extra is installed by that extra.
    for module, extra in EXTRA_OF_MODULE.items():
        wanted = {"matplotlib": "matplotlib", "scipy": "scipy", "yaml": "pyyaml", "tensorboard": "tensorboard"}
        if module in wanted:
            assert any(d.startswith(wanted[module]) for d in extras[extra]), (module, extra)


def test_every_package_folder_is_installed_and_agents_under_a_name_that_cannot_collide():
    setuptools = _pyproject()["tool"]["setuptools"]
    assert setuptools["package-dir"] == {"sma_gym_agents": "agents"}
    folders = {"sma_gym": "sma_gym", "agents": "sma_gym_agents"}
    expected = {
        ".".join((package, *init.parent.relative_to(ROOT / folder).parts))
        for folder, package in folders.items()
        for init in (ROOT / folder).rglob("__init__.py")
    }
    assert set(setuptools["packages"]) == expected
    assert "agents" not in setuptools["packages"]
    assert (ROOT / "agents" / "py.typed").is_file()


def test_the_readme_main_job_installs_the_train_extra():
    from test_repository import readme_commands

    main_job, tests = readme_commands()
    assert "'.[train]'" in main_job or '".[train]"' in main_job
    assert "'.[test]'" in tests


def test_envs_vector_envs_and_the_reference_controllers_work_without_any_extra():
    result = _run_lean(
        """
        import json
        import gymnasium as gym
        import sma_gym
        from sma_gym_agents import ControllerPolicy
        from sma_gym_agents.controllers import PID

        for env_id in ("SMATracking-v0", "SMASelfSensing-v0", "SMARobust-v0", "SMAMultiplexed-v0"):
            env = gym.make("sma_gym:" + env_id)
            env.reset(seed=0)
            env.step(env.action_space.sample())
        venv = gym.make_vec("sma_gym:SMATracking-v0", num_envs=3, vectorization_mode="vector_entry_point")
        venv.reset(seed=0)
        venv.step(venv.action_space.sample())
        env = gym.make("sma_gym:SMATracking-v0")
        policy = ControllerPolicy(PID, env)
        obs, _ = env.reset(seed=1)
        for _ in range(50):
            action, _ = policy.predict(obs)
            obs, *_ = env.step(action)
        loaded = sorted(m for m in ("scipy", "matplotlib", "torch", "stable_baselines3") if sys.modules.get(m))
        print(json.dumps({"loaded": loaded}))
        """
    )
    assert result == {"loaded": []}


def test_without_an_extra_each_command_names_the_extra_to_install():
    result = _run_lean(
        """
        import contextlib, io, json
        import gymnasium as gym
        import sma_gym
        from sma_gym.cli import main
        from sma_gym_agents.training import main as train_main

        out = {}
        for name, argv in {
            "diagnose": ["diagnose", "x.csv", "--out", "nowhere"],
            "evaluate": ["evaluate", "--out", "nowhere"],
            "fidelity": ["fidelity"],
        }.items():
            err = io.StringIO()
            with contextlib.redirect_stderr(err):
                code = main(argv)
            out[name] = [code, err.getvalue()]
        err = io.StringIO()
        with contextlib.redirect_stderr(err):
            out["train"] = [train_main(["--timesteps", "10"]), err.getvalue()]
        help_out = io.StringIO()
        try:
            with contextlib.redirect_stdout(help_out):
                train_main(["--help"])
        except SystemExit as done:
            out["train_help"] = [done.code, "--timesteps" in help_out.getvalue()]
        try:
            gym.make("sma_gym:SMATracking-v0", render_mode="rgb_array")
        except ModuleNotFoundError as e:
            out["render"] = [type(e).__name__, str(e)]
        try:
            gym.make_vec("sma_gym:SMATracking-v0", 2, vectorization_mode="vector_entry_point", render_mode="rgb_array")
        except ModuleNotFoundError as e:
            out["vector_render"] = [type(e).__name__, str(e)]  # at make, not at the first render()
        try:
            import sma_gym.envs.sb3  # noqa: F401
        except ModuleNotFoundError as e:
            out["sb3"] = [type(e).__name__, str(e)]
        print(json.dumps(out))
        """
    )
    assert result["diagnose"][0] == 2 and re.search(_hint("diagnose"), result["diagnose"][1])
    # One prefix: the message named the command twice ("sma-gym diagnose: error: sma-gym diagnose: ...").
    assert result["diagnose"][1].count("sma-gym diagnose:") == 1, result["diagnose"][1]
    assert result["train"][1].count("train.py:") == 1, result["train"][1]
    for name in ("evaluate", "fidelity"):
        # What the commands' module needs to load; evaluate also needs the train extra (below).
        assert result[name][0] == 2 and re.search(_hint("diagnose,plots"), result[name][1]), result[name]
        assert "matplotlib, scipy not installed" in result[name][1]
        # ... and the one install that makes evaluate work too (it took two to find out).
        assert re.search(r"evaluate needs stable-baselines3 as well, and " + _hint("train"), result[name][1])
    assert result["train"][0] == 2 and re.search(_hint("train"), result["train"][1])
    assert "pip install torch==2.13.0 " in result["train"][1], "the train hint pins torch as the README does"
    assert "CUDA" in result["train"][1], "and says why"
    assert result["train_help"] == [0, True], "train.py --help works before the train extra is installed"
    assert result["render"] == ["MissingExtraError", result["render"][1]]
    assert re.search(_hint("plots"), result["render"][1])
    assert result["vector_render"][0] == "MissingExtraError" and re.search(_hint("plots"), result["vector_render"][1])
    assert result["sb3"][0] == "MissingExtraError" and re.search(_hint("train"), result["sb3"][1])
    assert not (ROOT / "nowhere").exists(), "a missing extra is reported before any output is written"


def test_require_names_every_missing_module_and_the_extra():
    require("numpy", purpose="nothing")  # present: no error
    assert missing("numpy", "surely_not_a_module_xyz") == ["surely_not_a_module_xyz"]
    with pytest.raises(MissingExtraError, match=r"surely_not_a_module_xyz not installed.*pip install .*\[train\]'"):
        require("numpy", "surely_not_a_module_xyz", purpose="this", extra="train")


def test_calibration_names_a_missing_scipy_before_any_work(monkeypatch, capsys):
    """``python -m sma_gym.calibration bench|twin`` fit with scipy: in a lean install they
    exit 2 naming the extra, without starting (they used to fail inside the diagnosis)."""
    import sma_gym.calibration as calibration
    import sma_gym.extras as extras

    def started():
        raise AssertionError("the work started before the missing extra was reported")

    monkeypatch.setattr(extras, "missing", lambda *modules: [m for m in modules if m == "scipy"])
    monkeypatch.setattr(calibration, "identify_twin", started)
    monkeypatch.setattr(calibration, "calibrate_bench", started)
    for target in ("bench", "twin"):
        with pytest.raises(SystemExit) as exit_:
            calibration.main([target])
        assert exit_.value.code == 2
        err = capsys.readouterr().err
        assert f"python -m sma_gym.calibration {target}" in err and re.search(_hint("diagnose"), err), err
