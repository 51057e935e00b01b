"""Results over seeds: ``train.py --seeds N`` (or ``python -m sma_gym_agents.training.sweep``).

One seed is an anecdote. The sweep runs the same configuration with seeds ``--seed`` ..
``--seed + N - 1``, each as an ordinary ``train.py`` run in its own process and its own
folder (``<out>/seed-<s>/``, the single-run code path unchanged; its output in
``<out>/logs/seed-<s>.log``), ``--workers`` at a time. It then reports every goal of
:data:`sma_gym_agents.training.compare.GOALS` over the seeds the rliable way (Agarwal et al.,
"Deep RL at the edge of the statistical precipice", 2021): the interquartile mean (the
mean of the middle 50 % of the seeds, :func:`iqm`) with a 95 % percentile bootstrap
interval over seeds (:func:`bootstrap_ci`; with one task per goal the stratified
bootstrap is the plain bootstrap over runs), how many seeds met the goal, and the verdict
(:func:`goal_status`: met only if the interval's upper end meets it). Written to
``<out>/seeds.md`` and ``<out>/seeds.json``.

A sweep cut short (a session or a cluster job that ended, a machine that rebooted) goes on
with ``--resume``: the seeds that finished in ``<out>`` with the same configuration are
kept and only the others run; ``--seeds`` larger than before extends a finished sweep.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from sma_gym._io import sigterm_as_interrupt, stopped
from sma_gym._jit import available_cores
from sma_gym_agents.training.config import (
    MAX_SEED,
    ROOT,
    RUN_OUTPUTS,
    SWEEP_OUTPUTS,
    RunConfig,
    build_parser,
    parse_args,
    require_no_outputs_of,
    sweep_paths,
)

if TYPE_CHECKING:  # compare imports the evaluation harness; the sweep needs it only at the end
    from sma_gym_agents.training.compare import Goal

BOOTSTRAP_RESAMPLES = 2_000
BOOTSTRAP_SEED = 0
CONFIDENCE = 0.95
PREVIOUS_SWEEP_DIR = ".previous-sweep"
"""Where ``--overwrite`` keeps the earlier sweep (inside ``--out``) until a seed of the new one
has kept a file: a sweep stopped or failing before that puts the earlier one back."""
_NOT_PER_SEED = {"help", "seeds", "workers", "seed", "out", "overwrite", "resume"}
"""Options of the sweep itself, not passed on to each seed's run."""


def iqm(values: Any, axis: int | None = None) -> Any:
    """Interquartile mean: 25 % trimmed from each end, as rliable's
    ``metrics.aggregate_iqm``, i.e. ``scipy.stats.trim_mean(x, 0.25)``, which trims
    floor(n / 4) values from each end: the plain mean of 1-3 seeds, the middle three of 5."""
    from scipy.stats import trim_mean

    return trim_mean(np.asarray(values, dtype=float), 0.25, axis=axis)


def bootstrap_ci(
    values: Any,
    statistic: Any = iqm,
    resamples: int = BOOTSTRAP_RESAMPLES,
    confidence: float = CONFIDENCE,
    seed: int = BOOTSTRAP_SEED,
) -> tuple[float, float]:
    """Percentile bootstrap interval of ``statistic`` over runs (seeds), reproducible by
    ``seed``: the runs are resampled with replacement ``resamples`` times."""
    x = np.asarray(values, dtype=float)
    if x.ndim != 1 or len(x) == 0:
        raise ValueError(f"bootstrap_ci: expected a non-empty 1-d array of per-seed values, got shape {x.shape}")
    rng = np.random.default_rng(seed)
    samples = x[rng.integers(0, len(x), size=(resamples, len(x)))]
    stats = statistic(samples, axis=1)
    tail = 100 * (1 - confidence) / 2
    if np.isfinite(stats).all():
        lo, hi = np.percentile(stats, [tail, 100 - tail])
    else:
        # A run counted as +inf (it did not finish): no interpolation, which gives inf - inf = NaN.
        lo, hi = np.percentile(stats, tail, method="lower"), np.percentile(stats, 100 - tail, method="higher")
    return float(lo), float(hi)


