"""Tests of the independent truth generator ``tests/independent_sma.py`` (issue 12).

Four groups:

1. physical sanity of the independent model on its own;
2. independence check against our kernel (``sma_gym.Simulator``) on the same parameters:
   the two must agree in character, and a clearly different parameter set must not;
3. each hidden effect changes the outputs it should, and only those;
4. the generated traces round-trip through the project's CSV writer and loader.

Measured differences between the two generators (standard preset with the 6 K spread of
transformation temperatures of before 2026-11-25, 10 V unless said; the nominal is 8 K now,
and ``python -m pytest tests/test_independent_generator.py`` re-measures them):

=============================================== ============ ============ ==========
experiment                                      our kernel   independent  difference
=============================================== ============ ============ ==========
duty-1 step at 10 V: stroke after 5 s [mm]      9.525        9.421        -1.1 %
  rise time 10-90 % [s]                         0.177        0.169        -4.5 %
  dead time to 10 % [s]                         0.251        0.271        +8 %
  peak temperature [degC]                       108.2        111.5        +3.3 K
duty-1 step at 5 V: rise time 10-90 % [s]       0.849        0.837        -1.4 %
sine duty 0..0.2 at 0.1 Hz: position range [mm] 3.62-9.51    3.90-9.50    RMS 0.21 mm
  resistance [ohm]                              3.09-3.79    3.08-3.79    RMS 0.016 ohm
holding position at duty 0.06 after 40 s [mm]   4.93         2.74         -2.2 mm
duty that holds 5 mm after 40 s [-]             0.060        0.064        +6 %
same with h0, h2 halved (independent) [mm]      -            9.39         +4.5 mm
=============================================== ============ ============ ==========

The holding position misses the issue's 1.5 mm tolerance (a strict ``xfail`` below). The
cause is measured, not guessed: our kernel's nominal Preisach law spreads the hysteron
widths over [0, 15 K] (``Wire.hysteron_width_spread = 1``), which moves the major
*heating* branch 3.75 K below the A_s/A_f of Table 5.1 on average; the independent
generator uses the published branches. Shifting its A_s and A_f by -3.75 K makes it hold
4.91 mm at 0.06 (kernel 4.93). Near 5 mm the holding curve is steep (0.05 -> 0.07 duty
spans 0.2 -> 8.6 mm), so 4 K of branch temperature is 2 mm of position: the T4 calibration
of h0 (81.14 then) holds for our kernel's loop, and a model with the published branches would
need about 6 % more duty (or about 7 % less h0) to hold 5 mm. The logistic instead of
Gaussian spread accounts for less than 0.1 mm of it.
"""

from __future__ import annotations

import ast
import math
from pathlib import Path

import independent_sma as ind
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sma_gym.data import load_trace, write_trace
from sma_gym.data.measured import DIAGNOSIS_MIN_ROWS
from sma_gym.params import preset

STANDARD = preset("standard")
CONTROL_PERIOD_S = ind.CONTROL_PERIOD_S
POSITION_NOISE_M = 5e-6
RESISTANCE_NOISE_OHM = 2e-3


def _kernel(duty: np.ndarray, params=STANDARD) -> dict[str, np.ndarray]:
    """Our kernel on an open-loop duty sequence (only the tests compare against it)."""
    from sma_gym import Simulator

    sim = Simulator(params, control_period_s=CONTROL_PERIOD_S)
    out = sim.run(duty, record=("position_m", "temperature_c", "martensite_fraction", "resistance_ohm"))
    return {name: values[:, 0] for name, values in out.items()}


def _step_duty(seconds: float = 6.0) -> np.ndarray:
    """Rest for 1 s, then duty 1 (the report's open-loop voltage step, fig. 5.2)."""
    duty = np.zeros(int(round(seconds / CONTROL_PERIOD_S)))
    duty[1000:] = 1.0
    return duty


def _rise_times_s(position_m: np.ndarray, final_m: float, start_index: int = 1000) -> tuple[float, float]:
    """(10-90 % rise time, dead time from the step to 10 %) [s] of a contraction."""
    k10 = int(np.argmax(position_m >= 0.1 * final_m))
    k90 = int(np.argmax(position_m >= 0.9 * final_m))
    return (k90 - k10) * CONTROL_PERIOD_S, (k10 - start_index) * CONTROL_PERIOD_S


