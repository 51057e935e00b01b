"""Where a result came from: the package's version and, from a git checkout, its commit.

The nominal model changes between commits under the same env ids (the envs' Version
History), so a figure is only comparable with figures of the same model. Training runs
(``goals.json``, ``results.md``, ``seeds.md``), the diagnosis (``diagnosis.json``,
``cross_validation.json``), ``sma-gym fidelity`` (the table's last line, ``--json``'s
``provenance``) and ``sma-gym evaluate`` (``evaluation.md``'s last line) record
:func:`provenance` beside their figures. ``evaluation.json`` stays the list of records it
always was, so that readers of it do not break.
"""

from __future__ import annotations

import functools
import subprocess
from pathlib import Path
from typing import Any

SOURCE_ROOT = Path(__file__).resolve().parent.parent
"""The folder holding ``sma_gym/``: a git checkout's top for an editable install."""
RESULT_SOURCES = ("sma_gym", "agents", "train.py", "hyperparams")
"""What decides a result: uncommitted changes there make the commit alone not enough."""


def _run_git(root: Path, *args: str) -> subprocess.CompletedProcess | None:
    try:
        return subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=True, timeout=20, check=False)
    except (OSError, subprocess.SubprocessError):
        return None


def _git(*args: str) -> str | None:
    """``git -C SOURCE_ROOT <args>``'s output, or None if git is missing or fails."""
    done = _run_git(SOURCE_ROOT, *args)
    return done.stdout.strip() if done is not None and done.returncode == 0 else None


@functools.cache
def _provenance() -> tuple[tuple[str, Any], ...]:
    from sma_gym import __version__

    commit = modified = None
    top = _git("rev-parse", "--show-toplevel")
    # Only our own checkout: an installed package inside some other repository (a venv in a
    # project folder) must not report that repository's commit.
    if top is not None and Path(top).resolve() == SOURCE_ROOT:
        commit = _git("rev-parse", "--verify", "HEAD")
        status = _git("status", "--porcelain", "--untracked-files=no", "--", *RESULT_SOURCES)
        modified = None if status is None else bool(status)
    return (("sma_gym_version", __version__), ("commit", commit), ("modified", modified))


def provenance() -> dict[str, Any]:
    """``{"sma_gym_version", "commit", "modified"}``: the package version; the git commit of
    the source (None when not run from a git checkout of sma-gym); whether the files that
    decide results (:data:`RESULT_SOURCES`) had uncommitted changes (None if unknown).
    Computed once per process."""
    return dict(_provenance())


def results_differ(first: str, second: str, root: Path = SOURCE_ROOT) -> bool | None:
    """Whether two commits differ in the files that decide results (:data:`RESULT_SOURCES`):
    False when only other files (docs, tests, benchmarks) changed between them, None when
    git cannot tell (git missing, ``root`` not a checkout, a commit it does not have)."""
    done = _run_git(root, "diff", "--quiet", first, second, "--", *RESULT_SOURCES)
    if done is None or done.returncode not in (0, 1):
        return None
    return done.returncode == 1


def describe(record: dict[str, Any] | None) -> str:
    """One line for a report: ``sma-gym 0.4.0.dev0, commit 1a2b3c4d5e6f (with uncommitted changes)``."""
    if not record:
        return "sma-gym version not recorded"
    text = f"sma-gym {record.get('sma_gym_version', '?')}"
    commit = record.get("commit")
    if commit:
        text += f", commit {commit[:12]}"
        if record.get("modified"):
            text += " (with uncommitted changes)"
    else:
        text += " (not a git checkout: commit unknown)"
    return text
