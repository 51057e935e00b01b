"""``train.py``'s command: check every option, train, compare, write the run folder."""

from __future__ import annotations

import datetime
import sys
import time
from pathlib import Path

from agents.training.config import ROOT, RunConfig, parse_args, prepare_out


def default_out(run: RunConfig) -> Path:
    """``runs/<env>-<algo>-<local time>`` beside ``train.py``."""
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    return ROOT / "runs" / f"{run.env_id}-{run.algo}-{stamp}"


def main(argv: list[str] | None = None) -> int:
    """Run ``train.py`` with ``argv``; 0 on success, 2 (message on stderr) on a bad option."""
    from sma_gym._io import check_output_folder, locked_folder, write_json, write_text

    try:
        args = parse_args(argv)
        run = RunConfig.from_args(args)
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
    except ValueError as err:
        print(f"train.py: error: {err}", file=sys.stderr)
        return 2
    print(table)
    print(f"run folder: {out}")
    return 0
