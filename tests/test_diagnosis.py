"""The diagnosis workflow on data in which an effect is hidden, honest about the inverse crime.

Every synthetic case is generated with the effect in its *alternative* form where it has
one (the candidate is always the default form), nominal parameters perturbed by 5 %, 5 um
position noise with 1 um quantisation and 2 mOhm resistance noise, and diagnosed on a
held-out file with a different excitation (fit: steps, held out: sine).
"""

import hashlib
import json

import gymnasium as gym
import numpy as np
import pytest

from sma_gym.cli import main
from sma_gym.data import find_real_data_dir, load_trace
from sma_gym.diagnosis import diagnose
from sma_gym.diagnosis.synth import SynthSpec, generate, write
from sma_gym.effects import EFFECTS
from sma_gym.model import ModelConfig, load_model

FIT_SECONDS = 40.0
HELD_SECONDS = 30.0


def alternative_form(effect: str) -> str:
    forms = EFFECTS[effect].forms
    return forms[1] if len(forms) > 1 else "default"


def synthetic(effect: str | None, seed: int, excitation: str, seconds: float, **kwargs):
    form = "default" if effect is None else alternative_form(effect)
    trace, labels = generate(
        SynthSpec(
            ModelConfig(),
            effect=effect,
            form=form,
            excitation=excitation,
            duration_s=seconds,
            perturb=0.05,
            seed=seed,
            **kwargs,
        )
    )
    return trace


@pytest.mark.parametrize("effect", sorted(EFFECTS))
def test_every_effect_is_named_and_closes_the_heldout_gap(effect):
    fit = synthetic(effect, 7, "steps", FIT_SECONDS)
    held = synthetic(effect, 7, "sine", HELD_SECONDS)
    # One round: later rounds are tested below (two hidden effects); CI time is bounded.
    result = diagnose([fit], [held], ModelConfig(), max_rounds=1)
    assert result.verdict == "effect", (
        result.verdict,
        result.effect,
        [(c["name"], round(c["heldout_gain"], 3), round(c["delta_bic"], 1)) for c in result.candidates],
    )
    assert result.effect == effect
    held_before = result.gap_before["heldout"]["position"]
    held_refit = result.gap_nominal_refit["heldout"]["position"]
    held_after = result.gap_after["heldout"]["position"]
    # The gap shrinks by at least half: against the nominal model as given, and against
    # refitting the nominal parameters alone (so the effect itself closes it).
    assert held_after <= 0.5 * held_before
    assert held_after <= 0.5 * held_refit
    # The corrected model carries the effect, with the fitted parameters reported.
    assert result.corrected_model.effects.get(effect) is not None
    assert any(name.startswith(effect + ".") for name in result.parameters)


def test_clean_data_gives_no_missing_effect():
    fit = synthetic(None, 11, "steps", FIT_SECONDS)
    held = synthetic(None, 11, "sine", HELD_SECONDS)
    result = diagnose([fit], [held], ModelConfig())
    assert result.verdict == "none"
    assert result.effect is None
    # The nominal refit explains the data to about the noise.
    assert result.gap_after["heldout"]["position"] < 3 * result.noise["position"]
    assert not result.corrected_model.effects.active()


def two_effects(truth: ModelConfig, effect: str, form: str, seed: int):
    """Traces of ``truth`` (which carries one effect) with ``effect`` in ``form`` hidden on
    top, nominal perturbed by 5 %: ``trace(excitation, seconds)``."""

    def trace(excitation: str, seconds: float):
        spec = SynthSpec(
            truth, effect=effect, form=form, excitation=excitation, duration_s=seconds, perturb=0.05, seed=seed
        )
        return generate(spec)[0]

    return trace


