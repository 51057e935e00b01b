"""The full fidelity table: every result of the report against the simulator.

``sma-gym fidelity [--out DIR] [--json] [--quick]`` (or :func:`run`) runs the plant
experiments of :mod:`sma_gym.fidelity` and the evaluation harness
(:mod:`sma_gym_agents.evaluation`) with the report's controllers, and answers each of the 125
targets of :mod:`sma_gym.report_targets` with one row:

* Table 6.1 (B1-B40) and the chapter-6 statements (Q1-Q10): the ten controllers on the
  report's 8 mm step and 0.1 Hz sine, standard conditions;
* chapter 7 (7a-7s): PID, VSC3, VSC4 with and without feedforward under forced
  convection, 5 V, 15 V, 0.2 mm and 0.5 mm wire (standard from Table 6.1's runs);
* chapter 8 (8a-8j, 8l): the PID on the harness's 1 -> 7 mm steps and ramps, noise-free;
* chapter 9 (9e-9q): the PID on the multiplexed env, 3 mm step, noise-free.

Rows are computed from whatever the model is; nothing here knows today's numbers. The
words the report uses for its qualitative statements are read with the fixed meanings of
:mod:`sma_gym.fidelity` (``VISIBLE_ERROR_MM``, ``NO_OVERSHOOT_MM``, ``SIGNIFICANT_CHANGE``).

Runtime on 2 shared cores: full about 3 minutes (three sensor-noise seeds), ``quick``
about 1-1.5 minutes (one seed, two sine periods instead of three, a shorter chapter-9
sweep). The report's controllers run side by side in one vector env
(:func:`sma_gym_agents.evaluation.rollouts`: the same traces as one at a time).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from sma_gym import fidelity
from sma_gym.fidelity import (
    NO_OVERSHOOT_MM,
    SIGNIFICANT_CHANGE,
    VISIBLE_ERROR_MM,
    FidelityResult,
    Row,
    fmt,
    make_row,
    numeric_row,
    ratio,
)
from sma_gym.report_targets import target, within_factor, within_tolerance
from sma_gym_agents.controllers import PID
from sma_gym_agents.evaluation import (
    CHAPTER_7_CONDITIONS,
    CHAPTER_7_SPECS,
    CHAPTER_8_CASES,
    CHAPTER_9_FREQUENCIES,
    OSCILLATION_P2P_M,
    SINE_SECONDS,
    SINE_WINDOW_S,
    TABLE_6_1,
    Results,
    Trace,
    baseline,
    chapter_9_label,
    default_entries,
    run_chapter_7,
    run_chapter_8,
    run_chapter_9,
    run_table_6_1,
)


@dataclass(frozen=True)
class RunPlan:
    """How much to simulate: seeds, sine length and chapter 9's frequency sweep."""

    seeds: tuple[int, ...]
    sine_seconds: float
    chapter_9_sweep: tuple[tuple[int, tuple[float, ...]], ...]
    """(number of actuators, cycling frequencies swept at 10 V)."""

    def frequencies(self, n: int) -> tuple[float, ...]:
        return dict(self.chapter_9_sweep)[n]


FULL = RunPlan(
    seeds=(0, 1, 2), sine_seconds=SINE_SECONDS, chapter_9_sweep=tuple((n, CHAPTER_9_FREQUENCIES) for n in (1, 8, 16))
)
QUICK = RunPlan(
    seeds=(0,),
    sine_seconds=SINE_WINDOW_S[0] + 10.0,
    chapter_9_sweep=(
        (1, (100.0, 500.0, 2000.0, 3000.0, 4000.0)),
        (8, (100.0, 500.0, 2000.0, 3000.0, 4000.0)),
        (16, (2000.0, 3000.0)),
    ),
)
"""One seed, two sine periods (the first is the transient either way), a shorter chapter-9
sweep (16 actuators, 25 s each, are the slowest runs)."""

CH9_COUNT_CONDITIONS = (
    (1, 2000.0, 10.0),
    (8, 2000.0, 10.0),
    (16, 2000.0, 10.0),
    (16, 2000.0, 15.0),
    (16, 2000.0, 20.0),
)
WIGGLE_WINDOW_S = 0.2
"""Oscillation = RMS of the position about its 0.2 s moving average (removes the 10 s sine)."""


def chapter_9_conditions(plan: RunPlan) -> tuple[tuple[int, float, float], ...]:
    sweep = tuple((n, f, 10.0) for n, freqs in plan.chapter_9_sweep for f in freqs)
    return CH9_COUNT_CONDITIONS + tuple(c for c in sweep if c not in CH9_COUNT_CONDITIONS)


def run_harness(plan: RunPlan) -> Results:
    """Table 6.1 and chapters 7-9 with the report's controllers."""
    results = Results()
    run_table_6_1(default_entries(), results, plan.seeds, sine_seconds=plan.sine_seconds)
    run_chapter_7(
        [baseline(s) for s in CHAPTER_7_SPECS],
        results,
        plan.seeds,
        CHAPTER_7_CONDITIONS[1:],
        sine_seconds=plan.sine_seconds,
    )
    run_chapter_8([baseline(PID)], results, seeds=(0,), noise_m=0.0)
    run_chapter_9([baseline(PID)], results, conditions=chapter_9_conditions(plan), noise_m=0.0)
    return results


