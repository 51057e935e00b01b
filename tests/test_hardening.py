"""Issue 13: nothing hangs, nothing lies, nothing half-written.

One section per item of the issue; each test fails on the code before the fix.
"""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

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
            "assert sma_gym.__file__.startswith(%r), sma_gym.__file__\n"
            "print(j.caching_available())\n"
            "from sma_gym.physics.resistance import wire_resistance\n"
            "print(wire_resistance(0.0, 1.0, 20.0, 1e-6, 1e-6, 0.0, 0.0, 20.0, 0.1, 1e-8))\n"
        ) % str(site)
        out = _run([sys.executable, "-c", code], env=env, cwd=tmp_path)
        assert out.returncode == 0, out.stderr
        lines = out.stdout.split()
        assert lines[0] == "False" and float(lines[1]) > 0.0
        help_ = _run([sys.executable, "-c", "import sys; from sma_gym.cli import main; sys.exit(main(['--help']))"],
                     env=env, cwd=tmp_path)
        assert help_.returncode == 0, help_.stderr
        assert "usage: sma-gym" in help_.stdout
    finally:
        for path in tmp_path.rglob("*"):
            path.chmod(stat.S_IRWXU)
