"""The draw and the scoring of ``benchmarks/bench_diagnosis.py --grid`` (issue 12).

The grid is only a fair benchmark if its draw is balanced over every factor, reproducible
from its seed, never holds out the excitation it fitted, and asks the independent generator
only for effects it can hide. None of this needs a diagnosis to run: these tests draw, score
and, for ``--floor``, fit one model.
"""

from __future__ import annotations

import importlib.util
import sys
from collections import Counter
from pathlib import Path
from types import ModuleType

import pytest

from sma_gym.effects import EFFECTS

BENCH_PATH = Path(__file__).resolve().parent.parent / "benchmarks" / "bench_diagnosis.py"


@pytest.fixture(scope="module")
def bench() -> ModuleType:
    """The benchmark script, loaded by file path (``benchmarks`` is not a package)."""
    spec = importlib.util.spec_from_file_location("bench_diagnosis", BENCH_PATH)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("bench_diagnosis", module)  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def test_grid_is_reproducible_and_a_prefix_of_any_larger_grid(bench: ModuleType) -> None:
    """Same seed, same cases; a grid cut short is the smaller grid; another seed differs."""
    big = bench.draw_grid(60, seed=3)
    assert big == bench.draw_grid(60, seed=3)
    assert bench.draw_grid(17, seed=3) == big[:17]
    assert bench.draw_grid(60, seed=4) != big


@pytest.mark.parametrize("n", [24, 37, 120])
def test_every_factor_is_balanced_within_one_case_per_generator(bench: ModuleType, n: int) -> None:
    cases = bench.draw_grid(n, seed=0)
    by_generator = Counter(c.generator for c in cases)
    assert max(by_generator.values()) - min(by_generator.values()) <= 1
    for g in bench.GENERATORS:
        mine = [c for c in cases if c.generator == g]
        truths = bench.grid_truths(g)
        blocks, rest = divmod(len(mine), len(truths))
        counts = Counter(c.truth for c in mine)
        for truth in set(truths):
            per_block = truths.count(truth)
            # Complete shuffled blocks: each truth its share of every block, plus the partial one.
            assert blocks * per_block <= counts[truth] <= blocks * per_block + min(per_block, rest), (g, truth, counts)
        for attr, levels in (
            ("fit_excitation", bench.EXCITATIONS),
            ("sampling", bench.SAMPLING),
        ):
            values = [c.fit_excitation if attr == "fit_excitation" else (c.sample_rate_hz, c.sensors) for c in mine]
            tally = Counter(values)
            assert set(tally) <= set(levels)
            assert max(tally.values()) - min(tally.get(level, 0) for level in levels) <= 1, (g, attr, tally)


def test_cases_fit_and_hold_out_different_excitations_and_truths_the_generator_supports(bench: ModuleType) -> None:
    independent = set(bench.independent_module().INDEPENDENT_EFFECTS)
    for c in bench.draw_grid(90, seed=1):
        assert c.fit_excitation != c.heldout_excitation
        assert c.sample_rate_hz in (1000, 100) and c.sensors in ("all", "position")
        if c.truth == "none":
            assert c.size == 0.0 and c.effect_values() == {}
            continue
        assert c.size in bench.SIZES
        if c.generator == "independent":
            assert c.truth in independent
        else:
            # Our generator hides the effect in its alternative form, where it has one.
            forms = EFFECTS[c.truth].forms
            assert c.form == (forms[1] if len(forms) > 1 else "default")
        for name, value in c.effect_values().items():
            p = EFFECTS[c.truth].parameter(name)
            assert p.lower <= value <= p.upper, (c, name, value)


def test_effect_size_scales_the_deviation_from_off(bench: ModuleType) -> None:
    case = bench.GridCase(0, "ours", "convection_change", "power", "steps", "sine", 0.5, 1000, "all", 1)
    values = case.effect_values()
    assert values["scale"] == pytest.approx(1.3)  # off 1.0, typical 1.6
    assert values["h1_w_m2_k2"] == pytest.approx(0.3)  # off 0.0, typical 0.6


