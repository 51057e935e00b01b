"""Markdown tables and PNG plots of an evaluation (``sma-gym evaluate --out DIR``)."""

from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Sequence
from pathlib import Path, PurePosixPath, PureWindowsPath

from sma_gym._io import write_text
from sma_gym.electrical.multiplexer import io_counts
from sma_gym.plotting import new_figure, save
from sma_gym.provenance import describe, provenance
from sma_gym_agents.controllers import ALL_SPECS
from sma_gym_agents.evaluation import CHAPTER_8_CASES, ENDED_EARLY, STANDARD_STROKE_M, TABLE_6_1, Results


def _mm(value: float, signed: bool = True) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "osc."
    if isinstance(value, float) and math.isinf(value):
        return "never"
    return f"{value * 1e3:+.3f}" if signed else f"{value * 1e3:.3f}"


def _policies(results: Results, experiment: str) -> list[str]:
    return results.distinct(experiment, "policy")


def plot_groups(policies: Sequence[str]) -> dict[str, list[str]]:
    """Split policy names into the report's controllers (without / with feedforward), their
    self-sensing variants, and everything else (trained agents), which every plot shows."""
    labels = {s.label for s in ALL_SPECS}
    groups: dict[str, list[str]] = {"without_ff": [], "with_ff": [], "self_sensing": [], "agents": []}
    for p in policies:
        if p.endswith(" (self-sensing)") and p.removesuffix(" (self-sensing)") in labels:
            groups["self_sensing"].append(p)
        elif p in labels:
            groups["with_ff" if p.endswith(" + FF") else "without_ff"].append(p)
        else:
            groups["agents"].append(p)
    return groups