def goal_status(goal: Goal, entry: dict[str, Any]) -> str:
    """The verdict over seeds on one goal (``entry``: a :func:`summarise_seeds` entry).

    ``"met"`` when the upper end of the agent's 95 % interval meets the goal against the
    baseline's IQM, and more than one seed met it (a goal only one seed met is an anecdote);
    ``"missed"`` otherwise; ``"one seed"`` when there is only one (no interval to judge).
    """
    if entry["seeds"] < 2:
        return "one seed"
    baseline_mm = entry[goal.baseline_key]["iqm"]
    upper_mm = entry["agent_mm"]["ci95"][1]
    met = entry["met"] >= 2 and goal.meets(upper_mm * 1e-3, baseline_mm * 1e-3)
    return "met" if met else "missed"


BASELINE_LABELS = {"best_baseline_mm": "the best baseline of each seed", "vsc3_ff_mm": "VSC3 + FF"}
"""How ``seeds.md`` names a goal's baseline figure (the key of ``goals.json``)."""


def summarise_seeds(
    goals_by_seed: dict[int, dict[str, dict[str, Any]]],
    resamples: int = BOOTSTRAP_RESAMPLES,
    goals: Sequence[Goal] = (),
) -> dict[str, Any]:
    """Per goal: each figure (``agent_mm``, the baseline's) as per-seed values, IQM and
    95 % interval, and how many seeds met the goal. ``goals_by_seed``: seed -> the
    ``goals`` of that run's ``goals.json``; ``goals``: the run's goal definitions
    (:data:`~sma_gym_agents.training.compare.GOALS`), which add each one's ``status``
    (:func:`goal_status`)."""
    defined = {g.name: g for g in goals}
    seeds = sorted(goals_by_seed)
    names = list(dict.fromkeys(name for s in seeds for name in goals_by_seed[s]))
    out: dict[str, Any] = {}
    for name in names:
        runs = [goals_by_seed[s][name] for s in seeds if name in goals_by_seed[s]]
        figures = [k for k in runs[0] if k != "met"]
        entry: dict[str, Any] = {}
        for key in figures:
            values = [float(r[key]) for r in runs]
            # A seed whose run did not finish (NaN: it overheated the wire) is the worst an
            # error can be, +inf, not a hole: one NaN made the IQM and its interval NaN
            # and the goal "missed" though the other seeds met it.
            worst = [math.inf if math.isnan(v) else v for v in values]
            entry[key] = {
                "values": values,
                "iqm": float(iqm(worst)),
                "ci95": list(bootstrap_ci(worst, resamples=resamples)),
                "did_not_finish": sum(math.isnan(v) for v in values),
            }
        entry["met"] = sum(bool(r["met"]) for r in runs)
        entry["seeds"] = len(runs)
        if name in defined:
            entry["status"] = goal_status(defined[name], entry)
        out[name] = entry
    return out


