"""Property tests: whatever the input, the numbers stay physical.

Any duty sequence in [0, 1], any supply up to 30 V, any preset, any combination of effects,
either PWM mode, horizons up to a minute:

* no NaN or inf in the state (readings may be NaN only where no reading was possible);
* 0 <= xi <= 1 for every sub-element;
* 0 <= x <= eps0*l0, allowing below zero only the wire's thermal expansion (and a
  hair of mechanical overshoot), or what friction holds of it while the wire cools;
* the temperature never exceeds what the energy balance allows: neither the steady state
  of full power against convection (to surroundings as warm as the warm_surroundings
  effect can make them), nor the adiabatic rise of all energy put in;
* energy is accounted for: electrical in + latent = convected + stored + mechanical work,
  to 1e-9 of the input; and the mechanical work is kinetic + spring + dissipated to 0.1 %.
"""

import math

import numpy as np
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from sma_gym import ModelConfig, Simulator, preset, preset_names
from sma_gym.core import layout as L
from sma_gym.effects import EFFECTS
from sma_gym.physics.mechanics import FRICTION_FORMS, static_friction
from sma_gym.physics.thermal import convection_coefficient

READINGS = {L.S_R_MEAS, L.S_I_MEAS, L.S_V_MEAS}


def steady_state_bound(col, power_w, sink_c):
    """Temperature where the packed convection law carries ``power_w`` to surroundings at
    ``sink_c`` (bisection)."""

    def loss(t):
        h = convection_coefficient(
            t, col[L.P_H0], col[L.P_H1], col[L.P_H2], sink_c, int(col[L.P_CONV_FORM]), col[L.P_CONV_POWER_SCALE]
        )
        return h * col[L.P_SURFACE] * (t - sink_c)

    lo, hi = sink_c, sink_c + 1.0
    while loss(hi) < power_w and hi < sink_c + 1e5:
        hi = sink_c + 2.0 * (hi - sink_c)
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if loss(mid) < power_w else (lo, mid)
    return hi


def _scenario(name, voltage_v, effects, blocks, block_ms, mode):
    """(model, duty, PWM mode): a preset at a supply voltage with (effect, values, form)s."""
    model = ModelConfig(preset(name).with_changes(**{"driver.supply_voltage_v": voltage_v}))
    for effect_name, values, form in effects:
        model = model.with_effect(effect_name, values, form)
    return model, np.repeat(np.asarray(blocks, dtype=float), block_ms), mode


@st.composite
def scenarios(draw):
    name = draw(st.sampled_from(preset_names()))
    voltage = draw(st.floats(1.0, 30.0))
    effects = []
    for effect_name in draw(st.lists(st.sampled_from(sorted(EFFECTS)), max_size=3, unique=True)):
        effect = EFFECTS[effect_name]
        values = {p.name: draw(st.floats(p.lower, p.upper)) for p in effect.parameters}
        effects.append((effect_name, values, draw(st.sampled_from(effect.forms))))
    blocks = draw(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=25))
    block_ms = draw(st.integers(5, 2500))
    mode = draw(st.sampled_from(("averaged", "resolved")))
    return _scenario(name, voltage, effects, blocks, block_ms, mode)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenarios())
