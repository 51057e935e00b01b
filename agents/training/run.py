"""One training run into its folder: train, compare with the baselines, write the results.

The single-run path of ``train.py``, shared by its command line (:mod:`sma_gym_agents.training.cli`)
and by every seed of a sweep (:mod:`sma_gym_agents.training.sweep`).
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path
from typing import Any

from sma_gym_agents.training.config import RunConfig, prepare_out


def train_and_compare(
    run: RunConfig, out: Path, *, overwrite: bool = False, progress: bool = True
) -> tuple[str, dict[str, Any]]:
    """Train ``run`` into ``out`` and compare its best model with the baselines; write
    ``run.json``, ``results.md`` and ``goals.json`` (with the code's provenance: the model
    changes between commits under the same env id). ``(results.md text, goals)``;
    ``ValueError`` if ``out`` is not new or empty (unless ``overwrite``) or is in use."""
    from sma_gym._io import check_output_folder, locked_folder, write_json, write_text
    from sma_gym.provenance import describe, provenance

    # Every argument, --out included, is checked before anything is created.
    check_output_folder(out, must_be_empty=not overwrite)
    # Imported after the checks: a bad option is refused without loading stable-baselines3.
    from sma_gym_agents.training.compare import compare
    from sma_gym_agents.training.learn import train

    with locked_folder(out):
        if overwrite:
            prepare_out(out)
        write_json(out / "run.json", run.as_dict(), default=str)
        source = provenance()  # at the start: the code this process loaded, whatever is committed meanwhile
        started = time.perf_counter()
        try:
            info = train(run, out, progress=progress)
        except BaseException:
            _forget_unstarted(out)
            raise
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


def _forget_unstarted(out: Path) -> None:
    """After a run that failed before writing any file but ``run.json`` (a bad option the
    env or the algorithm refused), remove ``run.json`` and the empty folders it made, so
    that the corrected command can use the same ``--out``. A run that got further keeps
    its files (checkpoints are worth keeping)."""
    from sma_gym._io import LOCK_NAME

    files = [p for p in out.rglob("*") if p.is_file() and p.name not in ("run.json", LOCK_NAME)]
    if files:
        return
    (out / "run.json").unlink(missing_ok=True)
    for folder in sorted((p for p in out.rglob("*") if p.is_dir()), key=lambda p: len(p.parts), reverse=True):
        with contextlib.suppress(OSError):
            folder.rmdir()  # only ever succeeds on an empty folder
