"""``train.py``'s command: check every option, train, compare, write the run folder."""

from __future__ import annotations

import argparse
import datetime
import os
import sys
import time
from pathlib import Path

from agents.training.config import ROOT, RunConfig, parse_args, prepare_out


def default_out(run: RunConfig) -> Path:
    """``runs/<env>-<algo>-<local time>`` beside ``train.py``."""
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    return ROOT / "runs" / f"{run.env_id}-{run.algo}-{stamp}"


def default_sweep_out(run: RunConfig) -> Path:
    """``runs/<env>-<algo>-seeds-<local time>`` beside ``train.py``."""
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    return ROOT / "runs" / f"{run.env_id}-{run.algo}-seeds-{stamp}"


def check_sweep_args(args: argparse.Namespace) -> None:
    """``--seeds`` / ``--workers`` checked; ``args.workers`` defaulted to min(N, cores)."""
    if args.workers is not None and args.seeds is None:
        raise ValueError("--workers: only with --seeds N")
    if args.seeds is None:
        return
    if args.seeds < 1:
        raise ValueError(f"--seeds {args.seeds}: expected an integer >= 1")
    if args.workers is None:
        args.workers = max(1, min(args.seeds, os.cpu_count() or 1))
    if args.workers < 1:
        raise ValueError(f"--workers {args.workers}: expected an integer >= 1")


def main(argv: list[str] | None = None) -> int:
    """Run ``train.py`` with ``argv``; 0 on success, 2 (message on stderr) on a bad option,
    1 if seeds of a ``--seeds`` sweep failed."""
    try:
        args = parse_args(argv)
        check_sweep_args(args)
        run = RunConfig.from_args(args)
        if args.seeds is not None:
            return _sweep_main(args, run)
        return _single_main(args, run)
    except ValueError as err:
        print(f"train.py: error: {err}", file=sys.stderr)
        return 2


def _sweep_main(args: argparse.Namespace, run: RunConfig) -> int:
    """``--seeds N``: the runs in parallel processes, then ``seeds.md`` / ``seeds.json``."""
    from agents.training.sweep import prepare_sweep_out, sweep
    from sma_gym._io import check_output_folder, locked_folder

    out = Path(args.out) if args.out else default_sweep_out(run)
    check_output_folder(out, must_be_empty=not args.overwrite)
    with locked_folder(out):
        if args.overwrite:
            prepare_sweep_out(out)
        table, failed = sweep(args, run, out)
    print(table)
    print(f"sweep folder: {out}")
    return 1 if failed else 0


def _single_main(args: argparse.Namespace, run: RunConfig) -> int:
    """One run: train, compare, write the run folder (the path every seed of a sweep takes)."""
    from sma_gym._io import check_output_folder, locked_folder, write_json, write_text

    out = Path(args.out) if args.out else default_out(run)
    # Every argument, --out included, is checked before anything is created.
    check_output_folder(out, must_be_empty=not args.overwrite)
    # Imported after the checks: a bad option is refused without loading stable-baselines3.
    from agents.training.compare import compare
    from agents.training.learn import train

    with locked_folder(out):
        if args.overwrite:
            prepare_out(out)
        write_json(out / "run.json", run.as_dict(), default=str)
        started = time.perf_counter()
        info = train(run, out, progress=not args.no_progress)
        table, goals = compare(run, out)
        total = time.perf_counter() - started
        table += (
            f"\nTraining {info.train_time_s / 60:.1f} min, training + evaluation {total / 60:.1f} min "
            f"({run.timesteps} steps, {run.n_envs} envs, seed {run.seed}).\n"
        )
        write_text(out / "results.md", table)
        write_json(
            out / "goals.json",
            {"goals": goals, "train_time_s": info.train_time_s, "total_time_s": total, "validation_references": info.validation_references},
        )
    print(table)
    print(f"run folder: {out}")
    return 0
