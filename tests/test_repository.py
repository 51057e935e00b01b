"""The README's fresh-machine commands and CI stay in step."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def readme_commands():
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```(?:bash|sh)?\n(.*?)```", text, re.DOTALL)
    assert len(blocks) >= 2, "README must open with two command blocks"
    return blocks[0].strip(), blocks[1].strip()


def test_readme_opens_with_the_main_job_and_the_test_command():
    main_job, tests = readme_commands()
    assert "python train.py" in main_job or ".venv/bin/python train.py" in main_job
    assert "pytest" in tests
    # The pin the install hints give (sma_gym.extras.TORCH_PIN), so the two never disagree.
    from sma_gym.extras import TORCH_PIN

    assert TORCH_PIN in main_job and TORCH_PIN in tests


def test_ci_runs_the_readme_test_command_verbatim():
    _, tests = readme_commands()
    ci = (ROOT / ".ci" / "run").read_text()
    assert tests in ci


def test_the_test_commands_plugins_come_with_the_test_extra():
    """The README's test command runs pytest-xdist workers (``-n``): on a fresh machine the
    ``[test]`` extra it installs must bring the plugin, else pytest stops at the option."""
    tomllib = pytest.importorskip("tomllib", reason="tomllib is in the standard library from Python 3.11")

    _, tests = readme_commands()
    extra = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]["test"]
    if re.search(r"pytest\b.*\s-n\s", tests):
        assert any(re.match(r"pytest-xdist\b", requirement) for requirement in extra), extra


def test_package_metadata_uses_an_spdx_licence_and_ships_its_type_marker():
    """setuptools stops accepting ``license = {text = ...}`` tables in 2027 (PEP 639);
    ``py.typed`` tells type checkers the package's hints are meant for them."""
    tomllib = pytest.importorskip("tomllib", reason="tomllib is in the standard library from Python 3.11")

    root = Path(__file__).resolve().parents[1]
    project = tomllib.loads((root / "pyproject.toml").read_text())
    assert project["project"]["license"] == "MIT"
    assert "Typing :: Typed" in project["project"]["classifiers"]
    assert (root / "sma_gym" / "py.typed").is_file()
    assert "py.typed" in project["tool"]["setuptools"]["package-data"]["*"]


# --------------------------------------------------------------------------------------
# The README stays short, the docs' links resolve, and the code cites our own model page.
# --------------------------------------------------------------------------------------

README_MAX_LINES = 200
"""The README holds the commands, install, quick start, env table and links; the rest is in docs/."""

README_SECTIONS_NOT_COUNTED: tuple[str, ...] = ()
"""README sections exempt from the line limit while they are being rewritten elsewhere
(none: the training details moved to docs/training.md)."""

OLD_MODEL_CITATIONS: tuple[str, ...] = ()
"""Code files that may still cite the model page outside the repository (the one in the
shared spec folder) instead of docs/model.md, because others were editing them when the
citations changed. The test fails once a listed file no longer does: then remove it here,
until this is empty."""

CODE_FOLDERS = ("sma_gym", "agents", "tests", "benchmarks", "hyperparams", ".ci")
CODE_SUFFIXES = {".py", ".toml", ".json", ".cfg", ".ini", ".sh", ""}
_OLD_MODEL_PAGE = re.compile(r"\bMODEL" + r"\.md")  # split so this file does not match itself
_LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)\)|!\[[^\]]*\]\(([^)\s]+)\)")


def _docs() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def _strip_code(text: str) -> str:
    """Markdown without fenced code blocks and inline code (links there are not links)."""
    text = re.sub(r"```.*?```", "", text, flags=re.DOTALL)
    return re.sub(r"`[^`\n]*`", "", text)


def _slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def _anchors(path: Path) -> set[str]:
    text = re.sub(r"```.*?```", "", path.read_text(), flags=re.DOTALL)
    return {_slug(m.group(1)) for m in re.finditer(r"^#+ +(.+?) *#*$", text, re.MULTILINE)}


def _code_files() -> list[Path]:
    files = [ROOT / "train.py", ROOT / "pyproject.toml"]
    for folder in CODE_FOLDERS:
        files += [p for p in sorted((ROOT / folder).rglob("*")) if p.is_file() and p.suffix in CODE_SUFFIXES]
    return [p for p in files if "__pycache__" not in p.parts and p.exists()]