def table_6_1_markdown(results: Results, condition: str | None = None) -> str:
    """Table 6.1 for one condition (default: the one recorded, or ``"standard"`` among
    several), with the report's numbers in parentheses under ``"standard"`` only."""
    if condition is None:
        recorded = results.distinct("6.1", "condition")
        condition = recorded[0] if len(recorded) == 1 else "standard"
    scale = results.scales.get(condition, 1.0)
    scaled = (
        f"The report's 8 mm step and 1-7 mm sine at the same fractions of this actuator's usable stroke, "
        f"{scale * STANDARD_STROKE_M * 1e3:.2f} mm (the report's 9.5 mm): a step to {scale * 8:.2f} mm and a "
        f"sine from {scale * 1:.2f} to {scale * 7:.2f} mm."
    )
    lines = [
        f"### Table 6.1 ({condition} conditions): simulated" + (" (report)" if condition == "standard" else ""),
        "",
        *([] if scale == 1.0 else [scaled, ""]),
        "| controller | overshoot [mm] | steady-state error [mm] | max error heating [mm] | max error cooling [mm] | RMS step [mm] | RMS sine [mm] | energy sine [J] | worst RMS sine over seeds [mm] |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for p in _policies(results, "6.1"):
        try:
            v = {
                m: results.value("6.1", p, condition, ref, m)
                for ref, m in (
                    ("step", "overshoot_m"),
                    ("step", "steady_state_error_m"),
                    ("sine", "max_error_heating_m"),
                    ("sine", "max_error_cooling_m"),
                    ("sine", "energy_j"),
                )
            }
        except KeyError:
            continue  # not run under this condition, or ended early (listed below the table)
        rep = TABLE_6_1.get(p) if condition == "standard" else None

        def pair(key: str, idx: int, signed: bool = True, v: dict = v, rep: tuple | None = rep) -> str:
            sim = _mm(v[key], signed)
            if rep is None:
                return sim
            ref = "osc." if rep[idx] is None else f"{rep[idx]:+.3f}" if signed else f"{rep[idx]:.3f}"
            return f"{sim} ({ref})"

        lines.append(
            f"| {p} | {pair('overshoot_m', 0, False)} | {pair('steady_state_error_m', 1)} | "
            f"{pair('max_error_heating_m', 2)} | {pair('max_error_cooling_m', 3)} | "
            f"{_mm(results.value('6.1', p, condition, 'step', 'rms_error_m'), False)} | "
            f"{_mm(results.value('6.1', p, condition, 'sine', 'rms_error_m'), False)} | "
            f"{results.value('6.1', p, condition, 'sine', 'energy_j'):.2f} | "
            f"{_mm(results.value('6.1', p, condition, 'sine', 'rms_error_m', worst=True), False)} |"
        )
    return "\n".join(lines + ended_early_lines(results, "6.1", condition))


def ended_early_lines(results: Results, experiment: str, condition: str) -> list[str]:
    """A note naming each policy whose episode overheated under ``condition`` (that run has no
    other metrics), and when; empty when none did."""
    ended = [
        f"{r.policy} ({r.reference}, at {r.value:.3f} s)"
        for r in results.records
        if (r.experiment, r.condition, r.metric) == (experiment, condition, ENDED_EARLY)
    ]
    if not ended:
        return []
    return ["", f"Ended early, the wire overheated (the env's overheat limit): {', '.join(ended)}."]


def _ended_cell(results: Results, experiment: str, policy: str, condition: str, reference: str) -> str:
    """A table cell for a run with no metrics: when it overheated, else empty (not run)."""
    try:
        return f"overheated at {results.value(experiment, policy, condition, reference, ENDED_EARLY):.3f} s"
    except KeyError:
        return ""


def chapter_7_markdown(results: Results) -> str:
    conditions = results.distinct("7", "condition")
    lines = ["### Chapter 7: robustness (not retuned)", ""]
    for metric, ref, title in (
        ("rms_error_m", "sine", "RMS error on the 0.1 Hz sine [mm] (mean over seeds, worst in parentheses)"),
        ("overshoot_m", "step", "overshoot of the 8 mm step [mm]"),
        ("steady_state_error_m", "step", "steady-state error of the 8 mm step [mm]"),
        ("max_error_heating_m", "sine", "largest sine error while heating [mm]"),
        ("max_error_cooling_m", "sine", "largest sine error while cooling [mm]"),
    ):
        lines += [f"{title}", "", "| controller | " + " | ".join(conditions) + " |", "|---|" + "---|" * len(conditions)]
        for p in _policies(results, "7"):
            cells = []
            for c in conditions:
                try:
                    value = results.value("7", p, c, ref, metric)
                    cell = _mm(value, metric != "rms_error_m" and metric != "overshoot_m")
                    if metric == "rms_error_m":
                        cell += f" ({_mm(results.value('7', p, c, ref, metric, worst=True), False)})"
                    cells.append(cell)
                except KeyError:
                    cells.append(_ended_cell(results, "7", p, c, ref))
            lines.append(f"| {p} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


def chapter_8_markdown(results: Results) -> str:
    policies = _policies(results, "8")
    lines = [
        "### Chapter 8: efficiency of 1 -> 7 mm strokes [%] (Tables 8.1, 8.2)",
        "",
        "| case | report | " + " | ".join(policies) + " |",
        "|---|---|" + "---|" * len(policies),
    ]
    for label, _, _, report in CHAPTER_8_CASES:
        cells = []
        for p in policies:
            try:
                value = results.value("8", p, label, "1 -> 7 mm", "efficiency_percent")
                cells.append("not reached" if math.isnan(value) else f"{value:.3f}")
            except KeyError:
                cells.append(_ended_cell(results, "8", p, label, "1 -> 7 mm"))
        lines.append(f"| {label} | {report:.2f} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def chapter_9_markdown(results: Results) -> str:
    rows = [r for r in results.records if r.experiment == "9" and r.metric == "rise_time_s"]
    lines = [
        "### Chapter 9: multiplexed 3 mm step (rise time to 90 %, oscillation about its trend line over the last 2 s)",
        "",
        "| policy | condition | rise time [s] | p2p oscillation [mm] | overshoot [mm] |",
        "|---|---|---|---|---|",
    ]
    for r in rows:
        p2p = results.value("9", r.policy, r.condition, r.reference, "oscillation_p2p_m")
        over = results.value("9", r.policy, r.condition, r.reference, "overshoot_m")
        rise = "never" if math.isinf(r.value) else f"{r.value:.2f}"
        lines.append(f"| {r.policy} | {r.condition} | {rise} | {p2p * 1e3:.3f} | {over * 1e3:.3f} |")
    lines += [
        "",
        "Table 9.1: I/O counts",
        "",
        "| actuators | AI without | AI with | DO without | DO with |",
        "|---|---|---|---|---|",
    ]
    for n in (2, 4, 8, 16):
        c = io_counts(n)
        lines.append(
            f"| {n} | {c['analog_inputs_without']} | {c['analog_inputs_with']} | {c['digital_outputs_without']} | {c['digital_outputs_with']} |"
        )
    return "\n".join(lines)


def bank_markdown(results: Results) -> str:
    """The multiplexed bank's tables (issue 16): the bank step (experiment ``"9 bank"``) and
    tracking on independent references (``"9 bank tracking"``), each a mean over seeds with
    the worst seed in parentheses, lengths in mm."""

    def cell(experiment: str, r, metric: str, scale: float = 1e3) -> str:
        mean = results.value(experiment, r.policy, r.condition, r.reference, metric)
        worst = results.value(experiment, r.policy, r.condition, r.reference, metric, worst=True)
        if math.isinf(mean):
            return "never"
        return f"{mean * scale:.3f} ({worst * scale:.3f})"

    lines: list[str] = []
    steps = [r for r in results.records if r.experiment == "9 bank" and r.metric == "rise_time_s"]
    if steps:
        lines += [
            "### The bank step: one actuator 0 -> 8 mm while the others hold (mean over seeds, worst in parentheses)",
            "",
            "| policy | condition | rise to 90 % [s] | to 50 % [s] | holders' worst error [mm] |",
            "|---|---|---|---|---|",
        ]
        for r in steps:
            rise, half = (cell("9 bank", r, m, 1.0) for m in ("rise_time_s", "half_rise_time_s"))
            lines.append(
                f"| {r.policy} | {r.condition} | {rise} | {half} | {cell('9 bank', r, 'holders_max_error_m')} |"
            )
        lines.append("")
    tracking = [
        r for r in results.records if r.experiment == "9 bank tracking" and r.metric in ("rms_error_m", ENDED_EARLY)
    ]
    if tracking:
        lines += [
            "### The bank on independent references (RMS tracking error, mean over seeds, worst in parentheses)",
            "",
            "| policy | condition | RMS [mm] | energy [J] |",
            "|---|---|---|---|",
        ]
        for r in tracking:
            if r.metric == ENDED_EARLY:
                lines.append(f"| {r.policy} | {r.condition} | overheated at {r.value:.3f} s | |")
                continue
            energy = results.value("9 bank tracking", r.policy, r.condition, r.reference, "energy_j")
            lines.append(f"| {r.policy} | {r.condition} | {cell('9 bank tracking', r, 'rms_error_m')} | {energy:.1f} |")
    return "\n".join(lines).rstrip()


def _plot_responses(
    results: Results,
    experiment: str,
    condition: str,
    reference: str,
    policies: Sequence[str],
    title: str,
    out: Path,
    error_limit_mm: float = 1.5,
) -> Path | None:
    """Position, error and duty of ``policies``; None (no file) when none of them ran there."""
    traced = [
        (p, results.traces[(experiment, p, condition, reference)])
        for p in policies
        if (experiment, p, condition, reference) in results.traces
    ]
    if not traced:
        return None
    fig, axes = new_figure(3, 1, size=(8, 8))
    for p, trace in traced:
        t = trace.t
        axes[0, 0].plot(t, trace["position_m"][:, 0] * 1e3, label=p)
        axes[1, 0].plot(t, (trace["reference_m"][:, 0] - trace["position_m"][:, 0]) * 1e3, label=p)
        axes[2, 0].plot(t, trace["duty"][:, 0], label=p, lw=0.8)
        ref = trace["reference_m"][:, 0]
    if "ref" in locals():
        axes[0, 0].plot(t, ref * 1e3, "k--", lw=1, label="reference")
    axes[0, 0].set(ylabel="position [mm]", title=title)
    axes[1, 0].set(ylabel="error r - x [mm]")
    axes[1, 0].set_ylim(-error_limit_mm, error_limit_mm)
    axes[2, 0].set(ylabel="duty [-]", xlabel="time [s]")
    axes[0, 0].legend(fontsize=7)
    return save(fig, out)


def condition_slug(condition: str) -> str:
    """``condition`` as part of a file name: a model given by its path keeps only the file's
    name (its folders made names like ``table6_1_model_home_me_runs_..._corrected_model.json``,
    and a deep one longer than the 255 bytes a file name may have: the report failed after
    all the work), characters other than letters, digits, '.' and '-' become '_', and a name
    still longer than 80 characters is cut with a digest of the whole condition."""
    shown = condition
    head, sep, label = condition.partition("model ")
    if sep and ("/" in label or "\\" in label):
        label = PureWindowsPath(label).name if "\\" in label else PurePosixPath(label).name
        shown = f"{head}{sep}{label}"
    slug = re.sub(r"[^A-Za-z0-9.-]+", "_", shown).strip("_.") or "condition"
    if len(slug) > 80:
        slug = f"{slug[:60].rstrip('_.')}_{hashlib.sha256(condition.encode()).hexdigest()[:8]}"
    return slug


def write_report(results: Results, out: Path) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    paths: list[Path] = []
    sections = [
        "# Evaluation",
        "",
        "Simulated values, with the report's in parentheses where it gives them; a table whose title says so "
        "has the worst over seeds there instead (the report gives one run).",
        "",
        *[f"Note: {note}\n" for note in results.notes],
    ]
    policies_61 = _policies(results, "6.1")
    conditions_61 = results.distinct("6.1", "condition")
    for condition in conditions_61:
        sections += [table_6_1_markdown(results, condition), ""]
    groups = plot_groups(policies_61)
    if "standard" in conditions_61:
        # Figs. 6.2/6.3 without feedforward, 6.5/6.6 with it.
        for group, figures, title, suffix in (
            ("without_ff", (("step", "6_2"), ("sine", "6_3")), "{} response (cf. fig. {})", ""),
            (
                "with_ff",
                (("step", "6_5"), ("sine", "6_6")),
                "{} response with feedforward (cf. fig. {})",
                "_feedforward",
            ),
        ):
            for refname, fig in figures:
                paths.append(
                    _plot_responses(
                        results,
                        "6.1",
                        "standard",
                        refname,
                        groups[group] + groups["agents"],
                        title.format(refname, fig.replace("_", ".")),
                        out / f"fig{fig}_{refname}{suffix}.png",
                    )
                )
    if "self-sensing" in conditions_61:
        for refname in ("step", "sine"):
            paths.append(
                _plot_responses(
                    results,
                    "6.1",
                    "self-sensing",
                    refname,
                    groups["without_ff"] + groups["with_ff"] + groups["self_sensing"] + groups["agents"],
                    f"self-sensing, {refname}",
                    out / f"self_sensing_{refname}.png",
                )
            )
    # Any other condition (an actuator of the user's own, or an agent's model): its policies'
    # step and sine, so that every table has its figure.
    slugs: set[str] = set()
    for condition in conditions_61:
        if condition in ("standard", "self-sensing"):
            continue
        slug = condition_slug(condition)
        while slug in slugs:
            slug += "_"
        slugs.add(slug)
        for refname in ("step", "sine"):
            paths.append(
                _plot_responses(
                    results,
                    "6.1",
                    condition,
                    refname,
                    policies_61,
                    f"{refname} response, {condition}",
                    out / f"table6_1_{slug}_{refname}.png",
                    # The errors of a longer stroke at the same fractions of it are larger.
                    error_limit_mm=1.5 * max(1.0, results.scales.get(condition, 1.0)),
                )
            )
    if _policies(results, "7"):
        sections += [chapter_7_markdown(results), ""]
        conditions = sorted({r.condition for r in results.records if r.experiment == "7"})
        for c in conditions:
            slug = c.replace(" ", "_").replace(".", "")
            paths.append(
                _plot_responses(
                    results,
                    "7",
                    c,
                    "step",
                    _policies(results, "7"),
                    f"step, {c} (cf. figs. 7.1-7.9)",
                    out / f"chapter7_{slug}_step.png",
                )
            )
            paths.append(
                _plot_responses(
                    results,
                    "7",
                    c,
                    "sine",
                    _policies(results, "7"),
                    f"sine, {c} (cf. figs. 7.2-7.10)",
                    out / f"chapter7_{slug}_sine.png",
                )
            )
    if _policies(results, "8"):
        sections += [chapter_8_markdown(results), ""]
    if _policies(results, "9"):
        sections += [chapter_9_markdown(results), ""]
        fig, axes = new_figure(1, 1, size=(8, 4.5))
        for key, trace in results.traces.items():
            if key[0] == "9" and ("2000 Hz" in key[2]):
                x = trace["position_m"]
                x0 = x[:, 0, 0] if x.ndim == 3 else x[:, 0]
                axes[0, 0].plot(trace.t, x0 * 1e3, label=f"{key[1]}: {key[2]}")
        axes[0, 0].set(
            xlabel="time [s]", ylabel="position [mm]", title="Multiplexed step responses (cf. figs. 9.1-9.3)"
        )
        axes[0, 0].legend(fontsize=7)
        paths.append(save(fig, out / "fig9_multiplexed.png"))
    if _policies(results, "9 bank") or _policies(results, "9 bank tracking"):
        sections += [bank_markdown(results), ""]
    # The nominal model changes under the same env ids: the report names the code it measured.
    sections += [f"Code: {describe(provenance())}."]
    md = out / "evaluation.md"
    write_text(md, "\n".join(sections) + "\n")
    write_text(out / "evaluation.json", results.to_json() + "\n")
    return [md, out / "evaluation.json", *(p for p in paths if p is not None)]
