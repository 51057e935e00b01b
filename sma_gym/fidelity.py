"""``sma-gym fidelity``: the simulator held against the report's numbers (MODEL.md T1-T5, T8, T9).

Each target becomes one or more rows: the report's value, the simulated value, the
tolerance and pass/fail. Tolerances are fixed here, with their reasons, and are not to be
widened to make a row pass. Rows the lumped model cannot reproduce are listed in
:data:`KNOWN_GAPS` with the reason; they are reported as failing, not hidden.

Experiments (all with the report's standard actuator unless stated):

* T1/T2, fig. 5.2-5.3: open loop, duty 1 from rest, step at t = 1 s, 5 / 7.5 / 10 V.
* T3, §4.2, figs. 4.4-4.9: closed loop (P control, fan, 10 V, duty kept in [0.025, 0.8]
  so that the resistance is always measurable), 0.05 Hz sine between 1 and 7 mm; R from the
  simulated V/I readings, x from the position reading.
* T4, fig. 6.4: open loop, constant duty from rest held 60 s; the duty that ends at 5 mm
  (the report's way: "the voltage required to hold the actuator at a certain position").
* T5, §8: the evaluation harness's chapter-8 protocol with the report's PID: it holds 1 mm,
  then a step (or ramp of 1, 2, 3 s) to 7 mm; the efficiency is integral(F dx) /
  integral(P dt) from the step until the position first reaches 6.9 mm (the report states
  neither its window nor its controller).
* T8, §9: the harness's chapter-9 protocol: the report's PID on the multiplexed env, a
  3 mm step, 2 kHz cycling unless stated; the multiplexer caps each actuator's duty at 1/n.
  The report does not give the step; by its own T4 fit 16 actuators at 10 V can hold at
  most ~5 mm, so its step was smaller; we take 3 mm.
* T9, §4.1: the smallest duty with a resistance reading at 1 kHz and 500 Hz PWM.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from sma_gym.electrical.multiplexer import io_counts
from sma_gym.model import ModelConfig, load_model
from sma_gym.params import preset
from sma_gym.simulator import Simulator

REAL_DATA_DIR_CANDIDATES = ("../shared/data/real", "../../shared/data/real")


@dataclass
class Row:
    """One fidelity row."""

    target: str
    report: Any
    simulated: Any
    tolerance: str
    passed: bool
    note: str = ""

    def __post_init__(self) -> None:
        self.passed = bool(self.passed)

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        for key in ("report", "simulated"):
            value = d[key]
            if isinstance(value, (np.floating, np.integer)):
                d[key] = value.item()
            if isinstance(value, float) and not math.isfinite(value):
                d[key] = str(value)
        return d


KNOWN_GAPS: dict[str, str] = {
    "T5 efficiency step 5 V": (
        "Inconsistent with T1+T4 under any lumped heat balance: the report's four step "
        "efficiencies imply ~5.3 W of heat loss during the 1->7 mm stroke, while T4 (0.06 duty "
        "holds 5 mm at 10 V) allows at most ~2 W at those temperatures. The 7.5-15 V values fit "
        "within a factor 2; 5 V alone would need 4x more loss."
    ),
    "T8 higher cycling frequency responds faster": (
        "Nothing in the model makes energy delivery depend on the cycling frequency except the "
        "pulse_settling effect, which makes high frequencies slower, not faster."
    ),
    "T8 8 actuators oscillate at 4 kHz, 16 at 3 kHz": (
        "The base model has no high-frequency mechanism; with the pulse_settling effect "
        "(tau ~ 11 us) 8 actuators at 4 kHz do oscillate, but 16 actuators then stall."
    ),
}


@dataclass
class FidelityResult:
    rows: list[Row] = field(default_factory=list)
    plots: dict[str, Callable[[Path], Path]] = field(default_factory=dict)

    @property
    def all_passed(self) -> bool:
        return all(r.passed for r in self.rows if r.target not in KNOWN_GAPS)


def _within(value: float, target: float, rel: float) -> bool:
    return math.isfinite(value) and abs(value - target) <= rel * abs(target)


def _within_factor(value: float, target: float, factor: float) -> bool:
    return math.isfinite(value) and value > 0 and 1.0 / factor <= value / target <= factor


def _first_time(t: np.ndarray, mask: np.ndarray) -> float:
    idx = np.flatnonzero(mask)
    return float(t[idx[0]]) if idx.size else math.inf


# --------------------------------------------------------------------------------------
# T1 / T2: open-loop voltage steps (fig. 5.2, 5.3)
# --------------------------------------------------------------------------------------
T1_VOLTAGES = (5.0, 7.5, 10.0)


def voltage_steps(duration_s: float = 4.0, step_s: float = 1.0) -> dict[str, np.ndarray]:
    """Open-loop duty 1 from rest, step at ``step_s``, at 5, 7.5 and 10 V (one run, 3 columns)."""
    sim = Simulator([f"supply-{v:g}v" for v in T1_VOLTAGES])
    steps = int(round(duration_s * 1000))
    duty = np.zeros((steps, len(T1_VOLTAGES)))
    duty[int(round(step_s * 1000)) :] = 1.0
    out = sim.run(duty, record=("position_m", "temperature_c", "martensite_fraction", "stress_pa"))
    out["step_s"] = np.array(step_s)
    return out


def t1_rows(data: dict[str, np.ndarray]) -> list[Row]:
    t = data["time_s"][:, 0]
    x = data["position_m"]
    temp = data["temperature_c"]
    step = float(data["step_s"])
    stroke = preset("standard").driver.end_of_travel_m
    rows = []
    t90 = []
    for j, v in enumerate(T1_VOLTAGES):
        rise = _first_time(t, x[:, j] >= 0.9 * stroke) - step
        t90.append(rise)
        rows.append(
            Row(
                f"T1 open-loop rise to 90 % of stroke at {v:g} V [s]",
                "< 3.0 (inside the plotted 1-4 s window, fig. 5.2)",
                round(rise, 3),
                "<= 3.0 s after the step",
                rise <= 3.0,
            )
        )
    rows.append(
        Row(
            "T1 faster at higher voltage",
            "t(10 V) < t(7.5 V) < t(5 V)",
            " < ".join(f"{r:.3f}" for r in t90[::-1]),
            "strict ordering",
            t90[2] < t90[1] < t90[0],
        )
    )
    for j, v in enumerate(T1_VOLTAGES):
        peak = float(temp[:, j].max())
        rows.append(
            Row(
                f"T1 peak temperature while transforming at {v:g} V [degC]",
                "100-160 (fig. 5.3)",
                round(peak, 1),
                "in [100, 160]",
                100.0 <= peak <= 160.0,
            )
        )
    reached = float(x.max())
    rows.append(
        Row(
            "T2 stroke [mm]",
            9.5,
            round(reached * 1e3, 3),
            "+-0.3 mm (Table 3.1 gives one digit after the point)",
            abs(reached - 9.5e-3) <= 0.3e-3,
        )
    )
    return rows


def t2_limit_row() -> Row:
    """Position never exceeds eps0*l0, even at 30 V with the end-of-travel cut disabled."""
    base = preset("standard")
    models = [
        ModelConfig(base.with_changes(**{"driver.supply_voltage_v": v, "driver.end_of_travel_m": math.inf}))
        for v in (10.0, 20.0, 30.0)
    ]
    sim = Simulator(models)
    out = sim.run(np.ones(10000), record=("position_m",))
    peak = float(out["position_m"].max())
    limit = base.wire.max_stroke_m
    return Row(
        "T2 position never exceeds eps0*l0 (10-30 V, no end-of-travel cut, 10 s) [mm]",
        f"<= {limit * 1e3:.2f}",
        round(peak * 1e3, 3),
        "<= eps0*l0",
        peak <= limit,
    )


# --------------------------------------------------------------------------------------
# T3: resistance (§4.2)
# --------------------------------------------------------------------------------------
def resistance_loop(duration_s: float = 60.0) -> dict[str, np.ndarray]:
    """Closed-loop 0.05 Hz sine, 1-7 mm, P control with a fan at 10 V (§4.2)."""
    sim = Simulator("forced-convection")
    steps = int(round(duration_s * 1000))
    out = {k: np.zeros(steps) for k in ("t", "x", "x_meas", "r_meas", "temperature")}
    for k in range(steps):
        t = k * 1e-3
        ref = 4e-3 - 3e-3 * math.cos(2.0 * math.pi * 0.05 * t)
        duty = min(0.8, max(0.025, 1000.0 * (ref - sim.position_measured_m[0])))
        sim.step(duty)
        out["t"][k] = t + 1e-3
        out["x"][k] = sim.position_m[0]
        out["x_meas"][k] = sim.position_measured_m[0]
        out["r_meas"][k] = sim.resistance_measured_ohm[0]
        out["temperature"][k] = sim.temperature_c[0]
    return out


def cold_resistance() -> float:
    return float(Simulator("standard").resistance_ohm[0])


def heating_from_cold(duration_s: float = 3.0) -> dict[str, np.ndarray]:
    """Duty 0.8 from cold at 10 V (fan): the first rise, where R(x) is non-linear below 1 mm."""
    sim = Simulator("forced-convection")
    out = sim.run(np.full(int(duration_s * 1000), 0.8), record=("position_m", "resistance_measured_ohm"))
    return out


def t3_rows(loop: dict[str, np.ndarray], first_rise: dict[str, np.ndarray]) -> list[Row]:
    rows = []
    r_cold = cold_resistance()
    rows.append(
        Row(
            "T3 resistance extended and cold [ohm]",
            "3.7-3.8",
            round(r_cold, 4),
            "[3.70, 3.80] (§4.2, Table 3.1)",
            3.70 <= r_cold <= 3.80,
        )
    )
    sel = loop["t"] >= 20.0  # after the first period
    x = loop["x_meas"][sel]
    r = loop["r_meas"][sel]
    # Only samples in clear motion: at the turning points the wire crosses the 15 K
    # hysteresis band at constant position (vertical segments in R(x)), which fig. 4.9's
    # fits also leave out.
    v = np.gradient(loop["x"][sel]) / 1e-3
    band = (x > 1e-3) & (x < 6.5e-3) & np.isfinite(r)
    heat = band & (v > 1e-4)
    cool = band & (v < -1e-4)
    ph = np.polyfit(x[heat], r[heat], 1)
    pc = np.polyfit(x[cool], r[cool], 1)
    r7 = float(np.polyval(ph, 7e-3))
    rows.append(
        Row(
            "T3 resistance near 7 mm while heating [ohm]",
            3.25,
            round(r7, 4),
            "+-0.05 ohm (read from figs. 4.4-4.9, 0.1-ohm grid)",
            abs(r7 - 3.25) <= 0.05,
        )
    )
    resid = r[heat] - np.polyval(ph, x[heat])
    r2 = 1.0 - resid.var() / r[heat].var()
    rows.append(
        Row(
            "T3 R(x) linear while heating above 1 mm (R^2 of a line)",
            "linear (fig. 4.9)",
            round(float(r2), 5),
            ">= 0.98",
            r2 >= 0.98,
        )
    )
    # Below 1 mm the first rise from cold departs from that line (R changes with T at x ~ 0).
    xr = first_rise["position_m"][:, 0]
    rr = first_rise["resistance_measured_ohm"][:, 0]
    low = (xr < 1e-3) & np.isfinite(rr)
    dev_low = float(np.max(np.abs(rr[low] - np.polyval(ph, xr[low]))))
    dev_high = float(np.max(np.abs(resid)))
    ratio = dev_low / max(dev_high, 1e-12)
    rows.append(
        Row(
            "T3 R(x) non-linear below 1 mm (largest departure from the heating line, below / above 1 mm)",
            "non-linear (figs. 4.5, 4.9)",
            round(ratio, 2),
            ">= 3",
            ratio >= 3.0,
        )
    )
    slope_ratio = float(pc[0] / ph[0])
    rows.append(
        Row(
            "T3 heating and cooling R(x) slopes differ (cooling / heating)",
            "unequal (fig. 4.9)",
            round(slope_ratio, 4),
            "differ by >= 3 % (>10x the fits' standard error)",
            abs(slope_ratio - 1.0) >= 0.03,
        )
    )
    return rows


# --------------------------------------------------------------------------------------
# T4: holding duty (fig. 6.4)
# --------------------------------------------------------------------------------------
def holding_curve(model: ModelConfig | str = "standard", duties: np.ndarray | None = None, hold_s: float = 60.0) -> dict[str, np.ndarray]:
    """Steady positions for constant duties from rest (heating branch) and from above (cooling).

    Heating branch: duty d from rest for ``hold_s``. Cooling branch: 3 s at a duty that
    reaches 9 mm, then duty d for ``hold_s``.
    """
    if duties is None:
        duties = np.linspace(0.045, 0.075, 25)
    n = len(duties)
    m = load_model(model)
    steps = int(round(hold_s * 1000))
    sim = Simulator([m] * (2 * n))
    seq = np.empty((steps + 3000, 2 * n))
    seq[:, :n] = duties
    seq[:3000, n:] = 0.2
    seq[3000:, n:] = duties
    out = sim.run(seq, record=("position_m",))
    heating = out["position_m"][-1, :n]
    cooling = out["position_m"][-1, n:]
    return {"duty": np.asarray(duties), "x_heating": heating, "x_cooling": cooling}


def holding_duty_at(curve: dict[str, np.ndarray], position_m: float, branch: str = "heating") -> float:
    x = curve[f"x_{branch}"]
    order = np.argsort(x)
    return float(np.interp(position_m, x[order], curve["duty"][order]))


def t4_rows(curve: dict[str, np.ndarray]) -> list[Row]:
    d5 = holding_duty_at(curve, 5e-3, "heating")
    return [
        Row(
            "T4 duty holding 5 mm at 10 V (open loop, heating branch)",
            0.06,
            round(d5, 4),
            "+-10 % (fig. 6.4 scatters by about that from hysteresis)",
            _within(d5, 0.06, 0.10),
        )
    ]


# --------------------------------------------------------------------------------------
# T5: efficiency (§8)
# --------------------------------------------------------------------------------------
def _t5_cases():
    from agents.evaluation import CHAPTER_8_CASES

    return CHAPTER_8_CASES


T5_CASES = _t5_cases()


def efficiency_runs():
    """The report's PID on the chapter-8 protocol (the evaluation harness's), noise-free."""
    from agents.controllers import PID
    from agents.evaluation import Results, baseline, run_chapter_8

    results = Results()
    run_chapter_8([baseline(PID)], results, seeds=(0,), cases=T5_CASES, noise_m=0.0)
    return results


def t5_rows(runs) -> list[Row]:
    eff = np.array([runs.value("8", "PID", label, "1 -> 7 mm", "efficiency_percent") for label, *_ in T5_CASES])
    rows = []
    for (label, _, _, report), value in zip(T5_CASES, eff):
        rows.append(
            Row(
                f"T5 efficiency {label}",
                report,
                round(float(value), 3),
                "within a factor 2 (window and controller of §8 unstated)",
                _within_factor(float(value), report, 2.0),
                "%",
            )
        )
    steps = eff[:4]
    ramps = eff[4:]
    rows.append(
        Row(
            "T5 step efficiency rises with supply voltage (7.5 -> 10 -> 15 V and 5 V lowest)",
            "0.12 < 0.42 < 0.51 < 0.60",
            " , ".join(f"{v:.3f}" for v in steps),
            "5 V lowest; 7.5 V < 10 V within 5 % ; 10 V <= 15 V within 5 %",
            bool(steps[0] < min(steps[1:]) and steps[1] < steps[2] * 1.05 and steps[2] <= steps[3] * 1.05),
        )
    )
    rows.append(
        Row(
            "T5 ramp efficiency falls with ramp time (1 -> 2 -> 3 s)",
            "0.34 > 0.24 > 0.18",
            " > ".join(f"{v:.3f}" for v in ramps),
            "strict ordering",
            bool(ramps[0] > ramps[1] > ramps[2]),
        )
    )
    carnot = 100.0 * (1.0 - (75.0 + 273.15) / (110.0 + 273.15))
    rows.append(
        Row(
            "T5 every efficiency below the Carnot bound 1 - A_s/A_f",
            f"< {carnot:.1f} %",
            f"max {float(eff.max()):.3f} %",
            "< Carnot",
            bool(eff.max() < carnot),
        )
    )
    return rows


# --------------------------------------------------------------------------------------
# T8: multiplexing (§9)
# --------------------------------------------------------------------------------------
T8_STEP_M = 3e-3


def multiplexed_steps(conditions: Sequence[tuple[int, float, float]]):
    """The report's PID on the multiplexed env (the evaluation harness's chapter 9), noise-free."""
    from agents.controllers import PID
    from agents.evaluation import Results, baseline, run_chapter_9

    results = Results()
    run_chapter_9([baseline(PID)], results, conditions=conditions, noise_m=0.0)
    return results


T8_COUNT_CONDITIONS = ((1, 2000.0, 10.0), (8, 2000.0, 10.0), (16, 2000.0, 10.0), (16, 2000.0, 15.0), (16, 2000.0, 20.0))
T8_FREQUENCIES = (100.0, 500.0, 1000.0, 2000.0, 3000.0, 4000.0)
T8_FREQ_CONDITIONS = tuple((n, f, 10.0) for n in (1, 8, 16) for f in T8_FREQUENCIES)


def t8_rows(runs) -> list[Row]:
    from agents.evaluation import chapter_9_label

    def metric(n: int, f: float, v: float, name: str) -> float:
        return runs.value("9", "PID", chapter_9_label(n, f, v), "3 mm step", name)

    r1, r8, r16, r16_15, r16_20 = (metric(n, f, v, "rise_time_s") for n, f, v in T8_COUNT_CONDITIONS)
    over20 = metric(16, 2000.0, 20.0, "overshoot_m") * 1e3
    rows = [
        Row(
            "T8 rise time, 16 actuators at 10 V [s]",
            9.0,
            round(r16, 2),
            "within a factor 1.5: ill-conditioned, see note",
            _within_factor(r16, 9.0, 1.5),
            "At 1/16 duty the wire gets only ~10 % more power than it loses near the target, so "
            "+-8 % in h moves this rise time by -30 %/+60 % (see `sma-gym fidelity` docs).",
        ),
        Row(
            "T8 more actuators rise slower (1 < 8 < 16 at 10 V) [s]",
            "about 0.4 < 3.5 < 9 (figs. 9.4, 9.5)",
            f"{r1:.2f} < {r8:.2f} < {r16:.2f}",
            "strict ordering",
            r1 < r8 < r16,
        ),
        Row(
            "T8 16 actuators: 15 V much faster than 10 V [s]",
            "much faster",
            f"{r16_15:.2f} vs {r16:.2f}",
            "at most half the 10 V rise time",
            r16_15 <= 0.5 * r16,
        ),
        Row(
            "T8 rise time, 16 actuators at 20 V [s]",
            1.0,
            round(r16_20, 2),
            "within a factor 1.5 (read from fig. 9.3)",
            _within_factor(r16_20, 1.0, 1.5),
        ),
        Row(
            "T8 16 actuators at 20 V overshoot [mm]",
            "> 0 (with overshoot)",
            round(over20, 3),
            "> 0.05 mm",
            over20 > 0.05,
        ),
    ]

    def p2p(n: int, f: float) -> float:
        return metric(n, f, 10.0, "oscillation_p2p_m")

    def rise_f(n: int, f: float) -> float:
        return metric(n, f, 10.0, "rise_time_s")

    low = p2p(1, 100.0)
    high = max(p2p(1, f) for f in T8_FREQUENCIES[2:])
    rows.append(
        Row(
            "T8 low cycling frequency oscillates (1 actuator: 100 Hz vs >= 1 kHz, p2p of last 2 s) [mm]",
            "oscillates at low frequency",
            f"{low * 1e3:.3f} vs {high * 1e3:.3f}",
            "100 Hz p2p > 0.1 mm and > 5x the >= 1 kHz p2p",
            low > 1e-4 and low > 5.0 * high,
        )
    )
    rows.append(
        Row(
            "T8 1 actuator does not oscillate at 4 kHz (p2p of last 2 s) [mm]",
            "no oscillation",
            round(p2p(1, 4000.0) * 1e3, 4),
            "< 0.05 mm",
            p2p(1, 4000.0) < 5e-5,
        )
    )
    r_low = rise_f(8, 500.0)
    r_high = rise_f(8, 4000.0)
    rows.append(
        Row(
            "T8 higher cycling frequency responds faster",
            "faster at higher frequency (fig. 9.4)",
            f"8 actuators: {r_low:.2f} s at 500 Hz, {r_high:.2f} s at 4 kHz",
            "4 kHz rise at least 10 % shorter than 500 Hz",
            r_high <= 0.9 * r_low,
        )
    )
    osc8 = p2p(8, 4000.0)
    osc16 = p2p(16, 3000.0)
    rows.append(
        Row(
            "T8 8 actuators oscillate at 4 kHz, 16 at 3 kHz",
            "oscillate",
            f"p2p {osc8 * 1e3:.3f} mm and {osc16 * 1e3:.3f} mm",
            "both p2p > 0.1 mm",
            osc8 > 1e-4 and osc16 > 1e-4,
        )
    )
    for n in (2, 4, 8, 16):
        c = io_counts(n)
        expected = {2: 2, 4: 3, 8: 4, 16: 5}[n]
        rows.append(
            Row(
                f"T8 I/O counts for {n} actuators (AI without/with, DO without/with)",
                f"{n}/1, {n}/{expected}",
                f"{c['analog_inputs_without']}/{c['analog_inputs_with']}, {c['digital_outputs_without']}/{c['digital_outputs_with']}",
                "exact (Table 9.1)",
                c == {"analog_inputs_without": n, "analog_inputs_with": 1, "digital_outputs_without": n, "digital_outputs_with": expected},
            )
        )
    return rows


# --------------------------------------------------------------------------------------
# T9: resistance sensing needs the PWM on for ~50 us (§4.1)
# --------------------------------------------------------------------------------------
def minimum_sensing_duty(pwm_frequency_hz: float, pwm_mode: str) -> float:
    base = preset("standard").with_changes(**{"driver.pwm_frequency_hz": pwm_frequency_hz})
    duties = np.round(np.arange(0.0, 0.1001, 0.0025), 6)
    sim = Simulator(ModelConfig(base), n=len(duties), pwm_mode=pwm_mode)
    out = sim.run(np.tile(duties, (10, 1)), record=("resistance_measured_ohm",))
    valid = np.isfinite(out["resistance_measured_ohm"][-1])
    return float(duties[valid][0]) if valid.any() else math.inf


def t9_rows() -> list[Row]:
    rows = []
    for f, expected in ((1000.0, 0.05), (500.0, 0.025)):
        for mode in ("averaged", "resolved"):
            value = minimum_sensing_duty(f, mode)
            rows.append(
                Row(
                    f"T9 minimum duty for a resistance reading at {f:g} Hz PWM ({mode})",
                    expected,
                    value,
                    "exact on a 0.0025 duty grid",
                    abs(value - expected) < 1e-9,
                )
            )
    return rows


# --------------------------------------------------------------------------------------
# Running everything
# --------------------------------------------------------------------------------------
def run(quick: bool = False) -> FidelityResult:
    """Run every experiment; returns the rows and functions that draw the plots."""
    result = FidelityResult()
    steps = voltage_steps()
    result.rows += t1_rows(steps)
    result.rows.append(t2_limit_row())
    loop = resistance_loop(40.0 if quick else 60.0)
    first = heating_from_cold()
    result.rows += t3_rows(loop, first)
    curve = holding_curve()
    result.rows += t4_rows(curve)
    eff = efficiency_runs()
    result.rows += t5_rows(eff)
    mux = multiplexed_steps(T8_COUNT_CONDITIONS + tuple(c for c in T8_FREQ_CONDITIONS if c not in T8_COUNT_CONDITIONS))
    result.rows += t8_rows(mux)
    result.rows += t9_rows()
    for row in result.rows:
        if row.target in KNOWN_GAPS:
            row.note = ("known gap: " + KNOWN_GAPS[row.target] + (" " + row.note if row.note else "")).strip()

    from sma_gym import fidelity_plots as fp

    result.plots = {
        "fig5_2_voltage_steps.png": lambda out: fp.plot_voltage_steps(steps, out),
        "fig4_9_resistance_loop.png": lambda out: fp.plot_resistance_loop(loop, first, out),
        "fig6_4_holding_duty.png": lambda out: fp.plot_holding(curve, out),
        "fig8_efficiency.png": lambda out: fp.plot_efficiency(eff, T5_CASES, out),
        "fig9_multiplexed_rise.png": lambda out: fp.plot_multiplexed(mux, T8_COUNT_CONDITIONS, T8_FREQ_CONDITIONS, out),
        "bench_0.5mm_ht_vs_measured.png": lambda out: fp.plot_bench(out),
    }
    return result


def format_table(rows: Sequence[Row]) -> str:
    headers = ("target", "report", "simulated", "tolerance", "pass")
    body = [
        (
            r.target,
            str(r.report),
            str(r.simulated),
            r.tolerance,
            ("PASS" if r.passed else ("FAIL (known gap)" if r.target in KNOWN_GAPS else "FAIL")),
        )
        for r in rows
    ]
    widths = [min(70, max(len(h), *(len(b[i]) for b in body))) for i, h in enumerate(headers)]
    lines = ["  ".join(h.ljust(w) for h, w in zip(headers, widths))]
    lines.append("  ".join("-" * w for w in widths))
    for b in body:
        lines.append("  ".join(c.ljust(w) for c, w in zip(b, widths)))
    gaps = [r for r in rows if r.target in KNOWN_GAPS]
    if gaps:
        lines.append("")
        lines.append("Known gaps (reported, not hidden):")
        for r in gaps:
            lines.append(f"- {r.target}: {KNOWN_GAPS[r.target]}")
    return "\n".join(lines)


def main(out: str | None, as_json: bool, quick: bool = False) -> int:
    result = run(quick=quick)
    if out:
        folder = Path(out)
        folder.mkdir(parents=True, exist_ok=True)
        for name, draw in result.plots.items():
            draw(folder / name)
    if as_json:
        print(json.dumps([r.as_dict() for r in result.rows], indent=2))
    else:
        print(format_table(result.rows))
        if out:
            print(f"\nplots written to {Path(out).resolve()}")
    return 0 if result.all_passed else 1
