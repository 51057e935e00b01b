"""Model files shipped with the package: digital twins identified on measurements.

A *twin* is a whole model (actuator parameters and effects), identified by ``sma-gym
diagnose`` on measured runs, and resolved by name wherever a model is accepted
(``gymnasium.make(id, model="bench-0.5mm-ht")``, ``Simulator("bench-0.5mm-ht")``).

``bench-0.5mm-ht``
    The real bench of ``shared/data/real`` (0.5 mm HT Flexinol, 0.96 m, 24 V, 35 g sleigh,
    0.07 N/mm spring), identified on all four shared runs (``step01``, ``ramp01``,
    ``step03``, ``step07``) starting from the datasheet actuator ``bench-0.5mm-ht-datasheet``.
    Re-derive it with ``python -m sma_gym.calibration twin`` (writes this folder's JSON);
    the file's ``notes`` say which effects were found and the fit it reached.
"""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

TWINS = {"bench-0.5mm-ht": "bench-0.5mm-ht.json"}
"""Name -> file in this package."""


def twin_names() -> tuple[str, ...]:
    """Names of the shipped twins."""
    return tuple(TWINS)


def twin_path(name: str) -> Path:
    """Path of a shipped twin's model file."""
    if name not in TWINS:
        raise ValueError(f"twin = {name!r}: expected one of {', '.join(map(repr, TWINS))}")
    return Path(str(files(__name__).joinpath(TWINS[name])))
