"""``train.py``'s command: check every option, train, compare, write the run folder."""

from __future__ import annotations

import datetime
import sys
from pathlib import Path

from sma_gym._io import expand_home, interrupt_behind, sigterm_as_interrupt, stopped
from sma_gym.extras import MissingExtraError, require
from sma_gym_agents.training.config import ROOT, RunConfig, parse_args

TRAIN_NEEDS = ("stable_baselines3", "torch", "yaml", "tensorboard", "scipy", "matplotlib")
"""What ``train.py`` imports beyond the lean install (the ``train`` extra)."""


def default_out(run: RunConfig) -> Path:
    """``runs/<env>-<algo>-<local time>`` beside ``train.py``."""
    stamp = datetime.datetime.now().strftime("%Y%m%d-%H%M%S")
    return ROOT / "runs" / f"{run.env_id}-{run.algo}-{stamp}"


def main(argv: list[str] | None = None) -> int:
    """Run ``train.py`` with ``argv``; 0 on success, 2 (message on stderr) on a bad option,
    1 if seeds of a ``--seeds`` sweep failed, 130 on Ctrl-C (a line on stderr, no traceback)."""
    out: Path | None = None
    sweep = False
    try:
        args = parse_args(argv)  # --help works without the extra
        require(*TRAIN_NEEDS, purpose="train.py", extra="train")
        if args.out is not None and not args.out.strip():
            # '' read as "no --out" trained into ./runs; ' ' made a folder named ' '.
            raise ValueError(f"--out {args.out!r}: expected a folder name (leave the option out for runs/<run>)")
        expand_home(args)  # a quoted '~/runs' is the home folder, as sma-gym's commands read it
        with sigterm_as_interrupt():
            if args.seeds is not None or args.workers is not None or args.resume:
                from sma_gym_agents.training.sweep import check_sweep_args, sweep_main

                check_sweep_args(args)
                sweep, out = True, Path(args.out) if args.out else None
                return sweep_main(args, RunConfig.from_args(args))
            run = RunConfig.from_args(args)
            out = Path(args.out) if args.out else default_out(run)
            from sma_gym_agents.training.run import train_and_compare

            table, _ = train_and_compare(run, out, overwrite=args.overwrite, progress=not args.no_progress)
    except (ValueError, MissingExtraError) as err:
        if (interrupt := interrupt_behind(err)) is not None:  # a library's error for the user's Ctrl-C
            how, code = stopped(interrupt)
            print(f"train.py: {how}", file=sys.stderr)
            return code
        # A missing extra's message starts with what needs it ("train.py: "), the prefix here.
        print(f"train.py: error: {str(err).removeprefix('train.py: ')}", file=sys.stderr)
        return 2
    except KeyboardInterrupt as err:
        # Ctrl-C (or SIGTERM: a scheduler's stop) is the user's choice, not a bug: no
        # traceback; the shell's code for the signal. The checkpoints written so far stay
        # (they are worth keeping); without results.md the folder is never taken for a
        # finished run.
        how, code = stopped(err)
        if out is None or not out.exists():
            print(f"train.py: {how}", file=sys.stderr)
        elif not sweep and getattr(err, "run_kept_nothing", False):
            # Stopped before its first checkpoint: the run removed what it had begun (and
            # put back an earlier run it had set aside), so promise no checkpoints.
            print(f"train.py: {how} before the first checkpoint; nothing of this run is kept in {out}", file=sys.stderr)
        elif sweep:
            from sma_gym_agents.training.sweep import stopped_note

            print(f"train.py: {how}{stopped_note(err, out)}", file=sys.stderr)
        else:
            print(f"train.py: {how}{_interrupted_run_note(err, out)}", file=sys.stderr)
        return code
    print(table)
    print(f"run folder: {out}")
    return 0


def _interrupted_run_note(err: BaseException, out: Path) -> str:
    """What a single run stopped after its first file keeps, as it is on disk (the message
    promised checkpoints where there were none, and named final_model.zip for scoring where
    train.py scores best_model.zip), and where an earlier run it replaced is kept."""
    best, final = out / "best_model.zip", out / "final_model.zip"
    checkpoints = sorted((out / "checkpoints").glob("*.zip")) if (out / "checkpoints").is_dir() else []
    kept = [f"{len(checkpoints)} checkpoint(s) in checkpoints/"] if checkpoints else []
    kept += [p.name for p in (best, final) if p.is_file()]
    if final.is_file():
        scored = best if best.is_file() else final  # what train.py's comparison scores
        note = (
            f" while scoring; training had finished: {out} keeps {', '.join(kept)} but no results.md; "
            f"`sma-gym evaluate --policy {scored}` scores it, or pass --overwrite to train again"
        )
    else:
        note = (
            f"; {out} keeps {', '.join(kept) or 'no model yet'} but no final model or results.md; "
            "train into a new --out or pass --overwrite to start again"
        )
    previous = getattr(err, "previous_run", None)
    if previous is not None:
        note += (
            f"; the earlier run it was to replace is kept in {previous} (move its files back into {out} "
            "in place of this run's to restore it; the next --overwrite deletes it)"
        )
    return note