# --------------------------------------------------------------------------------------
# Reading the harness's results
# --------------------------------------------------------------------------------------
class Metrics:
    """Step and sine metrics of the step-and-sine experiments, lengths in mm."""

    def __init__(self, results: Results, sine_window_s: tuple[float, float]):
        self.results = results
        self.sine_window_s = sine_window_s

    @staticmethod
    def _key(condition: str) -> str:
        return "6.1" if condition == "standard" else "7"

    def __call__(self, policy: str, metric: str, reference: str = "step", condition: str = "standard") -> float:
        value = self.results.value(self._key(condition), policy, condition, reference, metric)
        return value * 1e3 if metric.endswith("_m") else value

    def change(self, policy: str, metric: str, reference: str, condition: str) -> float:
        """|metric| under ``condition`` over |metric| under standard conditions."""
        return ratio(abs(self(policy, metric, reference, condition)), abs(self(policy, metric, reference)))

    def wiggle_mm(self, policy: str, condition: str, heating: bool) -> float:
        """Oscillation while the sine reference rises (or falls), mean over seeds [mm]."""
        trace = self.results.traces[(self._key(condition), policy, condition, "sine")]
        return wiggle_mm(trace, heating, self.sine_window_s)


def wiggle_mm(trace: Trace, heating: bool, window_s: tuple[float, float]) -> float:
    """RMS of the position about its 0.2 s centred moving average while r rises (falls) [mm]."""
    from scipy.ndimage import uniform_filter1d

    x, r, t = trace["position_m"], trace["reference_m"], trace.t
    dt = t[1] - t[0]
    smooth = uniform_filter1d(x, size=max(3, int(round(WIGGLE_WINDOW_S / dt))), axis=0, mode="nearest")
    rate = np.gradient(r, axis=0)
    w = ((t >= window_s[0]) & (t <= window_s[1]))[:, None] & ((rate > 0) if heating else (rate < 0))
    hp = (x - smooth) ** 2
    return float(np.mean([math.sqrt(hp[w[:, j], j].mean()) for j in range(x.shape[1])])) * 1e3


def _ordered(values: Sequence[float], increasing: bool = True) -> bool:
    pairs = zip(values, values[1:])
    return all((a < b) if increasing else (a > b) for a, b in pairs)


def _sse_exists(value_mm: float) -> bool:
    return math.isfinite(value_mm) and abs(value_mm) > VISIBLE_ERROR_MM


def _sse_absent(value_mm: float) -> bool:
    return math.isfinite(value_mm) and abs(value_mm) <= VISIBLE_ERROR_MM


def _sse_text(value_mm: float) -> str:
    return "oscillates" if not math.isfinite(value_mm) else f"{value_mm:+.3f}"


# --------------------------------------------------------------------------------------
# Table 6.1 (B1-B40) and the chapter-6 statements (Q1-Q10)
# --------------------------------------------------------------------------------------
TABLE_6_1_HOW = "Table 6.1 protocol of sma_gym_agents.evaluation (8 mm step at 0.5 s; 0.1 Hz 1 -> 7 mm sine, last two periods), mean over seeds"


def table_6_1_rows(m: Metrics) -> list[Row]:
    rows = []
    for k, label in enumerate(TABLE_6_1):
        ids = [f"B{4 * k + j}" for j in range(1, 5)]
        rows.append(numeric_row(ids[0], m(label, "overshoot_m"), "mm", f"{label}: {TABLE_6_1_HOW}"))
        sse = m(label, "steady_state_error_m")
        if not target(ids[1]).numbers:  # "osc.": the statement is that it oscillates
            p2p = m(label, "oscillation_p2p_m")
            rows.append(
                make_row(
                    ids[1],
                    f"{_sse_text(sse)} (p2p {fmt(p2p)} mm)",
                    not math.isfinite(sse),
                    f"{label}: {TABLE_6_1_HOW}",
                    f"oscillates: > {OSCILLATION_P2P_M * 1e3:g} mm peak to peak about the trend line over the last second",
                )
            )
        else:
            rows.append(
                make_row(ids[1], f"{_sse_text(sse)} mm", target(ids[1]).within(sse), f"{label}: {TABLE_6_1_HOW}")
            )
        rows.append(numeric_row(ids[2], m(label, "max_error_heating_m", "sine"), "mm", f"{label}: {TABLE_6_1_HOW}"))
        rows.append(numeric_row(ids[3], m(label, "max_error_cooling_m", "sine"), "mm", f"{label}: {TABLE_6_1_HOW}"))
    return rows


