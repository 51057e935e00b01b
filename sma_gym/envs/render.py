"""Rendering an episode: position and reference, duty, resistance, temperature.

Fast enough for ``RecordVideo`` at every step (``benchmarks/bench_render.py``): the figure
is a :class:`matplotlib.figure.Figure` on its own Agg canvas (never pyplot, so the user's
global backend and figure list are untouched); axes, labels and title are drawn only when
an axis range changes (ranges are snapped to 1-2-5 steps of the data's span, so that happens
a few dozen times per episode), and otherwise the cached background is restored and only the
lines are drawn over it (blitting). A frame is a function of the episode so far alone.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from sma_gym.extras import require

WIDTH_IN = 6.4
DPI = 100
"""Frames are 640 x 640 pixels."""


class EpisodeHistory:
    """What an env records for rendering (only while a render mode is set).

    Values are kept in numpy buffers that double when full, so reading the whole history
    for a frame costs nothing however long the episode is.
    """

    FIELDS = ("t", "position", "reference", "duty", "resistance", "temperature")

    def __init__(self) -> None:
        self._data: dict[str, np.ndarray] = {}
        self._size = 0

    def __len__(self) -> int:
        return self._size

    def clear(self) -> None:
        self._size = 0

    def add(self, **values: Any) -> None:
        """Append one sample: each field a number, or an array (one entry per actuator)."""
        if not self._data or self._size == len(self._data["t"]):
            capacity = max(1024, 2 * self._size)
            for k in self.FIELDS:
                shape = np.shape(values[k])
                grown = np.empty((capacity, *shape))
                if k in self._data:
                    grown[: self._size] = self._data[k][: self._size]
                self._data[k] = grown
        for k in self.FIELDS:
            self._data[k][self._size] = values[k]
        self._size += 1

    def arrays(self) -> dict[str, np.ndarray]:
        """The samples so far, per field: (T,) or (T, n_actuators) views (do not modify)."""
        if not self._data:
            return {k: np.empty(0) for k in self.FIELDS}
        return {k: v[: self._size] for k, v in self._data.items()}


def _nice_at_least(x: float) -> float:
    """The smallest of 1, 2, 5 x 10^k that is at least ``x`` (> 0)."""
    base = 10.0 ** np.floor(np.log10(x))
    return float(next(m * base for m in (1.0, 2.0, 5.0, 10.0) if m * base >= x * (1 - 1e-12)))


def axis_limits(low: float, high: float, floor: float) -> tuple[float, float]:
    """Axis range of data spanning [``low``, ``high``]: a margin of 5 % of the span (at
    least ``floor``), snapped outward to a 1-2-5 step of about a tenth of the span.

    A function of the data alone, so a frame depends only on the episode so far (not on
    which frames were drawn before it, or on earlier episodes), and the range changes only
    at a few thresholds per episode (each change redraws the cached background)."""
    span = max(high - low, floor)
    step = _nice_at_least(span / 10)
    lo = np.floor((low - 0.05 * span) / step) * step
    hi = np.ceil((high + 0.05 * span) / step) * step
    return float(lo), float(hi)


def time_limits(start_s: float, end_s: float) -> tuple[float, float]:
    """Time axis from the episode's start to the next 1-2-5 step past its last sample (at
    least 1 s): never before the start, as the data's own range."""
    return start_s, start_s + _nice_at_least(max(end_s - start_s, 1.0))