def test_readme_fits_on_a_few_screens():
    lines = (ROOT / "README.md").read_text().splitlines()
    counted = len(lines)
    for title in README_SECTIONS_NOT_COUNTED:
        assert title in lines, f"{title!r} is no longer in README.md: remove it from README_SECTIONS_NOT_COUNTED"
        start = lines.index(title)
        end = next((i for i in range(start + 1, len(lines)) if lines[i].startswith("## ")), len(lines))
        counted -= end - start
    assert counted <= README_MAX_LINES, (
        f"README.md has {counted} lines (sections {README_SECTIONS_NOT_COUNTED} not counted), more than "
        f"{README_MAX_LINES}: move details into docs/ and link them"
    )


def test_every_relative_link_in_the_readme_and_docs_resolves():
    broken = []
    for doc in _docs():
        for match in _LINK.finditer(_strip_code(doc.read_text())):
            target = match.group(1) or match.group(2)
            if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto: ...
                continue
            path, _, anchor = target.partition("#")
            file = (doc.parent / path).resolve() if path else doc
            if not file.exists():
                broken.append(f"{doc.relative_to(ROOT)}: {target} (no such file)")
            elif anchor and file.suffix == ".md" and anchor not in _anchors(file):
                broken.append(f"{doc.relative_to(ROOT)}: {target} (no such heading)")
    assert not broken, "broken links:\n" + "\n".join(broken)


def test_the_readme_links_the_docs():
    readme = (ROOT / "README.md").read_text()
    missing = [p.name for p in sorted((ROOT / "docs").glob("*.md")) if f"(docs/{p.name})" not in readme]
    assert not missing, f"docs not linked from README.md: {missing}"


def test_code_cites_docs_model_md_not_the_page_outside_the_repository():
    citing = {str(p.relative_to(ROOT)) for p in _code_files() if _OLD_MODEL_PAGE.search(p.read_text(errors="replace"))}
    new = sorted(citing - set(OLD_MODEL_CITATIONS))
    assert not new, f"cite docs/model.md (the project's model page) instead, in: {new}"


def test_every_listed_old_citation_still_exists():
    gone = [f for f in OLD_MODEL_CITATIONS if not _OLD_MODEL_PAGE.search((ROOT / f).read_text())]
    assert not gone, f"these no longer cite the old model page: remove them from OLD_MODEL_CITATIONS: {gone}"


def test_cited_sections_of_docs_model_md_exist():
    """``docs/model.md §n`` (or ``§n-§m``) in code names a numbered heading of that page."""
    sections = set(re.findall(r"^## (\d+)\. ", (ROOT / "docs" / "model.md").read_text(), re.MULTILINE))
    cited = []
    for path in _code_files():
        for match in re.finditer(r"docs/model\.md`{0,2} (§\d+(?:-§\d+)?)", path.read_text(errors="replace")):
            cited += [(path, n) for n in re.findall(r"\d+", match.group(1))]
    missing = sorted(f"{p.relative_to(ROOT)}: §{n}" for p, n in cited if n not in sections)
    assert cited and not missing, f"sections cited but not in docs/model.md: {missing}"


def test_ruff_format_and_lint_pass_on_the_tracked_python_files():
    """ruff (pinned in the test extra; configured in pyproject.toml) passes on every tracked
    Python file: formatted, and lint-clean under the configured rules."""
    import shutil
    import subprocess
    import sys

    ruff = shutil.which("ruff") or str(Path(sys.executable).with_name("ruff"))
    if not Path(ruff).exists():
        pytest.skip("ruff is not installed (pip install -e '.[test]' installs it)")
    files = subprocess.run(
        ["git", "ls-files", "*.py"], cwd=ROOT, capture_output=True, text=True, check=True
    ).stdout.split()
    assert files
    lint = subprocess.run([ruff, "check", *files], cwd=ROOT, capture_output=True, text=True)
    assert lint.returncode == 0, lint.stdout + lint.stderr
    fmt = subprocess.run([ruff, "format", "--check", *files], cwd=ROOT, capture_output=True, text=True)
    assert fmt.returncode == 0, "run `ruff format` on: " + fmt.stdout + fmt.stderr