def statement_rows(m: Metrics) -> list[Row]:
    """Q1-Q10: the chapter-6 statements on the same runs."""
    over = {label: m(label, "overshoot_m") for label in TABLE_6_1}
    sse = {label: m(label, "steady_state_error_m") for label in TABLE_6_1}
    heat = {label: m(label, "max_error_heating_m", "sine") for label in TABLE_6_1}
    cool = {label: m(label, "max_error_cooling_m", "sine") for label in TABLE_6_1}
    sine_sum = {label: abs(heat[label]) + abs(cool[label]) for label in TABLE_6_1}
    rows = [
        make_row(
            "Q1",
            f"overshoot {fmt(over['VSC3'])} mm, steady-state error {_sse_text(sse['VSC3'])} mm",
            over["VSC3"] <= NO_OVERSHOOT_MM and _sse_exists(sse["VSC3"]),
            "VSC3, Table 6.1 step",
            f"overshoot <= {NO_OVERSHOOT_MM:g} mm and |error| > {VISIBLE_ERROR_MM:g} mm",
        ),
        make_row(
            "Q2",
            f"VSC4 error {_sse_text(sse['VSC4'])} mm (VSC3 {_sse_text(sse['VSC3'])}), overshoot {fmt(over['VSC4'])} mm (VSC3 {fmt(over['VSC3'])})",
            _sse_absent(sse["VSC4"]) and _sse_exists(sse["VSC3"]) and over["VSC4"] > over["VSC3"],
            "VSC4 against VSC3, Table 6.1 step",
            f"VSC4 |error| <= {VISIBLE_ERROR_MM:g} mm where VSC3's exceeds it, and VSC4 overshoots more",
        ),
        make_row(
            "Q3",
            f"VSC3 {_sse_text(sse['VSC3'])} mm -> VSC3 + FF {_sse_text(sse['VSC3 + FF'])} mm",
            _sse_exists(sse["VSC3"]) and _sse_absent(sse["VSC3 + FF"]),
            "Table 6.1 step",
            f"VSC3 |error| > {VISIBLE_ERROR_MM:g} mm, with feedforward <= {VISIBLE_ERROR_MM:g} mm",
        ),
        make_row(
            "Q4",
            " > ".join(f"{c} {fmt(over[c])}" for c in ("PID", "VSC2", "VSC4", "VSC3")) + " mm",
            _ordered([over[c] for c in ("PID", "VSC2", "VSC4", "VSC3")], increasing=False),
            "Table 6.1 step overshoots",
            "strict ordering",
        ),
    ]
    changes = {c: (over[c], over[c + " + FF"]) for c in ("PID", "VSC1", "VSC2")}
    rows.append(
        make_row(
            "Q5",
            ", ".join(f"{c} {fmt(a)} -> {fmt(b)} mm" for c, (a, b) in changes.items()),
            all(within_tolerance("overshoot", b, a) for a, b in changes.values()),
            "overshoot without -> with feedforward",
            "each within the overshoot tolerance (+-30 % or +-0.05 mm) of the one without",
        )
    )
    rows.append(
        make_row(
            "Q6",
            ", ".join(f"{c} {heat[c]:+.3f} -> {heat[c + ' + FF']:+.3f} mm" for c in ("VSC2", "VSC3")),
            all(abs(heat[c + " + FF"]) < abs(heat[c]) for c in ("VSC2", "VSC3")),
            "sine heating error without -> with feedforward",
            "|error| smaller with feedforward, both",
        )
    )
    rows.append(
        make_row(
            "Q7",
            f"VSC4 {cool['VSC4']:+.3f} -> {cool['VSC4 + FF']:+.3f} mm",
            abs(cool["VSC4 + FF"]) <= (1.0 - SIGNIFICANT_CHANGE) * abs(cool["VSC4"]),
            "sine cooling error without -> with feedforward",
            f"|error| at least {SIGNIFICANT_CHANGE:.0%} smaller",
        )
    )
    rows.append(
        make_row(
            "Q8",
            f"PID heating {heat['PID']:+.3f} mm, cooling {cool['PID']:+.3f} mm",
            abs(heat["PID"]) < abs(cool["PID"]),
            "PID sine: the cooling error follows the top reversal",
            "|heating error| < |cooling error|",
        )
    )
    rows.append(
        make_row(
            "Q9",
            f"VSC2 {cool['VSC2']:+.3f} mm, PID {cool['PID']:+.3f} mm",
            abs(cool["VSC2"]) < abs(cool["PID"]),
            "sine cooling errors",
            "|VSC2| < |PID|",
        )
    )
    best = min(sine_sum, key=sine_sum.get)
    rows.append(
        make_row(
            "Q10",
            f"VSC3 + FF: overshoot {fmt(over['VSC3 + FF'])} mm, error {_sse_text(sse['VSC3 + FF'])} mm, "
            f"|heat| + |cool| {fmt(sine_sum['VSC3 + FF'])} mm (best: {best} {fmt(sine_sum[best])})",
            over["VSC3 + FF"] <= NO_OVERSHOOT_MM and _sse_absent(sse["VSC3 + FF"]) and best == "VSC3 + FF",
            "§6.6: neither overshoot nor steady-state error, sine tracking not surpassed (Table 6.1's two sine errors summed)",
            f"overshoot <= {NO_OVERSHOOT_MM:g} mm, |error| <= {VISIBLE_ERROR_MM:g} mm, smallest sine error sum of the ten",
        )
    )
    return rows