# --------------------------------------------------------------------------------------
# 0. Independence by construction, and names a benchmark can score
# --------------------------------------------------------------------------------------


def test_generator_imports_nothing_from_our_kernel() -> None:
    """The generator may read parameters and write the data format, nothing else of ours."""
    source = Path(ind.__file__).read_text()
    imported: set[str] = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            imported.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            imported.add(node.module)
    ours = {name for name in imported if name.split(".")[0] == "sma_gym"}
    assert ours <= {"sma_gym.params", "sma_gym.data"}, ours


def test_effect_names_and_parameters_match_the_project() -> None:
    """A benchmark scores the diagnosis by name: every hidden effect must be a candidate
    of ``sma_gym.effects`` with the same parameter names, at a value inside its bounds."""
    from sma_gym.effects import EFFECTS

    required = {
        "sensor_lag",
        "convection_change",
        "coulomb_friction",
        "supply_sag",
        "latent_heat",
        "transformation_spread",
        "abbe_offset",
    }
    assert required <= set(ind.INDEPENDENT_EFFECTS)
    for name, values in ind.INDEPENDENT_EFFECTS.items():
        declared = {p.name: p for p in EFFECTS[name].parameters}
        assert set(values) == set(declared), name
        for key, value in values.items():
            assert declared[key].lower <= value <= declared[key].upper, (name, key)


# --------------------------------------------------------------------------------------
# 1. Physical sanity
# --------------------------------------------------------------------------------------


def test_at_rest_nothing_moves() -> None:
    run = ind.simulate(STANDARD, duty=np.zeros(5000))
    assert np.max(np.abs(run["position_m"])) < 1e-9
    assert np.max(np.abs(run["temperature_c"] - STANDARD.convection.ambient_temperature_c)) < 1e-9
    assert np.all(run["martensite_fraction"] == 1.0)
    assert np.all(run["electrical_energy_j"] == 0.0)


def test_full_duty_contracts_to_the_end_of_travel_and_stops_there() -> None:
    run = ind.simulate(STANDARD, duty=_step_duty(8.0))
    x = run["position_m"]
    eot, release = STANDARD.driver.end_of_travel_m, STANDARD.driver.end_of_travel_release_m
    # Overshoot after the cut is only the mass's momentum and the heat still in the wire.
    assert x.max() < eot + 0.1e-3
    # Then it holds there: the cut cycles within its release band, it never runs away or falls back.
    held = x[3000:]
    assert held.min() > eot - release - 0.1e-3
    assert run["cut"][1500:].any()
    # The cut is what keeps the wire from overheating (without it T would pass 300 degC).
    assert run["temperature_c"].max() < 125.0


def test_energy_balance() -> None:
    """Electrical energy in = convected + stored heat change + latent heat absorbed, to
    round-off (the RK4 books every account from the same stage rates); and the latent heat
    absorbed covers the mechanical work, so E_el >= convected + stored + work.

    Tolerance: 1e-6 of the electrical energy for the identity (only the clip of xi to
    [0, 1] could break it), 1e-3 for the inequality. The efficiency of the 1 -> 7 mm part
    of the step (work / electrical energy) is 0.50 %, the report's 0.51 % (T5, 10 V step;
    measured 0.38 / 0.46 / 0.56 % at 5 / 7.5 / 15 V against the report's 0.12 / 0.42 / 0.60 %)."""
    run = ind.simulate(STANDARD, duty=_step_duty(4.0))
    e_el = run["electrical_energy_j"]
    stored = float(run["heat_capacity_j_k"]) * (run["temperature_c"] - STANDARD.convection.ambient_temperature_c)
    identity = e_el - run["convected_energy_j"] - stored - run["latent_absorbed_j"]
    assert np.max(np.abs(identity)) <= 1e-6 * e_el[-1]
    slack = e_el - run["convected_energy_j"] - stored - run["mechanical_work_j"]
    assert np.all(slack >= -1e-3 * e_el[-1])
    assert e_el[-1] > 1.0  # it did heat: tens of W for seconds
    x = run["position_m"]
    k1, k7 = int(np.argmax(x >= 1e-3)), int(np.argmax(x >= 7e-3))
    work = run["mechanical_work_j"]
    efficiency = (work[k7] - work[k1]) / (e_el[k7] - e_el[k1])
    assert 0.0025 < efficiency < 0.01


