"""The diagnosis report: markdown and PNG plots (measured vs nominal vs corrected, residuals
by regime)."""

from __future__ import annotations

import json
import math
import os
import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sma_gym._io import STAGING_PREFIX, signals_deferred, write_json, write_text
from sma_gym.data.measured import MeasuredTrace
from sma_gym.diagnosis import fitting
from sma_gym.diagnosis.localise import pooled_regimes
from sma_gym.diagnosis.workflow import (
    BIC_THRESHOLD,
    CONTROL_PERIOD_S,
    HELDOUT_GAIN,
    HOLDOUT_FRACTION,
    LATER_ROUND_GAIN,
    NOISE_STOP,
    PARTIAL_GAIN,
    SEPARATION_BLOCKS,
    SEPARATION_T,
    STRUCTURED_RATIO,
    Diagnosis,
    explained_text,
    file_labels,
    holdout_cut_s,
)
from sma_gym.model import ModelConfig
from sma_gym.plotting import new_figure, save
from sma_gym.provenance import provenance

_SCALE = {"position": (1e3, "mm"), "resistance": (1.0, "ohm"), "current": (1.0, "A"), "voltage": (1.0, "V")}


def format_value(value: float, output: str) -> str:
    """An output's value in the unit the reports show it in (position in mm), with the unit."""
    scale, unit = _SCALE[output]
    return f"{value * scale:.4g} {unit}"