# --------------------------------------------------------------------------------------
# Chapter 7 (7a-7s)
# --------------------------------------------------------------------------------------
TRIO = ("PID", "VSC3", "VSC4")
TRIO_FF = tuple(c + " + FF" for c in TRIO)
CONDITIONS = tuple(label for label, _ in CHAPTER_7_CONDITIONS)


def _table_change_mm(m: Metrics, policy: str, condition: str) -> float:
    """Sum of the absolute changes of Table 6.1's four numbers from standard to ``condition``."""
    total = 0.0
    for metric, reference in (
        ("overshoot_m", "step"),
        ("steady_state_error_m", "step"),
        ("max_error_heating_m", "sine"),
        ("max_error_cooling_m", "sine"),
    ):
        total += abs(m(policy, metric, reference, condition) - m(policy, metric, reference))
    return total if math.isfinite(total) else math.inf  # an oscillation counts as the largest change


def _chapter_7_fan_rows(m: Metrics) -> list[Row]:
    """7a-7f: forced convection (a fan) against standard."""
    fan = CONDITIONS[1]
    rows = []
    change = {c: _table_change_mm(m, c, fan) for c in TRIO + TRIO_FF}
    rows.append(
        make_row(
            "7a",
            ", ".join(f"{c} {fmt(v)}" for c, v in change.items()) + " mm",
            all(change[p] < min(change[c] for c in group[1:]) for p, group in (("PID", TRIO), ("PID + FF", TRIO_FF))),
            "fan: sum of the absolute changes of Table 6.1's four numbers from standard",
            "PID's change the smallest of the three, without and with feedforward",
        )
    )
    s = {c: m(c, "steady_state_error_m", condition=fan) for c in TRIO + TRIO_FF}
    rows.append(
        make_row(
            "7b",
            f"VSC3 {_sse_text(s['VSC3'])}, VSC3 + FF {_sse_text(s['VSC3 + FF'])} mm",
            _sse_exists(s["VSC3"]) and _sse_exists(s["VSC3 + FF"]),
            "fan, step",
            f"both |error| > {VISIBLE_ERROR_MM:g} mm",
        )
    )
    rows.append(
        make_row(
            "7c",
            f"VSC4 {_sse_text(s['VSC4'])}, VSC4 + FF {_sse_text(s['VSC4 + FF'])} mm",
            _sse_exists(s["VSC4"]) and _sse_absent(s["VSC4 + FF"]),
            "fan, step",
            f"|error| > {VISIBLE_ERROR_MM:g} mm without feedforward, <= with",
        )
    )
    fall = {c: m.change(c, "max_error_cooling_m", "sine", fan) for c in ("PID", "VSC4")}
    rows.append(
        make_row(
            "7d",
            ", ".join(f"{c} x{fmt(v)}" for c, v in fall.items()),
            all(v <= 1.0 - SIGNIFICANT_CHANGE for v in fall.values()) and fall["VSC4"] < fall["PID"],
            "fan against standard: |sine cooling error| ratio",
            f"both at most {1 - SIGNIFICANT_CHANGE:g}x, VSC4's the larger fall",
        )
    )
    rise = {c: m.change(c, "max_error_heating_m", "sine", fan) for c in ("VSC3", "VSC4")}
    rows.append(
        make_row(
            "7e",
            ", ".join(f"{c} x{fmt(v)}" for c, v in rise.items()),
            all(v >= 1.0 + SIGNIFICANT_CHANGE for v in rise.values()),
            "fan against standard: |sine heating error| ratio",
            f"both at least {1 + SIGNIFICANT_CHANGE:g}x",
        )
    )
    o = {c: m(c, "overshoot_m", condition=fan) for c in TRIO}
    rows.append(
        make_row(
            "7f",
            ", ".join(f"{c} {fmt(v)}" for c, v in o.items()) + " mm overshoot",
            o["PID"] > max(o["VSC3"], o["VSC4"]) + NO_OVERSHOOT_MM,
            "fan, step",
            f"PID's overshoot exceeds both VSCs' by more than {NO_OVERSHOOT_MM:g} mm",
        )
    )
    return rows


