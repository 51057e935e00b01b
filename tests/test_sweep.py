"""Results over seeds (``train.py --seeds N``): the interquartile mean, its bootstrap
interval, the per-seed command lines, and a whole sweep with a stand-in for training."""

from __future__ import annotations

import json
import shutil
import sys

import numpy as np
import pytest

from sma_gym_agents.training import sweep as sweep_module
from sma_gym_agents.training.cli import main
from sma_gym_agents.training.config import build_parser, parse_args
from sma_gym_agents.training.sweep import bootstrap_ci, iqm, seed_argv, summarise_seeds


def test_iqm_is_the_mean_of_the_middle_half():
    assert iqm([1, 2, 3, 4, 5, 6, 7, 8]) == pytest.approx(4.5)  # mean of 3, 4, 5, 6
    assert iqm([1, 2, 3, 100]) == pytest.approx(2.5)  # an outlier seed does not move it
    assert iqm([0.0, 1.0, 2.0, 3.0, 50.0]) == pytest.approx(2.0)  # five seeds: middle three
    assert iqm([7.0]) == 7.0
    np.testing.assert_allclose(iqm(np.array([[1, 2, 3, 100], [4, 4, 4, 4]]), axis=1), [2.5, 4.0])


def test_bootstrap_interval_is_reproducible_and_brackets_the_iqm():
    assert bootstrap_ci([3.0, 3.0, 3.0, 3.0, 3.0]) == (3.0, 3.0)
    values = [0.52, 0.61, 0.55, 0.70, 0.58]
    lo, hi = bootstrap_ci(values)
    assert lo <= iqm(values) <= hi and min(values) <= lo < hi <= max(values)
    assert bootstrap_ci(values) == (lo, hi)  # seeded
    # Known inputs: two values, the IQM of a resample is the mean of {a, b} drawn with
    # replacement, so the interval spans the two values' extremes.
    assert bootstrap_ci([0.0, 1.0]) == (0.0, 1.0)
    with pytest.raises(ValueError, match="non-empty"):
        bootstrap_ci([])


def test_summary_counts_seeds_that_met_each_goal():
    def goals(agent, met):
        return {"RMS step below every baseline": {"agent_mm": agent, "best_baseline_mm": 1.0, "met": met}}

    summary = summarise_seeds({0: goals(0.5, True), 1: goals(0.9, True), 2: goals(1.2, False)})
    entry = summary["RMS step below every baseline"]
    assert entry["met"] == 2 and entry["seeds"] == 3
    assert entry["agent_mm"]["values"] == [0.5, 0.9, 1.2] and entry["agent_mm"]["iqm"] == pytest.approx(
        2.6 / 3
    )  # three seeds: nothing trimmed
    assert entry["best_baseline_mm"]["ci95"] == [1.0, 1.0]


def test_a_goal_is_met_over_seeds_only_if_the_interval_meets_it():
    from sma_gym_agents.training.compare import GOALS, ROBUST, SELF_SENSING, TRACKING

    step, sine = GOALS[ROBUST]  # strict: agent < best baseline's worst case

    def over(goal, values, baseline_mm):
        return {
            s: {
                goal.name: {
                    "agent_mm": v,
                    goal.baseline_key: baseline_mm,
                    "met": goal.meets(v * 1e-3, baseline_mm * 1e-3),
                }
            }
            for s, v in enumerate(values)
        }

    def status(goal, values, baseline_mm):
        return summarise_seeds(over(goal, values, baseline_mm), goals=(goal,))[goal.name]["status"]

    assert status(step, [3.59, 3.64, 3.60, 3.62, 3.61], 3.735) == "met"
    # The IQM beats the baseline but two seeds do not: the interval reaches above it.
    assert status(step, [0.90, 1.01, 0.95, 1.02, 0.97], 1.006) == "missed"
    assert status(step, [0.5, 1.5, 1.6], 1.0) == "missed"  # one seed in three
    assert status(step, [0.5], 1.0) == "one seed"  # no interval to judge by
    # Not strict, within a factor: 2x the best baseline with a position sensor.
    ss_step = GOALS[SELF_SENSING][0]
    assert status(ss_step, [0.90, 0.91, 0.92], 0.5) == "met"
    assert status(ss_step, [0.90, 1.2, 1.3], 0.5) == "missed"
    # Against a named baseline with a slack (overshoot no larger than VSC3 + FF's 0).
    overshoot = GOALS[TRACKING][2]
    assert status(overshoot, [0.0, 0.0, 0.0, 0.0], 0.0) == "met"
    assert status(overshoot, [0.0, 0.0, 0.0, 0.915, 0.066], 0.0) == "missed"
    # Without the definitions the summary counts but gives no verdict.
    assert "status" not in summarise_seeds(over(step, [1.0, 2.0], 3.0))[step.name]


