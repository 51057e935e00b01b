"""What the lean install leaves out, and how a user learns which extra to add.

``pip install sma-gym`` installs what the environments need (numpy, numba, gymnasium).
Everything else is an extra (``pyproject.toml``): ``plots`` (matplotlib: rendering and
report plots), ``diagnose`` (scipy, matplotlib), ``train`` (stable-baselines3 and its
logging, PyYAML, scipy, matplotlib), ``all``. Code that needs a module of an extra calls
:func:`require` first, so a missing one is one clear line naming the install command, not
a traceback from deep inside.
"""

from __future__ import annotations

import importlib.util

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


def install_hint(modules: list[str], extra: str | None = None) -> str:
    """``pip install 'sma-gym[train]'`` for the extra(s) that install ``modules``."""
    extras = [extra] if extra else sorted({EXTRA_OF_MODULE.get(m, "all") for m in modules})
    return f"pip install 'sma-gym[{','.join(extras)}]'"


def extra_error(error: ModuleNotFoundError, purpose: str, extra: str | None = None) -> ModuleNotFoundError:
    """For ``except ModuleNotFoundError as err: raise extra_error(err, ...) from err`` around
    module-level imports: a :class:`MissingExtraError` naming the extra when the missing
    module belongs to one, else ``error`` itself (a real bug stays visible)."""
    top = (error.name or "").split(".")[0]
    if top not in EXTRA_OF_MODULE:
        return error
    name = DISTRIBUTION_OF_MODULE.get(top, top)
    hint = install_hint([top], extra)
    return MissingExtraError(f"{purpose} needs {name}, which the lean install of sma-gym leaves out: {hint}", top, hint)


def require(*modules: str, purpose: str, extra: str | None = None) -> None:
    """Raise :class:`MissingExtraError` if any of ``modules`` is not installed.

    ``purpose`` says what needs them (``"sma-gym diagnose"``); ``extra`` overrides the
    extra named in the message (default: the smallest extra per module).
    """
    absent = missing(*modules)
    if absent:
        names = ", ".join(DISTRIBUTION_OF_MODULE.get(m, m) for m in absent)
        hint = install_hint(absent, extra)
        raise MissingExtraError(
            f"{purpose} needs {names}, which the lean install of sma-gym leaves out: {hint}", absent[0], hint
        )