def test_scoring_separates_right_not_wrong_and_confidently_wrong(bench: ModuleType) -> None:
    classify = bench.classify
    assert classify("none", "none", []) == "right"
    assert classify("sensor_lag", "effect", ["sensor_lag"]) == "right"
    assert classify("sensor_lag", "ambiguous", ["abbe_offset", "sensor_lag"]) == "ambiguous_with_truth"
    assert classify("sensor_lag", "ambiguous", ["abbe_offset", "coulomb_friction"]) == "miss"
    assert classify("sensor_lag", "effect", ["abbe_offset"]) == "confident_wrong"
    # The hidden effect plus a spurious one is still a confident wrong name.
    assert classify("sensor_lag", "effects", ["sensor_lag", "latent_heat"]) == "confident_wrong"
    assert classify("none", "effect", ["latent_heat"]) == "confident_wrong"
    assert classify("none", "unexplained", []) == "miss"
    assert classify("latent_heat", "none", []) == "miss"
    # A partial explanation names without confidence: never right, never a confident wrong name.
    assert classify("latent_heat", "partial", ["latent_heat"]) == "ambiguous_with_truth"
    assert classify("none", "partial", ["latent_heat"]) == "miss"
    assert bench.classify_clean("partial") == "partial"
    assert bench.classify_pair(["sensor_lag", "latent_heat"], "partial", ["latent_heat"]) == "ambiguous"
    # What a verdict names: the effects found, or an ambiguous round's rivals, never both.
    from types import SimpleNamespace

    found = SimpleNamespace(verdict="effects", effects_found=["sag", "lag"], effect=["sag", "lag"])
    rivals = SimpleNamespace(verdict="ambiguous", effects_found=["sag"], effect=["lag", "abbe"])
    nothing = SimpleNamespace(verdict="unexplained", effects_found=[], effect=None)
    partly = SimpleNamespace(verdict="partial", effects_found=["sag"], effect=["sag"])
    assert [bench.named_effects(r) for r in (found, rivals, nothing, partly)] == [
        ["sag", "lag"],
        ["lag", "abbe"],
        [],
        ["sag"],
    ]
    assert bench.answer_label(partly) == "partial(sag)"


def test_pairs_cover_every_pair_once_before_repeating_and_hold_out_another_excitation(bench: ModuleType) -> None:
    """``--pairs``: the library's unordered pairs each once in the first len(pairs) cases,
    two different effects per case, reproducible from the seed, held out on another
    excitation, fitted excitations balanced."""
    names = list(EFFECTS)
    n_pairs = len(names) * (len(names) - 1) // 2
    cases = bench.draw_pairs(n_pairs + 5, seed=1)
    assert cases == bench.draw_pairs(n_pairs + 5, seed=1) and cases != bench.draw_pairs(n_pairs + 5, seed=2)
    first_round = {frozenset(c.truth) for c in cases[:n_pairs]}
    assert len(first_round) == n_pairs and all(len(p) == 2 for p in first_round)
    assert all(c.fit_excitation != c.heldout_excitation for c in cases)
    counts = Counter(c.fit_excitation for c in cases[:20])
    assert max(counts.values()) - min(counts.values()) <= 1
    with pytest.raises(ValueError, match="pairs = 0"):
        bench.draw_pairs(0)
    # --cases reruns some of the draw (those a change can affect): an index outside it is
    # refused before any case runs.
    with pytest.raises(ValueError, match=r"--cases \[20\]: expected case indices from 0 to 19"):
        bench.run_pairs(20, only=[3, 20])


def test_pair_scoring_counts_both_only_when_nothing_else_is_named(bench: ModuleType) -> None:
    truth = ("sensor_lag", "latent_heat")
    assert bench.classify_pair(truth, "effects", ["latent_heat", "sensor_lag"]) == "both"
    assert bench.classify_pair(truth, "effect", ["sensor_lag"]) == "one"
    assert bench.classify_pair(truth, "effects", ["sensor_lag", "abbe_offset"]) == "confident_wrong"
    assert bench.classify_pair(truth, "ambiguous", ["sensor_lag", "supply_sag"]) == "ambiguous"
    assert bench.classify_pair(truth, "ambiguous", ["abbe_offset", "supply_sag"]) == "miss"
    assert bench.classify_pair(truth, "unexplained", []) == "miss"


def test_final_heldout_is_the_last_rounds_model(bench: ModuleType) -> None:
    """Each round records the model it leaves (the workflow's test
    ``test_no_candidates_is_the_nominal_refit_alone`` checks that); the benchmark scores the
    last one, which is the model the diagnosis returns."""
    from types import SimpleNamespace

    def rnd(verdict: str, held: float) -> dict:
        return {"verdict": verdict, "heldout_normalised_rms": held}

    assert bench.final_heldout(SimpleNamespace(rounds=[])) is None
    assert bench.final_heldout(SimpleNamespace(rounds=[rnd("unexplained", 13.1)])) == 13.1
    assert bench.final_heldout(SimpleNamespace(rounds=[rnd("effect", 9.0), rnd("none", 4.0)])) == 4.0