def seeds_table(
    run: RunConfig,
    seeds: list[int],
    summary: dict[str, Any],
    failed: list[int],
    elapsed_s: float,
    workers: int,
    kept: list[int] | None = None,
    sources: dict[int, dict[str, Any] | None] | None = None,
) -> str:
    """``seeds.md``: one row per goal, IQM [95 % interval] of the agent and the baseline;
    ``sources``: each finished seed's provenance (:func:`read_provenance`)."""
    budget = f"{run.timesteps} steps{' (--quick)' if run.quick else ''}, {run.n_envs} envs"
    timing = f"{workers} at a time, {elapsed_s / 60:.1f} min in all"
    if kept:
        ran = len(seeds) - len(kept)
        timing = (
            f"seeds {', '.join(map(str, kept))} kept from before (--resume); "
            f"{ran} run now, {workers} at a time, {elapsed_s / 60:.1f} min"
        )
    lines = [
        f"# {run.algo.upper()} on {run.env_id} over {len(seeds)} seeds"
        + (f" ({len(seeds) - len(failed)} finished)" if failed else ""),
        "",
        f"Seeds {', '.join(map(str, seeds))}; {budget} each; {timing}.",
        (
            f"Interquartile mean over seeds [95 % percentile bootstrap interval, {BOOTSTRAP_RESAMPLES} resamples]; "
            "each seed's figure is its results.md's (worst case over the harness's noise seeds), in mm."
        ),
        "",
        (
            "Goal status: met when the upper end of the agent's interval meets the goal against the "
            "baseline's IQM and more than one seed met it. With few seeds the interval is narrow for its "
            f"label: with {'up to 4 seeds it is their range' if len(seeds) <= 4 else f'{len(seeds)} seeds'}; "
            "for normal data its upper end falls below the true IQM in 12.7 / 6.8 / 4.6 / 2.7 % of draws at "
            "3 / 4 / 5 / 10 seeds, not 2.5 % (docs/training.md)."
        ),
        "",
        "| goal | agent | baseline | seeds met | goal status |",
        "|---|---|---|---|---|",
    ]

    def cell(figure: dict[str, Any]) -> str:
        lo, hi = figure["ci95"]
        return f"{figure['iqm']:.3f} [{lo:.3f}, {hi:.3f}]"

    for name, entry in summary.items():
        baseline = next(k for k in entry if k not in ("agent_mm", "met", "seeds", "status"))
        label = BASELINE_LABELS.get(baseline, baseline.removesuffix("_mm"))
        lines.append(
            f"| {name} | {cell(entry['agent_mm'])} | {cell(entry[baseline])} ({label}) "
            f"| {entry['met']}/{entry['seeds']} | {entry.get('status', '–')} |"
        )
    unfinished = {
        name: max(f.get("did_not_finish", 0) for f in entry.values() if isinstance(f, dict))
        for name, entry in summary.items()
    }
    if any(unfinished.values()):
        lines += [
            "",
            "Seeds whose run did not finish (the wire overheated: NaN in their goals.json) count as the worst figure, "
            "+inf: "
            + "; ".join(f"{name}: {k}" for name, k in unfinished.items() if k)
            + ". The IQM trims them where there are enough seeds; the interval's upper end is inf where a resample "
            "keeps them.",
        ]
    if failed:
        lines += ["", f"Failed seeds (see logs/): {', '.join(map(str, failed))}; the table is over the others."]
    if sources:
        lines += ["", provenance_line(sources)]
    return "\n".join(lines) + "\n"


def seed_argv(parser: argparse.ArgumentParser, args: argparse.Namespace, seed: int, out: Path) -> list[str]:
    """``train.py`` options of one seed's run: the sweep's own options replaced by
    ``--seed`` and ``--out``, every other option passed on as given (its log is no
    terminal, so the run prints a progress line a minute rather than a bar)."""
    argv: list[str] = []
    for action in parser._actions:
        if action.dest in _NOT_PER_SEED or not action.option_strings:
            continue
        value = getattr(args, action.dest, None)
        if value is None or value is False or (value == action.default and action.default is not None):
            continue
        flag = action.option_strings[-1]
        if isinstance(value, list):  # nargs="+" (--env-kwargs)
            argv += [flag, *map(str, value)]
        else:
            argv += [flag] if value is True else [flag, str(value)]
    return [*argv, "--seed", str(seed), "--out", str(out)]


def seed_command(argv: list[str]) -> list[str]:
    """The process of one seed's run: ``train.py``'s command in a fresh interpreter."""
    return [sys.executable, "-m", "sma_gym_agents.training", *argv]