def write_report(
    result: Diagnosis,
    out: Path,
    fit_traces: Sequence[MeasuredTrace],
    heldout_traces: Sequence[MeasuredTrace],
    nominal: ModelConfig,
    shown_out: Path | None = None,
) -> Path:
    """The markdown report and its plots into ``out``; ``shown_out``: the folder the report
    names for the corrected model (where the files end up, when ``out`` is a staging folder)."""
    shown = out if shown_out is None else shown_out
    plots = []
    names = iter(file_labels([*fit_traces, *heldout_traces]))  # a/run.csv, b/run.csv told apart
    for label, traces in (("fit", fit_traces), ("heldout", heldout_traces)):
        for k, trace in enumerate(traces):
            path = _trace_plot_path(out, label, k, trace)
            # Without held-out files each fitted file's end was held out while the rounds chose.
            cut_s = holdout_cut_s(trace) if label == "fit" and not heldout_traces else None
            plots.append(_plot_trace(trace, next(names), nominal, result, path, label, cut_s))
    plots.append(_plot_regimes(result, out / "residuals_by_regime.png"))
    if result.rounds:
        plots.append(_plot_rounds(result, out / "gap_by_round.png"))

    verdict = result.verdict
    if verdict == "effect":
        headline = f"**Missing effect: `{result.effect}`**"
    elif verdict == "effects":
        headline = f"**Missing effects: {', '.join(f'`{e}`' for e in result.effect)}** (in the order found: one per round, two where a round named a pair)"
    elif verdict == "ambiguous":
        headline = f"**Ambiguous: {' or '.join(f'`{e}`' for e in result.effect)}**. To tell them apart: {result.separating_experiment}."
    elif verdict == "partial":
        one = len(result.effect) == 1
        headline = (
            f"**Partly explained**: {' and '.join(f'`{e}`' for e in result.effect)} "
            f"{'improves' if one else 'improve'} the held-out prediction but {'closes' if one else 'close'} "
            f"{explained_text(result.explained)} (a finding closes at least {PARTIAL_GAIN:.0%}, or leaves at most "
            f"{STRUCTURED_RATIO:g}x the noise). Most of the misfit is something the library does not name, "
            f"which {'it' if one else 'they'} may stand in for: the corrected model carries "
            f"{'it' if one else 'them'}, but {'it is' if one else 'they are'} not named as found."
        )
    elif verdict == "none":
        headline = "**No missing effect**: the nominal model, with its uncertain parameters refitted, explains the data to the noise."
    else:
        headline = "**Unexplained**: the residuals stay structured, but no effect of the library explains them on held-out data."
    lines = [
        "# Diagnosis",
        "",
        headline,
        "",
        f"Nominal model: `{nominal.name}`. Fitted: {', '.join(file_labels([*fit_traces, *heldout_traces])[: len(fit_traces)])}. Held out: {result.held_out}.",
        f"Corrected model: `corrected_model.json` (`gymnasium.make(id, model={str(shown / 'corrected_model.json')!r})` "
        f"from where the command ran). Took {result.seconds:.0f} s."
        + (
            f" It also carries `{result.carried}`, the best held out of the last round's ambiguous candidates"
            " (not named as found)."
            if result.carried
            else ""
        )
        + (
            " It runs under the files' conditions ("
            + ", ".join(f"{k} {v:g}" for k, v in result.conditions.items())
            + ")."
            if result.conditions
            else ""
        )
        + "".join(
            f" The files differ in {k} ("
            + ", ".join(f"{name} {'not given' if v is None else f'{v:g}'}" for name, v in values.items())
            + f"): each was fitted under its own, and the model keeps {fitting.condition_value(result.corrected_model, k):g};"
            " set it for the conditions you simulate."
            for k, values in result.differing_conditions.items()
        )
        + (
            " It is the nominal model as given: refitted, its parameters predicted the held-out data worse"
            " (see the gap table), so no refit is kept."
            if result.kept_as_given
            else ""
        )
        + (
            " Its parameters were chosen on the fitted part of each file and then refitted on the whole files"
            ' (the effects and their forms unchanged; see "Refitted on the whole files"): in the gap table the'
            ' column "corrected, as chosen" is the model before that refit, whose held-out rows are held out (as'
            " in the Rounds table and the staircase), and the last column is the model refitted, whose held-out rows"
            " took part in its fit."
            if result.whole_file_refit
            else ""
        ),
        "",
        "## The gap (RMS error)",
        "",
    ]
    whole = result.whole_file_refit
    chosen_gap = whole["gap_selected"] if whole else result.gap_after
    if whole:
        lines += [
            "| data | output | nominal model | nominal refit only | corrected, as chosen | shrink "
            "| corrected, refitted on the whole files (held out: fitted) |",
            "|---|---|---|---|---|---|---|",
        ]
    else:
        lines += [
            "| data | output | nominal model | nominal refit only | corrected model | shrink |",
            "|---|---|---|---|---|---|",
        ]
    for data in ("fit", "heldout"):
        for output, before in result.gap_before[data].items():
            after = chosen_gap[data].get(output, math.nan)
            refit = result.gap_nominal_refit[data].get(output, math.nan)
            shrink = 1.0 - after / before if before > 0 else 0.0
            row = (
                f"| {data} | {output} | {format_value(before, output)} | {format_value(refit, output)} "
                f"| {format_value(after, output)} | {shrink * 100:.0f} % |"
            )
            if whole:
                row += f" {format_value(result.gap_after[data].get(output, math.nan), output)} |"
            lines.append(row)
    lines += [
        "",
        "Noise (robust estimate from the data): "
        + ", ".join(f"{k} {format_value(v, k)}" for k, v in result.noise.items()),
        "",
    ]
    if result.separating_experiment and verdict != "ambiguous":
        lines += [f"The last round was ambiguous; to tell its candidates apart: {result.separating_experiment}.", ""]
    lines += _round_lines(result) + _file_lines(result) + _whole_file_lines(result)
    lines += (
        [
            "## Parameters of the corrected model",
            "",
            "None was fitted: the corrected model is the nominal model as given, each fitted parameter at its"
            " nominal value (a scale of 1, a shift of 0), with no uncertainty.",
            "",
        ]
        if result.kept_as_given
        else ["## Fitted parameters of the corrected model", ""]
    ) + [
        "| parameter | value | uncertainty (1 sigma) | unit |",
        "|---|---|---|---|",
    ]
    for name, p in result.parameters.items():
        lines.append(f"| {name} | {p['value']:.5g} | {p['uncertainty']:.2g} | {p['unit']} |")
    if not result.kept_as_given:
        lines += ["", _uncertainty_caveat(result)]
    lines += [
        "",
        "## Candidates",
        "",
        f"Round 1's candidates. Supported = not inert (its effect did not end off), BIC lower than the nominal "
        f"refit's by more than {BIC_THRESHOLD:g}, held-out error lower by at least {HELDOUT_GAIN:.0%}, better "
        f"held out than the model as given, and better consistently along the held-out data (t >= "
        f"{SEPARATION_T:g} over {SEPARATION_BLOCKS} blocks); later rounds ask a gain of {LATER_ROUND_GAIN:.0%}. "
        "A candidate that is not supported can still be a rival of the best (docs/diagnosis.md, Verdict rules). "
        "A pair (A + B) is judged against each of its members and the refit: its delta BIC and gain here are "
        "against its better member.",
        "",
        "| candidate | delta BIC | held-out normalised RMS | held-out gain | supported, or why not |",
        "|---|---|---|---|---|",
    ]
    for c in result.candidates:
        why = "yes" if c["supported"] else c.get("not_supported_because", "")
        lines.append(
            f"| {c['name']} | {c['delta_bic']:+.1f} | {c['heldout_normalised_rms']:.3g} | {c['heldout_gain'] * 100:+.1f} % | {why} |"
        )
    lines += [
        "",
        "## Where the nominal model goes wrong",
        "",
        "The regimes overlap (a sample can be heating, in the transformation's onset and in a temperature band at "
        "once), so their shares add up to more than 100 %.",
        "",
    ]
    for output, regimes in result.where["most_concentrated"].items():
        lines.append(f"- {output}: most concentrated in {', '.join(regimes)}")
    for entry in result.where["files"]:
        lines += ["", f"### {entry['file']}", ""]
        for output, regimes in entry["regimes"].items():
            lines += [
                f"{output}:",
                "",
                "| regime | share of samples | share of squared error | RMS |",
                "|---|---|---|---|",
            ]
            for label, st in list(regimes.items())[:8]:
                lines.append(
                    f"| {label} | {st['fraction_of_samples'] * 100:.0f} % | {st['share_of_squared_error'] * 100:.0f} % | {format_value(st['rms'], output)} |"
                )
            windows = entry["windows"].get(output, [])
            if windows:
                lines.append("")
                lines.append(
                    "Worst 1 s windows: "
                    + ", ".join(
                        f"{w['start_s']:.0f}-{w['end_s']:.0f} s ({format_value(w['rms'], output)})" for w in windows
                    )
                )
            lines.append("")
    lines += ["## Plots", ""] + [f"![{p.stem}]({p.name})" for p in plots]
    md = out / "diagnosis.md"
    write_text(md, "\n".join(lines) + "\n")
    return md