def _switching_duty(seed: int, seconds: float) -> np.ndarray:
    """Rest, then a random sequence of duty levels held for 30-400 ms: many reversals,
    inside and outside the transformation ranges."""
    rng = np.random.default_rng(seed)
    duty = np.zeros(int(seconds / CONTROL_PERIOD_S))
    k = 1000
    while k < duty.size:
        length = int(rng.integers(30, 400))
        duty[k : k + length] = rng.choice([0.0, 0.03, 0.06, 0.1, 0.2, 0.5])
        k += length
    return duty


def _check_xi_bounded_and_continuous(run: dict[str, np.ndarray]) -> int:
    xi = run["martensite_fraction"]
    assert np.all((xi >= 0.0) & (xi <= 1.0))
    step = np.abs(np.diff(xi))
    switches = np.flatnonzero(np.diff(run["heating"]) != 0)
    # The fastest transformation (duty 1 at 10 V) moves xi by about 0.006 per ms; a jump of
    # the uncorrected rescaled-cosine law would be 0.1 or more. At a reversal xi continues.
    if switches.size:
        assert step[switches].max() < 2e-3
    assert step.max() < 1e-2
    return int(switches.size)


def test_martensite_fraction_stays_in_range_and_reversals_never_jump() -> None:
    run = ind.simulate(STANDARD, duty=_switching_duty(3, 20.0))
    assert _check_xi_bounded_and_continuous(run) > 20  # it did reverse, many times


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(seed=st.integers(0, 2**31 - 1), spread_k=st.floats(0.0, 20.0))
def test_reversals_never_jump_for_any_duty_sequence_or_spread(seed: int, spread_k: float) -> None:
    run = ind.simulate(
        STANDARD, duty=_switching_duty(seed, 6.0), effect="transformation_spread", effect_values={"spread_k": spread_k}
    )
    _check_xi_bounded_and_continuous(run)


def test_a_40_s_trace_has_every_row_and_a_finite_position() -> None:
    """Its speed (a few seconds per 40 s trace) is measured by
    ``benchmarks/bench_generators.py`` against our kernel in the same run, not here: a
    wall-clock bound fails on a loaded machine (19 s measured beside two benchmark jobs)."""
    trace, _ = ind.generate(STANDARD, excitation="random", duration_s=40.0, seed=1)
    assert trace.t.size == 40001
    assert np.all(np.isfinite(trace.position)) and np.all(np.isfinite(trace.duty))


# --------------------------------------------------------------------------------------
# 2. Independence check against our kernel
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize("voltage_v", [10.0, 5.0])
def test_open_loop_step_has_the_kernels_character(voltage_v: float) -> None:
    """Stroke within 15 %, 10-90 % rise time and dead time within 30 % (measured: stroke
    -1.1 %, rise -4.5 %, dead time +8 % at 10 V; -0.0 %, -1.4 %, +9 % at 5 V)."""
    params = STANDARD.with_changes(**{"driver.supply_voltage_v": voltage_v})
    duty = _step_duty(6.0)
    ours, theirs = _kernel(duty, params), ind.simulate(params, duty=duty)
    stroke_ours, stroke_theirs = ours["position_m"][-1], theirs["position_m"][-1]
    assert abs(stroke_theirs / stroke_ours - 1.0) < 0.15
    rise_ours, dead_ours = _rise_times_s(ours["position_m"], stroke_ours)
    rise_theirs, dead_theirs = _rise_times_s(theirs["position_m"], stroke_theirs)
    assert abs(rise_theirs / rise_ours - 1.0) < 0.30
    assert abs(dead_theirs / dead_ours - 1.0) < 0.30


def _sine_duty() -> np.ndarray:
    """Slow open-loop sine duty 0..0.2 at 0.1 Hz for 40 s (heats through and cools back)."""
    t = np.arange(40000) * CONTROL_PERIOD_S
    duty = 0.1 * (1.0 - np.cos(2.0 * math.pi * 0.1 * t))
    duty[:1000] = 0.0
    return duty


