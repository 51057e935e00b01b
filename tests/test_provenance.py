"""Every result records the code it came from (the model changes under the same env ids)."""

import shutil
import subprocess
from pathlib import Path

import pytest

from sma_gym import __version__
from sma_gym import provenance as prov


@pytest.fixture
def fresh(monkeypatch):
    """provenance() recomputed for a patched source root, and again afterwards."""
    prov._provenance.cache_clear()
    yield monkeypatch
    prov._provenance.cache_clear()


def test_the_checkout_reports_its_own_commit():
    record = prov.provenance()
    assert record["sma_gym_version"] == __version__
    top = prov._git("rev-parse", "--show-toplevel")
    if top is None or Path(top).resolve() != prov.SOURCE_ROOT:
        assert record["commit"] is None  # installed, not a checkout: unknown, never guessed
        return
    head = subprocess.run(["git", "-C", top, "rev-parse", "HEAD"], capture_output=True, text=True, check=True)
    assert record["commit"] == head.stdout.strip() and isinstance(record["modified"], bool)
    assert record is not prov.provenance()  # a copy: a caller cannot change the cached one


@pytest.mark.skipif(shutil.which("git") is None, reason="needs git")
def test_a_package_inside_another_repository_does_not_take_its_commit(tmp_path, fresh):
    subprocess.run(["git", "init", "-q", str(tmp_path)], check=True)
    (tmp_path / "site-packages").mkdir()
    fresh.setattr(prov, "SOURCE_ROOT", (tmp_path / "site-packages").resolve())
    assert prov.provenance()["commit"] is None and prov.provenance()["modified"] is None


def test_without_git_the_commit_is_unknown(fresh):
    fresh.setenv("PATH", "")  # no git executable to be found
    record = prov.provenance()
    assert record == {"sma_gym_version": __version__, "commit": None, "modified": None}


def test_describe():
    commit = "0123456789abcdef" * 2 + "01234567"
    assert prov.describe({"sma_gym_version": "0.1.0", "commit": commit, "modified": False}) == (
        "sma-gym 0.1.0, commit 0123456789ab"
    )
    assert prov.describe({"sma_gym_version": "0.1.0", "commit": commit, "modified": True}).endswith(
        "(with uncommitted changes)"
    )
    assert "commit unknown" in prov.describe({"sma_gym_version": "0.1.0", "commit": None, "modified": None})
    assert prov.describe(None) == "sma-gym version not recorded"