class EpisodePlot:
    """Draws an :class:`EpisodeHistory` into 640 x 640 RGB frames."""

    _AXES = (
        ("position", "position [mm]", 1e3, 1.0),
        ("duty", "duty [-]", 1.0, 0.1),
        ("resistance", "R [ohm]", 1.0, 0.5),
        ("temperature", "T [degC]", 1.0, 10.0),
    )
    """(field, label, scale, smallest span): one axis each, top to bottom."""

    def __init__(self) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.figure = Figure(figsize=(WIDTH_IN, WIDTH_IN), dpi=DPI)
        self.canvas = FigureCanvasAgg(self.figure)
        self.axes = self.figure.subplots(len(self._AXES), 1, sharex=True)
        for ax, (_, label, _, _) in zip(self.axes, self._AXES):
            ax.set_ylabel(label)
            ax.grid(True, alpha=0.3)
        self.axes[-1].set_xlabel("time [s]")
        self._lines: dict[str, list] = {}
        self._key: tuple | None = None
        self._limits: list[tuple[float, float]] = []
        self._background = None

    def frame(self, history: EpisodeHistory, title: str, labels: Sequence[str] | None = None) -> np.ndarray:
        """The history as an (H, W, 3) uint8 array."""
        h = history.arrays()
        # Before the first step (a reset env, or one drawn through ``env.unwrapped``) no sample: empty axes.
        per_actuator = {k: v.reshape(len(v), -1) if len(v) else v.reshape(0, 1) for k, v in h.items() if k != "t"}
        n = per_actuator["position"].shape[1] if len(h["t"]) else 1
        key = (title, n, tuple(labels or ()))
        if key != self._key:
            self._setup(title, n, labels)
            self._key = key
        t = h["t"]
        limits = [time_limits(float(t[0]), float(t[-1])) if len(t) else (0.0, 1.0)]
        for ax_fields, (_, _, scale, floor) in zip(self._fields(), self._AXES):
            # a reference is NaN where the task has none
            finite = [d[np.isfinite(d)] for d in (per_actuator[f] for f in ax_fields)]
            finite = [d for d in finite if d.size]
            if finite:
                low = min(float(d.min()) for d in finite) * scale
                high = max(float(d.max()) for d in finite) * scale
                limits.append(axis_limits(low, high, floor))
            else:
                limits.append((0.0, floor))
        for name, lines in self._lines.items():
            for j, line in enumerate(lines):
                line.set_data(t, per_actuator[name][:, j] * self._scale(name))
        if limits != self._limits or self._background is None:
            self._limits = limits
            self.axes[0].set_xlim(*limits[0])
            for ax, lim in zip(self.axes, limits[1:]):
                ax.set_ylim(*lim)
            self._draw_background()
        else:
            self.canvas.restore_region(self._background)
        for ax, ax_fields in zip(self.axes, self._fields()):
            for name in ax_fields:
                for line in self._lines[name]:
                    ax.draw_artist(line)
        return np.asarray(self.canvas.buffer_rgba())[:, :, :3].copy()

    def _fields(self) -> tuple[tuple[str, ...], ...]:
        return tuple(("position", "reference") if f == "position" else (f,) for f, _, _, _ in self._AXES)

    def _scale(self, name: str) -> float:
        return 1e3 if name in ("position", "reference") else 1.0

    def _setup(self, title: str, n: int, labels: Sequence[str] | None) -> None:
        for lines in self._lines.values():
            for line in lines:
                line.remove()
        legend = self.axes[0].get_legend()
        if legend is not None:
            legend.remove()
        self._lines = {}
        names = ("position", "reference", "duty", "resistance", "temperature")
        axis_of = {"position": 0, "reference": 0, "duty": 1, "resistance": 2, "temperature": 3}
        for name in names:
            ax = self.axes[axis_of[name]]
            self._lines[name] = []
            for j in range(n):
                suffix = f" {labels[j]}" if labels else ""
                # animated: drawn only by draw_artist over the cached background
                (line,) = ax.plot(
                    [],
                    [],
                    "--" if name == "reference" else "-",
                    color=f"C{j % 10}",
                    label=f"{name}{suffix}",
                    animated=True,
                    lw=1.2,
                )
                self._lines[name].append(line)
        if n <= 4:
            self.axes[0].legend(fontsize=7, loc="upper left")
        self.axes[0].set_title(title, fontsize=9)
        self._limits = [(0.0, 1.0), (0.0, 1.0), (0.0, 1.0), (0.0, 1.0), (0.0, 1.0)]
        self._background = None
        self.figure.tight_layout()

    def _draw_background(self) -> None:
        self.canvas.draw()
        self._background = self.canvas.copy_from_bbox(self.figure.bbox)


NON_INTERACTIVE_BACKENDS = frozenset({"agg", "cairo", "pdf", "pgf", "ps", "svg", "template"})
"""matplotlib backends that write files and never open a window."""


def check_render_mode(render_mode: str | None, modes: Sequence[str]) -> str | None:
    """``render_mode`` if it is one of ``modes`` or ``None``; a mode that draws needs the
    ``[plots]`` extra, refused when the env is made rather than at its first ``render()``."""
    if render_mode is not None and render_mode not in modes:
        raise ValueError(f"render_mode = {render_mode!r}: expected one of {list(modes)} or None")
    if render_mode is not None:
        require("matplotlib", purpose=f"render_mode={render_mode!r}", extra="plots")
    return render_mode


