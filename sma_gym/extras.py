"""What the lean install leaves out, and how a user learns which extra to add.

``pip install sma-gym`` installs what the environments need (numpy, numba, gymnasium).
Everything else is an extra (``pyproject.toml``): ``plots`` (matplotlib: rendering and
report plots), ``diagnose`` (scipy, matplotlib), ``train`` (stable-baselines3 and its
logging, PyYAML, scipy, matplotlib), ``all``. Code that needs a module of an extra calls
:func:`require` first, so a missing one is one clear line naming the install command, not
a traceback from deep inside.
"""

from __future__ import annotations

import functools
import importlib.metadata
import importlib.util
import json
from urllib.parse import unquote, urlparse

EXTRA_OF_MODULE: dict[str, str] = {
    "matplotlib": "plots",
    "scipy": "diagnose",
    "stable_baselines3": "train",
    "torch": "train",
    "yaml": "train",
    "tensorboard": "train",
    "tqdm": "train",
    "rich": "train",
}
"""Top-level module -> the extra that installs it (the smallest one that does)."""

DISTRIBUTION_OF_MODULE: dict[str, str] = {"yaml": "pyyaml", "stable_baselines3": "stable-baselines3"}
"""Import name -> distribution name, where they differ (for the message)."""


class MissingExtraError(ModuleNotFoundError):
    """A module of an extra is not installed; the message names the extra to install
    (``hint``: the ``pip install`` command alone)."""

    def __init__(self, message: str, name: str, hint: str) -> None:
        super().__init__(message, name=name)
        self.hint = hint


def missing(*modules: str) -> list[str]:
    """The ``modules`` (top-level import names) that are not installed."""
    absent = []
    for m in modules:
        try:
            found = importlib.util.find_spec(m) is not None
        except (ImportError, ValueError):  # a broken install, or sys.modules[m] is None
            found = False
        if not found:
            absent.append(m)
    return absent


@functools.cache
def _installed_from() -> tuple[str, bool]:
    """(what to give pip, editable?): the checkout this install came from, else ``sma-gym``."""
    origin: dict = {}
    # The first installed copy that records where it came from (a stray sma_gym.egg-info
    # in a checkout's folder records nothing).
    for dist in importlib.metadata.distributions(name="sma-gym"):
        text = dist.read_text("direct_url.json")
        if text:
            try:
                origin = json.loads(text)
            except ValueError:
                continue
            break
    url = urlparse(origin.get("url", ""))
    if url.scheme == "file":
        return unquote(url.path), bool(origin.get("dir_info", {}).get("editable"))
    return "sma-gym", False


TORCH_PIN = "torch==2.13.0"
"""The torch the README's commands install (tests/test_repository.py checks they agree)."""


def install_hint(modules: list[str], extra: str | None = None) -> str:
    """The ``pip install`` command that adds the extra(s) installing ``modules``: for the
    checkout it was installed from (``pip install -e '/path/to/sma-gym[diagnose]'``), else from
    the index. The ``train`` extra brings torch, whose default wheel on Linux is a multi-GB
    CUDA build: the hint says so."""
    extras = [extra] if extra else sorted({EXTRA_OF_MODULE.get(m, "all") for m in modules})
    where, editable = _installed_from()
    # The train extra brings torch: the README's pin, not a download URL (the machines we
    # document have only the package registries, where the pinned version is a CPU wheel).
    torch = f"{TORCH_PIN} " if "train" in extras else ""
    command = f"pip install {torch}{'-e ' if editable else ''}'{where}[{','.join(extras)}]'"
    if torch:
        command += " (torch pinned as in the README: unpinned, it pulls a multi-GB CUDA build)"
    return command


def extra_error(
    error: ModuleNotFoundError, purpose: str, extra: str | None = None, modules: tuple[str, ...] = ()
) -> ModuleNotFoundError:
    """For ``except ModuleNotFoundError as err: raise extra_error(err, ...) from err`` around
    module-level imports: a :class:`MissingExtraError` naming every missing one of ``modules``
    (and the one that failed) and the extra to install, when the failed module belongs to an
    extra; else ``error`` itself (a real bug stays visible)."""
    top = (error.name or "").split(".")[0]
    if top not in EXTRA_OF_MODULE:
        return error
    absent = list(dict.fromkeys([top, *missing(*modules)]))
    return _missing_extra(purpose, absent, extra)


def _missing_extra(purpose: str, absent: list[str], extra: str | None) -> MissingExtraError:
    names = ", ".join(DISTRIBUTION_OF_MODULE.get(m, m) for m in absent)
    hint = install_hint(absent, extra)
    return MissingExtraError(
        f"{purpose}: {names} not installed (the lean install leaves {'them' if len(absent) > 1 else 'it'} out): {hint}",
        absent[0],
        hint,
    )


def require(*modules: str, purpose: str, extra: str | None = None) -> None:
    """Raise :class:`MissingExtraError` if any of ``modules`` is not installed.

    ``purpose`` says what needs them (``"sma-gym diagnose"``); ``extra`` overrides the
    extra named in the message (default: the smallest extra per module).
    """
    absent = missing(*modules)
    if absent:
        raise _missing_extra(purpose, absent, extra)