def _round_lines(result: Diagnosis) -> list[str]:
    lines = [
        "## Rounds",
        "",
        "Each round refits the nominal parameters and the effects found so far with every remaining "
        "candidate (an ambiguous or unexplained round also fits its best names in pairs, and names a pair "
        "that beats each member alone; an unexplained round also refits its candidates with evidence in "
        "their other forms; an effect found before moves to another form when that form fits and predicts "
        "better); it stops when nothing is supported, the verdict is ambiguous, or the held-out "
        "residual is within 2x the noise (normalised RMS 1 = noise). A round that names nothing keeps its "
        "refit of the effects found where that predicts better than the model it started from. When effects "
        "were found in more than one round (or that refit holds two or more), each earlier one is then "
        "refitted out, and one the model no longer fits better by the BIC bar and predicts better with is "
        "taken out, the rest judged again without it (the last row says so and shows the model without them).",
        "",
        "| round | verdict | effect | held-out normalised RMS (refit only -> the round's model) | held-out position RMS | parameters at a bound |",
        "|---|---|---|---|---|---|",
    ]
    for r in result.rounds:
        effect = r["effect"]
        if not (isinstance(effect, str) or effect is None):  # a pair named together, or an ambiguous set
            effect = (" and " if r["verdict"] == "effects" else " or ").join(effect)
        for name, form in (r.get("named_forms") or {}).items():
            effect = effect.replace(name, f"{name} (its '{form}' form)")
        for name, form in (r.get("form_changed") or {}).items():
            effect = f"{effect}; " if effect else ""
            effect += f"{name} in its '{form}' form"
        if r.get("refit_adopted"):
            effect = f"{effect}; " if effect else ""
            effect += "the effects found refitted (predicts better: kept)"
        if r.get("reference_refitted_from"):
            effect = f"{effect}; " if effect else ""
            effect += f"judged again from the refit started where {r['reference_refitted_from']} left it (fits better)"
        for removed in r.get("removed") or []:
            effect = f"{effect}; " if effect else ""
            effect += (
                f"then {removed['effect']} taken out (with it ΔBIC {removed['delta_bic_of_keeping']:+.1f}, "
                f"held out {removed['heldout_gain_of_keeping']:+.1%}; without it "
                f"{removed['heldout_normalised_rms_without']:.3g})"
            )
        for swap in r.get("swaps") or []:
            if swap["swapped"]:
                effect = f"{effect}; " if effect else ""
                effect += (
                    f"then {swap['rival']} in place of {swap['effect']} (ΔBIC {swap['delta_bic_of_rival']:+.1f}, "
                    f"held out {swap['heldout_gain_of_rival']:+.1%}: {swap['heldout_normalised_rms_with_rival']:.3g})"
                )
        position = r["gap"]["heldout"].get("position", math.nan)
        bounds = "; ".join(r["parameters_at_bounds"]) or "none"
        lines.append(
            f"| {r['round']} | {r['verdict']} | {effect or ''} | {r['nominal_refit_heldout_normalised_rms']:.3g} -> "
            f"{r['heldout_normalised_rms']:.3g} | {format_value(position, 'position')} | {bounds} |"
        )
    if any(r["parameters_at_bounds"] for r in result.rounds):
        lines += [
            "",
            "A parameter at a bound is a finding, not a fit to trust: the data ask for more than the bound allows. "
            "Check the datasheet value it scales (transformation temperatures given at another stress, a "
            "convection law of another mounting), or the effect it may stand in for, and diagnose again from a "
            'nominal model with that value corrected (docs/diagnosis.md, Real bench: "Bounds are findings").',
        ]
    return lines + [""]


