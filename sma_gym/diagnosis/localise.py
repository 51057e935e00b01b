"""Where the nominal model's residuals concentrate: time windows and physical regimes.

Regimes are labelled from the nominal simulation's own state along the measured input
(what the model *thinks* the wire is doing), per sample:

* ``heating`` / ``cooling``: temperature rising / falling faster than 2 K/s;
* ``holding``: neither, with the power on;
* ``at rest``: neither, with the power off;
* ``transformation onset``: martensite fraction between 0.9 and 0.99 (start of M -> A or end
  of A -> M), ``transformation end``: between 0.01 and 0.1, ``transforming``: in between;
* ``motion reversal``: within 0.5 s of the direction of motion changing;
* temperature bands (below A_s, A_s..A_f, above A_f, stress-free values) and position
  bands (thirds of the stroke).

For each regime: its share of the samples, its share of the squared residual and its RMS.
A regime whose share of the error is much larger than its share of the samples is where
the model is wrong. Windows: the five non-overlapping 1 s windows with the largest RMS.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from sma_gym.diagnosis.fitting import TraceData, model_for_trace
from sma_gym.model import ModelConfig
from sma_gym.simulator import Simulator

RATE_K_PER_S = 2.0
REVERSAL_WINDOW_S = 0.5
WINDOW_S = 1.0
N_WINDOWS = 5


def regime_masks(model: ModelConfig, data: TraceData, control_period_s: float) -> dict[str, np.ndarray]:
    """Boolean masks over the trace's samples for each regime (from the nominal simulation)."""
    sim = Simulator(model_for_trace(model, data.trace), control_period_s=control_period_s)
    rec = sim.run(data.duty, record=("temperature_c", "martensite_fraction", "position_m", "power_w"))
    idx = np.clip(data.sample_steps, 0, None)
    t = data.trace.t
    temp = rec["temperature_c"][idx, 0]
    xi = rec["martensite_fraction"][idx, 0]
    x = rec["position_m"][idx, 0]
    power = rec["power_w"][idx, 0]
    dtemp = np.gradient(temp, t)
    masks: dict[str, np.ndarray] = {}
    masks["heating"] = dtemp > RATE_K_PER_S
    masks["cooling"] = dtemp < -RATE_K_PER_S
    steady = ~(masks["heating"] | masks["cooling"])
    masks["holding"] = steady & (power > 0.0)
    masks["at rest"] = steady & (power <= 0.0)
    masks["transformation onset"] = (xi > 0.9) & (xi < 0.99)
    masks["transforming"] = (xi >= 0.1) & (xi <= 0.9)
    masks["transformation end"] = (xi > 0.01) & (xi < 0.1)
    # Motion reversals: sign changes of a smoothed velocity, with a window around each.
    v = np.gradient(x, t)
    moving = np.abs(v) > 0.2e-3
    sign = np.sign(v) * moving
    last = 0.0
    rev_times = []
    for k in range(len(sign)):
        if sign[k] != 0:
            if last != 0 and sign[k] != last:
                rev_times.append(t[k])
            last = sign[k]
    rev = np.zeros(len(t), dtype=bool)
    for tr in rev_times:
        rev |= np.abs(t - tr) <= REVERSAL_WINDOW_S
    masks["motion reversal"] = rev
    w = model.actuator.wire
    masks[f"T < A_s ({w.austenite_start_c:g} degC)"] = temp < w.austenite_start_c
    masks["A_s <= T <= A_f"] = (temp >= w.austenite_start_c) & (temp <= w.austenite_finish_c)
    masks[f"T > A_f ({w.austenite_finish_c:g} degC)"] = temp > w.austenite_finish_c
    stroke = model.actuator.usable_stroke_m
    masks["x in first third of stroke"] = x < stroke / 3
    masks["x in middle third"] = (x >= stroke / 3) & (x < 2 * stroke / 3)
    masks["x in last third"] = x >= 2 * stroke / 3
    return masks


