"""The diagnosis's decision rules on small hand-made rounds (issue 12: no confident wrong names).

Each test builds the fitted candidates of one round by hand (BIC, held-out residuals) and
asks ``_judge`` for the verdict, so every rule is checked in milliseconds and apart from
the fits. Every test here fails on the rules before issue 12's second pass: a candidate
whose effect ended "off", a refit already at the noise, a runner-up the held-out data
cannot tell from the best, a gain within one held-out file's chance, a later effect that
only stands in for an earlier effect's form, and a supply sag on position-only data were
all named with confidence.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from sma_gym.cli import _print_diagnosis
from sma_gym.diagnosis import fitting, workflow
from sma_gym.diagnosis.report import cross_validation_table, write_outputs
from sma_gym.diagnosis.synth import SynthSpec, generate
from sma_gym.diagnosis.workflow import NOISE_STOP, Candidate, _judge
from sma_gym.model import ModelConfig
from sma_gym.params import preset

N = 4000
"""Held-out samples of the hand-made rounds."""


class HeldOut:
    """A stand-in for the held-out ``fitting.Problem``: each candidate's residuals by name."""

    def __init__(self) -> None:
        self.residuals: dict[str, np.ndarray] = {}

    def residual_matrix(self, parameters, points):
        return self.residuals[parameters][:, None]


def smooth(seed: int, rms: float, correlation_samples: int = 1) -> np.ndarray:
    """Residuals of a given RMS, white or smoothed over ``correlation_samples``."""
    r = np.random.default_rng(seed).normal(size=N + correlation_samples)
    if correlation_samples > 1:
        r = np.convolve(r, np.ones(correlation_samples), mode="valid")[:N]
    r = r[:N]
    return r * rms / math.sqrt(np.mean(r**2))


def candidate(held: HeldOut, name: str, bic: float, residuals: np.ndarray, inert: bool = False) -> Candidate:
    held.residuals[name] = residuals
    fit = SimpleNamespace(parameters=name, values=np.zeros(1), values_by_name=lambda: {})
    score = float(math.sqrt(np.mean(residuals**2)))
    return Candidate(name, fit, bic, score, inert=inert)


def judge(held: HeldOut, ref: Candidate, effects, bars=None, electrical: bool = True, gain: float = 0.10):
    return _judge(ref, effects, bars or [ref], 100.0, gain, electrical, held)


def fit_that_left(model: ModelConfig) -> SimpleNamespace:
    """A stand-in for a ``fitting.Fit`` that left ``model`` (what ``diagnose`` reads of it)."""
    return SimpleNamespace(
        model=model, offset=0.0, parameters=(), values=np.zeros(0), success=True, as_dict=dict, values_by_name=dict
    )


def returned(name: str, model: ModelConfig, score: float) -> Candidate:
    """A round's candidate whose fit left ``model``, held out at ``score`` times the noise."""
    return Candidate(name, fit_that_left(model), 0.0, score)


def round_of(
    verdict: str,
    effect,
    ref: tuple[ModelConfig, float],
    chosen: tuple[ModelConfig, float],
    as_given: float,
    chosen_name: str | None = None,
):
    """A faked round (``diagnose`` with ``_round`` replaced): its verdict and names, and the
    models its reference and its choice (``chosen_name``, default the names) left, each with
    its held-out score."""
    name = chosen_name or (effect if isinstance(effect, str) else "+".join(effect or ["nominal refit"]))
    return workflow._Round(
        verdict, effect, returned("nominal refit", *ref), returned(name, *chosen), [], None, as_given
    )


def diagnose_faked(monkeypatch, rounds: list, effects: list[str], **options):
    """``diagnose`` on a 3 s position-only step trace with its rounds faked, in order."""
    trace, _ = generate(SynthSpec(ModelConfig(), excitation="steps", duration_s=3.0, electrical=False, seed=0))
    queue = iter(rounds)
    monkeypatch.setattr(workflow, "_round", lambda *args, **kwargs: next(queue))
    return workflow.diagnose([trace], [], ModelConfig(), effects, **options)


def test_an_effect_that_ended_off_is_no_evidence_for_it():
    """Its gain came from the nominal parameters (a better optimum of the refit)."""
    held = HeldOut()
    ref = candidate(held, "nominal refit", 0.0, smooth(0, 10.0))
    off = candidate(held, "pulse_settling", -31.0, smooth(1, 6.0), inert=True)
    r = judge(held, ref, [off])
    assert r.verdict == "unexplained" and not off.supported
    assert off.why_not.startswith("inert")


def test_a_refit_at_the_noise_leaves_nothing_to_explain():
    """Clean data: the refit is within NOISE_STOP of the noise, so no effect is named even
    when one lowers the residual further (a supply sag stood in for a 2 % power error)."""
    held = HeldOut()
    ref = candidate(held, "nominal refit", 0.0, smooth(0, 0.95 * NOISE_STOP))
    sag = candidate(held, "supply_sag", -105.0, smooth(1, 1.16))
    r = judge(held, ref, [sag])
    assert r.verdict == "none" and r.effect is None


def test_a_runner_up_the_heldout_data_cannot_tell_apart_makes_it_ambiguous():
    """8 % apart on held-out data whose errors are smooth (correlated over 400 samples):
    the preference is within chance, so both are named. Without the smoothing the same 8 %
    is many standard errors and the best is named alone."""
    held = HeldOut()
    ref = candidate(held, "nominal refit", 0.0, smooth(0, 70.0, 400))
    best = candidate(held, "latent_heat", -75.0, smooth(1, 9.6, 400))
    runner = candidate(held, "transformation_spread", -69.0, smooth(2, 10.4, 400))
    r = judge(held, ref, [best, runner])
    assert r.verdict == "ambiguous" and r.effect == ["latent_heat", "transformation_spread"]

    held = HeldOut()
    ref = candidate(held, "nominal refit", 0.0, smooth(0, 70.0))
    best = candidate(held, "latent_heat", -75.0, smooth(1, 9.6))
    runner = candidate(held, "transformation_spread", -69.0, smooth(2, 10.4))
    assert judge(held, ref, [best, runner]).verdict == "effect"


def test_a_runner_up_short_of_the_bic_bar_still_counts_as_a_rival():
    held = HeldOut()
    ref = candidate(held, "nominal refit", 0.0, smooth(0, 20.0))
    best = candidate(held, "coulomb_friction", -30.0, smooth(1, 10.0))
    runner = candidate(held, "abbe_offset", -5.0, smooth(2, 10.2))  # dBIC -5: not supported
    r = judge(held, ref, [best, runner])
    assert not runner.supported and runner.why_not.startswith("fitted data: delta BIC")
    assert best.supported and best.why_not == "" and best.block_t > workflow.SEPARATION_T
    assert r.verdict == "ambiguous" and r.effect == ["coulomb_friction", "abbe_offset"]


def test_a_heldout_gain_within_chance_is_not_support():
    """15 % lower held-out RMS, but the held-out errors are smooth over 1000 samples (4
    independent stretches in the file): not distinguishable from the refit."""
    held = HeldOut()
    ref = candidate(held, "nominal refit", 0.0, smooth(0, 10.0, 1000))
    # Another smooth error, 15 % smaller.
    eff = candidate(held, "convection_change", -30.0, smooth(3, 8.5, 1000))
    assert eff.heldout_score < 0.9 * ref.heldout_score
    r = judge(held, ref, [eff])
    assert r.verdict == "unexplained" and not eff.supported
    # The report says why: past the BIC and gain bars, it fails the block test (its t shown).
    assert eff.why_not.startswith("held out: not consistently better") and eff.block_t < workflow.SEPARATION_T
    assert f"t = {eff.block_t:.2g}" in eff.why_not


def test_a_later_effect_must_beat_the_earlier_effects_other_forms():
    """Round 2 after a supply sag: a convection change lowers the residual by 30 %, but the
    sag in its quadratic form alone does as well, so the change only stands in for it."""
    held = HeldOut()
    ref = candidate(held, "nominal refit", 0.0, smooth(0, 10.0))
    form = candidate(held, "supply_sag (quadratic)", -40.0, smooth(1, 6.8))
    change = candidate(held, "convection_change", -35.0, smooth(2, 7.0))
    r = judge(held, ref, [change], bars=[ref, form], gain=workflow.LATER_ROUND_GAIN)
    assert r.verdict == "unexplained" and not change.supported
    # Against the refit alone it would have been named.
    held2 = HeldOut()
    ref2 = candidate(held2, "nominal refit", 0.0, smooth(0, 10.0))
    change2 = candidate(held2, "convection_change", -35.0, smooth(2, 7.0))
    assert judge(held2, ref2, [change2], gain=workflow.LATER_ROUND_GAIN).verdict == "effect"


@pytest.mark.parametrize("electrical", [True, False])
def test_a_supply_sag_is_named_only_where_voltage_or_current_was_measured(electrical):
    held = HeldOut()
    ref = candidate(held, "nominal refit", 0.0, smooth(0, 20.0))
    sag = candidate(held, "supply_sag", -60.0, smooth(1, 5.0))
    other = candidate(held, "latent_heat", -3.0, smooth(2, 19.0))
    r = judge(held, ref, [sag, other], electrical=electrical)
    if electrical:
        assert r.verdict == "effect" and r.effect == "supply_sag"
    else:
        assert r.verdict == "ambiguous" and r.effect == ["supply_sag", "latent_heat"]
        assert "voltage or current" in r.separating
        # Nor is it named in a pair: what a sag cannot identify alone, a pair cannot either.
        assert not any("supply_sag" in pair for pair in workflow._pairs_to_try(r, 0.10, electrical))


def test_a_supply_sag_that_explains_position_only_data_to_the_noise_is_named():
    """A new user's 0.8 ohm sag on position-only files, fitted to 0.7986 ohm and 0.96x the
    noise held out (the refit 64x, the best other candidate 31x), was "ambiguous"; so were
    both misses of the grid's seed 47 on our generator (1.01x, 0.96x). Short of the noise it
    stays ambiguous (the test above): it may absorb a heating law of another form."""
    held = HeldOut()
    ref = candidate(held, "nominal refit", 0.0, smooth(0, 63.8))
    sag = candidate(held, "supply_sag", -615.0, smooth(1, 0.957))
    other = candidate(held, "latent_heat", -209.0, smooth(2, 31.2))
    r = judge(held, ref, [sag, other], electrical=False)
    assert r.verdict == "effect" and r.effect == "supply_sag"
    # Within the noise but with a rival the held-out data cannot tell from it: ambiguous.
    held = HeldOut()
    ref = candidate(held, "nominal refit", 0.0, smooth(0, 63.8))
    sag = candidate(held, "supply_sag", -615.0, smooth(1, 0.957))
    twin = candidate(held, "latent_heat", -600.0, smooth(1, 0.96))
    assert judge(held, ref, [sag, twin], electrical=False).verdict == "ambiguous"


def test_the_resistivity_level_is_refitted_on_position_only_data_and_forms_reach_the_model():
    trace, _ = generate(SynthSpec(ModelConfig(), excitation="steps", duration_s=5.0, electrical=False, seed=1))
    data = fitting.prepare(trace, 1e-3)
    assert set(data.outputs) == {"position"}
    names = [p.name for p in fitting.Problem(ModelConfig(), [data], 1e-3).nominal_parameters()]
    assert "resistivity_scale" in names
    params = fitting.effect_parameters("supply_sag", "quadratic")
    model, _ = fitting.apply(ModelConfig(), params, np.array([1.0]))
    assert model.effects.get("supply_sag").form == "quadratic"
    with pytest.raises(ValueError, match="form"):
        fitting.effect_parameters("supply_sag", "cubic")


def test_batched_simulations_give_the_same_residuals_bit_for_bit_on_any_number_of_threads():
    traces = [
        generate(SynthSpec(ModelConfig(), excitation=kind, duration_s=4.0, electrical=electrical, seed=2))[0]
        for kind, electrical in (("steps", False), ("sine", True))
    ]
    data = [fitting.prepare(t, 1e-3) for t in traces]
    params = fitting.Problem(ModelConfig(), data, 1e-3).nominal_parameters()
    start = np.array([p.start for p in params])
    points = [start + 0.02 * k * np.array([p.upper - p.lower for p in params]) for k in range(5)]
    points = [np.clip(u, [p.lower for p in params], [p.upper for p in params]) for u in points]
    one = fitting.Problem(ModelConfig(), data, 1e-3, threads=1).residual_matrix(params, points)
    for threads in (2, 3, 8):
        many = fitting.Problem(ModelConfig(), data, 1e-3, threads=threads).residual_matrix(params, points)
        assert np.array_equal(one, many), threads
    for bad in (0, 9, 1.5, True):
        with pytest.raises(ValueError, match="threads"):
            fitting.Problem(ModelConfig(), data, 1e-3, threads=bad)