def _chapter_7_low_supply_rows(m: Metrics) -> list[Row]:
    """7g-7j: a 5 V supply against standard."""
    low = CONDITIONS[2]
    rows = []
    grow = {c: m(c, "rise_time_s", condition=low) - m(c, "rise_time_s") for c in TRIO}
    spread = max(grow.values()) - min(grow.values())
    rows.append(
        make_row(
            "7g",
            ", ".join(f"{c} +{fmt(v)} s" for c, v in grow.items()),
            all(math.isfinite(v) for v in grow.values())
            and spread <= SIGNIFICANT_CHANGE * float(np.mean(list(grow.values()))),
            "5 V against standard: growth of the rise time to 90 %",
            f"the three growths within {SIGNIFICANT_CHANGE:.0%} of their mean of each other",
        )
    )
    rows.append(
        make_row(
            "7h",
            f"PID overshoot {fmt(m('PID', 'overshoot_m'))} -> {fmt(m('PID', 'overshoot_m', condition=low))} mm",
            m("PID", "overshoot_m", condition=low) < m("PID", "overshoot_m"),
            "standard -> 5 V",
            "smaller at 5 V",
        )
    )
    s = {c: m(c, "steady_state_error_m", condition=low) for c in ("VSC3", "VSC4")}
    rows.append(
        make_row(
            "7i",
            ", ".join(f"{c} {_sse_text(v)}" for c, v in s.items()) + " mm",
            all(_sse_exists(v) for v in s.values()),
            "5 V, step",
            f"both |error| > {VISIBLE_ERROR_MM:g} mm",
        )
    )
    worse = {c: m.change(c, "rms_error_m", "sine", low) for c in TRIO}
    rows.append(
        make_row(
            "7j",
            ", ".join(f"{c} x{fmt(v)}" for c, v in worse.items()),
            worse["VSC3"] >= 2.0 and worse["VSC4"] >= 2.0 and 1.0 <= worse["PID"] <= 1.0 + 2 * SIGNIFICANT_CHANGE,
            "5 V against standard: sine RMS error ratio",
            f"'very bad': VSCs at least 2x; 'slightly worse': PID in [1, {1 + 2 * SIGNIFICANT_CHANGE:g}]x",
        )
    )
    return rows


def _chapter_7_high_supply_rows(m: Metrics) -> list[Row]:
    """7k-7m: a 15 V supply."""
    high = CONDITIONS[3]
    rows = []
    o = {c: m(c, "overshoot_m", condition=high) for c in TRIO}
    vsc_ratio = ratio(o["PID"], float(np.mean([o["VSC3"], o["VSC4"]])))
    rows.append(
        make_row(
            "7k",
            ", ".join(f"{c} {fmt(v)}" for c, v in o.items()) + f" mm overshoot (PID / VSC mean {fmt(vsc_ratio)})",
            o["VSC3"] > 0.0 and o["VSC4"] > 0.0 and within_factor(vsc_ratio, 4.0, 1.5),
            "15 V, step",
            "VSCs overshoot (> 0) and PID / mean VSC overshoot within a factor 1.5 of 4",
        )
    )
    wig = {c: (m.wiggle_mm(c, high, True), m.wiggle_mm(c, high, False)) for c in TRIO}
    errs = {
        c: (abs(m(c, "max_error_heating_m", "sine", high)), abs(m(c, "max_error_cooling_m", "sine", high)))
        for c in TRIO
    }
    rows.append(
        make_row(
            "7l",
            ", ".join(f"{c} {fmt(h)}/{fmt(k)}" for c, (h, k) in wig.items()) + " mm oscillation heating/cooling",
            all(h > 2.0 * k for h, k in wig.values()) and all(h > k for h, k in errs.values()),
            "15 V sine: RMS of x about its 0.2 s moving average while heating / cooling, and the max errors",
            "each: heating oscillation > 2x cooling's, and |heating error| > |cooling error|",
        )
    )
    deg = {
        c: (abs(m(c, "max_error_cooling_m", "sine", high)), abs(m(c + " + FF", "max_error_cooling_m", "sine", high)))
        for c in TRIO
    }
    rows.append(
        make_row(
            "7m",
            ", ".join(f"{c} {fmt(a)} -> {fmt(b)}" for c, (a, b) in deg.items()) + " mm",
            any(b > a for a, b in deg.values()),
            "15 V sine: |cooling error| without -> with feedforward",
            "larger with feedforward for at least one controller",
        )
    )
    return rows