def test_each_seed_runs_train_py_with_the_same_options_and_its_own_seed_and_folder(tmp_path):
    parser = build_parser()
    args = parse_args(
        ["--seeds", "3", "--workers", "2", "--quick", "--residual", "none", "--timesteps", "900", "--seed", "4"]
    )
    argv = seed_argv(parser, args, 5, tmp_path / "seed-5")
    assert argv == [
        "--timesteps",
        "900",
        "--residual",
        "none",
        "--quick",
        "--seed",
        "5",
        "--out",
        str(tmp_path / "seed-5"),
    ]
    # What a seed's process would run is an ordinary train.py configuration.
    assert parse_args(argv).seed == 5 and parse_args(argv).seeds is None


def test_bad_sweep_options_exit_2(capsys, tmp_path):
    with pytest.raises(ValueError, match="timesteps"):  # run_seed (for an external engine) refuses as train.py does
        sweep_module.run_seed(["--timesteps", "0"], 0, tmp_path / "seed-0")
    assert not (tmp_path / "seed-0").exists()
    assert main(["--seeds", "0"]) == 2 and "--seeds" in capsys.readouterr().err
    assert main(["--seeds", "2", "--workers", "0"]) == 2 and "--workers" in capsys.readouterr().err
    assert main(["--workers", "2"]) == 2 and "--seeds" in capsys.readouterr().err


@pytest.mark.skipif(not hasattr(__import__("os"), "sched_getaffinity"), reason="no CPU affinity on this platform")
def test_workers_default_to_the_cores_this_process_may_run_on(monkeypatch):
    """Found by a new user: under ``taskset -c 0`` the default ran two seeds at once on the
    one allowed core (``os.cpu_count()`` counts the machine's)."""
    import argparse
    import os

    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0})
    args = argparse.Namespace(seeds=4, seed=0, workers=None, resume=False, overwrite=False)
    sweep_module.check_sweep_args(args)
    assert args.workers == 1
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0, 1, 2})
    args.workers = None
    sweep_module.check_sweep_args(args)
    assert args.workers == 3


FAKE_RUN = """
import json, sys
from pathlib import Path
argv = sys.argv[1:]
seed, out = int(argv[argv.index("--seed") + 1]), Path(argv[argv.index("--out") + 1])
if seed == 13:
    sys.exit(3)
out.mkdir(parents=True)
goals = {"RMS step below every baseline": {"agent_mm": 0.5 + 0.1 * seed, "best_baseline_mm": 1.0, "met": seed < 12}}
code = {"sma_gym_version": "0.1.0", "commit": ("a" if seed < 12 else "b") * 40, "modified": False}
(out / "goals.json").write_text(json.dumps({"goals": goals, "provenance": code}))
print("trained", seed)
"""