def test_a_fit_on_part_of_a_file_simulates_it_only_as_far_as_it_reads_and_gets_the_same_residuals(monkeypatch):
    """A file without a held-out file is split (fitted part first): its fit reads nothing
    after the split, so it simulates nothing after it; the model is causal, so the fitted
    residuals are the same bit for bit, and the held-out part still simulates the whole file."""
    from sma_gym.simulator import Simulator

    trace, _ = generate(SynthSpec(ModelConfig(), excitation="steps", duration_s=4.0, electrical=True, seed=2))
    fit_mask, held_mask = workflow._split(trace)
    fitted = fitting.prepare(trace, 1e-3, fit_mask)
    held = fitting.prepare(trace, 1e-3, held_mask)
    params = fitting.Problem(ModelConfig(), [fitted], 1e-3).nominal_parameters()
    start = np.array([p.start for p in params])
    lower, upper = np.array([p.lower for p in params]), np.array([p.upper for p in params])
    points = [start, np.clip(start + 0.05 * (upper - lower), lower, upper)]
    steps = []
    run = Simulator.run
    monkeypatch.setattr(Simulator, "run", lambda self, duty, **k: steps.append(len(duty)) or run(self, duty, **k))
    for data, part in ((fitted, fit_mask), (held, held_mask)):
        steps.clear()
        batched = fitting.Problem(ModelConfig(), [data], 1e-3, threads=1).residual_matrix(params, points)
        assert steps == [int(data.sample_steps[part].max()) + 1]
        models, offsets = zip(*(fitting.apply(ModelConfig(), params, u) for u in points))
        whole = fitting.residuals(fitting.simulate(models, offsets, data, 1e-3), data)
        assert np.array_equal(batched, whole)
    assert int(held.sample_steps[held_mask].max()) + 1 == len(held.duty)  # the held-out part ends with the file
    assert int(fitted.sample_steps[fit_mask].max()) + 1 < 0.75 * len(fitted.duty)
    cut = fitting.simulate([ModelConfig()], [0.0], fitted, 1e-3, used_only=True)["position"][:, 0]
    assert np.isfinite(cut[fit_mask]).all() and np.isnan(cut[~fit_mask]).all()


def _refit_problem():
    """A nominal refit far from its optimum (the two fits' tests below)."""
    trace, _ = generate(SynthSpec(ModelConfig(), excitation="steps", duration_s=4.0, electrical=True, seed=3))
    problem = fitting.Problem(ModelConfig(), [fitting.prepare(trace, 1e-3)], 1e-3, threads=1)
    return problem, problem.nominal_parameters(), {"convection_scale": 2.0, "temperature_shift_k": 9.0}


def _solve_simulating_every_column(problem, params, x0, method, max_nfev):
    """scipy's least squares as ``Problem.fit`` calls it, but with the Jacobian's columns
    simulated with every residual (the reference the fit must reproduce)."""
    from scipy.optimize import least_squares

    lower = np.array([p.lower for p in params])
    upper = np.array([p.upper for p in params])
    span = upper - lower

    def every_step(u):
        h = 1e-3 * span
        h = np.where(u + h > upper, -h, h)
        res = problem.residual_matrix(params, [u] + [u + np.eye(len(u))[k] * h[k] for k in range(len(u))])
        return res[:, 0], (res[:, 1:] - res[:, :1]) / h[None, :]

    return least_squares(
        lambda u: every_step(u)[0],
        x0,
        jac=lambda u: every_step(u)[1],
        bounds=(lower, upper),
        x_scale=span,
        max_nfev=max_nfev,
        method=method,
    )


def test_a_fit_simulates_jacobian_columns_only_at_accepted_steps_and_ends_as_if_at_every_step():
    """The Jacobian's columns are simulated only where TRF asks for them (a rejected trial
    step needs only its residual), which is the same fit bit for bit as simulating them
    with every residual (a column does not depend on its batch, test above)."""
    problem, params, warm = _refit_problem()
    start = fitting.starts_for(params, warm)
    assert len(start) == 1
    ref = _solve_simulating_every_column(problem, params, start[0], "trf", 40)
    assert ref.status != 0  # converged within the budget: no dogbox continuation (next test)
    assert ref.nfev > ref.njev  # the data make TRF reject a step: the case the rule is for
    columns = []
    simulate = problem.residual_matrix
    problem.residual_matrix = lambda p, points: columns.append(len(points)) or simulate(p, points)
    fit = problem.fit("nominal refit", params, warm=warm)
    assert np.array_equal(fit.values, ref.x) and fit.cost == float(np.sum(ref.fun**2))
    assert sum(columns) == ref.nfev + len(params) * ref.njev < (len(params) + 1) * ref.nfev


def test_a_fit_stopped_by_its_budget_is_continued_by_dogbox_and_never_ends_worse():
    """A TRF run that ends at ``max_nfev`` is still descending: the fit continues it with
    dogbox from where it stopped and keeps the lower of the two (``POLISH_MAX_NFEV``)."""
    problem, params, warm = _refit_problem()
    start = fitting.starts_for(params, warm)[0]
    trf = _solve_simulating_every_column(problem, params, start, "trf", 3)
    assert trf.status == 0  # stopped by the budget: the case the rule is for
    polish = _solve_simulating_every_column(problem, params, trf.x, "dogbox", fitting.POLISH_MAX_NFEV)
    assert polish.cost < trf.cost
    fit = problem.fit("nominal refit", params, warm=warm, max_nfev=3)
    assert np.array_equal(fit.values, polish.x) and fit.cost == float(np.sum(polish.fun**2))
    # Never worse than TRF alone, whatever the budget.
    for budget in (2, 5):
        alone = _solve_simulating_every_column(problem, params, start, "trf", budget)
        assert problem.fit("nominal refit", params, warm=warm, max_nfev=budget).cost <= float(np.sum(alone.fun**2))


def test_an_inert_candidate_is_detected_from_its_fitted_residuals():
    trace, _ = generate(SynthSpec(ModelConfig(), excitation="steps", duration_s=5.0, electrical=False, seed=1))
    problem = fitting.Problem(ModelConfig(), [fitting.prepare(trace, 1e-3)], 1e-3)
    base = problem.nominal_parameters()
    for value, inert in ((0.0, True), (0.6, False)):
        params = base + fitting.effect_parameters("coulomb_friction")
        values = np.array([p.start for p in base] + [value])
        cost = float(np.sum(problem.residual_matrix(params, [values])[:, 0] ** 2))
        fit = fitting.Fit("coulomb_friction", params, values, values * 0, cost, 1, ModelConfig(), 0.0)
        assert workflow._inert(fit, problem) is inert


def test_a_form_that_changes_the_model_at_off_is_not_inert():
    """A power-law convection changes the model with its parameter at "off" (its level is
    the nominal convection scale's): judged against the effect taken out, not against "off"
    in its own form, it is not inert; the default form at "off" is."""
    trace, _ = generate(SynthSpec(ModelConfig(), excitation="steps", duration_s=5.0, electrical=False, seed=1))
    problem = fitting.Problem(ModelConfig(), [fitting.prepare(trace, 1e-3)], 1e-3)
    base = problem.nominal_parameters()
    for form, inert in (("default", True), ("power", False)):
        params = base + fitting.effect_parameters("convection_change", form)
        values = np.array([p.start for p in params])
        cost = float(np.sum(problem.residual_matrix(params, [values])[:, 0] ** 2))
        fit = fitting.Fit("convection_change", params, values, values * 0, cost, 1, ModelConfig(), 0.0)
        assert workflow._inert(fit, problem) is inert, form


def test_when_fitted_and_heldout_data_prefer_different_effects_neither_is_named_alone():
    """The held-out data prefer a convection change, the fitted data a pulse settling (in
    another optimum of the nominal parameters): the evidence disagrees."""
    held = HeldOut()
    ref = candidate(held, "nominal refit", 0.0, smooth(0, 10.3))
    change = candidate(held, "convection_change", -30.3, smooth(1, 8.5))
    settling = candidate(held, "pulse_settling", -31.1, smooth(2, 11.5))
    r = judge(held, ref, [change, settling])
    assert r.verdict == "ambiguous" and r.effect == ["convection_change", "pulse_settling"]


def test_a_better_fitting_candidate_that_also_generalises_is_left_to_the_next_round():
    """Two effects hidden: friction is best held out, the sensor lag fits better and also
    gains on held-out data; friction is named and the lag is the next round's."""
    held = HeldOut()
    ref = candidate(held, "nominal refit", 0.0, smooth(0, 32.0))
    friction = candidate(held, "coulomb_friction", -590.0, smooth(1, 17.9))
    lag = candidate(held, "sensor_lag", -1104.0, smooth(2, 27.7))
    r = judge(held, ref, [friction, lag])
    assert r.verdict == "effect" and r.effect == "coulomb_friction"


