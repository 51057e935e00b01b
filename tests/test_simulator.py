"""Behaviour of the simulator core: physics, numerics, sensors, PWM and multiplexer."""

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from sma_gym import ModelConfig, Multiplexer, Simulator, preset
from sma_gym.core import layout as L
from sma_gym.effects import EFFECTS
from sma_gym.electrical.multiplexer import io_counts


def run(model="standard", duty=None, seconds=5.0, **kwargs):
    sim = Simulator(model, **kwargs)
    if duty is None:
        duty = np.ones(int(seconds * 1000))
    rec = (
        "position_m",
        "temperature_c",
        "martensite_fraction",
        "stress_pa",
        "position_measured_m",
        "resistance_measured_ohm",
        "resistance_ohm",
        "power_w",
        "spring_force_n",
    )
    return sim, sim.run(duty, record=rec)


PLAY = ModelConfig(
    preset("standard").with_changes(
        **{"wire.minor_loop_law": "play", "wire.transformation_spread_k": 0.0, "wire.hysteron_width_spread": 0.0}
    )
)
"""sma-gym 0.1's hysteresis (one full-width play operator), kept as a named option."""


def test_an_unpowered_actuator_stays_exactly_at_rest():
    sim, out = run(duty=np.zeros(2000))
    assert np.all(out["position_m"] == 0.0)
    assert np.all(out["temperature_c"] == 20.0)
    assert np.all(out["martensite_fraction"] == 1.0)
    # No pulse, no resistance reading.
    assert np.all(np.isnan(out["resistance_measured_ohm"]))


def test_full_power_contracts_to_the_end_of_travel_and_no_further():
    p = preset("standard")
    sim, out = run(seconds=6.0)
    x = out["position_m"][:, 0]
    assert x.max() == pytest.approx(p.driver.end_of_travel_m, abs=0.4e-3)
    assert x.max() < p.wire.max_stroke_m
    # The cut keeps the wire in a limit cycle around the end of travel, not overheating.
    assert out["temperature_c"].max() < 130.0
    assert x[-2000:].min() > p.driver.end_of_travel_m - 1.0e-3


def test_duty_is_validated():
    sim = Simulator()
    for bad in (float("nan"), float("inf")):
        with pytest.raises(ValueError, match="duty"):
            sim.step(bad)
    with pytest.raises(ValueError, match="shape"):
        sim.step(np.ones(3))
    with pytest.raises(ValueError, match=r"duty\[5\]"):
        sim.run(np.r_[np.zeros(5), np.nan])
    # Out-of-range duties are clipped, not errors.
    sim.step(7.0)
    assert sim.duty_applied[0] == 1.0
    sim.step(-3)
    assert sim.duty_applied[0] == 0.0 and sim.power_w[0] == 0.0
    sim.step(7.0)
    assert float(sim.power_w[0]) == pytest.approx(10.0**2 / float(sim.resistance_ohm[0]), rel=0.01)


def test_heating_below_austenite_start_lengthens_the_wire():
    """Thermal expansion: x < 0 while the wire warms but has not started to transform (the
    play law without spread, whose transformation starts sharply at A_s)."""
    sim, out = run(PLAY, duty=np.full(30000, 0.04))
    assert out["martensite_fraction"][-1, 0] == 1.0
    assert 50.0 < out["temperature_c"][-1, 0] < 75.0
    w = preset("standard").wire
    expected = -w.thermal_expansion_martensite_1_k * (out["temperature_c"][-1, 0] - 20.0) * w.length_m
    assert out["position_m"][-1, 0] == pytest.approx(expected, rel=0.1)


def test_a_hot_austenitic_wire_lengthens_by_the_austenite_expansion():
    """Each phase expands by its own coefficient: a fully contracted wire heated further
    lengthens by alpha_A (11e-6 /K), not the martensite's 6.6e-6 or their mean 8.8e-6."""
    model = ModelConfig(PLAY.actuator.with_changes(**{"driver.end_of_travel_m": math.inf}))
    sim = Simulator([model, model])
    duty = np.repeat([[0.2, 0.3]], 15000, axis=0)
    out = sim.run(duty, record=("position_m", "temperature_c", "martensite_fraction"))
    assert np.all(out["martensite_fraction"][-1] == 0.0)
    x, t = out["position_m"][-1], out["temperature_c"][-1]
    assert t[1] - t[0] > 20.0
    w = preset("standard").wire
    assert (x[1] - x[0]) / (t[1] - t[0]) == pytest.approx(-w.thermal_expansion_austenite_1_k * w.length_m, rel=0.03)


def test_more_preload_raises_the_transformation_temperature():
    """Stress-shifted temperatures: more stress, later transformation."""
    light = ModelConfig(preset("standard").with_changes(**{"mechanism.spring_preload_n": 1.0}))
    heavy = ModelConfig(preset("standard").with_changes(**{"mechanism.spring_preload_n": 6.0}))
    sim = Simulator([light, heavy])
    out = sim.run(np.ones(2000), record=("temperature_c", "martensite_fraction"))
    start = [out["temperature_c"][np.argmax(out["martensite_fraction"][:, j] < 0.99), j] for j in range(2)]
    shift = (6.0 - 1.0) / preset("standard").wire.area_m2 / 10.3e6
    assert start[1] - start[0] == pytest.approx(shift, rel=0.15)


def effective_temperature(out, j=0):
    """T - sigma / C: what drives the transformation (the stress shifts the temperatures)."""
    return out["temperature_c"][:, j] - out["stress_pa"][:, j] / 10.3e6


def test_play_law_reversal_crosses_the_whole_hysteresis_before_moving():
    """Heat to about half transformed, then cool: xi never jumps, stays put while the
    effective temperature falls through the 15 K hysteresis, then rises along the
    cooling branch."""
    duty = np.r_[np.ones(330), np.zeros(6000)]
    _, out = run(PLAY, duty=duty)
    xi = out["martensite_fraction"][:, 0]
    te = effective_temperature(out)
    k = int(np.argmax(te))
    assert 0.2 < xi[k] < 0.8
    assert np.max(np.abs(np.diff(xi))) < 0.02  # no jump anywhere
    band = (np.arange(len(te)) > k) & (te > te[k] - 14.0)
    assert band.sum() > 100
    assert np.all(np.abs(xi[band] - xi[k]) < 1e-9)
    assert xi[-1] > xi[k] + 0.3


def test_nominal_law_moves_back_within_a_few_kelvin_of_a_reversal_and_never_jumps():
    """The nominal (Preisach) law: after a reversal mid-transformation the narrow hysterons
    start back at once, so xi has recovered measurably 3 K below the peak (0.010 with the
    8 K spread; the play law needs 15 K) and keeps rising smoothly, with no jump."""
    duty = np.r_[np.ones(330), np.zeros(6000)]
    _, out = run(duty=duty)
    xi = out["martensite_fraction"][:, 0]
    te = effective_temperature(out)
    k = int(np.argmax(te))
    assert 0.2 < xi[k] < 0.8
    assert np.max(np.abs(np.diff(xi))) < 0.02
    three_below = k + int(np.argmax(te[k:] < te[k] - 3.0))
    assert xi[three_below] > xi[k] + 0.005
    assert np.all(np.diff(xi[k:]) >= -1e-12)  # cooling only ever adds martensite
    assert xi[-1] > xi[k] + 0.3