def _halved_convection():
    c = STANDARD.convection
    return STANDARD.with_changes(**{"convection.h0_w_m2_k": c.h0_w_m2_k / 2, "convection.h2_w_m2_k3": c.h2_w_m2_k3 / 2})


@pytest.fixture(scope="module")
def sine_runs() -> dict[str, dict[str, np.ndarray]]:
    duty = _sine_duty()
    return {
        "kernel": _kernel(duty),
        "independent": ind.simulate(STANDARD, duty=duty),
        "independent h0/2": ind.simulate(_halved_convection(), duty=duty),
    }


def _range_m(x: np.ndarray) -> float:
    return float(x[10000:].max() - x[10000:].min())


def _rms(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a[10000:] - b[10000:]) ** 2)))


def test_slow_sine_duty_has_the_kernels_character(sine_runs) -> None:
    """Position swing within 15 % and an RMS difference under 0.5 mm (5 % of the stroke);
    resistance within 0.05 ohm RMS (measured: swing 5.61 vs 5.89 mm, RMS 0.21 mm, 0.016 ohm)."""
    ours, theirs = sine_runs["kernel"], sine_runs["independent"]
    assert abs(_range_m(theirs["position_m"]) / _range_m(ours["position_m"]) - 1.0) < 0.15
    assert _rms(theirs["position_m"], ours["position_m"]) < 0.5e-3
    assert _rms(theirs["resistance_ohm"], ours["resistance_ohm"]) < 0.05


def test_halved_convection_is_detected_as_different(sine_runs) -> None:
    """The same comparison must fail for a clearly different wire (h0 and h2 halved):
    measured swing 2.0 vs 5.9 mm, RMS 2.17 mm, ten times the nominal pair's difference."""
    ours, nominal, halved = sine_runs["kernel"], sine_runs["independent"], sine_runs["independent h0/2"]
    assert abs(_range_m(halved["position_m"]) / _range_m(ours["position_m"]) - 1.0) > 0.15
    assert _rms(halved["position_m"], ours["position_m"]) > 1.0e-3
    assert _rms(halved["position_m"], ours["position_m"]) > 4.0 * _rms(nominal["position_m"], ours["position_m"])


HOLD_DUTIES = (0.055, 0.06, 0.065, 0.07)


@pytest.fixture(scope="module")
def holding() -> dict[str, np.ndarray]:
    """Position [m] after 40 s at each constant duty of HOLD_DUTIES (rest for the first second)."""

    def final(run_fn, duty_value: float) -> float:
        duty = np.full(40000, duty_value)
        duty[:1000] = 0.0
        return float(run_fn(duty)["position_m"][-1])

    w = STANDARD.wire
    shifted = STANDARD.with_changes(
        **{"wire.austenite_start_c": w.austenite_start_c - 3.75, "wire.austenite_finish_c": w.austenite_finish_c - 3.75}
    )
    return {
        "kernel": np.array([final(_kernel, d) for d in HOLD_DUTIES]),
        "independent": np.array([final(lambda u: ind.simulate(STANDARD, duty=u), d) for d in HOLD_DUTIES]),
        "independent h0/2": np.array([final(lambda u: ind.simulate(_halved_convection(), duty=u), 0.06)]),
        "independent, heating branch -3.75 K": np.array([final(lambda u: ind.simulate(shifted, duty=u), 0.06)]),
    }


def test_duty_that_holds_5_mm_agrees_within_10_percent(holding) -> None:
    """T4 (fig. 6.4): duty 0.06 holds 5 mm. Measured after 40 s: kernel 0.060, independent 0.064."""
    duty_ours = np.interp(5e-3, holding["kernel"], HOLD_DUTIES)
    duty_theirs = np.interp(5e-3, holding["independent"], HOLD_DUTIES)
    assert abs(duty_theirs / duty_ours - 1.0) < 0.10
    # ... and halving the convection is far outside that: it holds the end of travel at 0.06.
    assert holding["independent h0/2"][0] - holding["kernel"][HOLD_DUTIES.index(0.06)] > 3e-3