def _uncertainty_caveat(result: Diagnosis) -> str:
    """What the uncertainties are, and, where the held-out gap ends above ``NOISE_STOP`` times the noise, why
    they understate how far a parameter may be from the actuator's (a user read a tight
    interval on a refit that ends at 20x the noise as the actuator's value)."""
    text = (
        "The uncertainties are statistical: the noise, inflated for correlated residuals. The error of a model "
        "whose form differs from the actuator's is not in them."
    )
    gap = result.rounds[-1]["heldout_normalised_rms"] if result.rounds else math.nan
    if math.isfinite(gap) and gap > NOISE_STOP:
        text += (
            f" The held-out gap ends at {gap:.3g}x the noise, so the corrected model does not explain everything: "
            "a parameter may stand in for what it lacks and be further from the actuator's value than its "
            "uncertainty says."
        )
    return text


def _file_lines(result: Diagnosis) -> list[str]:
    lines = [
        "## The gap per file (position RMS)",
        "",
        "| data | file | nominal model | corrected model |",
        "|---|---|---|---|",
    ]
    for label, files in result.gap_by_file.get("nominal", {}).items():
        for name, gaps in files.items():
            after = result.gap_by_file["corrected"][label][name].get("position", math.nan)
            lines.append(
                f"| {label} | {name} | {format_value(gaps.get('position', math.nan), 'position')} | {format_value(after, 'position')} |"
            )
    return lines + [""]


def _whole_file_lines(result: Diagnosis) -> list[str]:
    """Step 9's table: each whole file's RMS under the model as chosen on the fitted parts and
    as refitted on the whole files."""
    refit = result.whole_file_refit
    if not refit:
        return []
    lines = [
        "## Refitted on the whole files",
        "",
        "The model the rounds chose on the fitted part of each file, and the same model (effects and forms) "
        "with its parameters refitted on every sample of every file: the corrected model. RMS over each whole file.",
        "",
        "| file | output | chosen on the fitted parts | refitted on the whole files |",
        "|---|---|---|---|",
    ]
    for name, models in refit["rms_by_file"].items():
        for output, chosen in models["selected"].items():
            after = models["refitted"].get(output, math.nan)
            lines.append(f"| {name} | {output} | {format_value(chosen, output)} | {format_value(after, output)} |")
    lines += ["", "| parameter | chosen on the fitted parts | refitted | unit |", "|---|---|---|---|"]
    for name, p in refit["parameters_selected"].items():
        lines.append(f"| {name} | {p['value']:.5g} | {result.parameters[name]['value']:.5g} | {p['unit']} |")
    bounds = "; ".join(refit["parameters_at_bounds"]) or "none"
    return lines + ["", f"Refitted parameters at a bound: {bounds}.", ""]