def _major_loop_widths(model, fractions=(0.25, 0.5, 0.75)) -> list[float]:
    """Heat and cool quasi-statically (a 200 s half sine of duty to 0.16): the temperature
    difference [K] between the heating and the cooling branch at each fraction of the stroke."""
    t = np.arange(200_000) * 1e-3
    _, out = run(model, duty=0.16 * np.sin(np.pi * t / t[-1]))
    temp, x = out["temperature_c"][:, 0], out["position_m"][:, 0]
    k = int(np.argmax(x))
    widths = []
    for f in fractions:
        level = f * x[k]
        widths.append(float(temp[: k + 1][np.argmax(x[: k + 1] >= level)] - temp[k:][np.argmax(x[k:] <= level)]))
    return widths


def test_the_major_loop_is_the_hysterons_mean_width():
    """docs/model.md §3: the play law keeps the report's 15 K loop; the nominal law's widths,
    spread over [0, 15 K], make it 15 (1 - w / 2) = 7.5 K (measured 7.4-8.0 K along the stroke)."""
    assert _major_loop_widths(PLAY) == pytest.approx([15.0] * 3, abs=0.6)
    assert _major_loop_widths("standard") == pytest.approx([7.7] * 3, abs=0.6)


NARROW_COLD = ModelConfig(preset("standard")).with_actuator(**{"wire.hysteron_width_pairing": "narrow-cold"})


def _recovered_below_the_peak(model, heating_ms: int, kelvin: float) -> tuple[float, float]:
    """Heat at full duty for ``heating_ms``, then cool: (xi at the peak, xi gained ``kelvin``
    below the peak effective temperature)."""
    _, out = run(model, duty=np.r_[np.ones(heating_ms), np.zeros(6000)])
    xi = out["martensite_fraction"][:, 0]
    te = effective_temperature(out)
    k = int(np.argmax(te))
    return float(xi[k]), float(xi[k + int(np.argmax(te[k:] < te[k] - kelvin))] - xi[k])


@pytest.mark.parametrize(
    ("model", "hot_lags"), [("standard", False), (NARROW_COLD, True)], ids=["uncorrelated", "narrow-cold"]
)
def test_a_hot_reversal_lags_longer_than_a_cold_one_only_with_the_narrow_cold_pairing(model, hot_lags):
    """Reversed with little austenite formed, the wire starts back within 2 K either way;
    reversed nearly transformed, the nominal (uncorrelated) wire has moved back measurably
    4 K below the peak (0.009; the 8 K spread makes it lag longer than at a cold reversal,
    as the report's sine does), the narrow-cold one (the hottest hysterons the widest)
    barely (0.001)."""
    cold_peak, cold_gain = _recovered_below_the_peak(model, 250, 2.0)
    hot_peak, hot_gain = _recovered_below_the_peak(model, 400, 4.0)
    assert cold_peak > 0.8 and hot_peak < 0.4
    assert cold_gain > 0.004
    assert (hot_gain < 0.002) if hot_lags else (hot_gain > 0.005)


@pytest.mark.parametrize("model", ["standard", PLAY], ids=["preisach", "play"])
def test_minor_loops_close_return_point_memory(model):
    """Heat to a reversal point, cool a few kelvin, re-heat past it: on the way back the
    state rejoins the branch where it left it, and repeating the minor loop ends where the
    first one ended (no drift)."""
    sim = Simulator(model)
    rec = ("temperature_c", "stress_pa", "martensite_fraction")
    first = sim.run(np.r_[np.ones(300), np.zeros(700)], record=rec)
    te1 = effective_temperature(first)
    k = int(np.argmax(te1))
    te_rev, xi_rev = te1[k], first["martensite_fraction"][k, 0]
    assert te1[-1] < te_rev - 5.0  # cooled, inside the hysteresis
    second = sim.run(np.ones(300), record=rec)
    te2 = effective_temperature(second)
    xi2 = second["martensite_fraction"][:, 0]
    assert np.all(xi2[te2 <= te_rev - 0.5] >= xi_rev - 1e-9)  # below the peak: never past it
    # Just past the reversal point it continues on the branch it left.
    after = int(np.argmax(te2 > te_rev))
    assert xi2[after] == pytest.approx(xi_rev, abs=0.02)
    assert xi2[-1] < xi_rev - 0.1
    # A periodic minor loop (0.5 s heating, 0.5 s cooling about a holding point): once the
    # temperature cycle has settled, xi repeats from cycle to cycle instead of drifting.
    loop = np.r_[np.full(500, 0.12), np.zeros(500)]
    ends = [sim.run(loop, record=("martensite_fraction",))["martensite_fraction"][-1, 0] for _ in range(150)]
    # The approach is the temperature's (geometric, tau ~ 5 s), then nothing moves.
    assert np.ptp(ends[-5:]) < 1e-6
    assert abs(ends[-1] - ends[-40]) < 1e-5


def test_the_hysterons_span_the_spread_and_keep_heating_above_cooling():
    """The nominal set of hysterons: centres spread with the wire's standard deviation,
    widths from nearly zero to the full 15 K, every heating branch above its cooling branch."""
    from sma_gym.physics.transformation import hysteron_nodes

    shift_h, shift_c, weights, widening_k = hysteron_nodes(6.0, 1.0, 15.0, branch_range_k=35.0)
    assert widening_k == 0.0  # the standard wire's 35 K branches bridge these centres
    centres = (np.array(shift_h) + np.array(shift_c)) / 2
    narrowing = np.array(shift_c) - np.array(shift_h)
    assert np.sum(weights) == pytest.approx(1.0)
    assert np.sqrt(np.sum(np.array(weights) * centres**2)) == pytest.approx(6.0)
    assert narrowing.min() < 2.0 and narrowing.max() > 12.0 and np.all(narrowing <= 15.0)
    assert hysteron_nodes(0.0, 0.0, 15.0, law="play") == ([0.0], [0.0], [1.0], 0.0)
    with pytest.raises(ValueError, match="minor-loop law"):
        hysteron_nodes(6.0, 1.0, 15.0, law="duhem")


def test_wider_minor_loops_floor_or_draw_the_widths_and_keep_the_centres():
    """minor_loop_width: 'default' floors every loop at the share of the mean width (the wide
    ones kept), 'mean' draws every width that share towards the mean (the mean kept); the
    centres never move, and share 0 is the nominal set exactly."""
    from sma_gym.physics.transformation import hysteron_nodes

    def centres_and_widths(share: float, form: str) -> tuple[np.ndarray, np.ndarray]:
        shift_h, shift_c, _, _ = hysteron_nodes(
            8.0, 1.0, 15.0, branch_range_k=35.0, min_width_share=share, widths_form=form
        )
        h, c = np.array(shift_h), np.array(shift_c)
        return (h + c) / 2, 15.0 - (c - h)

    centres, widths = centres_and_widths(0.0, "default")
    assert hysteron_nodes(8.0, 1.0, 15.0, branch_range_k=35.0) == hysteron_nodes(
        8.0, 1.0, 15.0, branch_range_k=35.0, min_width_share=0.0, widths_form="mean"
    )
    mean = widths.mean()
    assert mean == pytest.approx(7.5)
    c_floor, w_floor = centres_and_widths(0.6, "default")
    np.testing.assert_allclose(c_floor, centres)
    np.testing.assert_allclose(w_floor, np.maximum(widths, 0.6 * mean))
    assert w_floor.min() == pytest.approx(4.5) and w_floor.max() == pytest.approx(widths.max())
    c_mean, w_mean = centres_and_widths(0.6, "mean")
    np.testing.assert_allclose(c_mean, centres)
    np.testing.assert_allclose(w_mean, widths + 0.6 * (mean - widths))
    assert w_mean.mean() == pytest.approx(mean)
    np.testing.assert_allclose(centres_and_widths(1.0, "mean")[1], mean)
    with pytest.raises(ValueError, match="minor-loop width form"):
        hysteron_nodes(8.0, 1.0, 15.0, widths_form="ceiling")
    with pytest.raises(ValueError, match="min_width_share"):
        hysteron_nodes(8.0, 1.0, 15.0, min_width_share=1.5)
    with pytest.raises(ValueError, match=r"minor_loop_width.min_width_share = 2"):
        ModelConfig(preset("standard")).with_effect("minor_loop_width", {"min_width_share": 2.0})