def _chapter_7_wire_rows(m: Metrics) -> list[Row]:
    """7n-7r: 0.2 mm and 0.5 mm wires (not retuned)."""
    thin, thick = CONDITIONS[4:6]
    rows = []
    same = {c: m.change(c, "rms_error_m", "sine", thin) for c in TRIO + TRIO_FF}
    rows.append(
        make_row(
            "7n",
            ", ".join(f"{c} x{fmt(v)}" for c, v in same.items()),
            all(abs(v - 1.0) <= SIGNIFICANT_CHANGE for v in same.values()),
            "0.2 mm wire against standard: sine RMS error ratio",
            f"each within +-{SIGNIFICANT_CHANGE:.0%}",
        )
    )
    vscs = ("VSC3", "VSC4", "VSC3 + FF", "VSC4 + FF")
    pid_over = m("PID", "overshoot_m", condition=thick)
    ok = {
        c: (
            m(c, "overshoot_m", condition=thick),
            m(c, "oscillation_p2p_m", condition=thick),
            m(c, "rise_time_s", condition=thick),
        )
        for c in vscs
    }
    rows.append(
        make_row(
            "7o",
            ", ".join(f"{c} {fmt(o_)} mm/{fmt(p)} mm/{fmt(r)} s" for c, (o_, p, r) in ok.items())
            + f" (PID overshoot {fmt(pid_over)} mm)",
            all(math.isfinite(r) and p <= OSCILLATION_P2P_M * 1e3 and o_ < pid_over for o_, p, r in ok.values()),
            "0.5 mm wire, step: overshoot / final p2p / rise time",
            f"each reaches 90 %, settles (p2p <= {OSCILLATION_P2P_M * 1e3:g} mm) and overshoots less than the PID",
        )
    )
    po = (m("PID", "overshoot_m"), pid_over)
    # §7.3: the PID's *step* response shows "a further increase of overshoot and
    # oscillations" (until 2026-12-07 the oscillation was read off the sine while heating,
    # micrometres that say nothing of the step). On the standard wire the report's PID
    # settles (Table 6.1: 0.000 mm), so more oscillation means one that shows: the table's
    # "oscillates" bar.
    pw = (m("PID", "oscillation_p2p_m"), m("PID", "oscillation_p2p_m", condition=thick))
    rows.append(
        make_row(
            "7p",
            f"overshoot {fmt(po[0])} -> {fmt(po[1])} mm, step oscillation p2p {fmt(pw[0])} -> {fmt(pw[1])} mm",
            po[1] > po[0] and pw[1] > pw[0] and pw[1] > OSCILLATION_P2P_M * 1e3,
            "PID step, standard -> 0.5 mm wire: overshoot, and the final p2p about the trend (as B6)",
            f"both larger, the oscillation > {OSCILLATION_P2P_M * 1e3:g} mm p2p",
        )
    )
    cool = {c: m(c, "max_error_cooling_m", "sine", thick) for c in TRIO}
    rows.append(
        make_row(
            "7q",
            ", ".join(f"{c} {v:+.3f}" for c, v in cool.items()) + " mm",
            all(abs(v) >= 1.0 for v in cool.values()),
            "0.5 mm wire, sine cooling error",
            "each |error| >= 1 mm (fig. 7.10's axis spans +-5 mm)",
        )
    )
    wig = {c: (m.wiggle_mm(c, "standard", True), m.wiggle_mm(c, thick, True)) for c in TRIO}
    rows.append(
        make_row(
            "7r",
            ", ".join(f"{c} {fmt(a)} -> {fmt(b)}" for c, (a, b) in wig.items()) + " mm",
            all(b >= 3.0 * a and b >= 0.05 for a, b in wig.values()),
            "sine, oscillation while heating (RMS about the 0.2 s moving average), standard -> 0.5 mm",
            "'heavy': each at least 3x standard and >= 0.05 mm",
        )
    )
    return rows


def _chapter_7_overall_rows(m: Metrics) -> list[Row]:
    """7s: every condition."""
    rows = []
    better = all(
        m(v, "overshoot_m", condition=c) < m(p, "overshoot_m", condition=c)
        for c in CONDITIONS
        for p, vs in (("PID", ("VSC3", "VSC4")), ("PID + FF", ("VSC3 + FF", "VSC4 + FF")))
        for v in vs
    )
    degrade = {c: float(np.mean([m.change(c, "rms_error_m", "sine", cond) for cond in CONDITIONS[1:]])) for c in TRIO}
    rows.append(
        make_row(
            "7s",
            "VSC overshoot below PID's in every condition: "
            + ("yes" if better else "no")
            + "; mean sine RMS ratio "
            + ", ".join(f"{c} x{fmt(v)}" for c, v in degrade.items()),
            better and min(degrade["VSC3"], degrade["VSC4"]) > degrade["PID"],
            "all six conditions, with and without feedforward; sine RMS error against standard over the five others",
            "VSC3/VSC4 overshoot less than the PID everywhere, and their sine degrades more",
        )
    )
    return rows


def chapter_7_rows(m: Metrics) -> list[Row]:
    """Rows 7a-7s: the controllers under the chapter-7 conditions (not retuned)."""
    return [
        *_chapter_7_fan_rows(m),
        *_chapter_7_low_supply_rows(m),
        *_chapter_7_high_supply_rows(m),
        *_chapter_7_wire_rows(m),
        *_chapter_7_overall_rows(m),
    ]


# --------------------------------------------------------------------------------------
# Chapter 8 (8a-8j, 8l)
# --------------------------------------------------------------------------------------
CH8_HOW = "the PID on sma_gym_agents.evaluation's chapter-8 protocol (hold 1 mm, step or ramp to 7 mm; integral F dx / integral P dt until 6.9 mm), noise-free"
EXPECTED_EFFICIENCY_PERCENT = 4.0  # §8: "in practice an efficiency of about 4 % is expected"