def test_what_the_data_allow_reads_the_hidden_effects_own_round_1_candidate(bench: ModuleType) -> None:
    """The grid reports, apart from the verdict rules, whether the truth's own round-1 fit
    passed the bars or was the best held out, and the clean data's refit floor."""

    def cand(name: str, held: float, supported: bool = False, inert: bool = False) -> dict:
        return {"name": name, "heldout_normalised_rms": held, "supported": supported, "inert": inert}

    refit = cand("nominal refit", 9.0)
    records = [
        {"truth": "sensor_lag", "round_candidates": [[refit, cand("sensor_lag", 2.0, True), cand("abbe_offset", 3.0)]]},
        {
            "truth": "abbe_offset",
            "round_candidates": [[refit, cand("sensor_lag", 2.0, True), cand("abbe_offset", 3.0)]],
        },
        {"truth": "latent_heat", "round_candidates": [[refit, cand("latent_heat", 9.0, inert=True)]]},
        {"truth": "supply_sag", "round_candidates": []},  # an error: no candidates
        {"truth": "none", "heldout_nominal_refit": 40.0, "round_candidates": [[refit]]},
        {"truth": "none", "heldout_nominal_refit": 60.0, "round_candidates": [[refit]]},
    ]
    assert bench._truth_in_first_round(records[0]) == {"supported": True, "inert": False, "best_heldout": True}
    assert bench._truth_in_first_round(records[1])["best_heldout"] is False
    assert bench._truth_in_first_round(records[4]) is None
    assert bench._detection(records) == {
        "truth_round1_cases": 3,
        "truth_supported_round1": 1,
        "truth_best_heldout_round1": 2,
        "truth_inert_round1": 1,
        "clean_refit_floor_median": 50.0,
    }


def test_datasheet_cases_are_balanced_reproducible_and_never_hide_an_effect(bench: ModuleType) -> None:
    """``--datasheet``: every datasheet error, size and sampling in complete blocks, the draw a
    prefix of any larger one, and a held-out excitation other than the fitted one."""
    cases = bench.draw_datasheet(24, seed=3)
    assert cases[:12] == bench.draw_datasheet(12, seed=3)
    assert cases != bench.draw_datasheet(24, seed=4)
    for field, levels in (
        ("error", tuple(bench.DATASHEET_TOLERANCES)),
        ("size", bench.DATASHEET_SIZES),
        ("fit_excitation", bench.EXCITATIONS),
    ):
        counts = Counter(getattr(c, field) for c in cases)
        assert set(counts) <= set(levels)
        assert max(counts.values()) - min(counts[level] for level in levels) <= 1
    assert all(c.heldout_excitation != c.fit_excitation for c in cases)


def test_off_datasheet_changes_one_value_by_its_tolerance(bench: ModuleType) -> None:
    from sma_gym.model import ModelConfig

    nominal = ModelConfig()
    a = nominal.actuator
    heat = bench.off_datasheet(nominal, "specific_heat", -0.5).actuator
    assert heat.wire.specific_heat_j_kg_k == pytest.approx(a.wire.specific_heat_j_kg_k * 0.96)
    assert heat.with_changes(**{"wire.specific_heat_j_kg_k": a.wire.specific_heat_j_kg_k}) == a
    branches = bench.off_datasheet(nominal, "branch_ranges", 1.0).actuator.wire
    assert branches.austenite_finish_c - branches.austenite_start_c == pytest.approx(
        1.1 * (a.wire.austenite_finish_c - a.wire.austenite_start_c)
    )
    # The branches widen about their centres: the 15 K loop stays.
    assert branches.austenite_start_c - branches.martensite_finish_c == pytest.approx(
        a.wire.austenite_start_c - a.wire.martensite_finish_c
    )
    assert bench.off_datasheet(nominal, "ambient", 1.0).actuator.convection.ambient_temperature_c == pytest.approx(
        a.convection.ambient_temperature_c + 3.0
    )
    with pytest.raises(ValueError, match="datasheet error = 'colour'"):
        bench.off_datasheet(nominal, "colour", 1.0)
    assert [bench.classify_clean(v) for v in ("none", "unexplained", "ambiguous", "effect", "effects")] == [
        "right",
        "unexplained",
        "ambiguous",
        "confident_wrong",
        "confident_wrong",
    ]


def test_pair_floor_fits_the_truths_own_model_down_to_the_noise(bench: ModuleType) -> None:
    """``--floor``: the truth's two effects in their hidden forms, fitted with the nominal
    parameters, reach the noise on data that nothing else perturbs; with another effect in
    place of the sensor lag they do not."""
    from sma_gym.diagnosis.synth import SynthSpec, generate
    from sma_gym.model import ModelConfig

    nominal = ModelConfig()
    case = bench.PairCase(0, "latent_heat", "sensor_lag", "steps", "sine", seed=3)
    truth = nominal.with_effect(
        "latent_heat", {p.name: p.typical for p in EFFECTS["latent_heat"].parameters}, "asymmetric"
    )

    def trace(excitation: str) -> object:
        spec = SynthSpec(truth, effect="sensor_lag", form="second-order", excitation=excitation, duration_s=8.0, seed=3)
        return generate(spec)[0]

    fit, held = trace("steps"), trace("sine")
    floor = bench.pair_floor(case, nominal, fit, held, {})
    assert floor < 1.5, floor
    one = bench.pair_floor(bench.PairCase(0, "latent_heat", "abbe_offset", "steps", "sine", 3), nominal, fit, held, {})
    assert one > 2.0 * floor, (one, floor)