def test_wider_minor_loops_hold_a_partial_contraction_after_switch_off():
    """A partial contraction (duty 0.12 for 3 s) switched off: with the narrowest loops wider
    the wire goes on contracting thermally for longer before it transforms back (peak
    0.08 s after switch-off nominally, 0.34 s at a share of 0.6, 0.37 s in the mean form),
    and it still returns."""
    duty = np.zeros(9000)
    duty[1000:4000] = 0.12

    def peak_delay_s(model: ModelConfig) -> tuple[float, float]:
        x = Simulator(model).run(duty, record=("position_m",))["position_m"][:, 0]
        return (int(np.argmax(x)) - 4000) * 1e-3, float(x[-1])

    nominal = ModelConfig(preset("standard"))
    base, base_end = peak_delay_s(nominal)
    wide, wide_end = peak_delay_s(nominal.with_effect("minor_loop_width", {"min_width_share": 0.6}))
    drawn, _ = peak_delay_s(nominal.with_effect("minor_loop_width", {"min_width_share": 0.6}, "mean"))
    assert base < 0.15 and wide > base + 0.15 and drawn > base + 0.15
    assert abs(wide_end - base_end) < 2e-4  # both back home within 0.2 mm


@pytest.mark.parametrize("count", [7, 11])
def test_the_narrow_cold_pairing_gives_the_coldest_hysteron_the_narrowest_loop(count):
    """'narrow-cold': the loop width grows with the centre; 'uncorrelated' keeps the same
    widths and centres, only paired differently (rank correlation near zero)."""
    from scipy.stats import spearmanr

    from sma_gym.physics.transformation import hysteron_nodes

    def centres_and_widths(pairing: str) -> tuple[np.ndarray, np.ndarray]:
        shift_h, shift_c, _, _ = hysteron_nodes(6.0, 1.0, 15.0, branch_range_k=35.0, max_nodes=count, pairing=pairing)
        h, c = np.array(shift_h), np.array(shift_c)
        return (h + c) / 2, 15.0 - (c - h)  # width = full loop minus the narrowing

    centres, widths = centres_and_widths("narrow-cold")
    assert np.all(np.diff(centres) > 0) and np.all(np.diff(widths) > 0)
    assert widths[0] < 1.5 and widths[-1] > 13.5  # 1.1 K and 13.9 K with 7 hysterons
    other_centres, other_widths = centres_and_widths("uncorrelated")
    np.testing.assert_allclose(other_centres, centres)
    np.testing.assert_allclose(np.sort(other_widths), widths)
    assert abs(spearmanr(other_centres, other_widths).statistic) < 0.3
    with pytest.raises(ValueError, match="width pairing"):
        hysteron_nodes(6.0, 1.0, 15.0, pairing="narrow-hot")
    with pytest.raises(ValueError, match="Wire.hysteron_width_pairing"):
        ModelConfig(preset("standard")).with_actuator(**{"wire.hysteron_width_pairing": "random"})


@pytest.mark.parametrize("law", ["play", "preisach"])
def test_a_wide_spread_on_narrow_branches_is_smooth_and_keeps_mean_and_variance(law):
    """A 0.5 mm HT wire's 10 K branches with a 12 K spread: a few discrete hysterons would
    leave plateaus between their cosines. The nodes move closer and the branches widen, so
    the quasi-static heating curve xi(T) has no plateau, and the transformation keeps the
    mean and the variance of the spread distribution convolved with the cosine."""
    from sma_gym.physics.transformation import COSINE_VARIANCE, hysteron_nodes

    spread_k, range_k = 12.0, 10.0
    shift_h, shift_c, weights, widening_k = hysteron_nodes(spread_k, 1.0, 10.0, law, branch_range_k=range_k)
    assert widening_k > 0.0
    width = range_k + widening_k
    temps = np.linspace(-80.0, 80.0, 16001)
    # Heating branches of every hysteron (xi from 1 to 0), each a cosine over `width`.
    u = np.clip((temps[:, None] - np.array(shift_h)[None, :] + width / 2) / width, 0.0, 1.0)
    xi = (0.5 * (1.0 + np.cos(np.pi * u)) * np.array(weights)[None, :]).sum(axis=1)
    slope = -np.gradient(xi, temps)
    inside = (xi > 0.05) & (xi < 0.95)
    assert slope[inside].min() > 0.35 * slope[inside].max()  # no plateau (0.24 unwidened)
    centres = (np.array(shift_h) + np.array(shift_c)) / 2
    assert np.dot(weights, centres) == pytest.approx(0.0, abs=1e-9)
    assert np.dot(weights, centres**2) + COSINE_VARIANCE * width**2 == pytest.approx(
        spread_k**2 + COSINE_VARIANCE * range_k**2
    )
    if law == "play":  # every hysteron's heating branch sits at its centre: the curve itself
        density = slope / np.trapezoid(slope, temps)
        mean = np.trapezoid(temps * density, temps)
        assert mean == pytest.approx(0.0, abs=0.05)
        assert np.trapezoid((temps - mean) ** 2 * density, temps) == pytest.approx(
            spread_k**2 + COSINE_VARIANCE * range_k**2, rel=0.01
        )


def test_pwm_ripple_does_not_make_xi_ratchet():
    """Pulse-by-pulse heating at a holding duty follows the averaged model: the gap comes
    only from the ripple (the hysteresis follows temperature peaks), shrinks as the ripple
    shrinks, and settles to a constant instead of growing (no ratchet). The hold itself
    settles slowly (~17 s): the falling resistance raises the power as the wire contracts."""
    duty = np.full(120000, 0.06)
    avg = run(duty=duty, pwm_mode="averaged")[1]["position_m"][:, 0]
    gaps = {}
    for f in (50.0, 500.0):
        model = ModelConfig(preset("standard").with_changes(**{"driver.pwm_frequency_hz": f}))
        res = run(model, duty=duty, pwm_mode="resolved")[1]["position_m"][:, 0]
        gaps[f] = res - avg
        tail = gaps[f][-20000:]
        assert tail.max() - tail.min() < 0.005e-3
    assert 0.0 < gaps[50.0][-1] < 0.3e-3
    assert abs(gaps[500.0][-1]) < 0.2 * gaps[50.0][-1]


def test_integration_converges_at_first_order_and_is_accurate_at_the_default_step():
    """Refine the accuracy bounds (sub-step cap, temperature and position change per
    sub-step, in and outside the cut's switching band) together: the error against a fine reference halves each time, and at the defaults it
    is within 1.5 % of the stroke, at 1 ms and at 10 ms control periods."""
    rng = np.random.default_rng(1)
    blocks = rng.uniform(0, 0.15, size=24)
    blocks[::5] = 1.0
    blocks[2::5] = 0.0
    duty = np.repeat(blocks, 500)
    fine = {
        "max_substep_s": 3e-5,
        "max_temperature_step_k": 0.01,
        "max_position_step_m": 0.2e-6,
        "max_temperature_step_at_cut_k": 0.0002,
        "max_position_step_at_cut_m": 0.02e-6,
    }
    ref = Simulator(**fine).run(duty, record=("position_m",))["position_m"][:, 0]
    err = {}
    for cap, dk, dx in ((10e-3, 0.5, 10e-6), (5e-3, 0.25, 5e-6), (2.5e-3, 0.125, 2.5e-6)):
        # The switching band's bounds refined in proportion (0.01 K and 1 um at the defaults).
        sim = Simulator(
            max_substep_s=cap,
            max_temperature_step_k=dk,
            max_position_step_m=dx,
            max_temperature_step_at_cut_k=dk / 50,
            max_position_step_at_cut_m=dx / 10,
        )
        x = sim.run(duty, record=("position_m",))["position_m"][:, 0]
        err[cap] = np.max(np.abs(x - ref))
    assert err[10e-3] < 0.15e-3
    assert err[10e-3] / err[5e-3] > 1.5 and err[5e-3] / err[2.5e-3] > 1.5
    coarse = Simulator(control_period_s=10e-3).run(duty[::10], record=("position_m",))["position_m"][:, 0]
    assert np.max(np.abs(coarse - ref[9::10])) < 0.15e-3