def chapter_8_rows(results: Results) -> list[Row]:
    eff = [results.value("8", "PID", label, "1 -> 7 mm", "efficiency_percent") for label, *_ in CHAPTER_8_CASES]
    ids = [f"8{c}" for c in "abcdefg"]
    rows = [numeric_row(i, v, "%", f"{label}: {CH8_HOW}") for i, v, (label, *_) in zip(ids, eff, CHAPTER_8_CASES)]
    steps, ramps = eff[:4], eff[4:]
    rows.append(
        make_row(
            "8h",
            " < ".join(fmt(v) for v in steps) + " %",
            _ordered(steps),
            "steps at 5 / 7.5 / 10 / 15 V",
            "strict ordering 5 < 7.5 < 10 < 15 V",
        )
    )
    rows.append(
        make_row(
            "8i",
            " > ".join(fmt(v) for v in ramps) + " %",
            _ordered(ramps, increasing=False),
            "ramps of 1 / 2 / 3 s at 10 V",
            "strict ordering",
        )
    )
    rows.append(
        make_row(
            "8j",
            f"step 10 V {fmt(steps[2])} % vs ramps up to {fmt(max(ramps))} %",
            steps[2] > max(ramps),
            "10 V step against every 10 V ramp",
            "step above every ramp",
        )
    )
    rows.append(
        make_row(
            "8l",
            f"largest {fmt(max(eff))} %",
            max(eff) <= EXPECTED_EFFICIENCY_PERCENT / 4.0,
            "every step and ramp",
            f"'far below' 4 %: at most a quarter of it ({EXPECTED_EFFICIENCY_PERCENT / 4:g} %), so also far below Carnot",
        )
    )
    return rows


# --------------------------------------------------------------------------------------
# Chapter 9 (9e-9q)
# --------------------------------------------------------------------------------------
def chapter_9_rows(results: Results, plan: RunPlan) -> list[Row]:
    def metric(n: int, f: float, v: float, name: str) -> float:
        return results.value("9", "PID", chapter_9_label(n, f, v), "3 mm step", name)

    def oscillates(n: int, f: float) -> bool:
        return metric(n, f, 10.0, "oscillation_p2p_m") > OSCILLATION_P2P_M

    def p2p_mm(n: int, f: float) -> float:
        return metric(n, f, 10.0, "oscillation_p2p_m") * 1e3

    how = "the PID on the multiplexed env, 3 mm step, noise-free"
    duty_ok = []
    for n, f, v in chapter_9_conditions(plan):
        duty = results.traces[("9", "PID", chapter_9_label(n, f, v), "3 mm step")]["duty"]
        duty_ok.append(abs(float(duty.max()) - 1.0 / n) <= 1e-9)
    r1, r8, r16, r16_15, r16_20 = (metric(n, f, v, "rise_time_s") for n, f, v in CH9_COUNT_CONDITIONS)
    over20 = metric(16, 2000.0, 20.0, "overshoot_m") * 1e3
    p2p20 = metric(16, 2000.0, 20.0, "oscillation_p2p_m") * 1e3
    rows = [
        make_row(
            "9e",
            f"largest applied duty = 1/n in {sum(duty_ok)} of {len(duty_ok)} runs",
            all(duty_ok),
            how + " (the PID asks for more during the rise)",
            "exactly 1/n",
        ),
        numeric_row("9f", r16, "s", f"16 actuators, 10 V, 2 kHz: rise to 90 %; {how}"),
        make_row(
            "9g",
            f"{fmt(r16_15)} s at 15 V vs {fmt(r16)} s at 10 V",
            r16_15 <= 0.5 * r16,
            f"16 actuators, 2 kHz; {how}",
            "at most half the 10 V rise time",
        ),
        numeric_row("9h", r16_20, "s", f"16 actuators, 20 V, 2 kHz: rise to 90 %; {how}"),
        make_row(
            "9i",
            f"{fmt(over20)} mm",
            over20 > NO_OVERSHOOT_MM,
            f"16 actuators, 20 V; {how}",
            f"overshoot > {NO_OVERSHOOT_MM:g} mm",
        ),
        make_row(
            "9j",
            f"p2p {fmt(p2p20)} mm about the trend over the last 2 s",
            p2p20 > OSCILLATION_P2P_M * 1e3,
            f"16 actuators, 20 V; {how}",
            f"p2p > {OSCILLATION_P2P_M * 1e3:g} mm",
        ),
        make_row(
            "9k",
            f"{fmt(r1)} < {fmt(r8)} < {fmt(r16)} s",
            _ordered([r1, r8, r16]),
            f"1, 8, 16 actuators at 10 V, 2 kHz; {how}",
            "strict ordering",
        ),
    ]
    freqs = plan.frequencies(1)
    low, high = freqs[0], freqs[-1]
    fast_p2p = max(p2p_mm(1, f) for f in freqs if f >= 1000.0)
    rows.append(
        make_row(
            "9l",
            f"1 actuator p2p {fmt(p2p_mm(1, low))} mm at {low:g} Hz vs <= {fmt(fast_p2p)} mm at >= 1 kHz",
            oscillates(1, low) and p2p_mm(1, low) > 5.0 * fast_p2p,
            f"p2p about the trend line over the last 2 s; {how}",
            f"p2p > {OSCILLATION_P2P_M * 1e3:g} mm and > 5x the >= 1 kHz ones",
        )
    )
    slow_f, high = plan.frequencies(8)[1], plan.frequencies(8)[-1]
    r_slow, r_fast = metric(8, slow_f, 10.0, "rise_time_s"), metric(8, high, 10.0, "rise_time_s")
    rows.append(
        make_row(
            "9m",
            f"8 actuators: {fmt(r_slow)} s at {slow_f:g} Hz, {fmt(r_fast)} s at {high:g} Hz",
            r_fast <= (1.0 - SIGNIFICANT_CHANGE) * r_slow,
            f"rise to 90 %; {how}",
            f"'substantially': at least {SIGNIFICANT_CHANGE:.0%} shorter",
        )
    )
    rows.append(
        make_row(
            "9n",
            f"p2p {fmt(p2p_mm(1, 4000.0))} mm",
            not oscillates(1, 4000.0),
            f"1 actuator, 4 kHz; {how}",
            f"p2p <= {OSCILLATION_P2P_M * 1e3:g} mm",
        )
    )
    rows.append(
        make_row(
            "9o",
            f"p2p {fmt(p2p_mm(8, 4000.0))} mm",
            oscillates(8, 4000.0),
            f"8 actuators, 4 kHz; {how}",
            f"p2p > {OSCILLATION_P2P_M * 1e3:g} mm",
        )
    )
    rows.append(
        make_row(
            "9p",
            f"p2p {fmt(p2p_mm(16, 3000.0))} mm",
            oscillates(16, 3000.0),
            f"16 actuators, 3 kHz; {how}",
            f"p2p > {OSCILLATION_P2P_M * 1e3:g} mm",
        )
    )
    higher_oscillate = any(oscillates(n, f) for n in (8, 16) for f in plan.frequencies(n) if f > 2000.0)
    no_osc_2k = not any(oscillates(n, 2000.0) for n in (1, 8, 16))
    faster_than_lower = all(
        metric(n, 2000.0, 10.0, "rise_time_s") <= metric(n, f, 10.0, "rise_time_s")
        for n in (1, 8, 16)
        for f in plan.frequencies(n)
        if f < 2000.0
    )
    rows.append(
        make_row(
            "9q",
            f"2 kHz oscillation-free: {no_osc_2k}; no slower than lower frequencies: {faster_than_lower}; "
            f"a higher frequency oscillates (8 or 16 actuators): {higher_oscillate}",
            no_osc_2k and faster_than_lower and higher_oscillate,
            f"1, 8, 16 actuators at 10 V; {how}",
            "an optimum: 2 kHz does not oscillate, rises no slower than any lower frequency, and going higher oscillates",
        )
    )
    return rows


