"""Matplotlib helpers shared by every report (headless: the Agg backend)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sma_gym._io import atomic_path
from sma_gym.extras import extra_error

try:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ModuleNotFoundError as err:
    raise extra_error(err, "sma-gym's report plots", "plots") from err


def new_figure(rows: int, cols: int, size: tuple[float, float] = (10, 6)):
    """A figure and a 2-D array of axes."""
    fig, axes = plt.subplots(rows, cols, figsize=size, squeeze=False)
    return fig, np.asarray(axes)


def save(fig, path: Path | str) -> Path:
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    for ax in fig.axes:
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    try:
        with atomic_path(target) as tmp:  # never a truncated PNG after an interrupt
            fig.savefig(tmp, dpi=110, format=target.suffix.lstrip(".") or "png")
    finally:
        plt.close(fig)
    return target
