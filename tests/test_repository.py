"""The README's fresh-machine commands and CI stay in step."""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def readme_commands():
    text = (ROOT / "README.md").read_text()
    blocks = re.findall(r"```(?:bash|sh)?\n(.*?)```", text, re.S)
    assert len(blocks) >= 2, "README must open with two command blocks"
    return blocks[0].strip(), blocks[1].strip()


def test_readme_opens_with_the_main_job_and_the_test_command():
    main_job, tests = readme_commands()
    assert "python train.py" in main_job or ".venv/bin/python train.py" in main_job
    assert "pytest" in tests
    assert "torch==2.13.0" in main_job and "torch==2.13.0" in tests


def test_ci_runs_the_readme_test_command_verbatim():
    _, tests = readme_commands()
    ci = (ROOT / ".ci" / "run").read_text()
    assert tests in ci


def test_package_metadata_uses_an_spdx_licence_and_ships_its_type_marker():
    """setuptools stops accepting ``license = {text = ...}`` tables in 2027 (PEP 639);
    ``py.typed`` tells type checkers the package's hints are meant for them."""
    import tomllib

    root = Path(__file__).resolve().parents[1]
    project = tomllib.loads((root / "pyproject.toml").read_text())
    assert project["project"]["license"] == "MIT"
    assert "Typing :: Typed" in project["project"]["classifiers"]
    assert (root / "sma_gym" / "py.typed").is_file()
    assert "py.typed" in project["tool"]["setuptools"]["package-data"]["*"]
