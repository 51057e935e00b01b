"""Parameters, presets, errata and model configuration files."""

import json
import math

import numpy as np
import pytest

from sma_gym import ModelConfig, Simulator, load_model, preset, preset_names
from sma_gym.effects import EFFECTS, EffectSet
from sma_gym.params import ActuatorParams, Convection, Driver, Mechanism, Wire, standard


def test_presets_cover_the_reports_conditions_and_the_bench():
    names = set(preset_names())
    for required in (
        "standard",
        "forced-convection",
        "supply-5v",
        "supply-7.5v",
        "supply-15v",
        "supply-20v",
        "wire-0.2mm",
        "wire-0.5mm",
        "bench-0.5mm-ht-datasheet",
    ):
        assert required in names
    assert preset("supply-15v").driver.supply_voltage_v == 15.0
    assert preset("wire-0.2mm").wire.diameter_m == pytest.approx(0.2e-3)
    assert preset("forced-convection").convection.h0_w_m2_k > 2.0 * standard().convection.h0_w_m2_k


def test_unknown_preset_names_the_value_and_the_choices():
    with pytest.raises(ValueError, match=r"'nope'.*'standard'"):
        preset("nope")


def test_errata_are_applied():
    w = standard().wire
    # c_p in J/(kg K), not 0.8374; mass = rho * A * l0, not d * A * rho.
    assert w.specific_heat_j_kg_k == pytest.approx(837.4)
    assert w.mass_kg == pytest.approx(6500 * math.pi * 0.3e-3**2 / 4 * 0.273)
    # The preload is the measured 2 N of fig. 8.1, i.e. ~28 MPa on 0.3 mm.
    assert standard().rest_stress_pa == pytest.approx(2.0 / (math.pi * 0.3e-3**2 / 4))


def test_diameter_scales_area_mass_surface_and_resistance_physically():
    thin, std, thick = preset("wire-0.2mm"), standard(), preset("wire-0.5mm")
    for p, d in ((thin, 0.2), (thick, 0.5)):
        ratio = d / 0.3
        assert p.wire.area_m2 / std.wire.area_m2 == pytest.approx(ratio**2)
        assert p.wire.mass_kg / std.wire.mass_kg == pytest.approx(ratio**2)
        assert p.wire.surface_m2 / std.wire.surface_m2 == pytest.approx(ratio)
        assert p.wire.cold_resistance_ohm / std.wire.cold_resistance_ohm == pytest.approx(ratio**-2)
        r_sim = Simulator(p).resistance_ohm[0]
        assert r_sim == pytest.approx(p.wire.cold_resistance_ohm)


@pytest.mark.parametrize(
    "build, name",
    [
        (lambda: Wire(diameter_m=-1e-3), "Wire.diameter_m"),
        (lambda: Wire(diameter_m=float("nan")), "Wire.diameter_m"),
        (lambda: Wire(austenite_start_c=110.0, austenite_finish_c=110.0), "Wire.austenite_finish_c"),
        (lambda: Wire(martensite_start_c=50.0, martensite_finish_c=60.0), "Wire.martensite_start_c"),
        (lambda: Driver(supply_voltage_v=0.0), "Driver.supply_voltage_v"),
        (lambda: Driver(supply_voltage_v=float("inf")), "Driver.supply_voltage_v"),
        (lambda: Mechanism(moving_mass_kg=0.0), "Mechanism.moving_mass_kg"),
        (lambda: Convection(h0_w_m2_k=-5.0), "Convection.h0_w_m2_k"),
    ],
)
def test_invalid_parameters_raise_naming_the_parameter(build, name):
    with pytest.raises(ValueError, match=name.replace(".", r"\.")):
        ActuatorParams(**_group_for(build()))


def _group_for(obj):
    key = {Wire: "wire", Driver: "driver", Mechanism: "mechanism", Convection: "convection"}[type(obj)]
    return {key: obj}


def test_with_changes_rejects_unknown_fields():
    with pytest.raises(ValueError, match="driver.voltage"):
        standard().with_changes(**{"driver.voltage": 12.0})
    changed = standard().with_changes(**{"driver.supply_voltage_v": 12.0, "wire.length_m": 0.3})
    assert changed.driver.supply_voltage_v == 12.0 and changed.wire.length_m == 0.3