def _integration_bench():
    """``benchmarks/bench_integration.py``, loaded by file path (``benchmarks`` is not a
    package): its duty sequences, reference accuracy and goal are the ones tested here."""
    path = Path(__file__).resolve().parent.parent / "benchmarks" / "bench_integration.py"
    spec = importlib.util.spec_from_file_location("bench_integration", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _minor_loop_bench():
    """``benchmarks/bench_minor_loops.py``, loaded by file path."""
    path = Path(__file__).resolve().parent.parent / "benchmarks" / "bench_minor_loops.py"
    spec = importlib.util.spec_from_file_location("bench_minor_loops", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    # Registered while it runs: its frozen dataclass resolves its own module.
    sys.modules[spec.name] = module
    try:
        spec.loader.exec_module(module)
    finally:
        del sys.modules[spec.name]
    return module


def test_the_minor_loop_comparison_measures_what_docs_model_md_says(monkeypatch):
    """The comparison of docs/model.md §3: of the candidate laws only the kernel's Preisach
    law starts back within 2 K *and* neither jumps nor drifts under ripple; the
    rescaled cosine jumps, the continuity-fixed and the Duhem-type laws drift, the play law
    waits for the whole hysteresis. The comparison's evaluation of the kernel's two laws is
    the kernel's own (within the 1 ms sampling of its recorded temperatures)."""
    bench = _minor_loop_bench()
    monkeypatch.setattr(bench, "RIPPLE_CYCLES", 300)
    model = ModelConfig(preset("standard"))
    sigma = bench.operating_stress_pa(model)
    r = {name: bench.measure(bench.law_function(name, model), sigma) for name in bench.LAWS}
    pre = r["preisach"]
    assert pre["lag_top_small_k"] < 2.0 and pre["lag_bottom_small_k"] < 2.0 and pre["lag_top_k"] < 5.0
    assert pre["jump"] < 1e-3 and pre["ripple_drift"] == 0.0
    assert pre["return_point"] < 1e-12 and pre["wiping_out"] < 1e-12
    assert r["play"]["lag_top_k"] > 14.0 and r["play"]["ripple_drift"] == 0.0
    assert r["rescaled"]["jump"] > 0.01 and r["rescaled"]["lag_top_k"] < 1.0
    for name in ("rescaled", "proportional", "duhem"):
        assert abs(r[name]["ripple_drift"]) > 0.02 and r[name]["return_point"] > 0.02, (name, r[name])
    for name in ("proportional", "duhem"):
        assert r[name]["jump"] < 1e-3, (name, r[name])
    for name in ("preisach", "play"):
        assert bench.kernel_check(name, model) < 1e-3


def test_the_cut_switches_where_the_position_crosses_it_not_at_a_substep_boundary():
    """Within 0.1 mm and 0.5 K of a 30 us reference everywhere, at 10 V and at 20 V. At 20 V
    the wire spends most of the time latched at the cut, a relay cycle (cut, cool by ~8 K
    until the position falls 0.2 mm, re-heat at ~1000 K/s) whose release time moves by
    ~0.6 ms per micrometre of position: only the switching band's tighter bounds keep it in
    phase (0.33 mm / 7.4 K without them). The 50 ms sequence at 20 V is the one on which a
    10 us reference parted from the 30 us one by 0.30 mm / 7.3 K while the mechanics were
    backward Euler (its numerical damping of the wire-mass mode set the overshoot at each
    cut); with the theta-method the two agree within 0.001 mm / 0.02 K."""
    bench = _integration_bench()
    rec, fine = bench.RECORD, bench.REFERENCE_30US
    for voltage, seed, block_ms in ((10.0, 1, 250), (20.0, 1, 250), (20.0, 4, 50)):
        duty = bench.duty_sequence(seed, block_ms)
        model = preset(f"supply-{voltage:g}v")
        ref = Simulator(model, **fine).run(duty, record=rec)
        out = Simulator(model).run(duty, record=rec)
        cut = ref["end_of_travel_cut"][:, 0]
        assert cut.sum() > 1000  # the sequence really works the cut
        assert np.count_nonzero(np.diff(cut) < 0) > 10  # ... and releases it, many times
        dx = np.abs(out["position_m"] - ref["position_m"])[:, 0]
        dt = np.abs(out["temperature_c"] - ref["temperature_c"])[:, 0]
        assert dx.max() < bench.GOAL_M and dt.max() < bench.GOAL_K, (voltage, dx.max(), dt.max())
        if block_ms == 50:
            finer = Simulator(model, **bench.REFERENCE_10US).run(duty, record=rec)
            parted_m, parted_k = bench._worst(finer, ref)
            assert parted_m < 0.01e-3 and parted_k < 0.1, (parted_m, parted_k)


def test_resolved_pwm_conducts_again_where_the_release_is_crossed_inside_a_pulse():
    """PWM-resolved: a wire latched by the cut conducts again from the instant its position
    falls below the release point if the PWM is in its pulse (the switch gates the MOSFET),
    not from whenever the sub-step happens to end. Up to the third release, or for as long
    as the 30 us and a 10 us reference agree, the default is within 0.1 mm / 0.5 K of the
    30 us one (7.5 K at 20 V when the release waited for the sub-step's end). The 20 V
    relay cycle amplifies sub-micrometre differences at each release, and the pulses sample
    the release at their own phase, so there the two references part at the fourth release
    (the second while the mechanics were backward Euler) and the default, 0.04 mm / 0.35 K
    off before it, releases 22 ms early there: no pointwise comparison measures the
    integrator beyond the third. Known weakness (measured
    2026-11-25): with the release's location inside a pulse switched off in the kernel
    (``drive = False`` when resolved) this test still passes, at 6 K as at 8 K (0.04-0.1 K
    from the reference), so it guards the in-pulse release only against a larger error
    than that one."""
    bench = _integration_bench()
    duty, rec = bench.duty_sequence(1, 250), bench.RECORD
    for voltage in (10.0, 20.0):
        model = preset(f"supply-{voltage:g}v")
        ref = Simulator(model, pwm_mode="resolved", **bench.REFERENCE_30US).run(duty, record=rec)
        finer = Simulator(model, pwm_mode="resolved", **bench.REFERENCE_10US).run(duty, record=rec)
        out = Simulator(model, pwm_mode="resolved").run(duty, record=rec)
        releases = np.flatnonzero(np.diff(ref["end_of_travel_cut"][:, 0]) < 0)
        assert releases.size > 3
        parted = (np.abs(finer["temperature_c"] - ref["temperature_c"])[:, 0] > 0.5 * bench.GOAL_K) | (
            np.abs(finer["position_m"] - ref["position_m"])[:, 0] > 0.5 * bench.GOAL_M
        )
        end = min(releases[2], int(np.argmax(parted)) if parted.any() else len(duty))
        assert end > releases[0] + 20  # the references agree past the first release at least
        dx = np.abs(out["position_m"] - ref["position_m"])[:end, 0]
        dt = np.abs(out["temperature_c"] - ref["temperature_c"])[:end, 0]
        assert dx.max() < bench.GOAL_M and dt.max() < bench.GOAL_K, (voltage, dx.max(), dt.max())


def test_resolved_and_averaged_pwm_agree_apart_from_ripple():
    duty = np.r_[np.ones(400), np.full(3000, 0.07), np.zeros(3000)]
    a = run(duty=duty, pwm_mode="averaged", max_substep_s=1e-4)[1]
    r = run(duty=duty, pwm_mode="resolved", max_substep_s=1e-4)[1]
    assert np.max(np.abs(a["position_m"] - r["position_m"])) < 0.05e-3
    assert np.max(np.abs(a["temperature_c"] - r["temperature_c"])) < 0.3


def test_energy_is_accounted_for():
    model = ModelConfig(preset("standard")).with_effect("latent_heat", {"change_j_kg": 10000.0})
    duty = np.r_[np.ones(600), np.full(4000, 0.06), np.zeros(5000)]
    no_latent = ModelConfig(preset("standard").with_changes(**{"wire.latent_heat_j_kg": 0.0}))
    sim = Simulator([no_latent, model, preset("supply-20v")], pwm_mode="resolved")
    sim.run(duty)
    e = sim.energy_balance()
    assert np.all(e["electrical"] > 1.0)
    # Thermal side: booked exactly.
    assert np.all(np.abs(e["residual"]) < 1e-9 * e["electrical"])
    # Mechanical side: the wire's work is kinetic + spring + dissipated, up to the
    # implicit step's numerical damping where it is not trapezoidal (stated tolerance: 0.1 %
    # of the input; measured about 4e-6).
    assert np.all(np.abs(e["mechanical_residual"]) < 1e-3 * e["electrical"])
    # Latent heat was absorbed while transforming, except on the wire without any.
    assert e["latent_released"][0] == 0.0 and e["latent_released"][1] != 0.0


def test_same_seed_same_result_bit_for_bit_with_noise():
    noisy = ModelConfig(
        preset("standard").with_changes(
            **{"sensors.position_noise_std_m": 2e-5, "sensors.resistance_noise_std_ohm": 0.01}
        )
    )
    duty = np.r_[np.ones(300), np.full(2000, 0.06)]
    a = Simulator(noisy, seed=7).run(duty, record=("position_measured_m", "resistance_measured_ohm"))
    b = Simulator(noisy, seed=7).run(duty, record=("position_measured_m", "resistance_measured_ohm"))
    c = Simulator(noisy, seed=8).run(duty, record=("position_measured_m",))
    assert np.array_equal(a["position_measured_m"], b["position_measured_m"])
    assert np.array_equal(a["resistance_measured_ohm"], b["resistance_measured_ohm"], equal_nan=True)
    assert not np.array_equal(a["position_measured_m"], c["position_measured_m"])
    # The noise has the configured size.
    clean = Simulator("standard").run(duty, record=("position_measured_m",))["position_measured_m"]
    assert np.std(a["position_measured_m"] - clean) == pytest.approx(2e-5, rel=0.1)


def test_warm_surroundings_slow_the_cooling_after_a_long_heating_and_relax_to_the_ambient():
    """The surroundings take up convected heat (their temperature rises while the wire is hot),
    so the wire cools more slowly after a long heating than with the room as its sink, more
    after a long heating than after a short one, and the surroundings relax back to the
    ambient. Off, they stay exactly at the ambient."""
    base = ModelConfig(preset("standard"))
    warm = base.with_effect("warm_surroundings", {"gain_k_j": 0.3, "time_constant_s": 20.0})
    long_heat = np.r_[np.full(20000, 0.2), np.zeros(40000)]
    short_heat = np.r_[np.full(1500, 0.2), np.zeros(15000)]
    rec = ("temperature_c", "surroundings_temperature_c", "position_m")
    a = Simulator(base).run(long_heat, record=rec)
    b = Simulator(warm).run(long_heat, record=rec)
    ambient = base.actuator.convection.ambient_temperature_c
    assert np.all(a["surroundings_temperature_c"] == ambient)
    assert b["surroundings_temperature_c"][19999, 0] > ambient + 5.0
    # Five seconds after switch-off the warm-surroundings wire is hotter, and more martensite
    # is still missing (less extension back).
    k = 20000 + 5000
    assert b["temperature_c"][k, 0] > a["temperature_c"][k, 0] + 2.0
    # The surroundings relax: 40 s (2 tau) later they have lost over half of their rise (the
    # wire keeps feeding them while it cools, so less than exp(-2)).
    rise_end = b["surroundings_temperature_c"][-1, 0] - ambient
    assert 0.0 < rise_end < 0.5 * (b["surroundings_temperature_c"][19999, 0] - ambient)
    short = Simulator(warm).run(short_heat, record=rec)
    assert short["surroundings_temperature_c"].max() < b["surroundings_temperature_c"].max()
    # The 'electrical' form (synthetic data only) warms them with the electrical power: from
    # the first pulse, and not at all once the current is off.
    electrical = Simulator(
        base.with_effect("warm_surroundings", {"gain_k_j": 0.3, "time_constant_s": 20.0}, "electrical")
    )
    c = electrical.run(long_heat, record=rec)["surroundings_temperature_c"][:, 0]
    assert c[99] - ambient > b["surroundings_temperature_c"][99, 0] - ambient > 0.0
    assert np.all(np.diff(c[20001:]) < 0.0)


def test_every_effect_at_its_off_value_changes_nothing_bit_for_bit():
    base = ModelConfig(preset("standard"))
    off = base
    for name, effect in EFFECTS.items():
        off = off.with_effect(name, effect.off_values)
    duty = np.r_[np.ones(500), np.full(3000, 0.065), np.zeros(3000), np.full(2000, 0.1)]
    rec = ("position_m", "position_measured_m", "temperature_c", "resistance_measured_ohm")
    for mode in ("averaged", "resolved"):
        a = Simulator(base, pwm_mode=mode).run(duty, record=rec)
        b = Simulator(off, pwm_mode=mode).run(duty, record=rec)
        for key in rec:
            assert np.array_equal(a[key], b[key], equal_nan=True), (mode, key)


def test_an_effect_counts_as_off_only_where_its_form_changes_nothing():
    """Every form at its off values: either ``is_off`` (and the model's name shows nothing)
    and the run is bit for bit the base's, or it is on. Three forms are another law at the
    off values (a latent heat released at 0.7x moved the wire 1 mm) and were called off."""
    base = ModelConfig(preset("standard"))
    duty = np.r_[np.ones(1500), np.zeros(2500), np.full(2000, 0.3)]
    reference = Simulator(base).run(duty, record=("position_m", "temperature_c"))
    own_law = []
    for name, effect in EFFECTS.items():
        for form in effect.forms:
            model = base.with_effect(name, effect.off_values, form)
            run = Simulator(model).run(duty, record=("position_m", "temperature_c"))
            same = all(np.array_equal(run[k], reference[k]) for k in run)
            assert model.effects.get(name).is_off == same, (name, form)
            assert (model.name == base.name) == same, (name, form)
            if not same:
                own_law.append(f"{name}/{form}")
    assert own_law == ["transformation_spread/uniform", "latent_heat/asymmetric", "convection_change/power"]


NOMINAL_PINNED = {
    # (position [mm], temperature [degC], resistance [ohm]) at the ends of the four holds
    "averaged": [
        (9.547692539, 109.00119272, 3.094518479),
        (9.296554736, 103.234819759, 3.098273342),
        (2.315172749, 76.000003288, 3.589982515),
        (5.039582386, 92.981272144, 3.394599036),
    ],
    "resolved": [
        (9.547901939, 109.00075563, 3.094502623),
        (9.294798099, 103.213588283, 3.098346954),
        (2.312697664, 75.990529097, 3.590178321),
        (5.038014866, 92.964409809, 3.394718453),
    ],
}
"""The standard model's numbers, recorded 2026-12-07."""


def test_the_nominal_model_is_pinned():
    """The nominal model's trajectory, pinned: comparing effects at their off values with
    the model without them cannot see a term that fails to vanish, since both run it (a
    1e-4 W/K loss left on for everyone passed every other test of this file). A deliberate
    change of the nominal physics updates these numbers in the same commit, saying why."""
    duty = np.r_[np.ones(500), np.full(3000, 0.065), np.zeros(3000), np.full(2000, 0.1)]
    for mode, pinned in NOMINAL_PINNED.items():
        out = Simulator("standard", pwm_mode=mode).run(duty, record=("position_m", "temperature_c", "resistance_ohm"))
        got = [
            (out["position_m"][k, 0] * 1e3, out["temperature_c"][k, 0], out["resistance_ohm"][k, 0])
            for k in (499, 3499, 6499, 8499)
        ]
        # 1e-5: room for another LLVM's rounding; 0.4 % more heat loss (a 1e-4 W/K leak) moves them by 1.5e-2.
        assert np.allclose(got, pinned, rtol=1e-5, atol=0.0), (mode, got)


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_every_form_of_an_effect_simulates_differently_from_its_default(name):
    """Each form's code reaches the kernel: a form the kernel ignored, or that pack_params
    did not store, would simulate exactly as the default form."""
    effect = EFFECTS[name]
    values = {p.name: p.typical for p in effect.parameters}
    duty = np.r_[np.ones(400), np.full(3000, 0.065), np.zeros(3000), np.full(3000, 0.1)]
    rec = ("position_measured_m", "resistance_measured_ohm")
    default = Simulator(ModelConfig(preset("standard")).with_effect(name, values)).run(duty, record=rec)
    assert len(effect.forms) >= 2
    for form in effect.forms[1:]:
        other = Simulator(ModelConfig(preset("standard")).with_effect(name, values, form=form)).run(duty, record=rec)
        assert not np.array_equal(default["position_measured_m"], other["position_measured_m"]), form


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_every_effect_at_its_typical_value_changes_its_declared_outputs(name):
    effect = EFFECTS[name]
    model = ModelConfig(preset("standard")).with_effect(name, {p.name: p.typical for p in effect.parameters})
    duty = np.r_[np.ones(400), np.full(3000, 0.065), np.zeros(3000), np.full(3000, 0.1)]
    rec = ("position_measured_m", "resistance_measured_ohm")
    a = Simulator("standard").run(duty, record=rec)
    b = Simulator(model).run(duty, record=rec)
    diff = np.nanmax(np.abs(a["position_measured_m"] - b["position_measured_m"]))
    assert diff > 0.05e-3, f"{name} changed the position reading by only {diff * 1e3:.4f} mm"
    if "resistance" in effect.outputs:
        assert np.nanmax(np.abs(a["resistance_measured_ohm"] - b["resistance_measured_ohm"])) > 1e-3


def test_coulomb_friction_makes_the_position_lag_and_stick():
    model = ModelConfig(preset("standard")).with_effect("coulomb_friction", {"force_n": 1.0})
    duty = np.r_[np.ones(350), np.zeros(4000)]
    free = Simulator("standard").run(duty, record=("position_m",))["position_m"][:, 0]
    stuck = Simulator(model).run(duty, record=("position_m",))["position_m"][:, 0]
    # Friction opposes the motion both ways: behind while contracting, ahead while extending.
    assert (free - stuck)[:400].max() > 0.3e-3
    assert (stuck - free)[400:].max() > 0.2e-3
    # And the mass truly sticks: stretches with exactly zero motion.
    assert np.sum(np.diff(stuck[350:]) == 0.0) > 200
    assert np.sum(np.diff(free[350:]) == 0.0) < 10


@pytest.mark.parametrize("form", ["default", "stribeck"])
def test_a_wire_never_pushes_a_friction_above_the_spring_force_holds_the_sleigh(form):
    """The real bench's spring pulls with 0.2 N at rest and 70 N/m: a 1 N friction holds the
    sleigh, once the wire has cooled, where the spring pulls with the friction's force
    (11.4 mm; 2/3 of that force for the Stribeck form's kinetic ...static band). The
    constitutive law alone would put the wire in compression (-4 MPa, pushing the sleigh
    home) while a stuck sleigh held the heating wire's expansion and after cooling."""
    bench = ModelConfig(preset("bench-0.5mm-ht-datasheet"))
    mech = bench.actuator.mechanism
    duty = np.r_[np.zeros(1000), np.full(20_000, 0.2), np.zeros(40_000)]
    free = Simulator(bench, control_period_s=1e-3).run(duty, record=("position_m",))["position_m"][:, 0]
    assert abs(free[-1]) < 0.2e-3  # without friction the spring takes it home
    held = bench.with_effect("coulomb_friction", {"force_n": 1.0}, form=form)
    r = Simulator(held, control_period_s=1e-3).run(duty, record=("position_m", "stress_pa", "velocity_m_s"))
    assert r["stress_pa"].min() >= 0.0
    assert (r["stress_pa"][:, 0] == 0.0).sum() > 100  # slack, not merely taut at 0
    x_end = r["position_m"][-1, 0]
    assert r["velocity_m_s"][-1, 0] == 0.0
    spring_n = mech.spring_preload_n + mech.spring_stiffness_n_m * x_end
    # Stuck where the spring's pull is within the friction band (kinetic force at re-stick,
    # static at most); the wire, slack, adds nothing.
    assert 0.99 <= spring_n <= (1.5 if form == "stribeck" else 1.0) + 1e-9
    assert x_end > 10e-3


def test_stribeck_friction_follows_its_parameters_not_the_sub_step_grid():
    """The Stribeck form sticks and slips in jumps of tens of um. Its breakaway and re-stick
    are located inside the sub-step and its slips are resolved, so the trajectory is a
    smooth function of the parameters and close to a fine reference. Before (2026-11-28),
    1 ppm of moving mass moved this trajectory by 11.9 um RMS and the default was about 25 um
    from the reference; now 0.0006 um and 3.9 um."""
    rng = np.random.default_rng(3)
    duty = np.repeat(rng.choice([0.0, 0.08, 0.1, 0.12], size=20), 500)  # 10 s below the cut
    model = ModelConfig().with_effect("coulomb_friction", {"force_n": 0.6}, form="stribeck")
    mass_kg = model.actuator.mechanism.moving_mass_kg
    heavier = model.with_actuator(**{"mechanism.moving_mass_kg": mass_kg * (1.0 + 1e-6)})

    def position(m, **kwargs):
        return Simulator(m, **kwargs).run(duty, record=("position_m",))["position_m"][:, 0]

    x = position(model)
    ref = position(model, max_substep_s=1e-6)
    steps = np.diff(ref)
    assert np.sum(np.abs(steps) > 20e-6) > 30  # it does stick and slip ...
    assert ref.max() < model.actuator.driver.end_of_travel_m - 5e-3  # ... away from the cut
    assert np.sum(np.diff(x) == 0.0) > 9000  # and truly sticks between slips

    def rms(a):
        return float(np.sqrt(np.mean(a**2)))

    assert rms(position(heavier) - x) < 0.05e-6
    assert rms(x - ref) < 6e-6


@pytest.mark.parametrize("form", ["default", "stribeck"])
def test_a_sliding_sleigh_loses_to_friction_what_the_dissipation_books(form):
    """The wire's work goes into motion, the spring and dissipation: the mechanical balance
    closes while the sleigh slides against friction (3 N, 20 V, full duty). The Stribeck
    form's slides step by the theta-method, where the friction held for the whole step must
    enter the end-of-step balance divided by theta: until 2026-12-07 it did not, so a slide
    felt theta (0.5-1) of its friction, and the balance was 0.013 J (27 % of the work) off."""
    model = ModelConfig(preset("supply-20v")).with_effect("coulomb_friction", {"force_n": 3.0}, form=form)
    for mode in ("averaged", "resolved"):
        sim = Simulator(model, pwm_mode=mode)
        x = sim.run(np.ones(110), record=("position_m",))["position_m"][:, 0]
        assert x[-1] > 7e-3  # it slid most of the stroke
        e = sim.energy_balance()
        # The Coulomb form sticks and slides by backward Euler, whose numerical damping
        # (energy_balance's docstring) takes 0.1 % of the work here; the theta-method ~1e-6.
        bar = 2e-3 if form == "default" else 1e-5
        assert abs(e["mechanical_residual"][0]) < bar * e["mechanical_work"][0], (mode, e["mechanical_residual"])


def test_resistance_reading_needs_the_pulse_to_outlast_the_settling_time():
    p = preset("standard").with_changes(**{"driver.pwm_frequency_hz": 1000.0})
    for mode in ("averaged", "resolved"):
        sim = Simulator(ModelConfig(p), n=3, pwm_mode=mode)
        sim.run(np.tile([0.049, 0.05, 0.3], (5, 1)))
        r = sim.resistance_measured_ohm
        assert np.isnan(r[0]) and np.isnan(sim.current_measured_a[0])
        assert r[1] == pytest.approx(sim.resistance_ohm[1], rel=1e-3)
        assert sim.current_measured_a[2] == pytest.approx(10.0 / sim.resistance_ohm[2], rel=1e-3)


def test_position_is_sampled_at_the_end_of_each_pwm_period():
    """With a 4 ms PWM period and 1 ms control steps, the reading changes every 4th step."""
    p = preset("standard").with_changes(**{"driver.pwm_frequency_hz": 250.0})
    sim = Simulator(ModelConfig(p), pwm_mode="resolved")
    out = sim.run(np.ones(800), record=("position_measured_m", "position_m"))
    reading = out["position_measured_m"][400:, 0]
    changes = np.flatnonzero(np.diff(reading) != 0.0)
    assert len(changes) > 50
    assert np.all(np.diff(changes) % 4 == 0)


def test_multiplexer_caps_duty_and_gives_each_actuator_its_own_slot():
    mux = Multiplexer(4, cycling_frequency_hz=1000.0)
    sim = Simulator("standard", n=4, multiplexer=mux, pwm_mode="resolved", max_substep_s=1e-5)
    # Actuator 2 asks for far more than 1/4: it gets 1/4 of the cycle at most.
    sim.step(np.array([0.0, 0.1, 1.0, 0.25]))
    power = sim.power_w
    full = 100.0 / sim.resistance_ohm
    assert power[0] == 0.0
    assert power[1] == pytest.approx(0.1 * full[1], rel=1e-3)
    assert power[2] == pytest.approx(0.25 * full[2], rel=1e-3)
    assert power[3] == pytest.approx(0.25 * full[3], rel=1e-3)
    # Within one cycle the pulses do not overlap: actuator j conducts only in [j/4, (j+1)/4).
    probe = Simulator("standard", n=4, multiplexer=mux, pwm_mode="resolved", control_period_s=0.25e-3)
    energy = []
    for _ in range(4):
        probe.step(np.full(4, 0.25))
        energy.append(probe.electrical_energy_j.copy())
    delta = np.diff(np.vstack([np.zeros(4), energy]), axis=0)
    assert np.all((delta > 0) == np.eye(4, dtype=bool))
    assert io_counts(16) == {
        "analog_inputs_without": 16,
        "analog_inputs_with": 1,
        "digital_outputs_without": 16,
        "digital_outputs_with": 5,
    }


def test_supply_sag_lowers_the_wire_voltage_reading():
    model = ModelConfig(preset("standard")).with_effect("supply_sag", {"series_resistance_ohm": 1.0})
    sim = Simulator(model)
    sim.run(np.full(10, 0.5))
    r = float(sim.resistance_ohm[0])
    assert sim.voltage_measured_v[0] == pytest.approx(10.0 * r / (r + 1.0), rel=1e-6)


def test_bad_constructor_arguments_are_named():
    with pytest.raises(ValueError, match="pwm_mode"):
        Simulator(pwm_mode="exact")
    with pytest.raises(ValueError, match="n = 0"):
        Simulator(n=0)
    with pytest.raises(ValueError, match="multiplexer.n_actuators"):
        Simulator(n=3, multiplexer=Multiplexer(4))
    with pytest.raises(ValueError, match="control_period_s"):
        Simulator(control_period_s=-1.0)
    with pytest.raises(ValueError, match="record"):
        Simulator().run(np.zeros(3), record=("warp",))
    with pytest.raises(ValueError, match="temperature_c"):
        Simulator().reset(temperature_c=200.0)


@pytest.mark.parametrize("extra_spread_k", [0.0, 12.0])
def test_a_warm_reset_rests_up_to_where_the_coldest_hysteron_starts_and_no_further(extra_spread_k):
    """Until 2026-12-07 a warm reset was allowed up to A_s + sigma0 / C_A (77.7 degC for the
    standard wire), where the spread wire's coldest hysteron has transformed for 16.6 K: a
    reset at 77 degC contracted 0.56 mm in 3 ms with no power. The limit is now that
    hysteron's start (with the model's own effects), where the wire stays martensitic and
    at rest; 1 K above it is refused."""
    model = ModelConfig(preset("standard"))
    if extra_spread_k:
        model = model.with_effect("transformation_spread", {"spread_k": extra_spread_k})
    limit = model.actuator.highest_rest_temperature_c
    assert limit == pytest.approx(61.14, abs=0.01)  # the wire's own hysterons: 16.6 K below 77.7
    sim = Simulator(model)
    with pytest.raises(ValueError, match=r"temperature_c = 77.0: .*start of the wire's transformation"):
        sim.reset(temperature_c=77.0)
    wire = model.actuator.wire
    shift_h, _, _, widening_k = wire.hysterons(extra_spread_k)
    start = wire.austenite_start_c - 0.5 * widening_k + min(shift_h)
    ambient_limit = start + model.actuator.rest_stress_pa / wire.stress_coefficient_austenite_pa_k
    assert (ambient_limit < limit - 5.0) if extra_spread_k else ambient_limit == pytest.approx(limit, abs=1e-9)
    # The warm wire rests 69 um extended, which slackens the spring and lowers its start.
    sim_limit = float(sim._rest_limit_c(slice(None))[0])
    assert ambient_limit - 0.05 < sim_limit < ambient_limit
    with pytest.raises(ValueError, match="temperature_c"):
        sim.reset(temperature_c=sim_limit + 1.0)
    sim.reset(temperature_c=sim_limit - 1e-9)
    rest_m = float(sim.position_m[0])
    out = sim.run(np.zeros(200), record=("position_m", "martensite_fraction"))
    assert np.all(out["martensite_fraction"] == 1.0)
    # Cooling takes back the expansion it started with, and no more.
    assert rest_m < 0.0 and np.all((out["position_m"] >= rest_m - 1e-9) & (out["position_m"] <= 0.0))
    # The limit is tight: with the wire's transformation starting 1 K colder after the same
    # reset, the unpowered wire transforms (the old bound allowed 16.6 K).
    sim.reset(temperature_c=sim_limit - 1e-9)
    sim.params[:, L.P_NODE_HEAT0 : L.P_NODE_HEAT0 + L.MAX_SPREAD_NODES] -= 1.0
    assert float(sim.run(np.zeros(5), record=("martensite_fraction",))["martensite_fraction"].min()) < 1.0


def test_a_vanishing_quadratic_sag_gives_the_unsagged_current():
    """Regression (found by hypothesis): the textbook quadratic root cancelled to zero
    current for a series resistance of 6e-240 ohm, and V/I then divided by zero."""
    for r_s in (6e-240, 1e-12, 1.0):
        model = ModelConfig(preset("standard")).with_effect(
            "supply_sag", {"series_resistance_ohm": r_s}, form="quadratic"
        )
        sim = Simulator(model)
        sim.run(np.ones(5))
        current = float(sim.current_measured_a[0])
        r = float(sim.resistance_ohm[0])
        assert np.isfinite(current) and current > 0
        if r_s < 1e-6:
            assert current == pytest.approx(10.0 / r, rel=1e-9)
        # supply = I R + R_s I^2 / I_ref holds.
        i_ref = 10.0 / preset("standard").wire.cold_resistance_ohm
        assert current * r + r_s * current**2 / i_ref == pytest.approx(10.0, rel=1e-9)


def test_every_declared_effect_form_has_a_meaning_in_the_physics():
    """A form added to an effect's declaration must get its code next to the physics that
    implements it (a missing one would fail here, not fall back to the default silently)."""
    from sma_gym.effects import EFFECTS
    from sma_gym.electrical.pwm import RISE_FORMS, SAG_FORMS
    from sma_gym.electrical.sensors import ABBE_FORMS, LAG_ORDERS
    from sma_gym.physics.mechanics import FRICTION_FORMS
    from sma_gym.physics.thermal import CONVECTION_FORMS, LATENT_COOLING_FACTORS, SURROUNDINGS_FORMS

    tables = {
        "warm_surroundings": SURROUNDINGS_FORMS,
        "pulse_settling": RISE_FORMS,
        "supply_sag": SAG_FORMS,
        "abbe_offset": ABBE_FORMS,
        "sensor_lag": LAG_ORDERS,
        "coulomb_friction": FRICTION_FORMS,
        "convection_change": CONVECTION_FORMS,
        "latent_heat": LATENT_COOLING_FACTORS,
    }
    for name, effect in EFFECTS.items():
        if name in tables:
            assert set(effect.forms) == set(tables[name]), name
        elif name not in ("transformation_spread", "minor_loop_width"):  # forms passed by name to hysteron_nodes
            assert effect.forms == ("default",), f"{name}: forms {effect.forms} need a code table"


def test_named_views_read_the_state_by_name():
    """Code outside the simulator reads quantities by name, never by layout index."""
    sim = Simulator("standard", n=3)
    sim.step(np.array([1.0, 0.5, 0.0]))
    values = sim.read(("position_m", "temperature_c", "duty"))
    assert np.array_equal(values["position_m"], sim.position_m)
    assert np.array_equal(values["duty"], sim.duty_applied)
    values["temperature_c"][:] = 0.0  # copies: the state is untouched
    assert np.all(sim.temperature_c > 0.0)
    one = sim.read_actuator(1, ("position_m", "time_s"))
    assert one == {"position_m": float(sim.position_m[1]), "time_s": float(sim.time_s[1])}
    assert type(one["position_m"]) is float
    assert sim.read_actuator(2, ("duty",)) == {"duty": 0.0}
    p = preset("standard")
    assert np.all(sim.usable_stroke_m == p.usable_stroke_m)
    assert np.all(sim.cold_resistance_ohm == p.wire.cold_resistance_ohm)
    assert not sim.end_of_travel_cut.any()
    with pytest.raises(ValueError, match="no_such_quantity"):
        sim.read(("no_such_quantity",))


def test_the_simulator_api_refuses_what_numpy_would_quietly_convert():
    """From an audit of the Python API: ``step("0.5")``, ``step(True)`` (duty 1), a complex
    duty (the imaginary part dropped with a warning) and ``reset(temperature_c=True)`` (1 degC)
    ran; ``record="position_m"`` was read as letters; a scalar True as ``reset``'s mask hit
    numpy's IndexError; ``set_model(True, ...)`` gave actuator 1 the model and every row its
    parameters; ``rng=3`` failed at the first step."""
    sim = Simulator("standard", n=3)
    for call, needle in (
        (lambda: sim.step("0.5"), "duty = '0.5': expected numbers, not strings"),
        (lambda: sim.step(True), "not booleans"),
        (lambda: sim.run(np.full((5, 3), 0.5 + 0.1j)), "not complex numbers"),
        (lambda: sim.step(10**400), "an integer of about 400 digits"),
        (lambda: sim.reset(temperature_c=True), "temperature_c = True"),
        (lambda: sim.reset([0], temperature_c=[30.0, 40.0]), "expected a scalar or one per actuator reset"),
        (lambda: sim.run(np.ones(3), record="position_m"), "record = 'position_m': expected a list or tuple"),
        (lambda: sim.read("position_m"), "names = 'position_m'"),
        (lambda: sim.reset(True), r"mask has shape \(\): expected booleans of shape \(3,\)"),
        (lambda: sim.reset([3]), r"indices must lie in \[0, 2\]"),
        (lambda: sim.set_model(True, "supply-15v"), "index = True"),
        (lambda: sim.run(np.r_[np.ones((2, 3)), [[1.0, np.nan, 1.0]]]), r"duty\[2, 1\] = "),
        (lambda: Simulator("standard", rng=3), "rng = 3: expected a numpy.random.Generator"),
        (lambda: Simulator("standard", seed=1.5), "seed = 1.5"),
        (lambda: Simulator("standard", n=10**12), r"n = 1000000000000: expected an integer in \[1, 10000000\]"),
        (lambda: Simulator("standard", pwm_slots=[(0.002, 0.0)]), r"pwm_slots\[0\] = \(0.002, 0.0\): expected"),
        (lambda: Simulator("standard", pwm_slots=[("0.002", 0.0, 1.0)]), r"pwm_slots\[0\].period_s = '0.002'"),
    ):
        with pytest.raises(ValueError, match=needle):
            call()
    assert sim.read_actuator(0, ["position_m", "temperature_c"]) == sim.read_actuator(
        0, ("position_m", "temperature_c")
    )


def test_a_copy_of_a_simulator_is_its_own_and_reset_seed_repeats_the_noise():
    """``copy.copy`` shared the state arrays and the generator (stepping the copy heated the
    original); ``reset`` had no seed, so a noisy run could not be repeated on one simulator."""
    import copy

    noisy = ModelConfig(preset("standard")).with_actuator(**{"sensors.position_noise_std_m": 1e-5})
    a = Simulator(noisy, seed=0)
    b = copy.copy(a)
    b.run(np.ones(500))
    assert a.time_s[0] == 0.0 and a.temperature_c[0] == pytest.approx(
        a.models[0].actuator.convection.ambient_temperature_c
    )
    duty = np.r_[np.ones(300), np.zeros(300)]
    a.reset(seed=7)
    first = a.run(duty, record=("position_measured_m",))["position_measured_m"]
    a.reset(seed=7)
    again = a.run(duty, record=("position_measured_m",))["position_measured_m"]
    assert np.array_equal(first, again)
    rng_before = a.rng
    with pytest.raises(ValueError, match="temperature_c"):
        a.reset(seed=8, temperature_c=500.0)
    assert a.rng is rng_before  # a refused reset changes nothing