def test_two_hidden_effects_are_both_named_and_nothing_more():
    """Sensor lag (second-order form) and Stribeck friction hidden together, nominal
    perturbed by 5 %. Round 1 names ``minor_loop_width`` (ΔBIC -334, held out +65 %), a
    look-alike of the friction (both hold the sleigh after a reversal), over the friction
    itself (-593, +47 %) and an Abbe offset, all three supported; the lag, by far the best
    on the fitted data (-1465), predicts only 17 % better alone. Round 2 adds the lag (6.63x
    the noise held out), and the friction is not supported on top of the width. With the
    lag in the model the friction, a rival of round 1, is fitted in the width's place
    (``workflow._swapped``): ΔBIC -289 and 64 % better held out, so it replaces the width.
    The answer is the two hidden effects and nothing more.

    History: until 2026-12-07 the data's Stribeck friction slid with theta (0.5-1) of its
    force (a kernel bug, docs/model.md §8), and an ambiguous round 1 paired the lag with the
    width; on the corrected data the answer was the width and the lag, a confident wrong
    name (a strict xfail here until the replacement step, 2026-12-07).

    Two rounds: a third finds nothing on top of the two and took two thirds of this test's
    CPU time (measured 2026-12-06). Later rounds that add nothing are judged over many
    cases by ``benchmarks/bench_diagnosis.py --pairs``, and the rules they apply by
    ``tests/test_diagnosis_rules.py``."""
    truth = ModelConfig().with_effect("sensor_lag", {"time_constant_s": 0.05}, "second-order")
    trace = two_effects(truth, "coulomb_friction", "stribeck", seed=7)
    result = diagnose([trace("steps", FIT_SECONDS)], [trace("sine", HELD_SECONDS)], ModelConfig(), max_rounds=2)
    assert result.verdict == "effects"
    assert sorted(result.effects_found) == ["coulomb_friction", "sensor_lag"]
    first, last = result.rounds
    assert first["verdict"] == "effect" and first["effect"] == "minor_loop_width"
    singles = {c["name"]: c for c in first["candidates"]}
    assert singles["minor_loop_width"]["supported"] and singles["coulomb_friction"]["supported"]
    assert last["effect"] == "sensor_lag"
    # The friction replaced the width once the lag was in the model; the record says so.
    swap = next(s for s in last["swaps"] if s["swapped"])
    assert (swap["effect"], swap["rival"]) == ("minor_loop_width", "coulomb_friction")
    assert swap["delta_bic_of_rival"] < -10 and swap["heldout_gain_of_rival"] > 0.05
    assert last["heldout_normalised_rms"] == swap["heldout_normalised_rms_with_rival"]
    assert {s.name for s in result.corrected_model.effects.active()} == {"coulomb_friction", "sensor_lag"}
    assert last["heldout_normalised_rms"] < 0.25 * first["nominal_refit_heldout_normalised_rms"]
    assert result.gap_after["heldout"]["position"] < 0.2 * result.gap_before["heldout"]["position"]


def test_no_candidates_is_the_nominal_refit_alone():
    """``effects=[]``: one round that only refits the nominal parameters."""
    fit = synthetic(None, 3, "steps", 8.0)
    result = diagnose([fit], [], ModelConfig(), effects=[])
    assert result.verdict == "none" and [r["round"] for r in result.rounds] == [1]
    assert result.rounds[0]["candidates"][0]["name"] == "nominal refit" and len(result.rounds[0]["candidates"]) == 1
    # The round reports the model it leaves, which the workflow returns (the refit), not the
    # model as given it started from (until 2026-11-27 a round that named nothing did).
    first = result.rounds[0]
    assert first["heldout_normalised_rms"] == first["nominal_refit_heldout_normalised_rms"]
    assert first["heldout_normalised_rms"] != first["as_given_heldout_normalised_rms"]
    # ... and is returned refitted on the whole file (step 9: no held-out file was given),
    # so the round's gap, still held out, is that of the refit as the round left it.
    assert first["candidates"][0]["parameters"] == result.whole_file_refit["parameters_selected"]
    assert first["gap"] != result.gap_after


def test_a_refit_that_predicts_worse_than_the_model_as_given_is_not_shipped(tmp_path, capsys):
    """Five seconds of a steps run that hardly move the wire (duty below 0.04): the nominal
    refit overfits them and predicts the held-out end worse than the nominal as given (0.20
    against 0.05 mm RMS, found by a new user), so the corrected model is the model as given,
    and the report and the console say so."""
    run = ["synth", "--out", str(tmp_path / "run.csv"), "--effect", "transformation_spread", "--excitation", "steps"]
    assert main([*run, "--duration", "20"]) == 0
    lines = (tmp_path / "run.csv").read_text().splitlines(keepends=True)
    (tmp_path / "start.csv").write_text("".join(lines[:5001]))
    assert main(["diagnose", str(tmp_path / "start.csv"), "--max-rounds", "1", "--out", str(tmp_path / "d")]) == 0
    assert "the corrected model is the model as given" in capsys.readouterr().out
    report = json.loads((tmp_path / "d" / "diagnosis.json").read_text())
    assert report["kept_as_given"] is True and report["verdict"] != "effect"
    assert report["whole_file_refit"] is None  # the model as given is not refitted on the whole file either
    first = report["rounds"][0]
    assert first["nominal_refit_heldout_normalised_rms"] > first["as_given_heldout_normalised_rms"]
    assert first["heldout_normalised_rms"] == first["as_given_heldout_normalised_rms"]
    assert report["gap_after"] == report["gap_before"]
    shipped = load_model(tmp_path / "d" / "corrected_model.json")
    assert shipped.actuator == ModelConfig().actuator and shipped.effects == ModelConfig().effects
    md = (tmp_path / "d" / "diagnosis.md").read_text()
    assert "model as given" in md
    # Its parameters are the nominal values, not fitted ones (the report's table said "Fitted").
    assert "None was fitted" in md and "Fitted parameters" not in md
    assert "uncertainties are statistical" not in md  # none was stated