def test_the_bench_twin_ships_with_its_effects_and_trains():
    """``bench-0.5mm-ht`` is the twin identified on the four shared real runs: a whole model
    (actuator and effects) resolved by name, distinct from the datasheet preset it started
    from, and an env steps on it."""
    import gymnasium as gym

    from sma_gym.model import model_names
    from sma_gym.models import twin_path

    twin = load_model("bench-0.5mm-ht")
    assert "bench-0.5mm-ht" in model_names() and "bench-0.5mm-ht-datasheet" in model_names()
    assert twin.actuator.name == "bench-0.5mm-ht" and "calibration twin" in twin.notes
    assert twin.effects.active(), "the twin carries the effects the diagnosis found"
    assert twin != ModelConfig(preset("bench-0.5mm-ht-datasheet"))
    assert load_model(str(twin_path("bench-0.5mm-ht"))) == twin
    env = gym.make("sma_gym:SMATracking-v0", model="bench-0.5mm-ht")
    obs, _ = env.reset(seed=0)
    for _ in range(200):
        obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        assert np.all(np.isfinite(obs)) and np.isfinite(reward)
    env.close()


def test_model_config_round_trips_through_json(tmp_path):
    model = ModelConfig(preset("bench-0.5mm-ht-datasheet")).with_effect("latent_heat", {"change_j_kg": 12000.0})
    model = model.with_effect("sensor_lag", {"time_constant_s": 0.02}, form="second-order")
    path = model.save(tmp_path / "m.json")
    again = load_model(str(path))
    assert again == model
    assert math.isinf(again.actuator.driver.end_of_travel_m)
    # The loaded model simulates identically.
    a, b = Simulator(model), Simulator(again)
    duty = np.r_[np.zeros(100), np.full(3000, 0.2)]
    assert np.array_equal(a.run(duty)["position_m"], b.run(duty)["position_m"])


def test_a_file_with_the_single_expansion_coefficient_loads_as_it_was_saved(tmp_path):
    """Model files written before each phase had its own expansion carry one
    ``thermal_expansion_1_k``: it becomes both phases' value, and a file that gives both
    names keeps them."""
    data = ModelConfig(preset("standard")).to_dict()
    wire = data["actuator"]["wire"]
    del wire["thermal_expansion_austenite_1_k"], wire["thermal_expansion_martensite_1_k"]
    wire["thermal_expansion_1_k"] = 8.8e-6
    path = tmp_path / "old.json"
    path.write_text(json.dumps(data))
    w = load_model(str(path)).actuator.wire
    assert w.thermal_expansion_austenite_1_k == w.thermal_expansion_martensite_1_k == 8.8e-6
    wire["thermal_expansion_austenite_1_k"] = 11e-6
    path.write_text(json.dumps(data))
    w = load_model(str(path)).actuator.wire
    assert (w.thermal_expansion_austenite_1_k, w.thermal_expansion_martensite_1_k) == (11e-6, 8.8e-6)