def localise(
    model: ModelConfig, data: TraceData, simulated: dict[str, np.ndarray], control_period_s: float
) -> dict[str, Any]:
    """Regimes and windows of one trace, for each measured output."""
    masks = regime_masks(model, data, control_period_s)
    t = data.trace.t
    out: dict[str, Any] = {"file": data.trace.name, "regimes": {}, "windows": {}, "totals": {}}
    for name, measured in data.outputs.items():
        r = measured - simulated[name][:, 0]
        valid = np.isfinite(r) & data.mask
        total = float(np.sum(r[valid] ** 2))
        out["totals"][name] = {"samples": int(valid.sum()), "squared_error": total}
        regimes = {}
        for label, m in masks.items():
            sel = m & valid
            if sel.sum() < 5:
                continue
            share = float(np.sum(r[sel] ** 2) / total) if total > 0 else 0.0
            frac = float(sel.sum() / valid.sum())
            regimes[label] = {
                "fraction_of_samples": frac,
                "share_of_squared_error": share,
                "concentration": share / frac if frac > 0 else 0.0,
                "rms": float(np.sqrt(np.mean(r[sel] ** 2))),
            }
        out["regimes"][name] = dict(sorted(regimes.items(), key=lambda kv: -kv[1]["concentration"]))
        out["windows"][name] = worst_windows(t[valid], r[valid])
    return out


def worst_windows(
    t: np.ndarray, r: np.ndarray, width: float = WINDOW_S, count: int = N_WINDOWS
) -> list[dict[str, float]]:
    """The ``count`` non-overlapping windows of ``width`` seconds with the largest RMS."""
    if t.size == 0:
        return []
    edges = np.arange(t[0], t[-1] + width, width)
    bins = np.digitize(t, edges) - 1
    sums = np.bincount(bins, weights=r**2, minlength=len(edges))
    counts = np.bincount(bins, minlength=len(edges))
    rms = np.sqrt(np.where(counts > 0, sums / np.maximum(counts, 1), 0.0))
    order = np.argsort(-rms)[:count]
    return [
        {"start_s": float(edges[k]), "end_s": float(edges[k] + width), "rms": float(rms[k])}
        for k in order
        if counts[k] > 0 and rms[k] > 0 and math.isfinite(rms[k])
    ]


def pooled_regimes(localised: list[dict[str, Any]], output: str = "position") -> dict[str, dict[str, float]]:
    """Each regime's share of the samples and of the squared error of ``output`` over all
    files together (each file weighted by its samples and its error, not one vote each: a
    regime on 4 % of a short file outranked the long file's main one), and their ratio,
    ``concentration``. A regime too rare to count in a file (under 5 samples) counts 0 there."""
    samples = sum(e["totals"][output]["samples"] for e in localised if output in e.get("totals", {}))
    error = sum(e["totals"][output]["squared_error"] for e in localised if output in e.get("totals", {}))
    sums: dict[str, list[float]] = {}
    for entry in localised:
        totals = entry.get("totals", {}).get(output)
        if totals is None:
            continue
        for label, stats in entry["regimes"].get(output, {}).items():
            acc = sums.setdefault(label, [0.0, 0.0])
            acc[0] += stats["fraction_of_samples"] * totals["samples"]
            acc[1] += stats["share_of_squared_error"] * totals["squared_error"]
    pooled = {}
    for label, (n, e) in sums.items():
        fraction = n / samples if samples > 0 else 0.0
        share = e / error if error > 0 else 0.0
        pooled[label] = {
            "fraction_of_samples": fraction,
            "share_of_squared_error": share,
            "concentration": share / fraction if fraction > 0 else 0.0,
        }
    return pooled


def summary(localised: list[dict[str, Any]], output: str = "position", top: int = 3) -> list[str]:
    """The regimes with the most concentrated error, pooled over files (:func:`pooled_regimes`)."""
    pooled = pooled_regimes(localised, output)
    ranked = sorted(pooled.items(), key=lambda kv: -kv[1]["concentration"])
    return [label for label, _ in ranked[:top]]