# --------------------------------------------------------------------------------------
# Everything
# --------------------------------------------------------------------------------------
def run(quick: bool = False) -> FidelityResult:
    """All 125 rows (in the spec's order) and the plots; ``quick`` for smoke tests."""
    plan = QUICK if quick else FULL
    plant = fidelity.run_plant(quick)
    results = run_harness(plan)
    m = Metrics(results, (SINE_WINDOW_S[0], plan.sine_seconds))
    rows = [
        *fidelity.plant_rows(plant),
        *table_6_1_rows(m),
        *statement_rows(m),
        *chapter_7_rows(m),
        *chapter_8_rows(results),
        *chapter_9_rows(results, plan),
    ]
    # The step-and-sine traces are large (about 7 MB each with three seeds) and not plotted.
    for key in [k for k in results.traces if k[0] in ("6.1", "7")]:
        del results.traces[key]
    result = FidelityResult(
        rows=fidelity.order_rows(rows), plots=fidelity.plant_plots(plant), skipped=fidelity.skipped_plots()
    )
    result.plots.update(harness_plots(results, plan))
    return result


def harness_plots(results: Results, plan: RunPlan) -> dict[str, Callable]:
    from sma_gym import fidelity_plots as fp

    def trace_of(n: int, f: float, v: float) -> Trace:
        return results.traces[("9", "PID", chapter_9_label(n, f, v), "3 mm step")]

    sweep = tuple(c for c in chapter_9_conditions(plan) if c[2] == 10.0 and c[0] in (1, 8, 16))
    return {
        "fig8_efficiency.png": lambda out: fp.plot_efficiency(results, CHAPTER_8_CASES, out),
        "fig9_multiplexed_rise.png": lambda out: fp.plot_multiplexed(trace_of, CH9_COUNT_CONDITIONS, sweep, out),
    }


def main(out: str | None, as_json: bool, quick: bool = False, shown_out: str | None = None) -> int:
    """``sma-gym fidelity``: print the table (or JSON) and write the plots; 1 if a counted row
    fails (``shown_out``: the folder named in the message, where a staging ``out`` is moved to)."""
    return fidelity.write_outputs(run(quick=quick), out, as_json, shown_out)