@pytest.mark.parametrize(("other_bic", "named"), [(-300.0, True), (-20.0, False)])
def test_an_unexplained_rounds_candidate_of_evidence_is_refitted_in_its_other_forms(monkeypatch, other_bic, named):
    """Grid seed 7 case 10 (an asymmetric latent heat hidden, position only at 100 Hz): the
    default-form latent heat fitted better by ΔBIC -44 and held out 20 % better, but not
    consistently over the blocks, so the round ended "unexplained" at 15.6x the noise. The
    candidates with evidence are refitted in their other forms; a form the fitted data
    prefer (lower BIC) replaces the default one and the round is judged again (the
    asymmetric form held out 0.87x). A form that fits worse changes nothing, and a
    candidate without evidence is not refitted."""
    held = HeldOut()
    base = fitting.NOMINAL[:1]
    n_eff = 100.0

    def made(name: str, form: str | None, bic: float, residuals: np.ndarray) -> Candidate:
        params = base + (fitting.effect_parameters(name, form) if form else ())
        held.residuals[params] = residuals
        fit = SimpleNamespace(name=name, parameters=params, values=np.zeros(len(params)), values_by_name=lambda: {})
        return Candidate(name, fit, bic, float(math.sqrt(np.mean(residuals**2))))

    ref_res = smooth(0, 15.6, 50)
    ref = made("nominal refit", None, 0.0, ref_res)
    # Better in two of the eight held-out blocks only, as good elsewhere: not support.
    lh_res = smooth(1, 15.6, 50)
    lh_res[: N // 4] *= 0.4
    latent = made("latent_heat", "default", -44.0, lh_res)
    lag = made("sensor_lag", "default", 2.7, smooth(2, 15.6, 50))
    first = workflow._judge(ref, [latent, lag], [ref], 220.0, 0.10, False, held)
    assert first.verdict == "unexplained"

    calls = []

    class Problem:
        def fit(self, name, params, warm=None, sweep_effect=None, **kwargs):
            calls.append((name, params[-1].form))
            held.residuals[params] = smooth(3, 0.87, 50)
            return SimpleNamespace(
                name=name,
                parameters=params,
                values=np.zeros(len(params)),
                cost=100.0 * math.exp(other_bic / n_eff),
                n=100,
                k=0,
                values_by_name=lambda: {},
            )

    monkeypatch.setattr(workflow, "_inert", lambda fit, problem: False)
    others = workflow._other_forms([ref, latent, lag], base, Problem(), held, n_eff, 0.10, lambda m: None)
    assert calls == [("latent_heat", "asymmetric")]
    assert set(others) == ({"latent_heat"} if named else set())
    again = workflow._judge(ref, [others.get(c.name, c) for c in (latent, lag)], [ref], 220.0, 0.10, False, held)
    if named:
        assert again.verdict == "effect" and again.effect == "latent_heat"
        assert workflow._form_of(again.chosen) == "asymmetric"
    else:
        assert again.verdict == "unexplained"


def unexplained_round_with_two_hidden(held: HeldOut):
    """Round 1 of a Coulomb friction and a pulse settling hidden together (the measured
    figures: ΔBIC and held-out normalised RMS): five candidates fit the fitted data better
    than the refit and every one predicts the held-out data worse."""
    ref = candidate(held, "nominal refit", 0.0, smooth(0, 13.1, 50))
    singles = [
        candidate(held, "coulomb_friction", -254.0, smooth(1, 31.1, 50)),
        candidate(held, "sensor_lag", -108.0, smooth(2, 28.7, 50)),
        candidate(held, "convection_change", -62.0, smooth(3, 15.4, 50)),
        candidate(held, "abbe_offset", -61.0, smooth(4, 18.6, 50)),
        candidate(held, "pulse_settling", -50.0, smooth(5, 34.8, 50)),
        candidate(held, "latent_heat", 1.0, smooth(6, 13.5, 50)),
        candidate(held, "transformation_spread", 4.9, smooth(0, 13.1, 50), inert=True),
    ]
    return ref, judge(held, ref, singles)


def test_effects_that_each_fit_better_and_predict_worse_are_tried_in_pairs():
    """Neither effect is supported alone, so the round is unexplained; its pairs include
    the two hidden ones (the best by BIC with every candidate past the bar). What has no
    evidence (latent heat: no BIC gain, no held-out gain) is paired with the best by BIC
    only, after every pair of evidence; an inert one never."""
    held = HeldOut()
    _, r = unexplained_round_with_two_hidden(held)
    assert r.verdict == "unexplained"
    pairs = workflow._pairs_to_try(r, 0.10, electrical=True)
    assert ("coulomb_friction", "pulse_settling") in pairs
    assert len(pairs) <= workflow.MAX_JOINT_PAIRS and len(set(pairs)) == len(pairs)
    assert [p for p in pairs if "latent_heat" in p] == [("coulomb_friction", "latent_heat")] == pairs[-1:]
    assert not any("transformation_spread" in p for p in pairs)
    # A clear verdict tries nothing; nor does an unexplained round with one candidate of evidence.
    ref = candidate(held, "nominal refit", 0.0, smooth(0, 20.0))
    named = judge(held, ref, [candidate(held, "sensor_lag", -40.0, smooth(7, 5.0))])
    assert named.verdict == "effect" and workflow._pairs_to_try(named, 0.10, True) == []
    lone = judge(held, ref, [candidate(held, "sensor_lag", -40.0, smooth(8, 25.0))])
    assert lone.verdict == "unexplained" and workflow._pairs_to_try(lone, 0.10, True) == []


def test_an_unexplained_rounds_best_is_paired_with_an_effect_its_residual_buries():
    """An Abbe offset and a pulse settling hidden at once (two-effect benchmark, seed 67,
    case 9, chirp fitted, sine held out; figures rounded): the offset fits far better
    (ΔBIC -746) but is only 6 % better held out; the settling, fitted alone under the
    offset's residual, shows nothing (ΔBIC +5.4, 0.4 % better held out), so it has no
    evidence. The round is unexplained and ends the diagnosis; the pair that holds the
    truth (its own model held out at the noise, the refit 7.8x) must be among its pairs."""
    held = HeldOut()
    refit = smooth(0, 7.82, 50)
    ref = candidate(held, "nominal refit", 0.0, refit)
    r = judge(
        held,
        ref,
        [
            candidate(held, "abbe_offset", -746.3, smooth(1, 7.35, 50)),
            candidate(held, "warm_surroundings", -29.8, smooth(2, 7.25, 50)),
            candidate(held, "latent_heat", -43.5, smooth(3, 8.39, 50)),
            candidate(held, "pulse_settling", 5.39, refit * 7.79 / 7.82),
            candidate(held, "convection_change", 0.26, refit * 7.79 / 7.82),
            candidate(held, "sensor_lag", 6.14, refit, inert=True),
        ],
    )
    assert r.verdict == "unexplained"
    pairs = workflow._pairs_to_try(r, 0.10, electrical=True)
    assert ("abbe_offset", "pulse_settling") in pairs and ("abbe_offset", "convection_change") in pairs
    assert not any("sensor_lag" in p for p in pairs)
    # Only the best by BIC takes partners without evidence.
    assert not any(set(p) == {"warm_surroundings", "pulse_settling"} for p in pairs)
    assert len(pairs) <= workflow.MAX_JOINT_PAIRS and len(set(pairs)) == len(pairs)


def test_an_ambiguous_rounds_best_is_paired_with_every_candidate_of_evidence_not_only_its_rivals():
    """A sensor lag and an Abbe offset hidden at once (two-effect benchmark, seed 2, case 2,
    figures rounded): the offset is best held out, a convection change its rival; the lag
    fits far better (ΔBIC -60) but gains nothing held out alone, so it is no rival. The
    pair that holds the truth is the best with the lag, which the rivals' pairs miss."""
    held = HeldOut()
    refit = smooth(0, 8.8, 50)
    ref = candidate(held, "nominal refit", 0.0, refit)
    offset = refit * 7.6 / 8.8  # better than the refit everywhere
    r = judge(
        held,
        ref,
        [
            candidate(held, "abbe_offset", -86.8, offset),
            candidate(held, "convection_change", -25.8, smooth(2, 7.35, 50)),
            candidate(held, "sensor_lag", -59.7, offset * 8.7 / 7.6),  # worse than the offset everywhere
            candidate(held, "latent_heat", -3.2, smooth(4, 9.4, 50)),
            candidate(held, "pulse_settling", 6.9, refit, inert=True),
        ],
    )
    assert r.verdict == "ambiguous" and "sensor_lag" not in r.effect
    pairs = workflow._pairs_to_try(r, 0.10, electrical=True)
    assert (r.effect[0], "sensor_lag") in pairs
    assert tuple(r.effect[:2]) in pairs  # the rivals' pair is still tried
    # No evidence of either kind, no pair: the latent heat (ΔBIC -3, worse held out), the inert one.
    assert not any("latent_heat" in p or "pulse_settling" in p for p in pairs)
    assert len(pairs) <= workflow.MAX_JOINT_PAIRS and len(set(pairs)) == len(pairs)


def test_an_ambiguous_rounds_best_is_paired_with_every_rival_not_only_the_first_three():
    """Two-effect benchmark, seed 131, case 7 (a convection change with a Coulomb friction
    hidden, figures rounded): the convection change is best held out, and the friction,
    ΔBIC +1.3 and 1 % better than the refit held out alone, is one of its rivals, fourth by
    held-out score behind wider minor loops and a uniform spread (look-alikes). The pairs of
    the first three names miss it; the best is paired with every rival."""
    held = HeldOut()
    refit = smooth(0, 27.1, 400)
    ref = candidate(held, "nominal refit", 0.0, refit)
    best = smooth(1, 16.6, 400)

    def rival(factor: float) -> np.ndarray:
        """Worse than the best in a quarter of the held-out data only: no consistent preference."""
        out = best * 0.9
        out[: N // 4] = best[: N // 4] * factor
        return out

    r = judge(
        held,
        ref,
        [
            candidate(held, "convection_change", -81.3, best),
            candidate(held, "minor_loop_width", -6.0, rival(2.3)),
            candidate(held, "transformation_spread", -52.3, rival(2.4)),
            candidate(held, "coulomb_friction", 1.3, rival(2.5)),
            candidate(held, "supply_sag", 4.5, refit, inert=True),
        ],
    )
    assert r.verdict == "ambiguous" and r.effect[0] == "convection_change"
    assert r.effect.index("coulomb_friction") >= workflow.JOINT_RIVALS
    pairs = workflow._pairs_to_try(r, 0.10, electrical=True)
    assert ("convection_change", "coulomb_friction") in pairs
    assert not any("supply_sag" in p for p in pairs)
    assert len(pairs) <= workflow.MAX_JOINT_PAIRS and len(set(pairs)) == len(pairs)


@pytest.mark.parametrize(("joint_rms", "named"), [(3.0, True), (14.0, False)])
def test_a_pair_is_named_only_when_it_predicts_better_than_the_refit(joint_rms, named):
    """The pair of an unexplained round must beat the refit as a single effect must (here
    it fits far better than either member; held out at 3 against the refit's 13.1 it is
    named, at 14 it is not, although it still beats both of its members)."""
    held = HeldOut()
    ref, r = unexplained_round_with_two_hidden(held)
    held.residuals["coulomb_friction + pulse_settling"] = smooth(9, joint_rms, 50)

    def fit(name, params, warm=None, **kwargs):
        return SimpleNamespace(
            name=name, parameters=name, values=np.zeros(1), cost=1.0, n=1000, k=12, values_by_name=lambda: {}
        )

    problem = SimpleNamespace(fit=fit)
    out = workflow._joint(
        r, [("coulomb_friction", "pulse_settling")], [ref], (), problem, held, 1000.0, 0.10, lambda m: None
    )
    joint = next(c for c in r.candidates if c.name == "coulomb_friction + pulse_settling")
    if named:
        assert out is not None and out.verdict == "effects"
        assert out.effect == ["coulomb_friction", "pulse_settling"]
        assert joint.why_not == ""
    else:
        assert out is None
        # The report says which bar the pair failed (it showed an empty cell).
        assert joint.why_not == "pair: held out not 10% better than each member and the reference"


@pytest.mark.parametrize(
    ("form_bic", "form_rms", "moves"),
    [
        (-1100.0, 1.6, True),  # what the data ask for (a delayed pulse settling)
        (-165.0, 4.5, True),  # 10 % better held out, unsteadily: still the better form
        (-165.0, 5.2, False),  # fits better, predicts worse
        (-5.0, 4.5, False),  # predicts better, but the fitted data hardly prefer it
        (-1100.0, 150.0, False),  # worse than the model as given
    ],
)
def test_an_effect_found_moves_to_the_form_that_fits_and_predicts_better(form_bic, form_rms, moves):
    """Round 2 after a pulse settling found in its default form (held out at 5.0x the
    noise). Its form is a parameter of an effect already found: it moves to the other form
    when that form is better by the BIC bar on the fitted data and better held out than the
    current form and the model as given, with no gain bar and no block test (which kept a
    latent heat in its worse form and hid the second hidden effect behind the difference)."""
    held = HeldOut()
    ref = candidate(held, "nominal refit", 0.0, smooth(0, 5.0, 50))
    other = candidate(held, "pulse_settling (delayed)", form_bic, smooth(1, form_rms, 50))
    out = workflow._better_form(ref, [({"pulse_settling": "delayed"}, other)], 143.0)
    assert (out is not None) == moves
    if moves:
        assert out[0] == {"pulse_settling": "delayed"}


@pytest.mark.parametrize("together", [True, False])
def test_two_effects_found_in_the_wrong_forms_move_to_their_other_forms_together(together):
    """Two-effect benchmark, seed 131, case 2 (a uniform spread with a power-law convection
    change hidden, steps fitted, chirp held out): rounds 1 and 2 named the convection change
    and the spread in their default forms, and round 3's reference held out 4.36x the noise
    where the truth's own model reaches 1.01x. Each effect moved alone to its other form
    fits better but predicts worse (the other's wrong form pulls the nominal parameters
    away); both moved together fit best and predict at the noise. The effects found are
    therefore also moved together, from each single move's end, and the round is fitted on
    top of the forms that win (figures illustrative). With one effect found there is
    nothing to combine."""
    held = HeldOut()
    found = ["convection_change", "transformation_spread"] if together else ["transformation_spread"]
    base = fitting.NOMINAL[:1] + tuple(p for e in found for p in fitting.effect_parameters(e))
    power = (("convection_change", "power"), ("transformation_spread", "default"))
    uniform = (("convection_change", "default"), ("transformation_spread", "uniform"))
    both = (("convection_change", "power"), ("transformation_spread", "uniform"))
    if not together:
        uniform = (("transformation_spread", "uniform"),)
    problem = FormProblem(
        held,
        costs={power: 900.0, uniform: 800.0, both: 300.0},
        held_rms={power: 5.0, uniform: 4.8, both: 1.0},
        default_cost=1000.0,
        default_rms=4.36,
    )
    n_eff = 1000.0
    ref = workflow._candidate(problem.fit("nominal refit", base), held, n_eff)
    problem.calls.clear()
    problem.starts.clear()
    refs = workflow._form_references(found, {}, problem, held, base, ref, n_eff, lambda m: None)
    if not together:
        assert [c for c, _ in refs] == [{"transformation_spread": "uniform"}] and len(problem.calls) == 1
        return
    assert [c for c, _ in refs] == [
        {"convection_change": "power"},
        {"transformation_spread": "uniform"},
        {"convection_change": "power", "transformation_spread": "uniform"},
    ]
    # Alone, neither move is taken: each fits better but predicts worse than the current forms.
    assert workflow._better_form(ref, refs[:2], 10.0) is None
    out = workflow._better_form(ref, refs, 10.0)
    assert out is not None and out[0] == {"convection_change": "power", "transformation_spread": "uniform"}
    # The combination also starts from where each single move ended.
    assert len(problem.starts[-1][2]) == 2


@pytest.mark.parametrize(("lag_pair_cost", "named"), [(475.0, ["coulomb_friction", "sensor_lag"]), (497.5, None)])
def test_pairs_the_heldout_data_cannot_tell_apart_are_named_only_when_the_fitted_data_can(lag_pair_cost, named):
    """Two pairs both beat their members and the refit, and predict the held-out data
    equally well (3.00 and 3.01, smooth errors). The held-out data cannot choose, so the
    fitted data must, by the BIC bar: at a cost 5 % lower (ΔBIC -51) the better-fitting pair
    is named although it predicts 0.3 % worse; at 0.5 % lower (ΔBIC -5) no pair is."""
    held = HeldOut()
    ref, r = unexplained_round_with_two_hidden(held)
    held.residuals["coulomb_friction + pulse_settling"] = smooth(9, 3.0, 50)
    held.residuals["coulomb_friction + sensor_lag"] = smooth(10, 3.01, 50)
    costs = {"coulomb_friction + pulse_settling": 500.0, "coulomb_friction + sensor_lag": lag_pair_cost}

    def fit(name, params, warm=None, **kwargs):
        return SimpleNamespace(
            name=name, parameters=name, values=np.zeros(1), cost=costs[name], n=1000, k=12, values_by_name=lambda: {}
        )

    problem = SimpleNamespace(fit=fit)
    pairs = [("coulomb_friction", "pulse_settling"), ("coulomb_friction", "sensor_lag")]
    out = workflow._joint(r, pairs, [ref], (), problem, held, 1000.0, 0.10, lambda m: None)
    assert all(c.supported for c in r.candidates if " + " in c.name)
    if named is None:
        assert out is None
    else:
        assert out is not None and out.verdict == "effects" and out.effect == named


class FormProblem:
    """A stand-in for the fitted ``fitting.Problem`` whose fits cost what ``costs`` gives the
    effects' forms (a tuple of (effect, form) of the fitted parameters), held out as
    ``held_rms`` gives them; every call is recorded."""

    def __init__(self, held: HeldOut, costs: dict, held_rms: dict, default_cost: float, default_rms: float):
        self.held, self.costs, self.held_rms = held, costs, held_rms
        self.default_cost, self.default_rms = default_cost, default_rms
        self.calls: list[tuple] = []
        self.starts: list[tuple] = []  # (forms, warm, also_from) of every call

    def fit(self, name, params, warm=None, sweep_effect=None, also_from=(), **kwargs):
        forms = tuple(sorted({(p.effect, p.form) for p in params if p.kind == "effect"}))
        self.calls.append((name, forms))
        self.starts.append((forms, warm, list(also_from)))
        self.held.residuals[params] = smooth(len(self.calls), self.held_rms.get(forms, self.default_rms), 50)
        return SimpleNamespace(
            name=name,
            parameters=params,
            values=np.zeros(len(params)),
            cost=self.costs.get(forms, self.default_cost),
            n=1000,
            k=len(params),
            values_by_name=lambda: {},
        )


def made_candidate(held: HeldOut, name: str, params: tuple, bic: float, rms: float, seed: int) -> Candidate:
    """A candidate fitted with real parameters (their forms are read off them)."""
    held.residuals[params] = smooth(seed, rms, 50)
    fit = SimpleNamespace(name=name, parameters=params, values=np.zeros(len(params)), values_by_name=lambda: {})
    return Candidate(name, fit, bic, rms)


@pytest.mark.parametrize("hidden_forms_fit", [True, False])
def test_a_pair_is_fitted_in_its_other_forms_and_named_in_the_forms_the_fitted_data_choose(hidden_forms_fit):
    """Two-effect benchmark, seed 53, case 1 (a uniform spread with wider minor loops in
    their mean form, ramps fitted, figures rounded): the round is ambiguous between the
    spread (12.1x the noise held out) and the width; their pair in the default forms fits
    far better than either (ΔBIC -152) but holds out 10.9x, short of the gain bar against
    the spread, and no pair was named. In the hidden forms the pair fits at the noise and
    holds out 1.0x: it is named, in those forms. When no other combination fits better
    (the fitted data choose the forms), the default-form pair stands and is not named."""
    held = HeldOut()
    base = fitting.NOMINAL[:1]
    spread_p = base + fitting.effect_parameters("transformation_spread")
    width_p = base + fitting.effect_parameters("minor_loop_width")
    ref = made_candidate(held, "nominal refit", base, 0.0, 14.2, 0)
    spread = made_candidate(held, "transformation_spread", spread_p, -20.5, 12.1, 1)
    width = made_candidate(held, "minor_loop_width", width_p, -120.9, 18.6, 2)
    offset = made_candidate(held, "abbe_offset", base + fitting.effect_parameters("abbe_offset"), -49.4, 14.2, 3)
    r = workflow._Round(
        "ambiguous",
        ["transformation_spread", "minor_loop_width"],
        ref,
        spread,
        [ref, spread, width, offset],
        None,
        20.0,
    )
    n_eff = 1000.0
    # The refit's cost, and the pair's in the default forms: ΔBIC about -150 against the width.
    refit_cost = 1000.0
    width_cost = refit_cost * math.exp((-120.9 - 1.0 * math.log(n_eff)) / n_eff)
    default_pair_cost = width_cost * math.exp(-152.0 / n_eff)
    hidden = (("minor_loop_width", "mean"), ("transformation_spread", "uniform"))
    problem = FormProblem(
        held,
        costs={
            hidden: default_pair_cost * (0.5 if hidden_forms_fit else 1.2),
            # The spread with the Abbe offset fits as the spread alone does.
            (("abbe_offset", "default"), ("transformation_spread", "default")): refit_cost * math.exp(-20.5 / n_eff),
        },
        held_rms={hidden: 1.0},
        default_cost=default_pair_cost,
        default_rms=10.9,
    )
    pairs = [("transformation_spread", "minor_loop_width"), ("transformation_spread", "abbe_offset")]
    out = workflow._joint(r, pairs, [ref], base, problem, held, n_eff, 0.10, lambda m: None)
    refitted = [
        c
        for c in problem.calls
        if c[1]
        not in (
            (("minor_loop_width", "default"), ("transformation_spread", "default")),
            (("abbe_offset", "default"), ("transformation_spread", "default")),
        )
    ]
    # The spread and the width in the three other combinations of their forms; the pair with
    # the Abbe offset fits no better than the spread alone (no evidence), so it is not refitted.
    assert len(refitted) == 3 and all("abbe_offset" not in dict(c[1]) for c in refitted)
    if hidden_forms_fit:
        assert out is not None and out.verdict == "effects"
        assert out.effect == ["transformation_spread", "minor_loop_width"]
        assert workflow._form_of(out.chosen) == "uniform + mean"
    else:
        assert out is None


def rivals_round(held: HeldOut, width_values: dict | None = None, settling_values: dict | None = None):
    """Two-effect benchmark, seed 89, case 5 (wider minor loops in their mean form with a
    delayed pulse settling hidden; figures rounded): round 1 ambiguous between the loops in
    their default form and the settling, whose default-form pair fits better than the loops
    alone by ΔBIC +5.7 only: no evidence for the pair in those forms."""
    base = fitting.NOMINAL[:1]
    width_p = base + fitting.effect_parameters("minor_loop_width")
    settling_p = base + fitting.effect_parameters("pulse_settling")
    offset_p = base + fitting.effect_parameters("abbe_offset")
    ref = made_candidate(held, "nominal refit", base, 0.0, 25.0, 0)
    width = made_candidate(held, "minor_loop_width", width_p, -400.0, 17.6, 1)
    settling = made_candidate(held, "pulse_settling", settling_p, -150.0, 18.1, 2)
    offset = made_candidate(held, "abbe_offset", offset_p, -60.0, 22.0, 3)
    width.fit.values_by_name = lambda: dict(width_values or {})
    settling.fit.values_by_name = lambda: dict(settling_values or {})
    r = workflow._Round(
        "ambiguous", ["minor_loop_width", "pulse_settling"], ref, width, [ref, width, settling, offset], None, 40.0
    )
    return ref, r


def rivals_problem(held: HeldOut, n_eff: float, hidden_fit: float) -> FormProblem:
    """Fits whose cost is the loops' but for the pair in the hidden forms (``hidden_fit``
    times the default-form pair's cost), held out at the noise there."""
    width_cost = 1000.0 * math.exp((-400.0 - 1.0 * math.log(n_eff)) / n_eff)
    default_pair_cost = width_cost * math.exp((5.7 + 1.0 * math.log(n_eff)) / n_eff)
    hidden = (("minor_loop_width", "mean"), ("pulse_settling", "delay"))
    return FormProblem(
        held,
        costs={hidden: default_pair_cost * hidden_fit},
        held_rms={hidden: 1.0},
        default_cost=default_pair_cost,
        default_rms=17.5,
    )


@pytest.mark.parametrize("hidden_forms_fit", [True, False])
def test_an_ambiguous_rounds_rivals_pair_is_fitted_in_its_other_forms_without_evidence(hidden_forms_fit):
    """The rivals' pair in its members' default forms fits no better than the loops alone
    (ΔBIC +5.7): it has no evidence, so its other forms were never tried, and the
    diagnosis ended ambiguous at 17.6x the noise where the truth's own model reaches 1.00x.
    An ambiguous round ends the rounds, so its first two rivals' pair is fitted in every
    other combination of forms anyway: named in the hidden forms when those fit better.
    A pair of other candidates without evidence is not refitted."""
    held = HeldOut()
    ref, r = rivals_round(held)
    n_eff = 1000.0
    problem = rivals_problem(held, n_eff, 0.5 if hidden_forms_fit else 1.2)
    pairs = [("minor_loop_width", "pulse_settling"), ("minor_loop_width", "abbe_offset")]
    out = workflow._joint(r, pairs, [ref], fitting.NOMINAL[:1], problem, held, n_eff, 0.10, lambda m: None)
    refitted = [c for c in problem.calls if any(form != "default" for _, form in c[1])]
    assert len(refitted) == 3 and all(c[0] == "minor_loop_width + pulse_settling" for c in refitted)
    if hidden_forms_fit:
        assert out is not None and out.verdict == "effects"
        assert workflow._form_of(out.chosen) == "mean + delay"
    else:
        assert out is None


@pytest.mark.parametrize("verdict", ["ambiguous", "unexplained"])
def test_a_pairs_other_forms_start_from_each_members_own_fit_only_for_an_ambiguous_rounds_rivals(verdict):
    """Seed 89, case 7 (a second-order sensor lag with a delayed settling): the pair in the
    hidden forms, started where the default-form pair ended, stopped with the delay at
    zero (29.9x the noise); from the lag's own fit it reached 1.00x. An ambiguous round's
    rivals' pair therefore also starts its other combinations of forms from each member's
    own fit: the nominal parameters where that member left them, each effect where its own
    fit did. Any other pair with evidence does not: on the real bench those starts added
    27 % to the simulated columns (round 2's pairs, which end unexplained either way) and
    changed nothing, and case 7 names both at 1.00x without them."""
    held = HeldOut()
    width = {"convection_scale": 1.3, "minor_loop_width.min_width_share": 0.7}
    settling = {"convection_scale": 0.8, "pulse_settling.rise_time_constant_s": 2e-5}
    ref, r = rivals_round(held, width, settling)
    problem = rivals_problem(held, 1000.0, 0.5)
    if verdict == "unexplained":
        # The same pair, with evidence (fitting far better than either member) so that its
        # other forms are tried, in a round with no rivals.
        r = replace(r, verdict="unexplained", effect=None)
        problem.default_cost *= 0.5
    workflow._joint(
        r,
        [("minor_loop_width", "pulse_settling")],
        [ref],
        fitting.NOMINAL[:1],
        problem,
        held,
        1000.0,
        0.10,
        lambda m: None,
    )
    others = [also for forms, _, also in problem.starts if any(form != "default" for _, form in forms)]
    both = {"minor_loop_width.min_width_share": 0.7, "pulse_settling.rise_time_constant_s": 2e-5}
    assert len(others) == 3
    members = [{**both, "convection_scale": 1.3}, {**both, "convection_scale": 0.8}]
    for also in others:
        assert also == (members if verdict == "ambiguous" else [])


def test_an_ambiguous_rounds_rivals_are_refitted_in_their_other_forms(monkeypatch):
    """Seed 89, case 12: a round ambiguous between wider minor loops in their default form
    (13.9x the noise held out) and an Abbe offset; the loops were hidden in their mean form.
    As an unexplained round's, an ambiguous round's candidates with evidence are refitted in
    their other forms, and the round is judged again: the loops, in the mean form, fit
    better and hold out at the noise, and are named alone."""
    held = HeldOut()
    costs = {
        (): 1000.0,
        (("minor_loop_width", "default"),): 800.0,
        (("minor_loop_width", "mean"),): 100.0,
        (("abbe_offset", "default"),): 810.0,
        (("abbe_offset", "wear"),): 805.0,
    }
    rms = {(): 20.0, (("minor_loop_width", "mean"),): 1.0, (("abbe_offset", "wear"),): 14.0}
    problem = FormProblem(held, costs, rms, default_cost=1000.0, default_rms=13.9)

    class Problem:
        electrical = True

        def __init__(self, *args, **kwargs):
            pass

        def nominal_parameters(self):
            return fitting.NOMINAL[:1]

        def fit(self, name, params, **kwargs):
            fit = problem.fit(name, params, **kwargs)
            fit.correlation_time_samples, fit.model, fit.offset = 1.0, None, 0.0
            return fit

        def residual_matrix(self, parameters, points):
            if parameters not in held.residuals:  # the model as given: the refit's parameters
                problem.fit("as given", parameters)
            return held.residual_matrix(parameters, points)

    monkeypatch.setattr(workflow.fitting, "Problem", Problem)
    monkeypatch.setattr(workflow, "_inert", lambda fit, problem: False)
    r = workflow._round(
        ModelConfig(), [], {}, ["minor_loop_width", "abbe_offset"], {}, None, [], [], 1e-3, 0.10, lambda m: None
    )
    assert r.verdict == "effect" and r.effect == "minor_loop_width"
    assert workflow._form_of(r.chosen) == "mean"
    assert [c.name for c in r.replaced] == ["minor_loop_width", "abbe_offset"]


@pytest.mark.parametrize(
    ("again", "effect_again", "verdict", "ref_rms"),
    [
        ((100.0, 1.0), (90.0, 0.99), "none", 1.0),  # the better reference is at the noise
        ((500.0, 4.0), (480.0, 3.9), "unexplained", 4.0),  # the effect gains little on it
        ((500.0, 4.0), (300.0, 1.5), "effect", 4.0),  # the effect still gains on it: named
        ((1000.0, 6.0), None, "effect", 6.0),  # no better optimum: named as before
        ((500.0, 7.0), None, "effect", 6.0),  # fits better but predicts worse: no better reference
    ],
)
def test_an_effect_is_named_only_if_the_reference_from_its_optimum_does_not_fit_as_well(
    monkeypatch, again, effect_again, verdict, ref_rms
):
    """Grid seed 83, case 12 (a 1.5x Abbe offset in its wear form, position only): round 2
    named a warm surroundings with a latent heat on top of the offset's wear form (6.28x
    the noise held out), at 1.10x. The offset alone, refitted from where the pair left the
    nominal parameters, fits to 1.16x the noise and holds out at 1.03x: the pair's gain was
    a better optimum of the nominal parameters that the reference's local fit had missed.
    Before a round names its winner, the reference is refitted from the winner's optimum
    (without the winner's effect); where that fits better by the BIC bar and predicts no
    worse, the round is judged again from it, once, every candidate refitted from there:
    ``none`` or ``unexplained`` where the effect gains too little on it, the effect named
    where it still does. Where no better reference is found, the effect is named as before."""
    held = HeldOut()
    base = fitting.NOMINAL[:1]
    held.residuals[base] = smooth(0, 20.0, 50)  # the model as given
    calls = []

    class Problem:
        electrical = True

        def __init__(self, *args, **kwargs):
            pass

        def nominal_parameters(self):
            return base

        def fit(self, name, params, warm=None, **kwargs):
            effect = len(params) > len(base)
            start = (warm or {}).get(base[0].name)
            calls.append((name, effect, start))
            if effect:
                value = 1.3
                cost, rms = effect_again if start == 1.1 and effect_again else (800.0, 3.0)
            else:
                value = 1.1 if start == 1.3 else 1.0  # from the winner's optimum: another one
                cost, rms = again if start == 1.3 else (1000.0, 6.0)
            values = np.array([value] + [0.5] * (len(params) - 1))
            held.residuals[params] = smooth(len(calls), rms, 50)
            return SimpleNamespace(
                name=name,
                parameters=params,
                values=values,
                cost=cost,
                n=1000,
                k=len(params),
                correlation_time_samples=1.0,
                model=None,
                offset=0.0,
                values_by_name=lambda params=params, values=values: {p.name: v for p, v in zip(params, values)},
            )

        def residual_matrix(self, parameters, points):
            return held.residual_matrix(parameters, points)

    monkeypatch.setattr(workflow.fitting, "Problem", Problem)
    monkeypatch.setattr(workflow, "_inert", lambda fit, problem: False)
    r = workflow._round(ModelConfig(), [], {}, ["latent_heat"], {}, None, [], [], 1e-3, 0.10, lambda m: None)
    assert [c for c in calls if not c[1] and c[2] == 1.3] == [("nominal refit", False, 1.3)]  # once
    rejudged = again[0] < 1000.0 and again[1] <= 6.0
    assert r.reference_from == ("latent_heat" if rejudged else None)
    # Refitted from the better reference (an unexplained round then also tries its other form).
    assert (("latent_heat", True, 1.1) in calls) == rejudged
    assert r.verdict == verdict
    assert r.ref.heldout_score == pytest.approx(ref_rms)
    assert r.effect == ("latent_heat" if verdict == "effect" else None)


@pytest.mark.parametrize("switch_fits", [True, False])
def test_a_later_candidate_is_also_fitted_with_the_effect_found_in_its_other_form(monkeypatch, switch_fits):
    """Two-effect benchmark, seed 53, case 11 (a uniform spread with an asymmetric latent
    heat, a sine fitted): round 1 named the latent heat in its default form; round 2's
    spread on top of it held out 9.0x the noise against 12.1x, under the later rounds' 25 %
    bar, in either of its forms, so the round was ``unexplained``. The best candidate by BIC
    is also fitted with the latent heat in its asymmetric form: where that fits better it
    replaces the candidate (held out 1.0x: named, and the latent heat keeps the new form);
    where it does not, nothing changes. Only the best candidate by BIC is fitted so."""
    held = HeldOut()
    base = fitting.NOMINAL[:1] + fitting.effect_parameters("latent_heat")
    ref = made_candidate(held, "nominal refit", base, 0.0, 12.1, 0)
    spread = made_candidate(
        held, "transformation_spread", base + fitting.effect_parameters("transformation_spread"), -349.0, 9.2, 1
    )
    conv = made_candidate(
        held, "convection_change", base + fitting.effect_parameters("convection_change"), -161.0, 9.3, 2
    )
    first = workflow._judge(ref, [spread, conv], [ref], 15.0, 0.25, True, held)
    assert first.verdict == "unexplained"  # 24 % and 23 % better held out: under the bar
    n_eff = 1000.0
    spread_cost = 1000.0 * math.exp(-350.0 / n_eff)
    switched = (("latent_heat", "asymmetric"), ("transformation_spread", "uniform"))
    problem = FormProblem(
        held,
        costs={switched: spread_cost * (0.3 if switch_fits else 2.0)},
        held_rms={switched: 1.0},
        default_cost=spread_cost * 2.0,
        default_rms=9.0,
    )
    monkeypatch.setattr(workflow, "_inert", lambda fit, problem: False)
    others = workflow._other_forms(
        first.candidates, base, problem, held, n_eff, 0.25, lambda m: None, {"latent_heat": "default"}
    )
    with_switch = [c for c in problem.calls if ("latent_heat", "asymmetric") in c[1]]
    # The spread in both its forms with the latent heat switched; the convection change, second by BIC, never.
    assert len(with_switch) == 2 and all(c[0] == "transformation_spread" for c in with_switch)
    if switch_fits:
        chosen = others["transformation_spread"]
        assert workflow._form_of(chosen) == "uniform"
        assert {(p.effect, p.form) for p in chosen.fit.parameters if p.kind == "effect"} == set(switched)
        again = workflow._judge(ref, [chosen, conv], [ref], 15.0, 0.25, True, held)
        assert again.verdict == "effect" and again.effect == "transformation_spread"
    else:
        assert "transformation_spread" not in others


def event_then_rest(seed: int, event_rms: float, rest_rms: float = 0.8, event_share: float = 0.35) -> np.ndarray:
    """A held-out step run: one event (smooth errors over 200 samples), then a long rest
    where the model leaves only noise."""
    n_event = int(event_share * N)
    event = smooth(seed, event_rms, 200)[:n_event]
    rest = np.random.default_rng(seed + 100).normal(size=N - n_event) * rest_rms
    return np.concatenate([event, rest])


def test_samples_both_models_fit_within_the_noise_do_not_dilute_the_heldout_preference():
    """A held-out run with one event and a long rest (the real bench's step runs): the
    effect is 7x better through the event and both models are at the noise at rest. The
    rest's ties are not evidence of an inconsistent preference (before: 5 of 8 blocks were
    noise against noise and the effect was not supported)."""
    held = HeldOut()
    ref = candidate(held, "nominal refit", 0.0, event_then_rest(0, 60.0))
    eff = candidate(held, "transformation_spread", -140.0, event_then_rest(1, 8.0))
    r = judge(held, ref, [eff])
    assert r.verdict == "effect" and r.effect == "transformation_spread"
    # The same event with the two models equally good through it stays unsupported.
    held = HeldOut()
    ref = candidate(held, "nominal refit", 0.0, event_then_rest(0, 60.0))
    eff = candidate(held, "transformation_spread", -140.0, event_then_rest(1, 55.0))
    assert judge(held, ref, [eff]).verdict == "unexplained"


def basin_problem(monkeypatch, distance, effects=()):
    """A ``fitting.Problem`` on a 2 s steps trace whose fitted cost is flat outside a narrow
    basin: every residual is 0.01 + min(``distance``(values by name), 1). ``effects``:
    (effect, form) pairs whose parameters follow the nominal ones. Returns the problem,
    its parameters and their names."""
    trace, _ = generate(SynthSpec(ModelConfig(), excitation="steps", duration_s=2.0, electrical=False, seed=1))
    problem = fitting.Problem(ModelConfig(), [fitting.prepare(trace, 1e-3)], 1e-3)
    params = problem.nominal_parameters() + tuple(p for e, f in effects for p in fitting.effect_parameters(e, f))
    names = [p.name for p in params]

    def residual_matrix(parameters, points):
        return np.array([np.full(50, 0.01 + min(distance(dict(zip(names, point))), 1.0)) for point in points]).T

    monkeypatch.setattr(problem, "residual_matrix", residual_matrix)
    return problem, params, names


def test_the_refit_sweeps_the_convection_scale_with_the_temperature_shift(monkeypatch):
    """A heat loss far from the nominal one leaves the wire where its transformation is
    saturated, and the local fit sees no slope there: here the cost is flat outside a
    basin around a shift of -2 K and a convection scale of 1.6 (measured on a power-law
    convection: the refit from a sweep of the shift alone stayed at a scale of 1.0007 and
    270x the noise). The grid over both parameters starts the fit inside the basin."""
    problem, params, names = basin_problem(
        monkeypatch,
        lambda v: math.hypot((v["temperature_shift_k"] + 2.0) / 4.0, math.log(v["convection_scale"] / 1.6) / 0.25),
    )
    both = dict(zip(names, problem.fit("refit", params, sweep=workflow.REFIT_SWEEP).values))
    assert abs(both["convection_scale"] - 1.6) < 0.05 and abs(both["temperature_shift_k"] + 2.0) < 0.5
    shift_only = dict(zip(names, problem.fit("refit", params, sweep=("temperature_shift_k",)).values))
    assert shift_only["convection_scale"] == pytest.approx(1.0)


def test_a_candidate_on_top_of_an_effect_found_is_swept_over_its_own_range(monkeypatch):
    """From round 2 on, a candidate (or an effect refitted in another form) is fitted on
    top of the effects found before. The sweep over its own parameter's range used to run
    only when it was the one effect parameter of the fit, so on top of an effect it started
    from its off value and half its typical size alone; and a form's fit then swept the
    shift and convection grid from the effect's best point and started only from that
    grid's best, which lies off the nominal values the effect was best at. Measured, a
    Stribeck friction on top of a supply sag: swept to 4.5x the noise on the fitted data,
    the grid's best at 14.2x, the fit ended at 5.9x. Here the cost is flat outside a narrow
    basin at a friction of 1.9 N and a shift of 0.3 K, between the grid's shifts."""
    problem, params, names = basin_problem(
        monkeypatch,
        lambda v: math.hypot((v["coulomb_friction.force_n"] - 1.9) / 0.3, (v["temperature_shift_k"] - 0.3) / 0.2),
        effects=(("supply_sag", "default"), ("coulomb_friction", "stribeck")),
    )
    warm = {"supply_sag.series_resistance_ohm": 1.0, "temperature_shift_k": 0.3}
    for sweep in ((), workflow.REFIT_SWEEP):
        fit = problem.fit("friction", params, warm=warm, sweep=sweep, sweep_effect="coulomb_friction")
        found = dict(zip(names, fit.values))
        assert found["coulomb_friction.force_n"] == pytest.approx(1.9, abs=0.1)
        assert found["temperature_shift_k"] == pytest.approx(0.3, abs=0.1)
        assert found["supply_sag.series_resistance_ohm"] == pytest.approx(1.0)
    unswept = dict(zip(names, problem.fit("friction", params, warm=warm).values))
    assert abs(unswept["coulomb_friction.force_n"] - 1.9) > 0.5


def test_a_fit_also_starts_from_each_point_it_is_given(monkeypatch):
    """``Problem.fit(also_from=...)``: a basin no start, sweep or grid reaches (a convection
    scale of 0.62 at a shift of 7.3 K) is found from a start given there, by name."""
    problem, params, names = basin_problem(
        monkeypatch,
        lambda v: math.hypot((v["temperature_shift_k"] - 7.3) / 0.2, (v["convection_scale"] - 0.62) / 0.02),
    )
    given = [{"temperature_shift_k": 7.2, "convection_scale": 0.63}, {}]
    found = dict(zip(names, problem.fit("refit", params, also_from=given).values))
    assert found["temperature_shift_k"] == pytest.approx(7.3, abs=0.05) and found["convection_scale"] > 0.6
    missed = dict(zip(names, problem.fit("refit", params).values))
    assert abs(missed["temperature_shift_k"] - 7.3) > 1.0


def test_an_effect_in_another_form_can_be_swept_from_its_off_value():
    """From round 2 on an effect found is refitted in its other forms, from a sweep over
    its range that starts at the off value: on a wire without a nominal spread (the real
    bench's datasheet model) the uniform spread at 0 K divided by zero."""
    model = ModelConfig(preset("bench-0.5mm-ht-datasheet"))
    trace, _ = generate(SynthSpec(model, excitation="steps", duration_s=5.0, electrical=False, seed=1))
    problem = fitting.Problem(model, [fitting.prepare(trace, 1e-3)], 1e-3)
    params = problem.nominal_parameters() + fitting.effect_parameters("transformation_spread", "uniform")
    points = [np.array([p.start for p in params[:-1]] + [v]) for v in (0.0, 6.0)]
    res = problem.residual_matrix(params, points)
    assert np.isfinite(res).all() and not np.array_equal(res[:, 0], res[:, 1])


def test_cross_validation_never_shows_the_left_out_run_to_the_diagnosis(monkeypatch):
    """Leave one run out: the model that predicts a run is chosen without it (it was the
    diagnosis's held-out data, whose gains and block test decided what the model carried)."""
    traces = [
        generate(SynthSpec(ModelConfig(), excitation=kind, duration_s=3.0, electrical=False, seed=k))[0]
        for k, kind in enumerate(("steps", "sine", "ramps"))
    ]
    seen = []

    def fake_diagnose(fit, held, nominal, *args, **kwargs):
        seen.append(([id(t) for t in fit], list(held)))
        # The second fold's last round was ambiguous: its model carries a candidate it does not name.
        carried = "sensor_lag" if len(seen) == 2 else None
        return SimpleNamespace(
            verdict="ambiguous" if carried else "none",
            effects_found=[],
            carried=carried,
            parameters={},
            corrected_model=nominal,
            noise={"position": 1e-6},
            whole_file_refit=None,
            explained={},
        )

    monkeypatch.setattr(workflow, "diagnose", fake_diagnose)
    cv = workflow.cross_validate(traces, ModelConfig(), max_rounds=1)
    for k, (fitted, held) in enumerate(seen):
        assert held == [] and id(traces[k]) not in fitted and len(fitted) == 2
    assert all(math.isfinite(f["position_rms_corrected_m"]) for f in cv["folds"])
    # What predicted each run is on record, the carried candidate included.
    assert [f["carried"] for f in cv["folds"]] == [None, "sensor_lag", None]
    rows = [line for line in cross_validation_table(cv).splitlines() if line.startswith("| synthetic |")]
    assert len(rows) == 3 and "| ambiguous | carries sensor_lag |" in rows[1] and "| none | - |" in rows[0]


def test_the_report_names_a_pair_found_together_with_and_an_ambiguous_set_with_or():
    from types import SimpleNamespace

    from sma_gym.diagnosis.report import _round_lines

    def rnd(number, verdict, effect):
        return {
            "round": number,
            "verdict": verdict,
            "effect": effect,
            "nominal_refit_heldout_normalised_rms": 30.0,
            "heldout_normalised_rms": 1.2,
            "gap": {"heldout": {"position": 1e-4}},
            "parameters_at_bounds": [],
        }

    text = "\n".join(
        _round_lines(
            SimpleNamespace(
                rounds=[
                    rnd(1, "effects", ["sensor_lag", "warm_surroundings"]),
                    rnd(2, "ambiguous", ["a", "b"]),
                    {**rnd(3, "none", None), "form_changed": {"sensor_lag": "second_order"}},
                    {
                        **rnd(4, "effect", "transformation_spread"),
                        "removed": [
                            {
                                "effect": "latent_heat",
                                "delta_bic_of_keeping": -5787.4,
                                "heldout_gain_of_keeping": -0.029,
                                "heldout_normalised_rms_without": 1.3,
                                "heldout_normalised_rms_with": 1.34,
                            }
                        ],
                    },
                    {**rnd(5, "effect", "latent_heat"), "named_forms": {"latent_heat": "asymmetric"}},
                ]
            )
        )
    )
    assert "| 1 | effects | sensor_lag and warm_surroundings |" in text
    assert "| 2 | ambiguous | a or b |" in text
    assert "| 3 | none | sensor_lag in its 'second_order' form |" in text
    assert (
        "| 4 | effect | transformation_spread; then latent_heat taken out (with it ΔBIC -5787.4, held out -2.9%" in text
    )
    assert "| 5 | effect | latent_heat (its 'asymmetric' form) |" in text


def test_the_staircase_shows_the_model_as_given_its_refit_and_what_each_round_did(tmp_path, monkeypatch):
    """The gap plot steps through every stage the report's tables list (the nominal refit
    included, which the first version left out), each labelled with what changed, its
    figures in mm, and keeps the last round visible (a step plot ending at it drew none)."""
    from types import SimpleNamespace

    import matplotlib.axes

    from sma_gym.diagnosis import report

    def gap(fit_mm, held_mm):
        return {"fit": {"position": fit_mm * 1e-3}, "heldout": {"position": held_mm * 1e-3}}

    rounds = [
        {"round": 1, "verdict": "effect", "effect": "transformation_spread", "gap": gap(0.5, 0.4)},
        {"round": 2, "verdict": "ambiguous", "effect": ["latent_heat", "coulomb_friction"], "gap": gap(0.3, 0.2)},
    ]
    result = SimpleNamespace(
        gap_before=gap(2.6, 3.0),
        gap_nominal_refit=gap(1.5, 0.8),
        rounds=rounds,
        noise={"position": 1.4e-5},
        carried="latent_heat",
        whole_file_refit=None,  # held-out files given: nothing refitted on the whole files
    )
    drawn = []
    original = matplotlib.axes.Axes.stairs
    monkeypatch.setattr(
        matplotlib.axes.Axes,
        "stairs",
        lambda ax, values, edges, **kw: drawn.append((values, edges)) or original(ax, values, edges, **kw),
    )
    report._plot_rounds(result, tmp_path / "gap_by_round.png")
    assert (tmp_path / "gap_by_round.png").stat().st_size > 0
    assert [list(np.round(v, 6)) for v, _ in drawn] == [[2.6, 1.5, 0.5, 0.3], [3.0, 0.8, 0.4, 0.2]]
    assert all(list(e) == [0, 1, 2, 3, 4] for _, e in drawn)  # one flat step per stage
    labels = [report._round_label(result, r) for r in rounds]
    assert labels == ["round 1\n+ transformation_spread", "round 2\nambiguous,\ncarries latent_heat"]
    # A pruned effect shows on the step of the round whose record holds it.
    pruned = {**rounds[0], "removed": [{"effect": "latent_heat"}]}
    assert report._round_label(result, pruned) == "round 1\n+ transformation_spread\n- latent_heat"
    # Refitted on the whole files (step 9): one more step, its fitted part only.
    drawn.clear()
    refitted = SimpleNamespace(**{**vars(result), "whole_file_refit": {"note": ""}, "gap_after": gap(0.25, 0.1)})
    report._plot_rounds(refitted, tmp_path / "gap_by_round.png")
    assert [list(np.round(v, 6)) for v, _ in drawn][0] == [2.6, 1.5, 0.5, 0.3, 0.25]
    assert np.isnan(drawn[1][0][-1]) and list(np.round(drawn[1][0][:-1], 6)) == [3.0, 0.8, 0.4, 0.2]


@pytest.mark.parametrize(("x_rms", "verdict"), [(20.0, "effect"), (32.0, "partial")])
def test_a_later_ambiguous_round_corrects_the_model_with_its_best_without_naming_it(monkeypatch, x_rms, verdict):
    """Round 1 names X; round 2 is ambiguous between Y (best held out) and Z. Both improve on
    round 2's reference; only which one is open. The corrected model carries X and Y (round
    1's own ambiguity already corrected with its best), the names found stay X, and the file
    and JSON say what it carries. (It kept X alone: on the real bench's fold that predicts
    `ramp01` the spread's 42 % held-out gain was thrown away, 1.13 -> 1.89 mm.) X's share of the
    gap is its own: at 40 -> 32x it closed 20 %, `partial`, however far the carried Y goes (a
    review found X named on Y's gain)."""
    base = ModelConfig()
    with_x = base.with_effect("convection_change", {"scale": 1.2})
    with_xy = with_x.with_effect("transformation_spread", {"spread_k": 4.0})

    rounds = [
        round_of("effect", "convection_change", (base, 40.0), (with_x, x_rms), 50.0),
        round_of(
            "ambiguous",
            ["transformation_spread", "latent_heat"],
            (with_x, x_rms),
            (with_xy, 11.0),
            x_rms,
            "transformation_spread",
        ),
    ]
    result = diagnose_faked(monkeypatch, rounds, ["convection_change", "transformation_spread", "latent_heat"])
    assert result.verdict == verdict and result.effects_found == ["convection_change"]
    assert result.explained["final_heldout_normalised_rms"] == x_rms
    assert result.carried == "transformation_spread" and result.as_dict()["carried"] == "transformation_spread"
    assert {s.name for s in result.corrected_model.effects.active()} == {"convection_change", "transformation_spread"}
    assert "carries transformation_spread" in result.corrected_model.notes


@pytest.mark.parametrize(
    ("reference", "final", "verdict", "as_given"),
    [
        (31.1, 19.1, "partial", 50.0),
        (26.6, 20.4, "partial", 50.0),
        (25.4, 6.42, "effect", 50.0),
        (4.5, 3.0, "effect", 50.0),
        # The better of the model as given and its refit is the reference: 60 -> 19 closes
        # 68 % of the refit's gap but 37 % of the model as given's.
        (30.0, 19.0, "partial", 30.0),
    ],
)
def test_an_effect_that_closes_little_of_a_large_gap_is_carried_but_not_named(
    monkeypatch, tmp_path, capsys, reference, final, verdict, as_given
):
    """Round 1 names X, closing the held-out gap from ``reference`` to ``final`` times the
    noise; round 2 finds nothing more. Closing less than half of it and leaving more than 3x
    the noise, X is carried by the corrected model but not named as found: the verdict is
    `partial`, not `effect`. (Grid seed 61: clean data of the independent generator named
    `latent_heat` for 31.1 -> 19.1x, a minor-loop width named with a warm surroundings for
    26.6 -> 20.4x; every name on our generator closed 75-99 %, the worst 25.4 -> 6.42x.)"""
    base = ModelConfig()
    with_x = base.with_effect("latent_heat", {"change_j_kg": -5000.0})
    refit = 60.0 if as_given < 50.0 else reference
    rounds = [
        round_of("effect", "latent_heat", (base, refit), (with_x, final), as_given),
        round_of("unexplained", None, (with_x, final), (with_x, final), final),
    ]
    result = diagnose_faked(monkeypatch, rounds, ["latent_heat", "convection_change"], max_rounds=2)
    assert result.verdict == verdict and result.effects_found == ["latent_heat"]
    assert result.effect == (["latent_heat"] if verdict == "partial" else "latent_heat")
    assert [s.name for s in result.corrected_model.effects.active()] == ["latent_heat"]
    explained = result.as_dict()["explained"]
    assert explained["gain"] == pytest.approx(1.0 - final / reference)
    # Scores that are not finite decide nothing.
    unknown = {"nominal_refit_heldout_normalised_rms": math.nan, "as_given_heldout_normalised_rms": math.nan}
    nan = workflow._explained([{**result.rounds[0], **unknown}])
    assert math.isnan(nan["gain"]) and not workflow._partial(nan)
    assert explained["final_heldout_normalised_rms"] == final
    if verdict == "partial":
        trace, _ = generate(SynthSpec(ModelConfig(), excitation="steps", duration_s=3.0, electrical=False, seed=0))
        paths = write_outputs(result, tmp_path, [trace], [], ModelConfig())
        text = paths["report"].read_text(encoding="utf-8")
        assert "**Partly explained**: `latent_heat` improves" in text and f"closes {1 - final / reference:.0%}" in text
        assert json.loads(paths["json"].read_text(encoding="utf-8"))["verdict"] == "partial"
        _print_diagnosis(result, paths, as_json=False)
        printed = capsys.readouterr().out
        assert printed.startswith("verdict: partial (latent_heat)\n  partly explained:")


@pytest.mark.parametrize(("refit_rms", "adopted"), [(12.0, True), (25.0, False)])
def test_a_round_that_names_nothing_keeps_its_refit_of_the_effects_found_if_it_predicts_better(
    monkeypatch, refit_rms, adopted
):
    """Round 1 names X (held out 20x the noise); round 2 names nothing, but its refit of the
    nominal parameters with X, started where round 1 ended and swept again, holds out
    ``refit_rms``. Better than 20: the user gets that refit (the same effects), and the
    round's row says so; worse: round 1's model stays. (Grid seed 10 case 20 returned round
    2's model at 6.45x the noise while round 3's refit of the same effects held out 1.59x.)"""
    base = ModelConfig()
    with_x = base.with_effect("convection_change", {"scale": 1.2})
    refitted = base.with_effect("convection_change", {"scale": 1.3})

    rounds = [
        round_of("effect", "convection_change", (base, 40.0), (with_x, 20.0), 50.0),
        round_of("unexplained", None, (refitted, refit_rms), (refitted, refit_rms), 20.0),
    ]
    result = diagnose_faked(monkeypatch, rounds, ["convection_change", "latent_heat"])
    assert result.verdict == "effect" and result.effects_found == ["convection_change"]
    scale = result.corrected_model.effects.active()[0].values["scale"]
    assert scale == (1.3 if adopted else 1.2)
    assert result.rounds[-1]["refit_adopted"] is adopted
    assert result.rounds[-1]["heldout_normalised_rms"] == (refit_rms if adopted else 20.0)
    assert result.as_dict()["rounds"][-1]["refit_adopted"] is adopted


@pytest.mark.parametrize(
    ("refit_rms", "judged"), [(2.0, ["abbe_offset", "convection_change", "latent_heat"]), (9.0, ["abbe_offset"])]
)
def test_after_a_refit_the_last_round_kept_every_effect_found_is_judged_against_the_others(
    monkeypatch, refit_rms, judged
):
    """Round 1 names X, round 2 the pair Y and Z, round 3 nothing. If round 3's refit of the
    three predicts better than round 2's model (held out 6x the noise) and is kept, every one
    of them is refitted out in turn, Y and Z too: they were judged on top of X, never on the
    better refit. Otherwise only X, the earlier round's, as before. (Grid seed 10 case 20:
    an Abbe offset hidden, a convection change and a spread named beside it in round 2.)"""
    base = ModelConfig()
    x = base.with_effect("abbe_offset", {"offset_m": 1e-4})
    xyz = x.with_effect("convection_change", {"scale": 1.2}).with_effect("latent_heat", {"change_j_kg": 1000.0})

    rounds = [
        round_of("effect", "abbe_offset", (base, 40.0), (x, 20.0), 50.0),
        round_of("effects", ["convection_change", "latent_heat"], (x, 20.0), (xyz, 6.0), 20.0),
        round_of("unexplained", None, (xyz, refit_rms), (xyz, refit_rms), 6.0),
    ]
    seen = []

    def pruned(earlier, full, problem, held_problem, say):
        seen.append(list(earlier))
        return None, None, []

    monkeypatch.setattr(workflow, "_pruned", pruned)
    effects = ["abbe_offset", "convection_change", "latent_heat", "transformation_spread"]
    result = diagnose_faked(monkeypatch, rounds, effects, max_rounds=3)
    assert result.effects_found == ["abbe_offset", "convection_change", "latent_heat"]
    assert seen == [judged]


@pytest.mark.parametrize(
    ("second_removal", "left"), [(True, ["latent_heat"]), (False, ["convection_change", "latent_heat"])]
)
def test_pruning_judges_the_rest_again_after_each_removal(monkeypatch, second_removal, left):
    """Rounds 1-3 name X, Y and Z. Pruning takes out X, then judges Y again without it (what
    X explained moved to the others) and takes it out too when it now fails the bars; the
    last effect always stays. Every check and every removal, in order, is in the last
    round's record. (Until 2026-11-29 one removal at most: grid seed 10 case 20 kept a
    spurious convection change beside its Abbe offset once the spread was taken out.)"""
    base = ModelConfig()
    names = ["abbe_offset", "convection_change", "latent_heat"]
    values = {
        "abbe_offset": {"offset_m": 1e-4},
        "convection_change": {"scale": 1.2},
        "latent_heat": {"change_j_kg": 1e3},
    }

    def model(effects):
        m = base
        for e in effects:
            m = m.with_effect(e, values[e])
        return m

    rounds = [
        round_of("effect", names[k], (model(names[:k]), 40.0 - k), (model(names[: k + 1]), 30.0 - k), 50.0)
        for k in range(3)
    ]
    calls = []

    def pruned(earlier, full, problem, held_problem, say):
        calls.append(list(earlier))
        record = {"effect": earlier[0], "removed": False, "heldout_normalised_rms_without": 5.0 + len(calls)}
        if len(calls) == 1 or second_removal:
            record["removed"] = True
            keep = [s.name for s in full.model.effects.active() if s.name != earlier[0]]
            return earlier[0], fit_that_left(model(keep)), [record]
        return None, None, [record]

    monkeypatch.setattr(workflow, "_pruned", pruned)
    result = diagnose_faked(monkeypatch, rounds, names + ["transformation_spread"], max_rounds=3)
    assert calls == [["abbe_offset", "convection_change"], ["convection_change"]]
    assert result.effects_found == left
    assert [s.name for s in result.corrected_model.effects.active()] == left
    last = result.rounds[-1]
    assert [r["effect"] for r in last["pruning"]] == ["abbe_offset", "convection_change"]
    assert [r["effect"] for r in last["removed"]] == names[: 3 - len(left)]
    assert last["heldout_normalised_rms"] == last["removed"][-1]["heldout_normalised_rms_without"]


@pytest.mark.parametrize(
    ("cost_without", "rms_without", "removed"),
    [
        (700.0, 1.95, "latent_heat"),  # fits better with it (ΔBIC -330), predicts worse: seed 2's case 0
        (505.0, 2.20, "latent_heat"),  # predicts 9 % better, but the fitted data hardly need it (ΔBIC -3)
        (500.0, 2.00, "latent_heat"),  # nothing either way
        # Fits better with it, but predicts only 2 % better: the held-out data cannot tell it
        # from its absence (seed 67's case 1: a width standing in for a friction, +2.1 %).
        (700.0, 2.04, "latent_heat"),
        (700.0, 2.20, None),  # both still better with it, 9 % held out: it stays
    ],
)
def test_an_effect_a_later_round_made_redundant_is_taken_out(cost_without, rms_without, removed):
    """Round 1 named warm surroundings with a latent heat, round 2 a spread (seed 2's case 0
    of the two-effect benchmark: the truth is the surroundings with the spread). Each round
    judged its candidates on top of what was found before, never the other way round, so
    the effects of earlier rounds are refitted out one at a time: one stays only while the
    model with it fits better by the BIC bar and predicts the held-out data better by more
    than the margin within which candidates are indistinguishable (5 %)."""
    assert workflow.PRUNE_MARGIN == workflow.AMBIGUITY_MARGIN == 0.05
    base = tuple(p for p in fitting.NOMINAL if p.kind != "offset") + (fitting.RESISTIVITY,)
    effects = {e: fitting.effect_parameters(e) for e in ("warm_surroundings", "latent_heat", "transformation_spread")}
    full_params = base + sum(effects.values(), ())
    held = HeldOut()
    costs = {full_params: 500.0}
    held.residuals[full_params] = smooth(0, 2.0, 50)

    def fitted(params):
        return SimpleNamespace(
            name="fit",
            parameters=params,
            values=np.zeros(len(params)),
            cost=costs[params],
            n=1000,
            k=len(params),
            correlation_time_samples=1.0,
            values_by_name=lambda: {},
            model=None,
            offset=0.0,
        )

    for name in ("warm_surroundings", "latent_heat"):
        without = tuple(p for p in full_params if p.effect != name)
        # Taking out the surroundings always costs much more than the bars.
        costs[without] = cost_without if name == "latent_heat" else 900.0
        held.residuals[without] = smooth(1, rms_without if name == "latent_heat" else 4.0, 50)
    problem = SimpleNamespace(fit=lambda name, params, **options: fitted(params))
    name, fit, records = workflow._pruned(
        ["warm_surroundings", "latent_heat"], fitted(full_params), problem, held, lambda m: None
    )
    # Every check is recorded, whether it removed the effect or not.
    assert [r["effect"] for r in records] == ["warm_surroundings", "latent_heat"]
    assert [r["removed"] for r in records] == [False, removed is not None]
    assert records[1]["heldout_normalised_rms_without"] == pytest.approx(rms_without)
    if removed is None:
        assert name is None and fit is None
    else:
        assert name == removed and all(p.effect != removed for p in fit.parameters)
        gain = records[1]["heldout_gain_of_keeping"]
        bars = records[1]["delta_bic_of_keeping"] > -workflow.BIC_THRESHOLD, gain <= workflow.PRUNE_MARGIN
        assert any(bars)


@pytest.mark.parametrize(
    ("rival_costs", "rival_rms", "swapped"),
    [
        # Fits better in its place (ΔBIC -288) and predicts 40 % better: the case of
        # tests/test_diagnosis.py (a width named for a friction, then the lag).
        ((300.0,), (1.2,), "coulomb_friction"),
        ((300.0,), (1.95,), None),  # fits better, predicts only 2.5 % better: within the margin
        ((498.0,), (1.2,), None),  # predicts better, but the fitted data hardly tell (ΔBIC -4)
        ((700.0,), (1.2,), None),  # predicts better, fits worse: the bars disagree
        ((300.0, 350.0), (1.6, 1.2), "abbe_offset"),  # both pass: the better held out replaces it
    ],
)
def test_an_earlier_effect_is_replaced_by_a_rival_of_its_round_only_when_both_bars_prefer_it(
    rival_costs, rival_rms, swapped
):
    """Round 1 named a minor-loop width over a Coulomb friction and an Abbe offset (all three
    supported: each holds the sleigh after a reversal, the width predicted best alone), round
    2 a sensor lag. With the lag in the model each rival of round 1 is fitted in the width's
    place, and replaces it only when the model with it fits better by the BIC bar *and*
    predicts the held-out data better by more than the margin within which candidates are
    indistinguishable (5 %); of several that do, the best held out."""
    base = tuple(p for p in fitting.NOMINAL if p.kind != "offset") + (fitting.RESISTIVITY,)
    lag = fitting.effect_parameters("sensor_lag")
    full_params = base + fitting.effect_parameters("minor_loop_width") + lag
    rivals = ["coulomb_friction", "abbe_offset"][: len(rival_costs)]
    held = HeldOut()
    costs = {full_params: 500.0}
    held.residuals[full_params] = smooth(0, 2.0, 50)

    def fitted(params, values=None):
        return SimpleNamespace(
            name="fit",
            parameters=params,
            values=np.zeros(len(params)) if values is None else values,
            cost=costs[params],
            n=1000,
            k=len(params),
            correlation_time_samples=1.0,
            values_by_name=lambda: {p.name: 0.0 for p in params},
            model=None,
            offset=0.0,
        )

    starts = []
    for k, (name, cost, rms) in enumerate(zip(rivals, rival_costs, rival_rms, strict=True)):
        params = base + lag + fitting.effect_parameters(name)
        costs[params] = cost
        held.residuals[params] = smooth(1 + k, rms, 50)

    def fit(name, params, **options):
        starts.append(options["warm"])
        return fitted(params)

    for name in rivals:
        costs[base + fitting.effect_parameters(name)] = 600.0
    round_fits = [
        Candidate(name, fitted(base + fitting.effect_parameters(name), np.full(len(base) + 1, 7.0)), 0.0, 1.0)
        for name in rivals
    ]
    problem = SimpleNamespace(fit=fit)
    name, fit_left, records = workflow._swapped(
        "minor_loop_width", round_fits, fitted(full_params), problem, held, lambda m: None
    )
    assert [(r["effect"], r["rival"]) for r in records] == [("minor_loop_width", r) for r in rivals]
    assert [r["swapped"] for r in records] == [r == swapped for r in rivals]
    # Each rival starts from the model and from its own values of round 1.
    own = fitting.effect_parameters(rivals[0])[0].name
    assert starts[0][own] == 7.0 and starts[0][lag[0].name] == 0.0
    if swapped is None:
        assert name is None and fit_left is None
    else:
        assert name == swapped
        assert {p.effect for p in fit_left.parameters if p.kind == "effect"} == {swapped, "sensor_lag"}
        record = next(r for r in records if r["swapped"])
        assert record["delta_bic_of_rival"] < -workflow.BIC_THRESHOLD
        assert record["heldout_gain_of_rival"] > workflow.PRUNE_MARGIN


def test_a_rival_of_a_later_round_is_fitted_with_its_own_parameters_only():
    """A rival of round 2 was fitted on top of round 1's effect: its round fit holds that
    effect's parameters too, which the model it is tried in has already (they were given
    twice). Round 1 found a latent heat, round 2 a minor-loop width with a Coulomb friction
    supported beside it, round 3 a sensor lag: the friction is fitted in the width's place
    with the latent heat and the lag once each."""
    base = tuple(p for p in fitting.NOMINAL if p.kind != "offset") + (fitting.RESISTIVITY,)
    heat, width, lag, friction = (
        fitting.effect_parameters(e) for e in ("latent_heat", "minor_loop_width", "sensor_lag", "coulomb_friction")
    )
    full = SimpleNamespace(
        name="fit",
        parameters=base + heat + width + lag,
        values=np.zeros(len(base) + 3),
        cost=500.0,
        n=1000,
        k=len(base) + 3,
        correlation_time_samples=1.0,
        values_by_name=lambda: {},
        model=None,
        offset=0.0,
    )
    round_fit = SimpleNamespace(parameters=base + heat + friction, values=np.zeros(len(base) + 2))
    fitted = []

    def fit(name, params, **options):
        fitted.append(params)
        return SimpleNamespace(**{**vars(full), "parameters": params, "cost": 600.0, "k": len(params)})

    held = HeldOut()
    held.residuals[full.parameters] = smooth(0, 2.0, 50)
    held.residuals[base + heat + lag + friction] = smooth(1, 2.0, 50)
    workflow._swapped(
        "minor_loop_width",
        [Candidate("coulomb_friction", round_fit, 0.0, 1.0)],
        full,
        SimpleNamespace(fit=fit),
        held,
        lambda m: None,
    )
    assert fitted == [base + heat + lag + friction]


def test_a_rival_that_replaces_an_earlier_effect_is_what_the_diagnosis_names(monkeypatch):
    """Round 1 names a minor-loop width with a Coulomb friction and a sensor lag supported
    beside it (the lag is found later, so it is no rival), round 2 the lag. The width's rival
    replaces it: the verdict, the effects found and the corrected model carry the friction,
    and the last round's record holds the replacement and the model's held-out score."""
    base = ModelConfig()
    width = base.with_effect("minor_loop_width", {"min_width_share": 0.5})
    both = width.with_effect("sensor_lag", {"time_constant_s": 0.05})
    swapped = base.with_effect("coulomb_friction", {"force_n": 0.6}).with_effect(
        "sensor_lag", {"time_constant_s": 0.05}
    )
    first = round_of("effect", "minor_loop_width", (base, 29.0), (width, 10.1), 40.0)
    rival = Candidate("coulomb_friction", fit_that_left(base), 0.0, 15.5, supported=True)
    lag = Candidate("sensor_lag", fit_that_left(base), 0.0, 24.1, supported=True)
    first.candidates = [first.ref, rival, lag, Candidate("latent_heat", fit_that_left(base), 0.0, 28.0)]
    rounds = [first, round_of("effect", "sensor_lag", (width, 10.1), (both, 6.63), 10.1)]
    tried = []

    def swap(name, rivals, full, problem, held_problem, say):
        tried.append((name, [c.name for c in rivals]))
        record = {"effect": name, "rival": rivals[0].name, "swapped": True, "heldout_normalised_rms_with_rival": 2.4}
        return rivals[0].name, fit_that_left(swapped), [record]

    monkeypatch.setattr(workflow, "_pruned", lambda *args: (None, None, []))
    monkeypatch.setattr(workflow, "_swapped", swap)
    effects = ["minor_loop_width", "coulomb_friction", "sensor_lag", "latent_heat"]
    result = diagnose_faked(monkeypatch, rounds, effects, max_rounds=2)
    assert tried == [("minor_loop_width", ["coulomb_friction"])]
    assert result.verdict == "effects" and result.effects_found == ["coulomb_friction", "sensor_lag"]
    assert sorted(s.name for s in result.corrected_model.effects.active()) == ["coulomb_friction", "sensor_lag"]
    last = result.rounds[-1]
    assert last["swaps"][0]["rival"] == "coulomb_friction" and last["heldout_normalised_rms"] == 2.4
    # The report's table and staircase say what replaced what.
    from sma_gym.diagnosis.report import _round_label, _round_lines

    last["swaps"][0].update(delta_bic_of_rival=-289.3, heldout_gain_of_rival=0.64)
    row = next(line for line in _round_lines(result) if line.startswith("| 2 |"))
    assert "then coulomb_friction in place of minor_loop_width (ΔBIC -289.3, held out +64.0%: 2.4)" in row
    assert _round_label(result, last).endswith("minor_loop_width -> coulomb_friction")


def test_the_generic_way_to_tell_candidates_apart_fits_their_number_and_the_data():
    """It said "both effects ... with resistance measured" for four candidates on files that
    measured resistance (found by a user)."""
    from sma_gym.diagnosis.workflow import generic_experiment

    assert "both effects" in generic_experiment(2, False) and "with resistance measured" in generic_experiment(2, False)
    four = generic_experiment(4, True)
    assert "the 4 candidates" in four and "resistance" not in four


def test_the_corrected_model_runs_under_the_conditions_its_files_were_fitted_under(tmp_path):
    """A 15 V bench diagnosed from the 10 V standard model: every fit ran at the sidecar's
    15 V, so the corrected model is saved at 15 V (it was saved at 10 V, 6 mm off its own
    file), renamed (no longer the preset), and re-simulated from the saved file it gives the
    gap the diagnosis reports. Files that differ in a condition keep the model's own value,
    and the notes and the diagnosis say so."""
    spec = SynthSpec(ModelConfig(preset("supply-15v")), excitation="steps", duration_s=12.0, electrical=False, seed=4)
    at_15v = replace(generate(spec)[0], path="bench15.csv")
    assert at_15v.conditions["supply_voltage_v"] == 15.0
    result = workflow.diagnose([at_15v], [], ModelConfig(), effects=[], max_rounds=1, threads=1)
    model = result.corrected_model
    assert model.actuator.driver.supply_voltage_v == 15.0
    same = {"wire_diameter_m": 3e-4, "pwm_frequency_hz": 500.0, "ambient_temperature_c": 20.0}
    assert result.conditions == {"supply_voltage_v": 15.0, **same}
    assert "supply_voltage_v = 15" in model.notes
    assert model.actuator.name == "standard-diagnosed" and "corrected by sma-gym diagnose" in model.actuator.description
    saved = ModelConfig.load(model.save(tmp_path / "corrected_model.json"))
    bare = replace(at_15v, conditions={})  # the file without its sidecar: the saved model alone
    data = fitting.prepare(bare, workflow.CONTROL_PERIOD_S)
    simulated = fitting.simulate([saved], [0.0], data, workflow.CONTROL_PERIOD_S)["position"][:, 0]
    rms = math.sqrt(np.mean((simulated - bare.position) ** 2))
    reported = result.gap_by_file["corrected"]["fit"]["bench15.csv"]["position"]
    assert rms < 2.0 * reported + 1e-4, (rms, reported)

    at_10v = replace(generate(replace(spec, model=ModelConfig(), seed=5))[0], path="bench10.csv")
    both = workflow.diagnose([at_15v, at_10v], [], ModelConfig(), effects=[], max_rounds=1, threads=1)
    assert both.corrected_model.actuator.driver.supply_voltage_v == 10.0  # the model's own
    assert both.differing_conditions == {"supply_voltage_v": {"bench15.csv": 15.0, "bench10.csv": 10.0}}
    assert "the files differ in supply_voltage_v (bench15.csv 15, bench10.csv 10)" in both.corrected_model.notes
    assert both.conditions == same


def test_without_held_out_files_the_chosen_model_is_refitted_on_the_whole_files(tmp_path, capsys):
    """Step 9: the model chosen on the first 70 % of each file (the rest held out for the
    verdict rules) is refitted on every sample. The corrected model, its parameters and its
    gaps are the refit's; the choice's parameters and each file's RMS before and after are
    recorded; the rounds keep the held-out evidence of the choice; held-out files are never
    fitted. (The model of the real bench's fold that predicts step07 had never seen the
    other runs' last 30 %: 0.388 mm on step07, refitted 0.332 mm.)"""
    from sma_gym.cli import _print_diagnosis
    from sma_gym.diagnosis.report import staircase_stages, write_report

    spec = SynthSpec(ModelConfig(), excitation="random", duration_s=10.0, electrical=False, perturb=0.05, seed=4)
    trace = replace(generate(spec)[0], path="runs/run.csv")
    result = workflow.diagnose([trace], [], ModelConfig(), effects=[], max_rounds=1, threads=1)
    refit = result.whole_file_refit
    assert refit is not None and not result.kept_as_given
    chosen, final = refit["parameters_selected"], result.parameters
    assert set(chosen) == set(final)
    assert any(abs(chosen[k]["value"] - final[k]["value"]) > 1e-6 * (1 + abs(chosen[k]["value"])) for k in chosen)
    before, after = (refit["rms_by_file"]["run.csv"][m]["position"] for m in ("selected", "refitted"))
    assert after < before
    # The corrected model is the refit: simulated on the whole file it gives the refit's RMS.
    whole = fitting.prepare(trace, workflow.CONTROL_PERIOD_S)
    offset = final.get("position_offset_m", {}).get("value", 0.0)
    sim = fitting.simulate([result.corrected_model], [offset], whole, workflow.CONTROL_PERIOD_S)
    assert fitting.rms_by_output(sim, whole)["position"] == pytest.approx(after, rel=1e-9)
    # The round's held-out figure is the choice's, measured before the refit saw that part, and
    # so is the record's gap of the model as chosen; the gaps of the model shipped are the refit's.
    chosen_held = refit["gap_selected"]["heldout"]["position"]
    assert result.rounds[-1]["gap"]["heldout"]["position"] == pytest.approx(chosen_held, rel=1e-9)
    assert chosen_held != pytest.approx(result.gap_after["heldout"]["position"])
    assert "refitted on the whole files" in result.corrected_model.notes
    # One label per file in every table (the split file was labelled by its path in the per-file gaps).
    assert set(result.gap_by_file["corrected"]["fit"]) == set(refit["rms_by_file"]) == {"run.csv"}
    text = write_report(result, tmp_path, [trace], [], ModelConfig()).read_text()
    assert "## Refitted on the whole files" in text and "took part in its fit" in text
    assert "| corrected, as chosen | shrink | corrected, refitted on the whole files (held out: fitted) |" in text
    assert "Refitted parameters at a bound:" in text
    # The staircase ends on the refitted model, its fitted part only (its held-out part was fitted).
    label, gap = staircase_stages(result)[-1]
    assert label.startswith("refitted on") and set(gap) == {"fit"} and gap["fit"] == result.gap_after["fit"]
    _print_diagnosis(result, {"report": tmp_path / "diagnosis.md", "model": tmp_path / "m.json"}, False)
    printed = capsys.readouterr().out
    assert "(as chosen; refitted on the whole files:" in printed and "in brackets was fitted" in printed
    fold = {"held_out": "a", "fitted": ["b"], "verdict": "none", "effects_found": [], "carried": None}
    fold |= {"position_rms_nominal_m": 1e-3, "position_rms_corrected_m": 1e-4, "refitted_on_whole_files": True}
    assert "then refitted on the whole of those runs" in cross_validation_table({"folds": [fold]})

    held = replace(generate(replace(spec, excitation="sine", seed=5, actuator_seed=4))[0], path="held.csv")
    judged = workflow.diagnose([trace], [held], ModelConfig(), effects=[], max_rounds=1, threads=1)
    assert judged.whole_file_refit is None and "refitted" not in judged.corrected_model.notes
    assert staircase_stages(judged)[-1][1] is judged.rounds[-1]["gap"]
    assert (
        "Refitted on the whole files" not in write_report(judged, tmp_path, [trace], [held], ModelConfig()).read_text()
    )


def test_an_effect_found_before_and_named_back_in_its_default_form_keeps_that_form():
    """A round may name its candidate together with an effect found before in another form
    (``_other_forms``). Only the other forms were recorded, so a latent heat found in its
    asymmetric form and named back in its default one stayed 'asymmetric' for the next
    round, which refitted it in a form no round had chosen, and the switch was in no
    record."""
    parameters = (
        *fitting.NOMINAL,
        *fitting.effect_parameters("latent_heat", "default"),
        *fitting.effect_parameters("transformation_spread", "uniform"),
    )
    forms, switched = workflow._forms_carried({"latent_heat": "asymmetric"}, ["latent_heat"], parameters)
    assert forms == {"latent_heat": "default", "transformation_spread": "uniform"}
    assert switched == {"latent_heat": "default"}  # the new candidate's form is no switch
    # Unchanged forms switch nothing.
    forms, switched = workflow._forms_carried(forms, ["latent_heat", "transformation_spread"], parameters)
    assert switched == {} and forms == {"latent_heat": "default", "transformation_spread": "uniform"}


def test_the_most_concentrated_regimes_are_pooled_over_the_samples_of_every_file():
    """A new user's trial: the report named "holding" first where its own plot ranked it
    fifth, because a regime on 4 % of a short file (concentration 5) counted as much as the
    long file's. Pooled, each file weighs by its samples and its squared error."""
    from sma_gym.diagnosis.localise import pooled_regimes, summary

    def entry(samples, error, regimes):
        stats = {k: {"fraction_of_samples": f, "share_of_squared_error": s} for k, (f, s) in regimes.items()}
        return {"regimes": {"position": stats}, "totals": {"position": {"samples": samples, "squared_error": error}}}

    files = [
        entry(1000, 1.0, {"holding": (0.3, 0.3), "cooling": (0.5, 0.7)}),
        entry(50, 0.01, {"holding": (0.04, 0.2)}),
    ]
    assert summary(files, top=1) == ["cooling"]
    pooled = pooled_regimes(files)
    assert pooled["holding"]["fraction_of_samples"] == pytest.approx(302 / 1050)
    assert pooled["holding"]["share_of_squared_error"] == pytest.approx(0.302 / 1.01)
    assert pooled["cooling"]["concentration"] == pytest.approx((0.7 / 1.01) / (500 / 1050))


@pytest.mark.parametrize("gap, far", [(24.0, True), (1.5, False), (math.nan, False)])
def test_the_report_says_the_uncertainties_leave_out_model_form_and_when_that_matters(gap, far):
    """The fitted parameters' uncertainties are statistical; a user read a tight one on a refit
    that ends far above the noise (the real bench's 20x) as the actuator's value."""
    from sma_gym.diagnosis.report import _uncertainty_caveat

    text = _uncertainty_caveat(SimpleNamespace(rounds=[{"heldout_normalised_rms": gap}]))
    assert "statistical" in text and "form differs" in text
    assert ("24x the noise" in text and "stand in for" in text) if far else ("x the noise" not in text)