def test_without_heldout_files_the_end_of_each_file_is_held_out():
    fit = synthetic("sensor_lag", 5, "random", 40.0)
    result = diagnose([fit], [], ModelConfig())
    assert "last 30 %" in result.held_out
    assert result.verdict == "effect" and result.effect == "sensor_lag"


def test_cli_writes_report_model_and_json_and_the_env_runs_on_the_correction(tmp_path, capsys):
    fit_path, fit_labels = write(
        SynthSpec(
            ModelConfig(),
            effect="latent_heat",
            form="asymmetric",
            excitation="steps",
            duration_s=FIT_SECONDS,
            perturb=0.05,
            seed=3,
        ),
        tmp_path / "fit.csv",
    )
    held_path, _ = write(
        SynthSpec(
            ModelConfig(),
            effect="latent_heat",
            form="asymmetric",
            excitation="chirp",
            duration_s=HELD_SECONDS,
            perturb=0.05,
            seed=3,
        ),
        tmp_path / "held.csv",
    )
    before = {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in (fit_path, held_path)}
    # diagnose never reads the labels: remove them to be sure.
    fit_labels.unlink()
    code = main(
        [
            "diagnose",
            str(fit_path),
            "--heldout",
            str(held_path),
            "--out",
            str(tmp_path / "out"),
            "--json",
            "--max-rounds",
            "1",
        ]
    )
    result = json.loads(capsys.readouterr().out)
    assert code == 0
    assert result["verdict"] == "effect" and result["effect"] == "latent_heat"
    for key in ("parameters", "where", "gap_before", "gap_after", "rounds", "effects_found", "gap_by_file"):
        assert key in result
    assert [r["round"] for r in result["rounds"]] == [1] and result["effects_found"] == ["latent_heat"]
    assert set(result["gap_by_file"]["corrected"]["heldout"]) == {"held.csv"}
    for gap in ("gap_before", "gap_after"):
        assert set(result[gap]) == {"fit", "heldout"}
        assert {"position", "resistance"} <= set(result[gap]["heldout"])
    assert all("uncertainty" in p for p in result["parameters"].values())
    assert result["where"]["files"][0]["regimes"]["position"]
    assert result["held_out_files"] == ["held.csv"] and result["held_out"] == "the file held.csv"
    # Every candidate says which rule it failed; the named one none.
    reasons = {c["name"]: (c["supported"], c["not_supported_because"]) for c in result["candidates"][1:]}
    assert result["candidates"][0]["name"] == "nominal refit"  # the reference, not a candidate for support
    assert reasons["latent_heat"] == (True, "") and all(s != bool(r) for s, r in reasons.values())
    assert result["conditions"] == {  # every condition synth's sidecar gives
        "supply_voltage_v": 10.0,
        "wire_diameter_m": 3e-4,
        "pwm_frequency_hz": 500.0,
        "ambient_temperature_c": 20.0,
    }
    out = tmp_path / "out"
    assert (out / "diagnosis.md").read_text().startswith("# Diagnosis")
    written = json.loads((out / "diagnosis.json").read_text())
    assert written["verdict"] == "effect" and written["provenance"]["sma_gym_version"]  # the code beside the verdict
    assert result == written  # --json printed the file's object: provenance and outputs too
    assert len(list(out.glob("*.png"))) >= 3
    # The corrected model loads and an env runs on it.
    model = load_model(str(out / "corrected_model.json"))
    assert model.effects.get("latent_heat").values["change_j_kg"] < -3000
    env = gym.make("sma_gym:SMATracking-v0", model=str(out / "corrected_model.json"))
    env.reset(seed=0)
    env.step(np.array([0.5], dtype=np.float32))
    # The input files were not modified.
    assert before == {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in (fit_path, held_path)}


