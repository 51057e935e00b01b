"""Rendering an episode: position and reference, duty, resistance, temperature."""

from __future__ import annotations

from typing import Sequence

import numpy as np


class EpisodeHistory:
    """What an env records for rendering (only while a render mode is set)."""

    FIELDS = ("t", "position", "reference", "duty", "resistance", "temperature")

    def __init__(self) -> None:
        self.data: dict[str, list] = {k: [] for k in self.FIELDS}

    def clear(self) -> None:
        for v in self.data.values():
            v.clear()

    def add(self, **values) -> None:
        for k in self.FIELDS:
            self.data[k].append(values[k])

    def arrays(self) -> dict[str, np.ndarray]:
        return {k: np.asarray(v, dtype=float) for k, v in self.data.items()}


def draw(history: EpisodeHistory, title: str, labels: Sequence[str] | None = None, figure=None):
    """Draw the history into a matplotlib figure (new or reused); returns the figure."""
    import matplotlib.pyplot as plt

    if figure is None:
        figure, _ = plt.subplots(4, 1, figsize=(6.4, 6.4), sharex=True)
    axes = figure.axes
    for ax in axes:
        ax.clear()
        ax.grid(True, alpha=0.3)
    h = history.arrays()
    t = h["t"]
    if t.size:
        pos = np.atleast_2d(h["position"].T).T if h["position"].ndim > 1 else h["position"][:, None]
        ref = np.atleast_2d(h["reference"].T).T if h["reference"].ndim > 1 else h["reference"][:, None]
        for j in range(pos.shape[1]):
            name = labels[j] if labels else ""
            axes[0].plot(t, pos[:, j] * 1e3, label=f"position {name}".strip())
            axes[0].plot(t, ref[:, j] * 1e3, "--", label=f"reference {name}".strip())
        axes[1].plot(t, h["duty"])
        axes[2].plot(t, h["resistance"])
        axes[3].plot(t, h["temperature"])
    axes[0].set_ylabel("position [mm]")
    axes[0].set_title(title, fontsize=9)
    if t.size and pos.shape[1] <= 4:
        axes[0].legend(fontsize=7, loc="upper left")
    axes[1].set_ylabel("duty [-]")
    axes[2].set_ylabel("R [ohm]")
    axes[3].set_ylabel("T [degC]")
    axes[3].set_xlabel("time [s]")
    figure.tight_layout()
    return figure


def to_rgb(figure) -> np.ndarray:
    """The figure as an (H, W, 3) uint8 array."""
    figure.canvas.draw()
    rgba = np.asarray(figure.canvas.buffer_rgba())
    return rgba[:, :, :3].copy()