def _round_label(result: Diagnosis, entry: dict[str, Any]) -> str:
    """What a round did to the model, for the staircase's axis."""
    names = entry["effect"] if isinstance(entry["effect"], list) else [entry["effect"]]
    if entry["verdict"] in ("effect", "effects"):
        added = "\n".join(f"+ {name}" for name in names)
    elif entry["verdict"] == "ambiguous" and result.carried is not None and entry is result.rounds[-1]:
        added = f"ambiguous,\ncarries {result.carried}"
    else:
        added = f"{entry['verdict']}:\nnothing added"
    for removed in entry.get("removed") or []:
        added += f"\n- {removed['effect']}"
    for swap in entry.get("swaps") or []:
        if swap["swapped"]:
            added += f"\n{swap['effect']} -> {swap['rival']}"
    return f"round {entry['round']}\n{added}"


def staircase_stages(result: Diagnosis) -> list[tuple[str, dict[str, dict[str, float]]]]:
    """The staircase's stages, each a label and its gap (``{"fit"|"heldout": {output: RMS}}``):
    the model as given, its refit, each round, and the model refitted on the whole files
    (step 9) with its fitted part only, since its held-out part took part in its fit."""
    stages = [("nominal\nas given", result.gap_before), ("nominal\nrefit", result.gap_nominal_refit)]
    stages += [(_round_label(result, r), r["gap"]) for r in result.rounds]
    if result.whole_file_refit:
        stages.append(("refitted on\nthe whole files\n(nothing held out)", {"fit": result.gap_after["fit"]}))
    return stages


def _plot_rounds(result: Diagnosis, path: Path) -> Path:
    """The staircase: position RMS of the model as given, its refit, and after each round,
    on the fitted and the held-out data, against twice the noise (log scale: the gap
    shrinks by orders of magnitude towards the noise)."""
    stages = staircase_stages(result)
    fig, axes = new_figure(1, 1, size=(max(7.0, 1.9 * len(stages)), 4.5))
    ax = axes[0, 0]
    edges = np.arange(len(stages) + 1)
    values = {
        label: np.array([gap.get(label, {}).get("position", math.nan) for _, gap in stages]) * 1e3
        for label in ("fit", "heldout")
    }
    for label, style in (("fit", "-"), ("heldout", "--")):
        if not np.all(np.isnan(values[label])):
            ax.stairs(values[label], edges, baseline=None, ls=style, lw=2.0, label=label)
    # Each stage's figures: the higher above its line, the lower below, so that close
    # values stay legible.
    for k in range(len(stages)):
        pair = [v[k] for v in values.values() if np.isfinite(v[k])]
        for value in pair:
            above = value >= max(pair)
            ax.annotate(
                f"{value:.3g}",
                (k + 0.5, value),
                textcoords="offset points",
                xytext=(0, 3 if above else -3),
                ha="center",
                va="bottom" if above else "top",
                fontsize=7,
            )
    noise = result.noise.get("position")
    if noise:
        ax.axhline(2 * noise * 1e3, color="k", lw=0.8, ls=":", label="2x noise")
    ax.set_yscale("log")
    ax.set_xticks(edges[:-1] + 0.5, [name for name, _ in stages], fontsize=8)
    ax.set(xlim=(0, len(stages)), ylabel="position RMS [mm]", title="The gap after each round")
    ax.legend(fontsize=8)
    return save(fig, path)


