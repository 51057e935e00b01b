"""The import graph: ``sma_gym`` never imports ``sma_gym_agents``, and no two modules import each other.

The repository's ``agents/`` folder is installed as the package ``sma_gym_agents``
(``pyproject.toml``: a top-level ``agents`` collides with other distributions). Every module of
``sma_gym`` and ``sma_gym_agents`` (and ``train.py``) is parsed with :mod:`ast`;
every ``import`` statement counts, at module level or inside a function (an import hidden
in a function still makes the dependency, it only delays it). Imports under
``if TYPE_CHECKING:`` count too: a type is a dependency of the code that names it.
``from package import name`` is an edge to ``package.name`` when that is a module, else to
``package``; importing ``a.b.c`` is an edge to ``a.b.c`` only (not to the packages above,
whose ``__init__`` merely re-exports).
"""

from __future__ import annotations

import ast
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = {"sma_gym": "sma_gym", "agents": "sma_gym_agents"}
"""Repository folder -> the name its package is installed and imported under."""
PACKAGES = tuple(FOLDERS.values())

KNOWN_CYCLES: tuple[frozenset[str], ...] = ()
"""Cycles tolerated for now, each the exact set of modules of one strongly connected component
(none: the last one, diagnosis report <-> workflow, went when the writers moved into the
report module). The test fails while a listed cycle no longer exists, so this cannot go stale."""