class Renderer:
    """What a single env needs for ``render_mode``: the history, the plot, a human window."""

    def __init__(self, render_mode: str | None, modes: Sequence[str]):
        self.render_mode = check_render_mode(render_mode, modes)
        self.history = EpisodeHistory()
        self._plot: EpisodePlot | None = None
        self._window: Any = None
        self._last_human_t = -np.inf

    def __getstate__(self) -> dict[str, Any]:
        # The plot's matplotlib canvas and a window cannot be pickled (copy.deepcopy, a
        # planner's snapshot); the copy draws its own at its first render().
        return {**self.__dict__, "_plot": None, "_window": None, "_last_human_t": -np.inf}

    def record(self, **values: Any) -> None:
        """Record one sample (only while a render mode is set)."""
        if self.render_mode is not None:
            self.history.add(**values)

    def render(self, title: str, labels: Sequence[str] | None = None) -> np.ndarray | None:
        """The frame (``rgb_array``), or show it in a window (``human``, every 100 ms of sim time)."""
        if self.render_mode is None:
            import gymnasium as gym

            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human' to make()")
            return None
        if self._plot is None:
            self._plot = EpisodePlot()
        if self.render_mode == "rgb_array":
            return self._plot.frame(self.history, title, labels)
        t = float(self.history.arrays()["t"][-1]) if len(self.history) else 0.0
        if self._window is not None and t - self._last_human_t < 0.1:
            return None
        self._last_human_t = t
        self._show(self._plot.frame(self.history, title, labels))
        return None

    def _show(self, frame: np.ndarray) -> None:
        # Human mode is the one place pyplot is wanted: the user asked for a window.
        import matplotlib.pyplot as plt

        if self._window is None:
            backend = str(plt.get_backend())
            if backend.lower() in NON_INTERACTIVE_BACKENDS:
                import gymnasium as gym

                # Without a display pyplot falls back to a file backend, and the window would
                # silently never appear.
                gym.logger.warn(
                    f"render_mode='human': matplotlib's backend {backend!r} shows no window (no display?); "
                    "use render_mode='rgb_array' for frames (e.g. gymnasium's RecordVideo), or set MPLBACKEND "
                    "to an interactive backend"
                )
            figure = plt.figure(figsize=(WIDTH_IN, WIDTH_IN), dpi=DPI)
            ax = figure.add_axes((0, 0, 1, 1))
            ax.set_axis_off()
            self._window = ax.imshow(frame)
        else:
            self._window.set_data(frame)
        plt.pause(0.001)

    def reset(self) -> None:
        self.history.clear()

    def close(self) -> None:
        if self._window is not None:
            import matplotlib.pyplot as plt

            plt.close(self._window.figure)
            self._window = None
        self._plot = None


class EpisodeRendering:
    """``render()`` and ``close()`` of the single and the multiplexed env (a mixin).

    The env sets ``sim`` (a :class:`~sma_gym.Simulator`), ``task`` (its task state) and
    ``_ref`` (the references of the last step) and calls :meth:`_init_rendering` when it is
    made, :meth:`_start_rendering` after a reset and :meth:`_rendered_step` after a step
    (only while ``render_mode`` is set: nothing is recorded otherwise).
    Every actuator of ``sim`` is drawn, each in its own colour.
    """

    metadata: dict[str, Any]
    render_mode: str | None
    _renderer: Renderer

    def _init_rendering(self, render_mode: str | None, control_period_s: float) -> None:
        self._renderer = Renderer(render_mode, self.metadata["render_modes"])
        self.render_mode = render_mode
        self.metadata = dict(self.metadata, render_fps=max(1, round(1.0 / control_period_s)))

    def _start_rendering(self) -> None:
        self._renderer.reset()
        self._record()

    def _rendered_step(self) -> None:
        self._record()
        if self.render_mode == "human":
            self.render()

    def _record(self) -> None:
        if self.render_mode is None:
            return  # nothing is drawn: skip building the sample (it is on every step's path)
        sim = self.sim  # type: ignore[attr-defined]
        self._renderer.record(
            t=sim.time_s[0],
            position=sim.position_m,
            reference=self._ref,  # type: ignore[attr-defined]
            duty=sim.duty_applied,
            resistance=self.task.held[:, 0],  # type: ignore[attr-defined]
            temperature=sim.temperature_c,
        )

    def _render_title(self) -> str:
        raise NotImplementedError

    def _render_labels(self) -> list[str] | None:
        """Legend label of each actuator (``None``: no legend entries per actuator)."""
        return None

    def render(self) -> np.ndarray | None:
        """``rgb_array``: the episode so far as a (640, 640, 3) uint8 frame; ``human``: show it."""
        return self._renderer.render(self._render_title(), self._render_labels())

    def close(self) -> None:
        """Close the human-mode window, if any, and drop the figure."""
        self._renderer.close()