@pytest.mark.xfail(
    strict=True,
    reason=(
        "known gap, measured: at duty 0.06 the kernel holds 4.93 mm, the independent generator "
        "2.74 mm; our Preisach width spread lowers the heating branch 3.75 K below Table 5.1's"
    ),
)
def test_holding_position_at_duty_006_within_1p5_mm(holding) -> None:
    i = HOLD_DUTIES.index(0.06)
    assert abs(holding["independent"][i] - holding["kernel"][i]) < 1.5e-3


def test_holding_gap_is_explained_by_the_kernels_loop_narrowing(holding) -> None:
    """With its heating branch lowered by the kernel's mean hysteron narrowing (half of the
    mean width 7.5 K) the independent generator holds where the kernel does (4.91 vs 4.93 mm)."""
    i = HOLD_DUTIES.index(0.06)
    assert abs(holding["independent, heating branch -3.75 K"][0] - holding["kernel"][i]) < 0.5e-3


# --------------------------------------------------------------------------------------
# 3. Effects
# --------------------------------------------------------------------------------------


def _effect_duty() -> np.ndarray:
    """Open loop (so a sensor effect cannot feed back into the plant): heat, cool, hold, cool."""
    return np.concatenate(
        [np.zeros(1000), np.full(2000, 0.15), np.full(3000, 0.03), np.full(4000, 0.08), np.full(3000, 0.03)]
    )


@pytest.fixture(scope="module")
def clean_trace():
    trace, _ = ind.generate(
        STANDARD, duty=_effect_duty(), position_noise_m=0.0, position_resolution_m=0.0, resistance_noise_ohm=0.0
    )
    return trace


#: effect -> (outputs it must change, outputs it must leave exactly as they were).
CHANGES = {
    "sensor_lag": (("position",), ("resistance", "current", "wire_voltage")),
    "abbe_offset": (("position",), ("resistance", "current", "wire_voltage")),
    "convection_change": (("position", "resistance"), ("wire_voltage",)),
    "coulomb_friction": (("position",), ("wire_voltage",)),
    "supply_sag": (("position", "resistance", "wire_voltage"), ()),
    "latent_heat": (("position", "resistance"), ("wire_voltage",)),
    "transformation_spread": (("position", "resistance"), ("wire_voltage",)),
    "minor_loop_width": (("position", "resistance"), ("wire_voltage",)),
}
#: "Changed" means an RMS change of at least three times the noise of a synthetic trace
#: (over thousands of samples that is far above what noise alone can do).
THRESHOLDS = {"position": 3 * POSITION_NOISE_M, "resistance": 3 * RESISTANCE_NOISE_OHM, "wire_voltage": 1e-2}


def _rms_finite(a: np.ndarray, b: np.ndarray) -> float:
    both = np.isfinite(a) & np.isfinite(b)
    return float(np.sqrt(np.mean((a[both] - b[both]) ** 2)))


@pytest.mark.parametrize("effect", sorted(CHANGES))
def test_each_effect_changes_the_outputs_it_should(effect: str, clean_trace) -> None:
    """At its typical size an effect moves an output by an RMS of at least three times the
    noise of a synthetic trace (5 um position, 2 mOhm resistance); a sensor effect leaves the
    electrical readings exactly as they were. Measured RMS changes [um / mOhm]: lag 26/0,
    Abbe 144/0, convection x1.6 1213/97, Coulomb 0.6 N 45/3.2, sag 1 ohm 1221/96,
    latent -12 J/g 285/23, spread +6 K 248/21, minor-loop width share 0.6 170/15."""
    trace, labels = ind.generate(
        STANDARD,
        duty=_effect_duty(),
        effect=effect,
        position_noise_m=0.0,
        position_resolution_m=0.0,
        resistance_noise_ohm=0.0,
    )
    assert labels["effect"] == effect
    changed, untouched = CHANGES[effect]
    for column in changed:
        change = _rms_finite(getattr(trace, column), getattr(clean_trace, column))
        assert change > THRESHOLDS[column], (effect, column, change)
    for column in untouched:
        np.testing.assert_array_equal(getattr(trace, column), getattr(clean_trace, column))
    # Readability of R (pulse long enough, power on) depends only on the duty and the cut.
    assert np.isfinite(trace.resistance).sum() > 0.9 * trace.t.size