def _module_files() -> dict[str, Path]:
    """Dotted module name -> file, for every module of the project."""
    modules = {"train": ROOT / "train.py"}
    for folder, package in FOLDERS.items():
        for path in sorted((ROOT / folder).rglob("*.py")):
            parts = (package, *path.relative_to(ROOT / folder).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts = parts[:-1]
            modules[".".join(parts)] = path
    return modules


def _imports(name: str, path: Path, modules: set[str]) -> set[str]:
    """Project modules that module ``name`` imports anywhere in its file."""
    is_package = path.name == "__init__.py"
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            targets = [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: from the package this module is in (or is)
                base = name.split(".")
                base = base[: len(base) - node.level + (1 if is_package else 0)]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            targets = [
                f"{source}.{alias.name}" if f"{source}.{alias.name}" in modules else source for alias in node.names
            ]
        else:
            continue
        for target in targets:
            # The longest project module the dotted name starts with (import a.b.c as x).
            while target and target not in modules:
                target = target.rpartition(".")[0]
            if target and target != name:
                found.add(target)
    return found


def import_graph() -> dict[str, set[str]]:
    """Module -> the project modules it imports."""
    files = _module_files()
    return {name: _imports(name, path, set(files)) for name, path in files.items()}


def cycles(graph: dict[str, set[str]]) -> list[frozenset[str]]:
    """Strongly connected components of more than one module (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[frozenset[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = set()
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.add(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(frozenset(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def _path(graph: dict[str, set[str]], component: frozenset[str]) -> str:
    """One cycle through ``component``, as ``a -> b -> a`` (for the failure message)."""
    start = min(component)
    trail = [start]
    seen = {start}
    while True:
        nxt = sorted(w for w in graph[trail[-1]] if w in component)
        step = next((w for w in nxt if w == start), None) or next((w for w in nxt if w not in seen), nxt[0])
        trail.append(step)
        if step in seen:
            return " -> ".join(trail[trail.index(step) :])
        seen.add(step)


def test_the_graph_sees_function_level_and_relative_imports():
    """The parser itself: a hidden (function-level) import and a relative one are edges."""
    graph = import_graph()
    assert "sma_gym_agents.evaluation" in graph["sma_gym_agents.report"]
    assert graph["train"] == {"sma_gym_agents.training"}
    assert all(name.startswith(PACKAGES) or name == "train" for name in graph)
    assert len(graph) > 40


def test_no_code_imports_the_folder_name_agents():
    """Only ``sma_gym_agents`` is installed: ``import agents`` would work in a checkout (the
    folder is on the path) and fail, or load another distribution's package, elsewhere."""
    offenders = []
    tracked = subprocess.run(["git", "ls-files", "*.py"], cwd=ROOT, capture_output=True, text=True, check=True)
    for path in (ROOT / name for name in tracked.stdout.split()):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else []
            if isinstance(node, ast.ImportFrom) and not node.level:
                names = [node.module or ""]
            offenders += [f"{path.relative_to(ROOT)}: {n}" for n in names if n.split(".")[0] == "agents"]
    assert not offenders, "import sma_gym_agents, not agents:\n" + "\n".join(offenders)


def test_sma_gym_imports_nothing_from_agents():
    graph = import_graph()
    offenders = sorted(
        f"{module} imports {target}"
        for module, targets in graph.items()
        if module.split(".")[0] == "sma_gym"
        for target in targets
        if target.split(".")[0] == "sma_gym_agents"
    )
    assert not offenders, "sma_gym must not depend on agents (agents -> sma_gym only):\n" + "\n".join(offenders)


def test_no_import_cycles_but_the_listed_ones_and_every_listed_one_still_exists():
    graph = import_graph()
    found = cycles(graph)
    new = [c for c in found if c not in KNOWN_CYCLES]
    assert not new, "import cycles:\n" + "\n".join(_path(graph, c) for c in new)
    gone = [sorted(c) for c in KNOWN_CYCLES if c not in found]
    assert not gone, f"listed cycles that no longer exist (remove them from KNOWN_CYCLES): {gone}"


def test_sma_gym_command_finds_the_agents_subcommands_through_entry_points():
    from sma_gym.cli import COMMANDS_GROUP, Command, build_parser, plugin_commands

    plugins = {c.name: c for c in plugin_commands()}
    assert set(plugins) == {"fidelity", "evaluate"}, f"{COMMANDS_GROUP} entry points (reinstall: pip install -e .)"
    assert all(isinstance(c, Command) and c.run.__module__ == "sma_gym_agents.commands" for c in plugins.values())
    help_text = build_parser().format_help()
    assert all(name in help_text for name in ("bench", "diagnose", "evaluate", "fidelity", "synth"))


def test_python_dash_m_sma_gym_is_the_sma_gym_command_and_says_its_version():
    """Where the scripts folder is not on PATH, ``python -m sma_gym`` is the command."""
    import subprocess
    import sys

    from sma_gym import __version__

    done = subprocess.run([sys.executable, "-m", "sma_gym", "--version"], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == f"sma-gym {__version__}", done.stderr


# --- the numba cache follows every compiled source ---------------------------------------------


def test_the_compiled_sources_are_every_module_that_defines_compiled_code_and_the_layout():
    """``_jit.COMPILED_SOURCES`` keys the cache: a module that defines a compiled function and
    is missing from it would be cached stale after an edit of it alone."""
    from sma_gym._jit import COMPILED_SOURCES, PACKAGE_DIR

    defining = {
        path.relative_to(PACKAGE_DIR).as_posix() for path in PACKAGE_DIR.rglob("*.py") if "@njit" in path.read_text()
    }
    assert set(COMPILED_SOURCES) == defining | {"_jit.py", "core/layout.py"}


STALE_PROBE = """
import sys
sys.path.insert(0, sys.argv[1])
import sma_gym._jit as jit
if sys.argv[2] == "tracked":
    from pathlib import Path
    jit.track_sources(Path(sys.argv[1]) / "pkg", ("a.py", "b.py"))
from pkg.b import g
print(g())
"""


def test_a_cached_function_recompiles_when_a_function_it_calls_changes_in_another_file(tmp_path):
    """numba keys a cached function on its own file only, though the functions it calls from
    other files are compiled into it: edit only the callee's file and the caller ran the old
    code from its cache (numba 0.68.1: 11 below, not 12). sma_gym tracks its own sources
    this way at import."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    callee = "from sma_gym._jit import njit\nVALUE = {}\n\n@njit(cache=True)\ndef f():\n    return VALUE\n"
    (pkg / "a.py").write_text(callee.format(1))
    (pkg / "b.py").write_text(
        "from sma_gym._jit import njit\nfrom pkg.a import f\n\n@njit(cache=True)\ndef g():\n    return f() + 10\n"
    )
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path / "cache")}

    def g() -> str:
        cmd = [sys.executable, "-c", STALE_PROBE, str(tmp_path), "tracked"]
        out = subprocess.run(cmd, capture_output=True, text=True, timeout=300, env=env)
        assert out.returncode == 0, out.stderr
        return out.stdout.strip()

    assert g() == "11"
    (pkg / "a.py").write_text(callee.format(2))
    assert g() == "12"