class _Children:
    """The seeds' child processes, stopped together when the sweep is stopped.

    Ctrl-C in a terminal reaches the whole process group, children included; SIGTERM from
    a scheduler or ``timeout`` reaches this process alone, and its pool's threads then
    waited for the children to finish their runs (hours) before the sweep could end."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._live: set[subprocess.Popen] = set()
        self.stopping = False

    def run(self, command: list[str], **kwargs: Any) -> int:
        """Run ``command`` to its end (``subprocess.Popen``'s ``kwargs``); its exit code.
        Once stopping, nothing new starts: the code is then SIGTERM's, as if it had run."""
        with self._lock:
            if self.stopping:
                return 128 + signal.SIGTERM
            child = subprocess.Popen(command, **kwargs)
            self._live.add(child)
        try:
            return child.wait()
        finally:
            with self._lock:
                self._live.discard(child)

    def stop(self) -> None:
        """Terminate every live child (each ends as after Ctrl-C) and start no more."""
        with self._lock:
            self.stopping = True
            for child in self._live:
                with contextlib.suppress(ProcessLookupError):
                    child.terminate()


def _run_seed_process(argv: list[str], log: Path, threads: int, children: _Children) -> int:
    """One seed's run as a child process, its output in ``log``; the exit code."""
    env = dict(os.environ)
    # One thread per run: the runs are the parallelism (numba and BLAS pools would
    # oversubscribe the cores the other runs use).
    for name in ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS", "OPENBLAS_NUM_THREADS"):
        env.setdefault(name, str(threads))
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    with log.open("w") as handle:
        return children.run(seed_command(argv), stdout=handle, stderr=subprocess.STDOUT, env=env)


def run_seed(options: list[str], seed: int, out: str | Path) -> dict[str, Any]:
    """Train one seed in this process (``train.py`` with ``options``, ``--seed`` and
    ``--out``) and return its goals (as ``goals.json`` records them): the function a
    cluster engine (docs/training.md, Ray Tune) calls once per seed. ``ValueError`` on a
    bad option, as ``train.py`` exits 2."""
    from sma_gym_agents.training.run import train_and_compare

    run = RunConfig.from_args(parse_args([*options, "--seed", str(seed)]))
    _, goals = train_and_compare(run, Path(out), progress=False)
    return goals


def read_goals(folder: Path) -> dict[str, dict[str, Any]]:
    """The goals a finished run wrote to ``folder/goals.json``."""
    return json.loads((folder / "goals.json").read_text())["goals"]


def goals_problem(folder: Path, run: RunConfig) -> str | None:
    """Why ``folder/goals.json`` is no finished run of ``run`` (None if it is): unreadable, none
    of the env's goals, or a goal without numeric figures (NaN for a run that did not finish)
    and a true/false ``met``. A parsed file with a ``null`` figure crashed the sweep's table after
    the other seeds had trained, and one with no goals was counted as a seed of none."""
    from sma_gym_agents.training.compare import GOALS, goal_key

    try:
        goals = read_goals(folder)
    except (OSError, ValueError, KeyError, TypeError) as err:
        return str(err)
    if not isinstance(goals, dict):
        return f"'goals' is a {type(goals).__name__}, not a table"
    # At least one of the env's goals (a run of an older version may lack a goal added since:
    # its table row then counts the seeds that have it).
    expected = [g.name for g in GOALS[goal_key(run)]]
    if not any(name in goals for name in expected):
        return f"none of the env's goals ({', '.join(expected)})"
    for name, entry in goals.items():
        if not isinstance(entry, dict) or not isinstance(entry.get("met"), bool):
            return f"goal {name!r}: expected figures and a true/false 'met', got {entry!r}"
        for key, value in entry.items():
            if key != "met" and (isinstance(value, bool) or not isinstance(value, (int, float))):
                return f"goal {name!r}: {key} = {value!r}, expected a number"
    return None


def read_provenance(folder: Path) -> dict[str, Any] | None:
    """The code a finished run recorded in ``folder/goals.json`` (None before it did)."""
    return json.loads((folder / "goals.json").read_text()).get("provenance")


def provenance_line(sources: dict[int, dict[str, Any] | None]) -> str:
    """``seeds.md``'s line on the code the seeds ran: one line if they all ran the same,
    otherwise each group of seeds with its code and a warning (kept seeds of ``--resume``
    may come from an older commit, whose model may differ)."""
    from sma_gym.provenance import RESULT_SOURCES, describe, results_differ

    groups: dict[str, list[int]] = {}
    for seed, record in sorted(sources.items()):
        groups.setdefault(describe(record), []).append(seed)
    if len(groups) == 1:
        return f"Code: {next(iter(groups))} (every seed)."
    parts = "; ".join(f"seeds {', '.join(map(str, seeds))}: {text}" for text, seeds in groups.items())
    records = list(sources.values())
    commits = [r.get("commit") if r else None for r in records]
    if all(commits) and not any(r.get("modified") for r in records):
        # Commits that changed only docs, tests or benchmarks ran the same code.
        if all(results_differ(commits[0], c) is False for c in commits[1:]):
            return (
                f"Code: the seeds ran different commits ({parts}) that differ only outside the files that decide "
                f"results ({', '.join(RESULT_SOURCES)}): the same code."
            )
    return f"Code: **the seeds did not all run the same code** ({parts}); compare them only if the model is the same."


def _field_defaults() -> dict[str, Any]:
    """RunConfig's fields that have a plain default, as ``run.json`` would record them: what a
    ``run.json`` written before such a field existed meant by leaving it out."""
    plain = {f.name: f.default for f in dataclasses.fields(RunConfig) if f.default is not dataclasses.MISSING}
    return _as_recorded(plain)


def _as_recorded(config: dict[str, Any]) -> dict[str, Any]:
    """A configuration as ``run.json`` holds it once read back (tuples as lists, ...)."""
    return json.loads(json.dumps(config, default=str))


def finished_seeds(run: RunConfig, seeds: list[int], out: Path) -> list[int]:
    """The seeds of ``seeds`` that finished in ``out`` (``seed-<s>/goals.json`` written, as a
    run writes it last) with ``run``'s configuration, for ``--resume``. ``ValueError``
    naming the seed and every differing option if a seed folder holds another
    configuration: its results would be mixed into a table that is not theirs."""
    kept = []
    expected = _as_recorded({**run.as_dict(), "seed": None})
    present = sorted(int(p.name[5:]) for p in out.glob("seed-*") if p.is_dir() and p.name[5:].isdigit())
    outside = [s for s in present if s not in seeds]
    if outside:
        # They would stay in the folder beside a seeds.md that does not count them.
        raise ValueError(
            f"--resume: {out} holds seeds {outside}, which seeds {seeds[0]}-{seeds[-1]} (--seed {seeds[0]} --seeds "
            f"{len(seeds)}) leave out; resume with that sweep's --seed and --seeds (or more seeds), or choose a new --out"
        )
    for seed in seeds:
        folder = out / f"seed-{seed}"
        record = folder / "run.json"
        if not record.is_file():
            continue
        try:
            loaded = json.loads(record.read_text())
            if not isinstance(loaded, dict):
                raise TypeError(f"a JSON {type(loaded).__name__}, not an object")
            # A field added since that run was written (residual_filter_s) had its default then.
            recorded = {**_field_defaults(), **loaded, "seed": None}
        except (OSError, json.JSONDecodeError, TypeError) as err:
            raise ValueError(f"--resume: {record}: not readable as a run's configuration ({err})") from None
        differs = sorted(k for k in expected.keys() | recorded.keys() if expected.get(k) != recorded.get(k))
        if differs:
            shown = "; ".join(f"{k}: {recorded.get(k)!r} there, {expected.get(k)!r} now" for k in differs)
            raise ValueError(
                f"--resume: {folder} was trained with another configuration ({shown}); "
                "resume with the options of that sweep, or choose a new --out"
            )
        if (folder / "goals.json").is_file():
            problem = goals_problem(folder, run)
            if problem is not None:
                # A run writes it last and atomically: unreadable, it is no finished run.
                print(
                    f"train.py: seed {seed}: {folder / 'goals.json'} is not readable ({problem}); trained again",
                    flush=True,
                )
                continue
            kept.append(seed)
    return kept


def sweep(args: argparse.Namespace, run: RunConfig, out: Path) -> tuple[str, int]:
    """Run ``args.seeds`` seeds ``args.workers`` at a time into ``out`` (with ``args.resume``,
    only those that did not finish there before); write ``seeds.md`` and ``seeds.json``;
    ``(table, number of failed seeds)``."""
    from sma_gym._io import write_json, write_text

    parser = build_parser()
    seeds = [run.seed + k for k in range(args.seeds)]
    kept = finished_seeds(run, seeds, out) if args.resume else []
    for seed in kept:
        print(f"train.py: seed {seed} kept (finished in {out / f'seed-{seed}'} before)", flush=True)
    (out / "logs").mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    children = _Children()

    def one(seed: int) -> int:
        argv = seed_argv(parser, args, seed, out / f"seed-{seed}")
        if (out / f"seed-{seed}").exists():
            # Only with --resume: an interrupted or failed run of this seed, started over.
            argv.append("--overwrite")
        code = _run_seed_process(argv, out / "logs" / f"seed-{seed}.log", run.threads, children)
        print(f"train.py: seed {seed} {seed_status(code, out, seed)}", flush=True)
        return code

    # Threads only wait on the child processes, which do the work.
    to_run = [s for s in seeds if s not in kept]
    with ThreadPoolExecutor(max_workers=max(1, min(args.workers, len(to_run)))) as pool:
        try:
            codes = dict(zip(to_run, pool.map(one, to_run), strict=True))
        except KeyboardInterrupt:  # Ctrl-C or SIGTERM: the pool's exit waits for its threads
            pool.shutdown(wait=False, cancel_futures=True)
            children.stop()
            raise
    elapsed = time.perf_counter() - started
    # A seed stopped or killed after it wrote its goals (which a run writes last) finished:
    # it was reported "kept" and then left out of the table as failed.
    failed = [s for s, code in codes.items() if code != 0 and goals_problem(out / f"seed-{s}", run) is not None]
    done = {s: read_goals(out / f"seed-{s}") for s in seeds if s not in failed}
    from sma_gym_agents.training.compare import GOALS, goal_key

    summary = summarise_seeds(done, goals=GOALS[goal_key(run)]) if done else {}
    sources = {s: read_provenance(out / f"seed-{s}") for s in done}
    table = seeds_table(run, seeds, summary, failed, elapsed, args.workers, kept, sources)
    write_text(out / "seeds.md", table)
    write_json(
        out / "seeds.json",
        {
            "config": {**run.as_dict(), "seed": None},
            "seeds": seeds,
            "kept": kept,
            "failed": failed,
            "workers": args.workers,
            "elapsed_s": elapsed,
            "statistic": "interquartile mean (scipy.stats.trim_mean, 0.25)",
            "interval": {
                "method": "percentile bootstrap over seeds",
                "confidence": CONFIDENCE,
                "resamples": BOOTSTRAP_RESAMPLES,
                "seed": BOOTSTRAP_SEED,
            },
            "goals": summary,
            "provenance": {str(s): record for s, record in sources.items()},
        },
        default=str,
    )
    return table, len(failed)


def require_sweep_folder(out: Path) -> None:
    """``--resume`` continues a sweep: refuse a folder that holds anything a sweep does not
    write (a single run's folder, a folder of the user's files), which it would mix into."""
    import re

    from sma_gym._io import LOCK_NAME

    if not out.is_dir():
        return
    foreign = sorted(
        p.name
        for p in out.iterdir()
        if p.name not in (*SWEEP_OUTPUTS, LOCK_NAME, PREVIOUS_SWEEP_DIR)
        and not (p.is_dir() and re.fullmatch(r"seed-\d+", p.name))
    )
    if foreign:
        shown = ", ".join(foreign[:5]) + (", ..." if len(foreign) > 5 else "")
        raise ValueError(
            f"--resume: --out {str(out)!r} is not a sweep's folder (it holds {shown}, which a sweep does not write); "
            "give the --out of the sweep to continue, or a new folder"
        )


def prepare_sweep_out(out: Path) -> None:
    """Delete a previous sweep's outputs from ``out``."""
    for path in sweep_paths(out):
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        else:
            path.unlink()


def set_aside_sweep(out: Path) -> Path:
    """Move a previous sweep's outputs in ``out`` into :data:`PREVIOUS_SWEEP_DIR`
    (``--overwrite``) and return that folder: gone from ``out``, so none is counted as the new
    sweep's, but not yet deleted (a sweep's seeds are hours of training)."""
    aside = out / PREVIOUS_SWEEP_DIR
    if aside.exists():  # left by a sweep killed outright: older than the sweep in out
        shutil.rmtree(aside)
    aside.mkdir(parents=True)
    for path in sweep_paths(out):
        path.rename(aside / path.name)
    return aside


def sweep_kept_nothing(out: Path) -> bool:
    """True if no seed of the sweep in ``out`` has kept a file (a seed's run removes what it
    wrote when it stops or is refused before its first checkpoint; logs are not results)."""
    from sma_gym._io import LOCK_NAME

    return not any(
        p.is_file() and p.name != LOCK_NAME
        for folder in sweep_paths(out)
        if folder.name.startswith("seed-")
        for p in ([folder] if folder.is_file() else folder.rglob("*"))
    )


def put_back_sweep(aside: Path, out: Path) -> None:
    """Undo :func:`set_aside_sweep` after a sweep that kept nothing: its logs and empty seed
    folders removed, the earlier sweep's outputs back in ``out``."""
    prepare_sweep_out(out)
    for path in aside.iterdir():
        path.rename(out / path.name)
    aside.rmdir()


def default_sweep_out(run: RunConfig) -> Path:
    """``runs/<env>-<algo>-seeds-<local time>`` beside ``train.py``."""
    import datetime

    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    return ROOT / "runs" / f"{run.env_id}-{run.algo}-seeds-{stamp}"


def check_sweep_args(args: argparse.Namespace) -> None:
    """``--seeds`` / ``--workers`` checked; ``args.workers`` defaulted to min(N, cores)."""
    if args.seeds is None:
        raise ValueError(f"{'--resume' if args.resume else '--workers'}: only with --seeds N")
    if args.resume and args.overwrite:
        raise ValueError("--resume keeps the finished seeds of --out and --overwrite deletes them: give one of the two")
    if args.seeds < 1:
        raise ValueError(f"--seeds {args.seeds}: expected an integer >= 1")
    if args.seed + args.seeds - 1 > MAX_SEED:
        raise ValueError(
            f"--seed {args.seed} with --seeds {args.seeds}: the last seed, {args.seed + args.seeds - 1}, is past {MAX_SEED} "
            "(numpy's and torch's seeds are 32-bit unsigned)"
        )
    if args.workers is None:
        args.workers = max(1, min(args.seeds, available_cores()))
    if args.workers < 1:
        raise ValueError(f"--workers {args.workers}: expected an integer >= 1")


STOPPED_CODES = (130, 143, -2, -15)
"""A seed's exit codes when it was stopped (Ctrl-C, SIGTERM: the shell's 128 + n, or the
negative signal number), not failed: the sweep's own interrupt reaches its children too."""


def seed_status(code: int, out: Path, seed: int) -> str:
    """What the sweep says of a seed's run that ended with exit ``code``."""
    if code == 0:
        return "done"
    if code in STOPPED_CODES and (out / f"seed-{seed}" / "goals.json").is_file():
        # The stop reached it after it had written its results, which finished_note and
        # --resume count as finished ("stopped ... --resume runs it again" was not true).
        return "finished before the stop (kept)"
    if (out / f"seed-{seed}" / "goals.json").is_file():
        return f"finished, then ended with exit {code} (kept; see logs/seed-{seed}.log)"
    if code in STOPPED_CODES:
        return f"stopped (exit {code}: interrupted, not failed; --resume runs it again)"
    return f"FAILED (exit {code}, see logs/seed-{seed}.log)"


def finished_note(out: Path) -> str:
    """Which seeds of the sweep in ``out`` finished (their ``goals.json``), for the line an
    interrupted sweep prints."""
    import re

    done = sorted(
        int(m.group(1))
        for p in out.glob("seed-*/goals.json")
        if (m := re.fullmatch(r"seed-(\d+)", p.parent.name)) is not None
    )
    return f"seeds {', '.join(map(str, done))} finished and are kept" if done else "no seed finished yet"


def stopped_note(err: BaseException, out: Path | None) -> str:
    """What the line of a stopped sweep in ``out`` says after "interrupted" / "terminated"."""
    if (put_back := getattr(err, "sweep_put_back", None)) is not None:
        return f" before any seed kept a file; the earlier sweep in {put_back} is back as it was"
    if out is None or not out.exists():
        return ""
    return f"; {finished_note(out)}; --resume --out {out} continues the sweep"


def sweep_main(args: argparse.Namespace, run: RunConfig) -> int:
    """``train.py --seeds N``: the folder checked and locked, the sweep, its table printed;
    0, or 1 if seeds failed."""
    from sma_gym._io import check_output_folder, locked_folder

    if args.resume and not args.out:
        raise ValueError("--resume: give the --out folder of the sweep to continue")
    out = Path(args.out) if args.out else default_sweep_out(run)
    try:
        check_output_folder(out, must_be_empty=not (args.overwrite or args.resume))
    except ValueError as err:
        if not (out / "seeds.json").is_file() and not any(out.glob("seed-*")):
            raise
        # --overwrite deletes the finished seeds; --resume keeps them.
        raise ValueError(f"{err} (--resume continues this sweep and keeps its finished seeds)") from None
    if args.resume:
        require_sweep_folder(out)
        if not out.exists():
            print(f"train.py: --resume: {out} does not exist yet; nothing to continue, the sweep starts", flush=True)
    if args.overwrite:
        # A single run's files would stay beside the sweep's, and --resume then refused the folder.
        require_no_outputs_of(out, "a single run", [out / name for name in RUN_OUTPUTS], "a new --out (or no --seeds)")
    with locked_folder(out):
        previous = set_aside_sweep(out) if args.overwrite else None
        try:
            table, failed = sweep(args, run, out)
        except BaseException as err:
            if previous is not None:
                if sweep_kept_nothing(out):
                    put_back_sweep(previous, out)
                    err.sweep_put_back = out  # what main's message says of --out
                else:
                    shutil.rmtree(previous)
            raise
        if previous is not None:
            shutil.rmtree(previous)
    print(table)
    print(f"sweep folder: {out}")
    return 1 if failed else 0


def main(argv: list[str] | None = None) -> int:
    """``python -m sma_gym_agents.training.sweep``: ``train.py`` with ``--seeds`` (default 5)."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not any(a == "--seeds" or a.startswith("--seeds=") for a in argv):
        argv = ["--seeds", "5", *argv]
    args = None
    try:
        args = parse_args(argv)
        check_sweep_args(args)
        with sigterm_as_interrupt():
            return sweep_main(args, RunConfig.from_args(args))
    except ValueError as err:
        print(f"train.py: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as err:  # as train.py's (a traceback before 2026-12-06)
        how, code = stopped(err)
        out = Path(args.out) if getattr(args, "out", None) else None
        print(f"train.py: {how}{stopped_note(err, out)}", file=sys.stderr)
        return code


if __name__ == "__main__":
    sys.exit(main())