def test_none_with_noise_stays_within_noise_of_the_clean_trace(clean_trace) -> None:
    noisy, labels = ind.generate(
        STANDARD,
        duty=_effect_duty(),
        effect="none",
        seed=7,
        position_noise_m=POSITION_NOISE_M,
        position_resolution_m=1e-6,
        resistance_noise_ohm=RESISTANCE_NOISE_OHM,
    )
    assert labels["effect"] is None
    dx = noisy.position - clean_trace.position
    dr = noisy.resistance - clean_trace.resistance
    dr = dr[np.isfinite(dr)]
    # Std within 15 % of the noise (plus 1 um quantisation, 0.29 um std), mean within 4 sigma/sqrt(n).
    assert abs(np.std(dx[1:]) / math.hypot(POSITION_NOISE_M, 1e-6 / math.sqrt(12)) - 1.0) < 0.15
    assert abs(np.mean(dx[1:])) < 4 * POSITION_NOISE_M / math.sqrt(dx.size)
    assert abs(np.std(dr) / RESISTANCE_NOISE_OHM - 1.0) < 0.15
    assert abs(np.mean(dr)) < 4 * RESISTANCE_NOISE_OHM / math.sqrt(dr.size)


# --------------------------------------------------------------------------------------
# 4. The project's data format
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("excitation", "sample_period_s", "electrical"),
    [
        ("steps", 1e-3, True),
        ("ramps", 1e-3, True),
        ("sine", 1e-2, False),
        ("chirp", 1e-3, True),
        ("random", 1e-2, False),
    ],
)
def test_trace_round_trips_through_the_csv_writer_and_loader(
    excitation: str, sample_period_s: float, electrical: bool, tmp_path: Path
) -> None:
    """What ``sma-gym diagnose`` loads (``min_rows=DIAGNOSIS_MIN_ROWS``) is what was generated:
    1 kHz with R, I, V and 100 Hz position-only files, for every excitation."""
    trace, labels = ind.generate(
        STANDARD,
        excitation=excitation,
        duration_s=8.0,
        effect="coulomb_friction",
        sample_period_s=sample_period_s,
        electrical=electrical,
        seed=5,
    )
    assert labels["generator"] == "independent"
    path = write_trace(tmp_path / f"{excitation}.csv", trace)
    loaded = load_trace(path, min_rows=DIAGNOSIS_MIN_ROWS)
    assert loaded.t.size == trace.t.size == int(round(8.0 / sample_period_s)) + 1
    np.testing.assert_allclose(np.diff(loaded.t), sample_period_s, rtol=1e-9)
    for column in ("t", "duty", "position", "resistance", "current", "wire_voltage"):
        original = getattr(trace, column)
        if original is None:
            assert getattr(loaded, column) is None
            continue
        np.testing.assert_array_equal(getattr(loaded, column), original)  # repr() round-trips floats
    assert loaded.conditions == {"supply_voltage_v": 10.0, "pwm_frequency_hz": 500.0}
    # A closed-loop recording: rest first, then the P controller moves the actuator.
    assert np.all(trace.duty[: int(0.9 / sample_period_s)] == 0.0)
    assert trace.position.max() > 2e-3


@pytest.mark.parametrize("sample_period_s", [2e-3, 1e-2])
def test_a_slower_file_holds_the_duty_the_actuator_got(sample_period_s: float) -> None:
    """The P controller commands once per sample, so the file's duty column (held from each
    row to the next) is exactly the duty applied at every 1 ms step: a file that logged one
    duty in ten of a 1 ms loop would describe an input the actuator never got."""
    every = int(round(sample_period_s / ind.CONTROL_PERIOD_S))
    trace, _ = ind.generate(STANDARD, excitation="random", duration_s=6.0, sample_period_s=sample_period_s, seed=9)
    noise = {"position_noise_m": 5e-6, "position_resolution_m": 1e-6, "resistance_noise_ohm": 2e-3}  # generate's
    run = ind.simulate(STANDARD, excitation="random", duration_s=6.0, seed=9, controller_every=every, **noise)
    applied = run["duty"].reshape(-1, every)
    assert np.all(applied == applied[:, :1]), "the duty changed inside a sample interval"
    np.testing.assert_array_equal(trace.duty[:-1], applied[:, 0])
    assert applied.max() > 0.5 and np.unique(applied[:, 0]).size > 50  # a closed loop at work