# Failures random draws once found, kept: friction holding a cooling wire 40 um below its
# thermal expansion (the bound needed the friction band), a subnormal spread whose uniform
# centres divided by an underflowed std, and surroundings warmed by the supply (the
# temperature bound needed the warmer sink).
@example(
    _scenario(
        "wire-0.3mm", 10.0, [("coulomb_friction", {"force_n": 0.5}, "default")], [1.0] + [0.0] * 10, 2000, "averaged"
    )
)
@example(
    _scenario(
        "bench-0.5mm-ht-datasheet",
        1.0,
        [("transformation_spread", {"spread_k": 2.225073858507e-311}, "uniform")],
        [0.0] * 5,
        5,
        "averaged",
    )
)
@example(
    _scenario(
        "bench-0.5mm-ht-datasheet",
        15.0,
        [
            ("convection_change", {"scale": 2.0, "h1_w_m2_k2": 2.0}, "default"),
            ("warm_surroundings", {"gain_k_j": 1.0, "time_constant_s": 2.0}, "electrical"),
        ],
        [1.0],
        2221,
        "averaged",
    )
)
def test_any_input_keeps_the_state_physical(scenario):
    model, duty, mode = scenario
    duty = duty[:60000]
    sim = Simulator(model, pwm_mode=mode)
    rec = sim.run(duty, record=("position_m", "temperature_c", "martensite_fraction"))
    state = sim.state
    finite_rows = [r for r in range(L.N_STATE) if r not in READINGS]
    assert np.all(np.isfinite(state[:, finite_rows]))
    for name in ("position_m", "temperature_c", "martensite_fraction"):
        assert np.all(np.isfinite(rec[name]))

    p = model.actuator
    nodes = state[:, L.S_XI_NODE0 : L.S_XI_NODE0 + int(sim.params[0, L.P_N_NODES])]
    assert np.all((nodes >= 0.0) & (nodes <= 1.0))
    xi = rec["martensite_fraction"]
    assert np.all((xi >= -1e-12) & (xi <= 1.0 + 1e-12))

    x = rec["position_m"]
    t = rec["temperature_c"]
    t_amb = p.convection.ambient_temperature_c
    alpha = max(p.wire.thermal_expansion_austenite_1_k, p.wire.thermal_expansion_martensite_1_k)
    expansion = alpha * np.maximum(t - t_amb, 0.0) * p.wire.length_m
    # Friction may hold the sleigh where the hot, expanded wire left it while the wire cools:
    # the wire then strains elastically, by at most the static force over its softest
    # stiffness (E_M A / l0; the spring in parallel only stiffens it).
    held_m = static_friction(
        model.effects.value("coulomb_friction", "force_n"), FRICTION_FORMS[model.effects.form("coulomb_friction")]
    ) / (p.wire.youngs_modulus_martensite_pa * p.wire.area_m2 / p.wire.length_m)
    assert np.all(x <= p.wire.max_stroke_m)
    assert np.all(x >= -expansion - held_m - 5e-6)

    # Temperature bound from the energy balance: the steady state of the largest possible
    # electrical power against the model's own convection law (any form), and the adiabatic
    # rise of all the energy put in. Latent heat may add its Delta_H / c_p on top.
    w = p.wire
    r_min = (
        min(w.resistivity_martensite_ohm_m, w.resistivity_austenite_ohm_m)
        * (1.0 - w.max_transformation_strain) ** 2
        * w.length_m
        / w.area_m2
        * 0.9
    )
    p_max = p.driver.supply_voltage_v**2 / r_min
    latent_margin = (
        max(0.0, w.latent_heat_j_kg + model.effects.value("latent_heat", "change_j_kg")) / w.specific_heat_j_kg_k
    )
    # Warm surroundings raise the sink the wire convects to: dT_s/dt = g P_src - (T_s - T_amb)/tau
    # keeps T_s - T_amb below g times the energy the source ever delivered (the electrical
    # input, plus the latent heat for the convected form) and, for an electrical source,
    # below g P_max tau.
    gain = model.effects.value("warm_surroundings", "gain_k_j")
    sink_rise = gain * (sim.electrical_energy_j[0] + latent_margin * w.heat_capacity_j_k)
    if model.effects.form("warm_surroundings") == "electrical":
        sink_rise = min(sink_rise, gain * p_max * model.effects.value("warm_surroundings", "time_constant_s"))
    t_ss = steady_state_bound(sim.params[0], p_max, t_amb + sink_rise)
    # Above the warmest sink, the wire only gains what the supply puts in.
    adiabatic = t_amb + sink_rise + sim.electrical_energy_j[0] / w.heat_capacity_j_k
    assert t.max() <= max(t_amb, min(t_ss, adiabatic)) + latent_margin + 0.5

    e = sim.energy_balance()
    scale_e = max(e["electrical"][0], 1e-6)
    assert abs(e["residual"][0]) <= 1e-9 * scale_e + 1e-12
    assert abs(e["mechanical_residual"][0]) <= 1e-3 * scale_e + 1e-9


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**31 - 1), st.sampled_from(("averaged", "resolved")))
def test_same_seed_gives_the_same_result_bit_for_bit(seed, mode):
    noisy = ModelConfig(
        preset("standard").with_changes(
            **{"sensors.position_noise_std_m": 1e-5, "sensors.resistance_noise_std_ohm": 0.005}
        )
    )
    duty = np.random.default_rng(seed).uniform(0.0, 0.2, size=2000)
    a = Simulator(noisy, seed=seed, pwm_mode=mode)
    b = Simulator(noisy, seed=seed, pwm_mode=mode)
    ra = a.run(duty, record=("position_measured_m", "resistance_measured_ohm", "temperature_c"))
    rb = b.run(duty, record=("position_measured_m", "resistance_measured_ohm", "temperature_c"))
    for key in ra:
        assert np.array_equal(ra[key], rb[key], equal_nan=True)
    assert np.array_equal(a.state, b.state, equal_nan=True)
    assert not math.isnan(ra["position_measured_m"][-1, 0])