def _plot_trace(
    trace: MeasuredTrace,
    name_shown: str,
    nominal: ModelConfig,
    result: Diagnosis,
    path: Path,
    label: str,
    cut_s: float | None = None,
) -> Path:
    """Measured against the nominal and the corrected model, and the position residuals;
    ``cut_s``: where the file's held-out part began while the rounds chose (marked)."""
    data = fitting.prepare(trace, CONTROL_PERIOD_S)
    sims = fitting.simulate([nominal, result.corrected_model], [0.0, 0.0], data, CONTROL_PERIOD_S)
    outputs = list(data.outputs)[:2]
    corrected = "corrected (refitted on the whole files)" if result.whole_file_refit else "corrected"
    fig, axes = new_figure(len(outputs) + 1, 1, size=(11, 3.0 * (len(outputs) + 1)))
    t = trace.t
    for k, name in enumerate(outputs):
        scale, unit = _SCALE[name]
        ax = axes[k, 0]
        ax.plot(t, data.outputs[name] * scale, "k", lw=1.0, label="measured")
        ax.plot(t, sims[name][:, 0] * scale, "C0", lw=1.0, label="nominal")
        ax.plot(t, sims[name][:, 1] * scale, "C3", lw=1.0, label=corrected)
        ax.set(ylabel=f"{name} [{unit}]", title=f"{name_shown} ({label})" if k == 0 else "")
        ax.legend(fontsize=8)
    for k in range(len(outputs) + 1) if cut_s is not None else ():
        ax = axes[k, 0]
        ax.axvline(cut_s, color="0.4", lw=0.8, ls=":")
        if k == 0:
            ax.annotate("held out while choosing \u2192", (cut_s, 0.02), xycoords=("data", "axes fraction"), fontsize=7)
    ax = axes[len(outputs), 0]
    scale, unit = _SCALE["position"]
    ax.plot(t, (data.outputs["position"] - sims["position"][:, 0]) * scale, "C0", lw=0.8, label="measured - nominal")
    ax.plot(
        t, (data.outputs["position"] - sims["position"][:, 1]) * scale, "C3", lw=0.8, label=f"measured - {corrected}"
    )
    ax.set(xlabel="time [s]", ylabel=f"position residual [{unit}]")
    ax.legend(fontsize=8)
    return save(fig, path)


def _plot_regimes(result: Diagnosis, path: Path) -> Path:
    fig, axes = new_figure(1, 1, size=(10, 4.5))
    ax = axes[0, 0]
    pooled = pooled_regimes(result.where["files"], "position")
    labels = list(pooled)
    frac = [pooled[k]["fraction_of_samples"] for k in labels]
    share = [pooled[k]["share_of_squared_error"] for k in labels]
    idx = np.arange(len(labels))
    ax.bar(idx - 0.2, np.array(frac) * 100, 0.4, label="share of samples")
    ax.bar(idx + 0.2, np.array(share) * 100, 0.4, label="share of squared position error")
    ax.set_xticks(idx, labels, rotation=35, ha="right", fontsize=7)
    ax.set(ylabel="%", title="Where the nominal model's position error concentrates (regimes overlap)")
    ax.legend(fontsize=8)
    return save(fig, path)


def cross_validation_table(cv: dict[str, Any]) -> str:
    """The leave-one-run-out table as markdown."""
    lines = [
        "| predicted run | fitted on | verdict | effects | position RMS, nominal | corrected |",
        "|---|---|---|---|---|---|",
    ]
    for f in cv["folds"]:
        # A carried candidate is in the predicting model, so the table says so, apart from the names.
        carried = [f"carries {f['carried']}"] if f.get("carried") else []
        effects = ", ".join(f["effects_found"] + carried) or "-"
        lines.append(
            f"| {f['held_out']} | {', '.join(f['fitted'])} | {f['verdict']} | {effects} | "
            f"{f['position_rms_nominal_m'] * 1e3:.3f} mm | {f['position_rms_corrected_m'] * 1e3:.3f} mm |"
        )
    if any(f.get("refitted_on_whole_files") for f in cv["folds"]):
        lines += [
            "",
            f"Each fold's model was chosen on the first {100 - round(HOLDOUT_FRACTION * 100)} % of each run it was "
            "fitted on (the rest held out for the verdict rules) and then refitted on the whole of those runs; the "
            "predicted run took no part.",
        ]
    return "\n".join(lines) + "\n"


OUTPUT_PATTERNS = (
    "diagnosis.md",
    "diagnosis.json",
    "corrected_model.json",
    "residuals_by_regime.png",
    "gap_by_round.png",
    "fit_*_*.png",
    "heldout_*_*.png",
)
"""Every file :func:`write_outputs` may write into its folder (glob patterns): what an
earlier diagnosis in the same folder left there and a new one replaces."""