def test_cli_reports_bad_files_with_exit_code_two_and_leaves_them_alone(tmp_path, capsys):
    bad = tmp_path / "bad.csv"
    bad.write_text("t,duty,position\n0,0,0\n0.001,1.7,0\n0.001,0,5\n")
    digest = hashlib.sha256(bad.read_bytes()).hexdigest()
    code = main(["diagnose", str(bad), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2
    assert f"{bad}:3:duty" in err and f"{bad}:4:t" in err and "millimetres" in err
    assert hashlib.sha256(bad.read_bytes()).hexdigest() == digest
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("excitation", ["steps", "chirp"])
def test_a_file_sampled_at_100_hz_holds_the_duty_the_actuator_got(excitation):
    """At 100 Hz the recording's controller commands every 10 ms, so the model that made the
    data, run on the file's duty column, reproduces the file to the noise. (A 1 ms loop logged
    every 10th step hid nine duties in ten: the truth itself missed by 12-27x the noise, and
    no diagnosis could get a clean 100 Hz file right.)"""
    from sma_gym.diagnosis import fitting
    from sma_gym.diagnosis.synth import perturb

    spec = SynthSpec(ModelConfig(), excitation=excitation, duration_s=20.0, perturb=0.05, sample_period_s=0.01, seed=3)
    trace, _ = generate(spec)
    assert np.all(trace.duty[: int(1.0 / 0.01)] == 0.0) and trace.duty.max() > 0.5  # 1 s at rest
    truth, _ = perturb(spec.truth(), spec.perturb, np.random.default_rng(spec.seed))
    # The truth without sensor noise: the residual is then the file's noise alone.
    exact = truth.with_actuator(
        **{
            f"sensors.{name}": 0.0
            for name in (
                "position_noise_std_m",
                "position_resolution_m",
                "resistance_noise_std_ohm",
                "current_noise_std_a",
                "voltage_noise_std_v",
            )
        }
    )
    data = fitting.prepare(trace, 1e-3)
    rms = fitting.rms_by_output(fitting.simulate([exact], [0.0], data, 1e-3), data)
    assert rms["position"] < 1.5 * spec.position_noise_m, rms
    assert rms["resistance"] < 1.5 * spec.resistance_noise_ohm, rms


@pytest.mark.parametrize("excitation", ["sine", "chirp", "steps"])
def test_the_noise_read_off_a_100_hz_file_is_the_sensor_noise_not_the_motion(excitation):
    """Every "within 2x the noise" and the weights of position against R rest on the noise
    read off the file. At 100 Hz the wire moves up to ~0.1 mm between rows; first differences
    counted that as noise (up to 1.9x the true 5 um on these files)."""
    from sma_gym.diagnosis import fitting

    spec = SynthSpec(ModelConfig(), excitation=excitation, duration_s=30.0, perturb=0.05, sample_period_s=0.01, seed=3)
    trace, _ = generate(spec)
    data = fitting.prepare(trace, 1e-3)
    # The file's position noise: sensor noise and a 1 um quantisation.
    true_m = float(np.hypot(spec.position_noise_m, spec.position_resolution_m / np.sqrt(12.0)))
    assert abs(data.noise["position"] / true_m - 1.0) < 0.12, data.noise
    # White noise alone: the estimate is unbiased whatever the differences' order.
    rng = np.random.default_rng(0)
    assert abs(fitting.noise_level(rng.normal(0.0, 2e-3, 20000), 0.0) / 2e-3 - 1.0) < 0.03


def test_synth_cli_writes_data_sidecar_and_separate_labels(tmp_path, capsys):
    code = main(
        [
            "synth",
            "--out",
            str(tmp_path / "s.csv"),
            "--effect",
            "coulomb_friction:force_n=0.8",
            "--form",
            "stribeck",
            "--excitation",
            "ramps",
            "--duration",
            "10",
        ]
    )
    assert code == 0
    trace = load_trace(tmp_path / "s.csv")
    assert trace.duration_s == pytest.approx(10.0, abs=0.01)
    labels = json.loads((tmp_path / "s.labels.json").read_text())
    assert (
        labels["effect"] == "coulomb_friction"
        and labels["effect_values"] == {"force_n": 0.8}
        and labels["form"] == "stribeck"
    )
    assert "effect" not in json.loads((tmp_path / "s.csv.json").read_text())
    assert json.loads((tmp_path / "s.csv.json").read_text())["model"] == "standard"
    assert "note" not in capsys.readouterr().err
    assert main(["synth", "--out", str(tmp_path / "s.csv"), "--duration", "10"]) == 2  # no overwrite
    assert "--overwrite" in capsys.readouterr().err
    # A model file has no name diagnose could look up: the sidecar names none, and synth says so.
    mine = ModelConfig().with_actuator(**{"wire.diameter_m": 0.25e-3}).save(tmp_path / "mine.json")
    assert main(["synth", "--out", str(tmp_path / "m.csv"), "--duration", "7", "--model", str(mine)]) == 0
    assert "model" not in json.loads((tmp_path / "m.csv.json").read_text())
    assert f"--model {mine}" in capsys.readouterr().err
    assert main(["synth", "--out", str(tmp_path / "t.csv"), "--effect", "warp"]) == 2


@pytest.mark.skipif(find_real_data_dir() is None, reason="../shared/data/real is not present on this machine")
def test_real_bench_data_smoke_run(tmp_path):
    """Smoke only: the real files run through the workflow end to end (no thresholds tuned to them)."""
    folder = find_real_data_dir()
    fit = load_trace(folder / "step01.csv")
    held = load_trace(folder / "ramp01.csv")
    result = diagnose([fit], [held], load_model("bench-0.5mm-ht-datasheet"), max_rounds=1)
    assert result.verdict in ("effect", "partial", "ambiguous", "none", "unexplained")
    assert set(result.gap_before) == {"fit", "heldout"}
    assert np.isfinite(result.gap_after["heldout"]["position"])


def test_cross_validation_predicts_every_run_from_the_others(tmp_path, capsys):
    """Three runs of one actuator with a hidden sensor lag: each is predicted by the model
    diagnosed on the other two, and the table says how well."""
    paths = []
    for k, excitation in enumerate(("steps", "sine", "ramps")):
        spec = SynthSpec(
            ModelConfig(), effect="sensor_lag", excitation=excitation, duration_s=12.0, perturb=0.0, seed=20 + k
        )
        paths.append(write(spec, tmp_path / f"run{k}.csv")[0])
    args = [
        "diagnose",
        *map(str, paths),
        "--cross-validate",
        "--effects",
        "sensor_lag,abbe_offset",
        "--max-rounds",
        "1",
    ]
    assert main([*args, "--out", str(tmp_path / "cv"), "--json"]) == 0
    cv = json.loads(capsys.readouterr().out)
    assert cv == json.loads((tmp_path / "cv" / "cross_validation.json").read_text())  # with its provenance
    assert [f["held_out"] for f in cv["folds"]] == ["run0.csv", "run1.csv", "run2.csv"]
    for fold in cv["folds"]:
        assert fold["held_out"] not in fold["fitted"] and len(fold["fitted"]) == 2
        assert fold["effects_found"] == ["sensor_lag"]
        assert fold["position_rms_corrected_m"] < 0.5 * fold["position_rms_nominal_m"]
        # How much of its held-out gap the fold closed: what its verdict was judged on.
        assert fold["explained"]["gain"] >= 0.5 and fold["verdict"] == "effect"
    rows = [
        line for line in (tmp_path / "cv" / "cross_validation.md").read_text().splitlines() if line.startswith("| run")
    ]
    assert len(rows) == 3
    written = json.loads((tmp_path / "cv" / "cross_validation.json").read_text())
    assert written["folds"] == cv["folds"] and "commit" in written["provenance"]
    # Held-out files and a single file make no sense here.
    assert main(["diagnose", str(paths[0]), "--cross-validate", "--out", str(tmp_path / "x")]) == 2


def test_two_effects_that_rival_each_other_are_fitted_as_a_pair_and_both_named():
    """A warm surrounding and a second-order sensor lag hidden together (the two-effect
    benchmark's case 15, shorter): alone each explains part of the residual, so the round
    is ambiguous between them; fitted jointly the pair beats each by the BIC and held-out
    bars, and both are named in one round (verdict ``effects``), with the held-out residual
    brought near the noise."""
    truth = ModelConfig().with_effect("warm_surroundings", {"gain_k_j": 0.1, "time_constant_s": 20.0}, "electrical")
    trace = two_effects(truth, "sensor_lag", "second-order", seed=881251967)
    result = diagnose([trace("steps", 60.0)], [trace("ramps", 40.0)], ModelConfig(), max_rounds=2)
    assert result.verdict == "effects" and sorted(result.effects_found) == ["sensor_lag", "warm_surroundings"]
    first = result.rounds[0]
    assert first["verdict"] == "effects"
    joint = [c for c in first["candidates"] if c["name"] == "warm_surroundings + sensor_lag"]
    assert joint and joint[0]["supported"]
    assert first["heldout_normalised_rms"] < 0.2 * first["as_given_heldout_normalised_rms"]
    assert {s.name for s in result.corrected_model.effects.active()} == {"sensor_lag", "warm_surroundings"}
