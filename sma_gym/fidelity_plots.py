"""Plots for ``sma-gym fidelity`` (PNG, matplotlib's non-interactive backend)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sma_gym.plotting import new_figure, save


def plot_voltage_steps(data: dict[str, np.ndarray], out: Path) -> Path:
    """Fig. 5.2 / 5.3 style: position, temperature, martensite fraction and stress."""
    fig, axes = new_figure(2, 2, size=(11, 7))
    t = data["time_s"][:, 0]
    for j, v in enumerate((5.0, 7.5, 10.0)):
        axes[0, 0].plot(t, data["position_m"][:, j] * 1e3, label=f"{v:g} V")
        axes[0, 1].plot(t, data["temperature_c"][:, j], label=f"{v:g} V")
        axes[1, 0].plot(t, data["martensite_fraction"][:, j], label=f"{v:g} V")
        axes[1, 1].plot(t, data["stress_pa"][:, j] / 1e6, label=f"{v:g} V")
    axes[0, 0].set(
        xlabel="time [s]", ylabel="position [mm]", title="Open-loop voltage step (cf. fig. 5.2)", ylim=(0, 12)
    )
    axes[0, 1].set(xlabel="time [s]", ylabel="temperature [degC]", title="Temperature (cf. fig. 5.3)")
    axes[0, 1].axhspan(100, 160, color="0.9", label="fig. 5.3 peak range")
    axes[1, 0].set(xlabel="time [s]", ylabel="martensite fraction [-]")
    axes[1, 1].set(xlabel="time [s]", ylabel="stress [MPa]")
    for ax in axes.flat:
        ax.set_xlim(1.0, 4.0)
        ax.legend(fontsize=8)
    return save(fig, out)


def plot_resistance_loop(loop: dict[str, np.ndarray], first: dict[str, np.ndarray], out: Path) -> Path:
    """Fig. 4.5 / 4.9 style: measured resistance against measured position.

    Column 0 of ``loop`` is the 1 -> 7 mm sine at 10 V, column 3 fig. 4.4's 0 -> 8 mm sine.
    """
    fig, axes = new_figure(1, 2, size=(11, 4.5))
    sel = loop["t"] >= 20.0
    v = np.gradient(loop["x"][:, 0])
    heat = sel & (v > 0)
    cool = sel & (v < 0)
    ax = axes[0, 0]
    ax.plot(loop["r_meas"][heat, 0], loop["x_meas"][heat, 0] * 1e3, ".", ms=1.5, label="heating")
    ax.plot(loop["r_meas"][cool, 0], loop["x_meas"][cool, 0] * 1e3, ".", ms=1.5, label="cooling")
    ax.plot(
        first["resistance_measured_ohm"][:, 0],
        first["position_m"][:, 0] * 1e3,
        "-",
        lw=1,
        color="0.4",
        label="first rise from cold",
    )
    ax.set(xlabel="resistance [ohm]", ylabel="position [mm]", title="Position - resistance, 10 V (cf. figs. 4.5, 4.9)")
    ax.legend(fontsize=8)
    ax = axes[0, 1]
    ax.plot(loop["t"], loop["x_meas"][:, 3] * 1e3, label="position [mm]")
    ax2 = ax.twinx()
    ax2.plot(loop["t"], loop["r_meas"][:, 3], color="C3", lw=0.8, label="resistance [ohm]")
    ax.set(xlabel="time [s]", ylabel="position [mm]", title="0.05 Hz sine 0-8 mm, P control, fan, 10 V (cf. fig. 4.4)")
    ax2.set_ylabel("resistance [ohm]")
    return save(fig, out)


def plot_holding(curve: dict[str, np.ndarray], slope_per_m: float, out: Path) -> Path:
    """Fig. 6.4 style: duty that holds a position at 10 V, heating and cooling branch, and the fits."""
    fig, axes = new_figure(1, 1, size=(6.5, 4.5))
    ax = axes[0, 0]
    ax.plot(curve["x_heating"] * 1e3, curve["duty"], "o-", ms=3, label="simulated, reached while heating")
    ax.plot(curve["x_cooling"] * 1e3, curve["duty"], "s-", ms=3, label="simulated, reached while cooling")
    xs = np.linspace(0, 5, 10)
    ax.plot(xs, 12 * xs * 1e-3, "k--", label="report's fit 12 x (fig. 6.4)")
    if np.isfinite(slope_per_m):
        ax.plot(xs, slope_per_m * xs * 1e-3, "C3:", label=f"simulated fit through the origin {slope_per_m:.3g} x")
    ax.plot([5], [0.06], "k*", ms=12, label="0.06 at 5 mm (A26)")
    ax.set(
        xlabel="position [mm]",
        ylabel="duty cycle [-]",
        title="Holding duty at 10 V (cf. fig. 6.4)",
        xlim=(-0.5, 10),
        ylim=(0, 0.09),
    )
    ax.legend(fontsize=8)
    return save(fig, out)


def plot_efficiency(runs, cases: Sequence[tuple], out: Path) -> Path:
    """Chapter 8: simulated against reported efficiencies, and the strokes."""
    fig, axes = new_figure(1, 2, size=(11, 4.5))
    ax = axes[0, 0]
    labels = [c[0] for c in cases]
    report = [c[3] for c in cases]
    simulated = [runs.value("8", "PID", label, "1 -> 7 mm", "efficiency_percent") for label in labels]
    idx = np.arange(len(cases))
    ax.bar(idx - 0.2, report, 0.4, label="report (Tables 8.1, 8.2)")
    ax.bar(idx + 0.2, simulated, 0.4, label="simulated (PID)")
    ax.set_xticks(idx, labels, rotation=30, fontsize=8)
    ax.set(ylabel="efficiency [%]", title="Efficiency of 1 -> 7 mm strokes")
    ax.legend(fontsize=8)
    ax = axes[0, 1]
    for label in labels:
        trace = runs.traces[("8", "PID", label, "1 -> 7 mm")]
        ax.plot(trace.t - 4.0, trace["position_m"][:, 0] * 1e3, label=label)
    ax.set(
        xlabel="time from step [s]", ylabel="position [mm]", xlim=(-0.5, 4), title="PID strokes (cf. figs. 8.1, 8.2)"
    )
    ax.legend(fontsize=7)
    return save(fig, out)


def plot_multiplexed(
    trace_of: Callable[[int, float, float], Any], count_conditions, freq_conditions, out: Path
) -> Path:
    """Chapter 9: step responses against number of actuators, supply and cycling frequency.

    ``trace_of(n, f, v)`` returns the trace of n actuators cycled at f Hz on v volts.
    """

    def x0(n: int, f: float, v: float):
        trace = trace_of(n, f, v)
        return trace.t, trace["position_m"][:, 0, 0] * 1e3

    fig, axes = new_figure(1, 4, size=(18, 4.2))
    ax = axes[0, 0]
    for n, f, v in count_conditions:
        t, x = x0(n, f, v)
        ax.plot(t, x, label=f"{n} act., {v:g} V")
    ax.set(xlabel="time [s]", ylabel="position [mm]", title="Multiplexed PID step, 2 kHz (cf. figs. 9.1-9.3)")
    ax.legend(fontsize=8)
    for k, n in enumerate((1, 8, 16)):
        ax = axes[0, k + 1]
        for nn, f, v in freq_conditions:
            if nn == n:
                t, x = x0(nn, f, v)
                ax.plot(t, x, lw=1, label=f"{f:g} Hz")
        ax.set(xlabel="time [s]", ylabel="position [mm]", title=f"{n} actuator(s), 10 V (cf. fig. 9.5)")
        ax.set_xlim(0, {1: 1.0, 8: 8.0, 16: 25.0}[n])
        ax.legend(fontsize=7)
    return save(fig, out)


def plot_bench(out: Path) -> Path:
    """The real bench's four shared runs beside the datasheet model and the twin
    ``bench-0.5mm-ht`` (identified on them), each sensor zero read off its rest segment."""
    from sma_gym.data import REAL_BENCH_RUNS, load_trace, real_bench_folder
    from sma_gym.simulator import Simulator

    folder = real_bench_folder()
    if folder is None:
        # An empty figure would pass for a plot of the runs (fidelity.skipped_plots says why).
        raise FileNotFoundError(f"the real bench's runs {', '.join(REAL_BENCH_RUNS)} (../shared/data/real)")
    fig, axes = new_figure(2, 2, size=(11, 8))
    for ax, name in zip(axes.flat, REAL_BENCH_RUNS):
        trace = load_trace(folder / name)
        ends, duty = trace.duty_at_control_steps(1e-3)
        rest = trace.t < trace.t[np.flatnonzero(trace.duty > 0)[0]] if np.any(trace.duty > 0) else trace.t < np.inf
        zero_m = float(np.mean(trace.position[rest]))
        ax.plot(trace.t, (trace.position - zero_m) * 1e3, "k", lw=1.5, label="measured")
        for model, colour in (("bench-0.5mm-ht-datasheet", "C0"), ("bench-0.5mm-ht", "C1")):
            rec = Simulator(model).run(duty, record=("position_measured_m",))
            ax.plot(ends, rec["position_measured_m"][:, 0] * 1e3, colour, label=model)
        ax2 = ax.twinx()
        ax2.plot(trace.t, trace.duty, color="0.6", lw=0.8)
        ax2.set_ylabel("duty [-]", color="0.5")
        ax.set(xlabel="time [s]", ylabel="position from rest [mm]", title=f"Real bench, {name}")
        ax.legend(fontsize=8, loc="center right")
    return save(fig, out)