def _trace_plot_path(out: Path, label: str, k: int, trace: MeasuredTrace) -> Path:
    return out / f"{label}_{k}_{Path(trace.name).stem}.png"


def output_paths(out: Path, fit_traces: Sequence[MeasuredTrace], heldout_traces: Sequence[MeasuredTrace]) -> list[Path]:
    """The files :func:`write_outputs` writes into ``out`` for these traces (known before
    the diagnosis runs, so that a command can refuse to write over one of its inputs)."""
    names = [out / name for name in OUTPUT_PATTERNS if "*" not in name]
    for label, traces in (("fit", fit_traces), ("heldout", heldout_traces)):
        names += [_trace_plot_path(out, label, k, trace) for k, trace in enumerate(traces)]
    return names


RECORD_KEY = "outputs"
"""The key of ``diagnosis.json`` that lists the files the run wrote into its folder."""


def previous_outputs(out: Path) -> list[Path]:
    """The files an earlier diagnosis wrote into ``out``: those its ``diagnosis.json`` lists,
    or (a run from before that list) those matching :data:`OUTPUT_PATTERNS`. Every run
    writes ``diagnosis.json``: a folder without one holds no earlier diagnosis, whatever its
    files are named."""
    record = out / "diagnosis.json"
    if not record.is_file():
        return []
    try:
        data = json.loads(record.read_text())
    except (OSError, ValueError):
        data = None
    if not isinstance(data, dict) or not {"verdict", "gap_before", "gap_after"} <= set(data):
        # Not a diagnosis's record (a file of the user's that shares the name): nothing here
        # is ours to remove, neither what it lists nor by a name pattern.
        return []
    listed = data.get(RECORD_KEY)
    if isinstance(listed, list) and all(isinstance(n, str) and Path(n).name == n for n in listed):
        return sorted(out / n for n in set(listed) | {"diagnosis.json"} if (out / n).is_file())
    return sorted({p for pattern in OUTPUT_PATTERNS for p in out.glob(pattern) if p.is_file()})


def write_outputs(
    result: Diagnosis,
    out: Path,
    fit_traces: Sequence[MeasuredTrace],
    heldout_traces: Sequence[MeasuredTrace],
    nominal: ModelConfig,
) -> dict[str, Path]:
    """Corrected model file, markdown report, JSON and plots into ``out``.

    Every file is written into a staging folder first and only then moved into ``out``
    (one rename each, the corrected model last), and the earlier run's files that this run
    does not write are removed after: an interrupt while writing leaves the earlier set
    whole (or, in a new folder, nothing), never a mix of two runs nor a corrected model
    without the report and JSON that justify it.
    """
    out.mkdir(parents=True, exist_ok=True)
    for leftover in out.glob(STAGING_PREFIX + "*"):
        shutil.rmtree(leftover, ignore_errors=True)  # a killed run's (the caller holds the folder's lock)
    earlier = previous_outputs(out)
    staging = out / f"{STAGING_PREFIX}{os.getpid()}"
    staging.mkdir()
    try:
        write_report(result, staging, fit_traces, heldout_traces, nominal, shown_out=out)
        names = sorted(p.name for p in staging.iterdir()) + ["diagnosis.json", "corrected_model.json"]
        # The code beside the verdicts: the nominal model changes between commits.
        record = {**result.as_dict(), "provenance": provenance(), RECORD_KEY: names}
        write_json(staging / "diagnosis.json", record, default=json_default)
        result.corrected_model.save(staging / "corrected_model.json")
        with signals_deferred():
            for name in names:
                os.replace(staging / name, out / name)  # the corrected model last (see names)
            # An earlier run's files that this one did not write would read as this run's.
            for stale in earlier:
                if stale.name not in names:
                    stale.unlink(missing_ok=True)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return {"model": out / "corrected_model.json", "json": out / "diagnosis.json", "report": out / "diagnosis.md"}


def json_default(value: Any) -> Any:
    """``json.dumps`` ``default=`` for the numpy scalars a diagnosis holds."""
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    if isinstance(value, np.bool_):
        return bool(value)
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
