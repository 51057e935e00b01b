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


def test_the_checkout_reports_its_own_commit(fresh):
    # fresh: computed now, not at the process's first call, so that a commit made while the
    # suite runs (provenance is cached per process on purpose) is not reported as a mismatch.
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


def test_commits_that_changed_only_docs_decide_the_same_results(tmp_path, monkeypatch):
    import subprocess

    from sma_gym.provenance import results_differ
    from sma_gym_agents.training.sweep import provenance_line

    def git(*args):
        return subprocess.run(["git", "-C", str(tmp_path), *args], capture_output=True, text=True, check=True).stdout

    git("init", "-q")
    git("config", "user.email", "t@example.org")
    git("config", "user.name", "t")
    commits = []
    for path, text in (("sma_gym/kernel.py", "a = 1\n"), ("docs/x.md", "docs\n"), ("sma_gym/kernel.py", "a = 2\n")):
        (tmp_path / path).parent.mkdir(exist_ok=True)
        (tmp_path / path).write_text(text)
        git("add", "-A")
        git("commit", "-qm", path)
        commits.append(git("rev-parse", "HEAD").strip())
    assert results_differ(commits[0], commits[1], tmp_path) is False
    assert results_differ(commits[1], commits[2], tmp_path) is True
    assert results_differ(commits[0], "f" * 40, tmp_path) is None  # a commit git does not have
    # seeds.md's line: an unknown pair of commits keeps the warning.
    record = {"sma_gym_version": "0.1.0", "modified": False}
    line = provenance_line({0: {**record, "commit": "a" * 40}, 1: {**record, "commit": "b" * 40}})
    assert "did not all run the same code" in line
    # Commits git finds equal where results are decided: the same code, said so.
    import sma_gym.provenance

    monkeypatch.setattr(sma_gym.provenance, "results_differ", lambda a, b: a[0] == "c" or b[0] == "c")
    line = provenance_line({0: {**record, "commit": "a" * 40}, 1: {**record, "commit": "b" * 40}})
    assert "differ only outside the files that decide results" in line and "aaaaaaaaaaaa" in line
    line = provenance_line({0: {**record, "commit": "a" * 40}, 1: {**record, "commit": "c" * 40}})
    assert "did not all run the same code" in line
    modified = provenance_line({0: {**record, "commit": "a" * 40}, 1: {**record, "commit": "b" * 40, "modified": True}})
    assert "did not all run the same code" in modified