def test_a_sweep_runs_every_seed_in_its_own_folder_and_writes_the_table(tmp_path, monkeypatch, capsys):
    """The sweep's machinery with a stand-in for training (each seed's real run is train.py's
    single-run path, tested in test_train.py)."""
    monkeypatch.setattr(sweep_module, "seed_command", lambda argv: [sys.executable, "-c", FAKE_RUN, *argv])
    out = tmp_path / "sweep"
    assert main(["--seeds", "4", "--seed", "10", "--workers", "2", "--quick", "--out", str(out)]) == 1  # seed 13 fails
    printed = capsys.readouterr().out
    assert "seed 13 FAILED" in printed and f"sweep folder: {out}" in printed
    assert sorted(p.name for p in out.glob("seed-*")) == ["seed-10", "seed-11", "seed-12"]
    assert (out / "logs" / "seed-10.log").read_text().strip() == "trained 10"
    data = json.loads((out / "seeds.json").read_text())
    assert data["seeds"] == [10, 11, 12, 13] and data["failed"] == [13]
    goal = data["goals"]["RMS step below every baseline"]
    assert goal["met"] == 2 and goal["seeds"] == 3 and goal["agent_mm"]["iqm"] == pytest.approx(1.6)
    assert goal["status"] == "missed"  # the env's goal definition applied: 1.6 mm is not below 1.0 mm
    table = (out / "seeds.md").read_text()
    assert "| RMS step below every baseline | 1.600 [" in table and "| 2/3 | missed |" in table
    assert "(the best baseline of each seed)" in table  # named, not the JSON key "best_baseline"
    assert "Failed seeds" in table
    # Seed 12 ran other code than 10 and 11: the table says so, and seeds.json keeps each.
    assert "did not all run the same code" in table and "seeds 10, 11: sma-gym 0.1.0, commit aaaaaaaaaaaa" in table
    assert data["provenance"]["12"]["commit"] == "b" * 40
    # A sweep never mixes with another's files: refused (naming --resume, which keeps the
    # finished seeds that --overwrite deletes), then replaced with --overwrite.
    assert main(["--seeds", "2", "--quick", "--out", str(out)]) == 2
    assert "--resume continues this sweep and keeps its finished seeds" in capsys.readouterr().err
    assert main(["--seeds", "2", "--quick", "--out", str(out), "--overwrite"]) == 0
    assert sorted(p.name for p in out.glob("seed-*")) == ["seed-0", "seed-1"]


FAKE_RESUMED_RUN = """
import json, sys
from pathlib import Path
argv = sys.argv[1:]
seed, out = int(argv[argv.index("--seed") + 1]), Path(argv[argv.index("--out") + 1])
out.mkdir(parents=True, exist_ok="--overwrite" in argv)
from sma_gym_agents.training.config import RunConfig, parse_args  # a run records its configuration first
(out / "run.json").write_text(json.dumps(RunConfig.from_args(parse_args(argv)).as_dict(), default=str))
goals = {"RMS step below every baseline": {"agent_mm": 1.0 + seed, "best_baseline_mm": 2.0, "met": True}}
code = {"sma_gym_version": "0.1.0", "commit": ("a" if seed < 12 else "b") * 40, "modified": False}
(out / "goals.json").write_text(json.dumps({"goals": goals, "provenance": code}))
print("trained", seed, "--overwrite" in argv)
"""


def _finished_before(folder, options, seed, agent_mm=None):
    """A seed folder as an earlier sweep left it: run.json, and goals.json if it finished."""
    from sma_gym_agents.training.config import RunConfig

    folder.mkdir(parents=True)
    run = RunConfig.from_args(parse_args([*options, "--seed", str(seed)]))
    (folder / "run.json").write_text(json.dumps(run.as_dict(), default=str))
    if agent_mm is not None:
        goals = {"RMS step below every baseline": {"agent_mm": agent_mm, "best_baseline_mm": 2.0, "met": True}}
        (folder / "goals.json").write_text(json.dumps({"goals": goals}))