def test_bad_model_files_give_clear_errors(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        load_model(str(bad))
    wrong = tmp_path / "wrong.json"
    complete = ModelConfig().to_dict()  # a model file gives every parameter
    wrong.write_text(json.dumps({**complete, "effects": {"warp_drive": {}}}))
    with pytest.raises(ValueError, match="warp_drive"):
        load_model(str(wrong))
    out_of_bounds = tmp_path / "oob.json"
    out_of_bounds.write_text(json.dumps({**complete, "effects": {"latent_heat": {"change_j_kg": -1e6}}}))
    with pytest.raises(ValueError, match="change_j_kg"):
        load_model(str(out_of_bounds))
    with pytest.raises(ValueError, match="does not exist"):
        load_model(str(tmp_path / "missing.json"))


def test_every_effect_declares_units_bounds_and_an_off_value_inside_them():
    assert len(EFFECTS) >= 8
    for effect in EFFECTS.values():
        assert effect.parameters
        assert "default" in effect.forms
        for p in effect.parameters:
            assert p.unit
            assert p.lower <= p.off <= p.upper
            assert p.lower <= p.typical <= p.upper and p.typical != p.off


UNIT_OF_SUFFIX = {
    "_k": "K",
    "_share": "-",
    "_j_kg": "J/kg",
    "scale": "-",
    "_w_m2_k2": "W/(m^2 K^2)",
    "_k_j": "K/J",
    "_s": "s",
    "_n": "N",
    "_m": "m",
    "_ohm": "ohm",
}
"""How an effect parameter's name ends -> its unit (names carry their units)."""


def test_every_effect_parameter_is_named_in_its_unit():
    """A wrong unit ("W/m" for a conductance_w_k) passed the test above, which asks only for
    one: the name's ending must give the declared unit (a new ending goes into the table)."""
    for effect in EFFECTS.values():
        for p in effect.parameters:
            endings = [e for e in UNIT_OF_SUFFIX if p.name.endswith(e)]
            assert endings, f"{effect.name}.{p.name}: its name ends in no unit of UNIT_OF_SUFFIX"
            assert p.unit == UNIT_OF_SUFFIX[max(endings, key=len)], (effect.name, p.name, p.unit)


BOUND_EXEMPT = {("Driver", "end_of_travel_m"): "inf (no cut) is allowed; Driver.validate checks the rest"}


def test_every_numeric_parameter_has_a_bound_row():
    """A field without a Bound row takes NaN, inf, 1e6 or -500 silently: every numeric field
    of every part has one, or an exemption that says how it is checked."""
    import dataclasses

    from sma_gym.params import _PARTS

    for part in _PARTS.values():
        bounded = {name for bound in part._BOUNDS for name in bound.fields}
        for f in dataclasses.fields(part):
            if isinstance(f.default, bool) or not isinstance(f.default, (int, float)):
                continue
            assert f.name in bounded or (part.__name__, f.name) in BOUND_EXEMPT, f"{part.__name__}.{f.name}"
    assert all(any(f.name == field for f in dataclasses.fields(_PARTS[p.lower()])) for p, field in BOUND_EXEMPT)


def test_effect_values_outside_bounds_are_rejected():
    with pytest.raises(ValueError, match=r"coulomb_friction\.force_n"):
        EffectSet.of({"coulomb_friction": {"force_n": 99.0}})
    with pytest.raises(ValueError, match="form"):
        EffectSet.of({"sensor_lag": {"parameters": {"time_constant_s": 0.1}, "form": "third-order"}})


@pytest.mark.parametrize("argv", [["--help"], ["nonsense"]])
def test_the_calibration_command_answers_help_and_refuses_an_unknown_target_without_calibrating(argv, monkeypatch):
    """Before, any argument but 'bench' or 'twin' (``--help`` too) ran the standard
    calibration for minutes."""
    from sma_gym import calibration

    def never(*args, **kwargs):
        raise AssertionError("calibrated")

    for name in ("calibrate", "calibrate_bench", "identify_twin"):
        monkeypatch.setattr(calibration, name, never)
    with pytest.raises(SystemExit) as stop:
        calibration.main(argv)
    assert stop.value.code == (0 if argv == ["--help"] else 2)


def test_surroundings_past_the_wires_transformation_are_refused_by_name():
    """Ambient 150 degC, or a superelastic wire (A_s = 0 degC) at 20 degC, was accepted: the
    wire moved with no power (2.5 mm after one step, then past its stroke) while the env
    reported it at rest. Both are refused, naming the field and the wire's rest limit."""
    p = preset("standard")
    limit = p.highest_rest_temperature_c
    assert limit == pytest.approx(
        p.wire.coldest_heating_start_c + p.rest_stress_pa / p.wire.stress_coefficient_austenite_pa_k
    )
    # The 8 K spread starts the coldest hysteron 16.6 K below A_s + sigma0 / C_A = 77.7 degC.
    with pytest.raises(
        ValueError, match=r"Convection.ambient_temperature_c = 150.0: expected a value below .* 61.1 degC"
    ):
        p.with_changes(**{"convection.ambient_temperature_c": 150.0})
    superelastic = {
        "wire.austenite_start_c": 0.0,
        "wire.austenite_finish_c": 10.0,
        "wire.martensite_start_c": -5.0,
        "wire.martensite_finish_c": -15.0,
    }
    with pytest.raises(ValueError, match=r"ambient_temperature_c = 20.0: .*Wire.austenite_start_c = 0.0"):
        p.with_changes(**superelastic)
    assert p.with_changes(**{"convection.ambient_temperature_c": limit - 1.0}).convection.ambient_temperature_c < limit


def test_a_boolean_quantity_and_a_name_that_is_not_text_are_refused_where_they_are_given():
    """with_changes took True as a 1 V supply, and name=3 was saved into a file that load then
    refused: both are refused at once (a model file refused them already)."""
    p = preset("standard")
    with pytest.raises(ValueError, match=r"Driver.supply_voltage_v = True: .*not a boolean"):
        p.with_changes(**{"driver.supply_voltage_v": True})
    with pytest.raises(ValueError, match=r"ActuatorParams.name = 3: expected a non-empty string"):
        p.with_changes(name=3)
    with pytest.raises(ValueError, match=r"ActuatorParams.description = None: expected a string"):
        p.with_changes(description=None)


def test_a_numpy_number_given_as_a_value_is_saved_as_the_number_it_stands_for(tmp_path):
    """np.float32(12) as a supply voltage was accepted, and then ModelConfig.save failed with
    "Object of type float32 is not JSON serializable", naming no field."""
    p = preset("standard").with_changes(**{"driver.supply_voltage_v": np.float32(12), "wire.length_m": np.int64(1)})
    ModelConfig(p).save(tmp_path / "m.json")
    loaded = load_model(tmp_path / "m.json").actuator
    assert loaded.driver.supply_voltage_v == 12.0 and loaded.wire.length_m == 1.0


def test_a_wire_whose_expansion_eats_its_transformation_strain_is_refused():
    """Its loaded reach, and so the envs' position scale, was 0 (positions divided by 0)."""
    p = preset("standard")
    with pytest.raises(
        ValueError, match=r"max_transformation_strain = 0.001: the loaded, heated wire does not contract"
    ):
        p.with_changes(**{"wire.max_transformation_strain": 0.001})
    assert p.with_changes(**{"wire.max_transformation_strain": 0.01}).loaded_reach_m > 0.0


def test_parts_effects_and_configs_are_checked_when_built_and_stay_as_checked():
    """From an audit of the Python API: a Wire(diameter_m=-1) was built (checked only inside
    ActuatorParams); ``effects=['latent_heat']`` failed with an AttributeError and a setting
    under another effect's key was silently filed under its own; an effect's checked values
    could be changed afterwards; a 0-d array value passed every check and failed to save."""
    from sma_gym.effects import EffectSetting

    with pytest.raises(ValueError, match="Wire.diameter_m = -1"):
        Wire(diameter_m=-1)
    with pytest.raises(ValueError, match="Driver.supply_voltage_v = nan"):
        Driver(supply_voltage_v=float("nan"))
    base = ModelConfig(standard())
    with pytest.raises(ValueError, match="'latent_heat' is no EffectSetting"):
        ModelConfig(standard(), effects=["latent_heat"])
    with pytest.raises(ValueError, match="expected a mapping of parameter names"):
        base.with_effect("latent_heat", None)
    with pytest.raises(ValueError, match="a setting of 'latent_heat': expected one of 'coulomb_friction'"):
        EffectSet.of({"coulomb_friction": EffectSetting("latent_heat", {"change_j_kg": -1000.0})})
    with pytest.raises(ValueError, match="ModelConfig.notes = None"):
        ModelConfig(standard(), notes=None)
    friction = base.with_effect("coulomb_friction", {"force_n": 0.1})
    with pytest.raises(TypeError):
        friction.effects.get("coulomb_friction").values["force_n"] = float("nan")
    saved = json.loads(json.dumps(standard().with_changes(**{"driver.supply_voltage_v": np.array(15.0)}).to_dict()))
    assert saved["driver"]["supply_voltage_v"] == 15.0


def test_a_model_path_may_start_at_the_home_folder(tmp_path, monkeypatch):
    """``model="~/x.json"`` said the file did not exist (a shell expands ``~``, Python does not)."""
    import gymnasium as gym

    monkeypatch.setenv("HOME", str(tmp_path))
    ModelConfig(standard()).with_effect("latent_heat", {"change_j_kg": 24200.0}).save(tmp_path / "mine.json")
    assert load_model("~/mine.json").effects.get("latent_heat") is not None
    env = gym.make("sma_gym:SMATracking-v0", model="~/mine.json")
    assert env.unwrapped.settings.model.effects.get("latent_heat") is not None
