"""One training run into its folder: train, compare with the baselines, write the results.

The single-run path of ``train.py``, shared by its command line (:mod:`sma_gym_agents.training.cli`)
and by every seed of a sweep (:mod:`sma_gym_agents.training.sweep`).
"""

from __future__ import annotations

import contextlib
import shutil
import time
from pathlib import Path
from typing import Any

from sma_gym_agents.training.config import (
    RUN_OUTPUTS,
    RunConfig,
    put_back_outputs,
    require_no_outputs_of,
    set_aside_outputs,
    sweep_paths,
)


def train_and_compare(
    run: RunConfig, out: Path, *, overwrite: bool = False, progress: bool = True
) -> tuple[str, dict[str, Any]]:
    """Train ``run`` into ``out`` and compare its best model with the baselines; write
    ``run.json``, ``results.md`` and ``goals.json`` (with the code's provenance: the model
    changes between commits under the same env id). ``(results.md text, goals)``;
    ``ValueError`` if ``out`` is not new or empty (unless ``overwrite``) or is in use."""
    from sma_gym._io import check_output_folder, locked_folder, signals_deferred, write_json, write_text
    from sma_gym.provenance import describe, provenance

    # Every argument, --out included, is checked before anything is created.
    check_output_folder(out, must_be_empty=not overwrite)
    if overwrite and out.is_dir():
        # A sweep's files would stay beside this run's, and its --resume then refused the folder.
        require_no_outputs_of(out, "a seed sweep", sweep_paths(out), "a new --out (or --seeds to overwrite the sweep)")
    # Imported after the checks: a bad option is refused without loading stable-baselines3.
    from sma_gym_agents.training.compare import compare
    from sma_gym_agents.training.learn import train

    source = provenance()  # at the start: the code this process loaded, whatever is committed meanwhile
    with locked_folder(out):
        # --overwrite: the earlier run is set aside, not deleted, until this one has trained,
        # so that a run refused at its start (a value only the algorithm checks) changes nothing.
        # Setting it aside and starting run.json happen whole: a Ctrl-C between them hid
        # the earlier run in .previous-run, and the next --overwrite deleted it.
        with signals_deferred():
            previous = set_aside_outputs(out) if overwrite else None
            write_json(out / "run.json", run.as_dict(), default=str)
        started = time.perf_counter()
        try:
            info = train(run, out, progress=progress)
        except BaseException as err:
            # The clean-up happens whole too (a second signal, the terminal's beside a sweep's,
            # interrupted it and left the earlier run set aside beside the new files).
            with signals_deferred():
                unstarted = _forget_unstarted(out)
                if previous is not None and unstarted:
                    put_back_outputs(previous, out)
            err.run_kept_nothing = unstarted  # what an interrupt's message may promise (cli.main)
            # A run that wrote checkpoints keeps them; the earlier run stays set aside beside
            # them (not mixed in, not deleted: until 2026-12-07 it was deleted), named by the message.
            err.previous_run = previous if previous is not None and previous.exists() else None
            raise
        if previous is not None:
            shutil.rmtree(previous)
        table, goals = compare(run, out)
        total = time.perf_counter() - started
        table += (
            f"\nTraining {info.train_time_s / 60:.1f} min, training + evaluation {total / 60:.1f} min "
            f"({info.timesteps or run.timesteps} steps, {run.n_envs} envs, seed {run.seed}); {describe(source)}.\n"
        )
        write_text(out / "results.md", table)
        write_json(
            out / "goals.json",
            {
                "goals": goals,
                "train_time_s": info.train_time_s,
                "total_time_s": total,
                "validation_references": info.validation_references,
                "provenance": source,
            },
        )
    return table, goals


def _forget_unstarted(out: Path) -> bool:
    """After a run that failed before writing any file but ``run.json`` and its TensorBoard
    log (a bad option the env or the algorithm refused, an interrupt before the first
    checkpoint), remove them and the empty folders it made, so that the corrected command
    can use the same ``--out``; True then. A run that got further keeps its files
    (checkpoints are worth keeping); False."""

    def written(p: Path) -> bool:  # by this run, worth keeping (the user's own files are neither)
        return p.relative_to(out).parts[0] in set(RUN_OUTPUTS) - {"run.json", "tb"}

    if any(p.is_file() and written(p) for p in out.rglob("*")):
        return False
    (out / "run.json").unlink(missing_ok=True)
    if (out / "tb").is_dir():
        shutil.rmtree(out / "tb")
    # Only the run's own folders: a user's empty folder in --out stays, as the set-aside run.
    made = (p for p in out.rglob("*") if p.is_dir() and p.relative_to(out).parts[0] in RUN_OUTPUTS)
    for folder in sorted(made, key=lambda p: len(p.parts), reverse=True):
        with contextlib.suppress(OSError):
            folder.rmdir()  # only ever succeeds on an empty folder
    return True