def test_a_resumed_sweep_keeps_the_seeds_that_finished_and_reruns_the_others(tmp_path, monkeypatch, capsys):
    """An interrupted sweep goes on with --resume: finished seeds are kept, an interrupted one
    is started over, the missing ones run, and the table is over all of them. A folder of
    another configuration is refused and left as it was."""
    monkeypatch.setattr(sweep_module, "seed_command", lambda argv: [sys.executable, "-c", FAKE_RESUMED_RUN, *argv])
    options = ["--quick", "--residual", "none"]
    out = tmp_path / "sweep"
    _finished_before(out / "seed-0", options, 0, agent_mm=7.0)  # finished: kept, not retrained
    _finished_before(out / "seed-1", options, 1)  # interrupted: run.json but no goals.json
    (out / "seed-1" / "checkpoints").mkdir()
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}

    # Another configuration in the folder: refused before anything runs or is deleted.
    assert main(["--seeds", "3", *options, "--n-envs", "2", "--resume", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "seed-0" in err and "n_envs" in err and "another configuration" in err
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert not (out / "seed-2").exists() and not (out / "seeds.md").exists()

    assert main(["--seeds", "3", *options, "--workers", "2", "--resume", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "seed 0 kept" in printed
    assert not (out / "logs" / "seed-0.log").exists()  # never retrained
    assert (out / "logs" / "seed-1.log").read_text().strip() == "trained 1 True"  # started over
    assert (out / "logs" / "seed-2.log").read_text().strip() == "trained 2 False"
    data = json.loads((out / "seeds.json").read_text())
    assert data["seeds"] == [0, 1, 2] and data["kept"] == [0] and data["failed"] == []
    assert data["goals"]["RMS step below every baseline"]["agent_mm"]["values"] == [7.0, 2.0, 3.0]
    assert "kept from before (--resume)" in (out / "seeds.md").read_text()

    # Extending the finished sweep to five seeds runs only seeds 3 and 4.
    assert main(["--seeds", "5", *options, "--resume", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert all(f"seed {s} kept" in printed for s in (0, 1, 2)) and "seed 3 done" in printed
    data = json.loads((out / "seeds.json").read_text())
    assert data["kept"] == [0, 1, 2] and data["goals"]["RMS step below every baseline"]["seeds"] == 5


def test_resume_refuses_seeds_it_would_leave_out_and_retrains_a_seed_whose_goals_are_unreadable(
    tmp_path, monkeypatch, capsys
):
    """--resume with another --seed or fewer --seeds trained into the same folder, and the
    seeds left out stayed beside a table that did not count them; a kept seed whose
    goals.json was damaged crashed the sweep with a JSON traceback after every other seed
    had trained."""
    monkeypatch.setattr(sweep_module, "seed_command", lambda argv: [sys.executable, "-c", FAKE_RESUMED_RUN, *argv])
    options = ["--quick", "--residual", "none"]
    out = tmp_path / "sweep"
    for seed in (0, 1):
        _finished_before(out / f"seed-{seed}", options, seed, agent_mm=7.0)
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    for extra in (["--seeds", "1"], ["--seeds", "2", "--seed", "5"]):
        assert main([*extra, *options, "--resume", "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert "holds seeds [" in err and "leave out" in err and "Traceback" not in err, err
        assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    # Cut short by a full disk, a figure gone, no goal, or run.json not an object (from an
    # audit: the second crashed the table after the other seeds had trained, the third was
    # counted as a seed of no goal, the fourth was a traceback).
    step = "RMS step below every baseline"
    for damaged in (
        '{"goals": ',
        json.dumps({"goals": {step: {"agent_mm": None, "best_baseline_mm": 2.0, "met": True}}}),
        json.dumps({"goals": {}}),
    ):
        shutil.rmtree(out / "seed-1")
        _finished_before(out / "seed-1", options, 1, agent_mm=7.0)
        (out / "seed-1" / "goals.json").write_text(damaged)
        assert main(["--seeds", "2", *options, "--resume", "--out", str(out)]) == 0
        printed = capsys.readouterr().out
        assert "seed 0 kept" in printed and "goals.json is not readable" in printed and "seed 1 kept" not in printed
        assert json.loads((out / "seeds.json").read_text())["kept"] == [0]
    (out / "seed-1" / "run.json").write_text("[]")
    assert main(["--seeds", "2", *options, "--resume", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "run.json: not readable as a run's configuration (a JSON list, not an object)" in err
    assert "Traceback" not in err


def test_resume_options_are_checked(capsys, tmp_path):
    assert main(["--resume", "--out", str(tmp_path)]) == 2 and "--resume: only with --seeds" in capsys.readouterr().err
    assert main(["--seeds", "2", "--resume"]) == 2 and "--out" in capsys.readouterr().err
    assert main(["--seeds", "2", "--resume", "--overwrite", "--out", str(tmp_path)]) == 2
    assert "give one of the two" in capsys.readouterr().err


def test_a_run_json_from_before_the_residual_filter_reads_as_no_filter(tmp_path):
    """A sweep folder written before ``residual_filter_s`` existed resumes as the unfiltered
    configuration it was, and is refused, by name, for a filtered one."""
    from dataclasses import replace

    from sma_gym_agents.training.config import RunConfig
    from sma_gym_agents.training.sweep import finished_seeds

    run = RunConfig.from_args(parse_args(["--quick", "--residual", "none"]))
    folder = tmp_path / "seed-0"
    folder.mkdir()
    old = {k: v for k, v in run.as_dict().items() if k != "residual_filter_s"}
    (folder / "run.json").write_text(json.dumps({**old, "seed": 0}))
    goals = {"RMS step below every baseline": {"agent_mm": 1.0, "best_baseline_mm": 2.0, "met": True}}
    (folder / "goals.json").write_text(json.dumps({"goals": goals}))
    assert finished_seeds(run, [0], tmp_path) == [0]
    with pytest.raises(ValueError, match=r"residual_filter_s: 0.0 there, 0.1 now"):
        finished_seeds(replace(run, residual_filter_s=0.1), [0], tmp_path)


def test_sigterm_stops_a_sweep_and_its_seeds_at_once(tmp_path, monkeypatch, capsys):
    """A scheduler's SIGTERM reaches the sweep's process, not its seeds' children: the pool's
    threads then waited for every child to finish its run (here 60 s; a real seed, hours).
    Now the children are terminated, no queued seed starts, and ``--resume`` is offered."""
    import os
    import signal
    import threading
    import time

    started = tmp_path / "started"
    started.mkdir()
    child = "import sys, time, pathlib; pathlib.Path(sys.argv[1], sys.argv[2]).write_text(''); time.sleep(60)"
    # Each child writes its seed's argv tail into ``started`` and sleeps.
    monkeypatch.setattr(
        sweep_module,
        "seed_command",
        lambda argv: [sys.executable, "-c", child, str(started), argv[argv.index("--seed") + 1]],
    )

    def stop_once_both_run() -> None:  # the handler is in place once the sweep has started them
        deadline = time.monotonic() + 120
        while len(list(started.iterdir())) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        if len(list(started.iterdir())) >= 2:
            os.kill(os.getpid(), signal.SIGTERM)

    threading.Thread(target=stop_once_both_run, daemon=True).start()
    begun = time.monotonic()
    code = main(["--seeds", "3", "--workers", "2", "--quick", "--out", str(tmp_path / "sweep")])
    assert code == 143 and time.monotonic() - begun < 30
    captured = capsys.readouterr()
    assert "terminated; no seed finished yet; --resume --out" in captured.err
    assert "FAILED" not in captured.out  # a stopped seed is "stopped", not failed
    assert sorted(p.name for p in started.iterdir()) == ["0", "1"]  # the queued third never started


def test_overwrite_keeps_the_earlier_sweep_until_a_seed_of_the_new_one_kept_a_file(tmp_path, monkeypatch, capsys):
    """``--overwrite`` deleted the earlier sweep (hours of seeds) before the new one started:
    a Ctrl-C a minute later left neither. Now it is set aside and put back when the new sweep
    stops before any seed kept a file, and deleted once one has (or the sweep ends)."""
    out = tmp_path / "sweep"
    _finished_before(out / "seed-0", ["--quick"], 0, agent_mm=1.5)
    (out / "logs").mkdir()
    (out / "logs" / "seed-0.log").write_text("the earlier sweep's log")
    (out / "seeds.md").write_text("the earlier table")
    before = {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()}

    def stopped_early(args, run, folder):  # a seed started (log, empty folder), then Ctrl-C
        (folder / "logs").mkdir()
        (folder / "logs" / "seed-0.log").write_text("new")
        (folder / "seed-0").mkdir()
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep_module, "sweep", stopped_early)
    assert main(["--seeds", "2", "--quick", "--out", str(out), "--overwrite"]) == 130
    assert f"before any seed kept a file; the earlier sweep in {out} is back as it was" in capsys.readouterr().err
    assert {p.relative_to(out): p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    assert not (out / sweep_module.PREVIOUS_SWEEP_DIR).exists()

    def stopped_later(args, run, folder):  # seed 0 kept a checkpoint before the stop
        (folder / "seed-0" / "checkpoints").mkdir(parents=True)
        (folder / "seed-0" / "checkpoints" / "model_1000_steps.zip").write_text("new")
        raise KeyboardInterrupt

    monkeypatch.setattr(sweep_module, "sweep", stopped_later)
    assert main(["--seeds", "2", "--quick", "--out", str(out), "--overwrite"]) == 130
    assert f"interrupted; no seed finished yet; --resume --out {out} continues the sweep" in capsys.readouterr().err
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()) == [
        "seed-0/checkpoints/model_1000_steps.zip"
    ]
    # A folder left by a sweep killed outright is no stranger to --resume.
    (out / sweep_module.PREVIOUS_SWEEP_DIR).mkdir()
    sweep_module.require_sweep_folder(out)


def test_a_seed_that_ended_badly_after_writing_its_goals_counts_and_overwrite_keeps_to_its_own_kind(
    tmp_path, monkeypatch, capsys
):
    """From an audit: a seed stopped or killed (the OOM killer's -9) after it had written its
    goals.json, which a run writes last, was reported kept and then left out of the table as
    failed; and --overwrite of a single run into a sweep's folder (or the reverse) left the
    other kind's files beside its own, after which --resume refused the folder."""
    ends_badly = FAKE_RESUMED_RUN + "\nimport os\nos._exit(9 if seed == 0 else 0)\n"
    monkeypatch.setattr(sweep_module, "seed_command", lambda argv: [sys.executable, "-c", ends_badly, *argv])
    options = ["--quick", "--residual", "none"]
    out = tmp_path / "sweep"
    assert main(["--seeds", "2", *options, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "seed 0 finished, then ended with exit 9 (kept" in printed and "(1 finished)" not in printed
    assert json.loads((out / "seeds.json").read_text())["failed"] == []
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    assert main([*options, "--overwrite", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert f"--overwrite: {out} holds a seed sweep's outputs (seeds.md, seeds.json, logs, seed-0, seed-1)" in err
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
    single = tmp_path / "single"
    _finished_before(single, options, 0)
    (single / "results.md").write_text("a single run's")
    assert main(["--seeds", "2", *options, "--overwrite", "--out", str(single)]) == 2
    assert f"--overwrite: {single} holds a single run's outputs (run.json, results.md)" in capsys.readouterr().err
    assert (single / "results.md").read_text() == "a single run's" and not (single / "seed-0").exists()
