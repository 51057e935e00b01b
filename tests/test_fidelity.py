"""The fidelity table: every result of the report gets one row, with the spec's tolerance.

The table is computed once per module (``--quick``: one seed, two sine periods, about
1.5 minutes on 2 cores). :data:`MIN_PASS_COUNT` is the number of rows the quick run passes
on the current model: a model change that loses a row fails here; one that gains rows
should raise it.
"""

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

from sma_gym import fidelity
from sma_gym._io import output_list
from sma_gym.cli import main
from sma_gym.provenance import describe, provenance
from sma_gym.report_targets import (
    TABLE_RELATIVE,
    TOLERANCES,
    load_targets,
    parse_report_targets,
    target,
    within_tolerance,
)
from sma_gym_agents import report_targets as table
from sma_gym_agents.commands import FIDELITY_OUTPUTS
from sma_gym_agents.evaluation import CHAPTER_8_CASES, Record, Results

MIN_PASS_COUNT = 78
"""Rows with status ``pass`` in the quick run of the current model (raise it, never lower it:
lowered once, 82 -> 78 on 2026-12-07, when a review of the rows, not a model change, moved A1
and B9 to calibration, 9r to not simulable and 7p's oscillation to the step it is about)."""

SPEC = Path(__file__).resolve().parents[2] / "shared" / "spec" / "REPORT_TARGETS.md"


@pytest.fixture(scope="module")
def result():
    return table.run(quick=True)


# --------------------------------------------------------------------------------------
# The targets
# --------------------------------------------------------------------------------------
@pytest.mark.skipif(not SPEC.exists(), reason="../shared/spec/REPORT_TARGETS.md is not on this machine")
def test_shipped_targets_match_the_spec_file():
    assert parse_report_targets(SPEC.read_text(encoding="utf-8")) == load_targets()


def test_targets_are_the_reports_125_rows_with_known_tolerances():
    targets = load_targets()
    ids = [t.id for t in targets]
    assert len(ids) == 125 and len(set(ids)) == 125
    assert {t.tolerance for t in targets} <= set(TOLERANCES)
    assert ids[:2] == ["A1", "A2"] and "9a-d" in ids and ids[-1] == "9r"
    assert target("B4").numbers == (-0.097,) and target("B4").tolerance == "sine error"
    assert target("B6").tolerance == "qualitative"  # "osc."
    assert {t.id for t in targets if t.calibration} == {
        "A3",
        "A10",
        "A11",
        "A14",
        "A25",
        "A26",
        "B1",
        "B14",
        "B17",
        "B37",
        "9a-d",
        "9e",
    }


def test_tolerance_convention():
    assert within_tolerance("table", 0.129, 0.1) and not within_tolerance("table", 0.131, 0.1)
    assert within_tolerance("control error", 0.029, 0.0) and not within_tolerance("control error", -0.031, 0.0)
    assert within_tolerance("overshoot", 0.049, 0.0) and within_tolerance("overshoot", 1.29, 1.0)
    assert not within_tolerance("overshoot", 1.31, 1.0)
    assert within_tolerance("sine error", -0.19, -0.1) and not within_tolerance("sine error", 0.1, -0.1)
    assert not within_tolerance("sine error", -0.21, -0.1)
    assert within_tolerance("figure", 1.49, 1.0) and not within_tolerance("figure", 0.66, 1.0)
    assert not within_tolerance("table", math.nan, 1.0)
    with pytest.raises(ValueError):
        within_tolerance("qualitative", 1.0, 1.0)
    assert (
        fidelity.ratio(1.0, 0.0) == math.inf
        and math.isnan(fidelity.ratio(0.0, 0.0))
        and fidelity.ratio(3.0, 2.0) == 1.5
    )


# --------------------------------------------------------------------------------------
# The table
# --------------------------------------------------------------------------------------
def test_every_target_gets_exactly_one_row_in_the_spec_order(result):
    assert [r.id for r in result.rows] == [t.id for t in load_targets()]


def test_statuses_follow_the_flags(result):
    for r in result.rows:
        t = target(r.id)
        assert r.status in fidelity.STATUSES
        if r.status == "not simulable":
            assert r.within_tolerance is None and r.how
            continue
        assert isinstance(r.within_tolerance, bool)
        assert (r.status == "calibration") == (t.calibration or r.id in fidelity.CALIBRATED_HERE), r.id
        assert (r.status == "disputed") == (r.id in fidelity.DISPUTES), r.id
        if r.status in ("pass", "fail"):
            assert (r.status == "pass") == r.within_tolerance, r.id
    assert [r.id for r in result.rows if r.status == "not simulable"] == ["A5", "9r"]


def test_rows_tuned_here_are_calibration_with_their_reason_and_arithmetic_is_not_simulated(result):
    """A review of every row against its measurement (2026-12-07) found three counted as
    passes that reproduce nothing: A1's stroke is the driver's cut, set to it; B9's
    overshoot identified the controllers' filter; 9r is arithmetic about another design."""
    rows = {r.id: r for r in result.rows}
    assert set(fidelity.CALIBRATED_HERE) == {"A1", "B9"}
    for rid in fidelity.CALIBRATED_HERE:
        assert rows[rid].status == "calibration" and not target(rid).calibration
        assert "calibration here" in rows[rid].how
    assert rows["9r"].status == "not simulable" and rows["9r"].within_tolerance is None
    text = fidelity.format_table(result.rows)
    assert "Calibration rows the spec's list does not flag:\n- A1 (stroke): the driver's end-of-travel cut" in text


def test_the_holding_slope_dispute_claims_only_what_its_numbers_show():
    """The argument said no model could be within 1.5x of both 12 and 7 /m; 1.71x apart,
    9.2 /m is within 1.31x of each. The row keeps the convention's factor 1.5 (it had 2)."""
    argument = fidelity.DISPUTES["A27"]()
    assert "no model" not in argument and "1.71x apart" in argument and "between 8.0 and 10.5 /m" in argument
    assert target("A27").tolerance == "figure"


def test_disputed_rows_print_their_argument(result, capsys):
    disputed = [r for r in result.rows if r.status == "disputed"]
    assert {r.id for r in disputed} == {"8a", "A24", "A27", "A28"}
    for r in disputed:
        assert len(r.argument) > 100 and any(c.isdigit() for c in r.argument)
    assert all(not r.argument for r in result.rows if r.status != "disputed")
    text = fidelity.format_table(result.rows)
    for r in disputed:
        assert r.argument in text


def test_the_heating_against_cooling_dispute_follows_from_the_reports_rows(result):
    """Row A28's argument, checked: fig. 6.4's loss, read as a constant or along its line,
    makes 5 V heat more than twice as fast as the wire cools, and Table 8.1's implied loss
    more than twice as slow; the simulated wire, calibrated to fig. 6.4, lies between the
    figure's two readings."""
    f = fidelity.heating_cooling_dispute_figures()
    assert f["faster_constant_loss"] > fidelity.SIMILAR_FACTOR
    assert f["faster_along_line"] > f["faster_constant_loss"]
    assert f["slower_implied_loss"] > fidelity.SIMILAR_FACTOR
    assert f["holding_loss_w"] < f["similar_loss_w"] < f["implied_loss_min_w"]
    row = next(r for r in result.rows if r.id == "A28")
    heat_s, cool_s = (float(v) for v in re.findall(r"([0-9.]+) s\b", row.simulated))
    assert f["faster_constant_loss"] < cool_s / heat_s < f["faster_along_line"]
    assert row.within_tolerance is False and row.status == "disputed"


def test_the_efficiency_dispute_follows_from_the_reports_rows():
    """Row 8a's argument, checked: every pair of Table 8.1's step efficiencies implies more
    than twice the loss fig. 6.4 allows; with fig. 6.4's loss some stroke energy puts 7.5, 10
    and 15 V within +-30 % at once, and none can bring 5 V within its band."""
    f = fidelity.efficiency_dispute_figures()
    assert f["implied_loss_min_w"] > 2.0 * f["holding_loss_w"]
    assert f["best_5v_percent"] > f["band_5v_upper_percent"]
    work_j = f["energy_15v_j"] * target("8d").numbers[0] / 100.0
    loss_w, r_ohm = f["holding_loss_w"], f["resistance_ohm"]

    def efficiency(own_j: np.ndarray, volts: float) -> np.ndarray:
        return 100.0 * work_j * (1.0 - loss_w * r_ohm / volts**2) / own_j

    own_j = np.linspace(1.0, 10.0, 9001)
    fits = np.ones_like(own_j, dtype=bool)
    for row, volts in (("8b", 7.5), ("8c", 10.0), ("8d", 15.0)):
        fits &= np.abs(efficiency(own_j, volts) - target(row).numbers[0]) <= TABLE_RELATIVE * target(row).numbers[0]
    assert fits.any()
    assert np.all(efficiency(own_j[fits], 5.0) > f["band_5v_upper_percent"])


def test_summary_counts_add_up(result):
    s = result.summary
    assert sum(s.counts.values()) == s.total == 125
    assert s.within == sum(bool(r.within_tolerance) for r in result.rows)
    assert s.within_not_calibration == s.within - sum(
        bool(r.within_tolerance) for r in result.rows if r.status == "calibration"
    )
    assert s.counts["pass"] <= s.within_not_calibration <= s.within
    line = s.line()
    assert f"pass {s.counts['pass']} / fail {s.counts['fail']}" in line and "total 125" in line
    assert fidelity.format_table(result.rows).endswith(line)


def test_minimum_pass_count(result):
    assert result.summary.counts["pass"] >= MIN_PASS_COUNT, fidelity.format_table(
        [r for r in result.rows if r.status == "fail"]
    )


def test_cli_prints_json_rows_and_writes_the_plots(tmp_path, capsys, monkeypatch, result):
    monkeypatch.setattr(table, "run", lambda quick=False: result)  # the table of the fixture, through the CLI
    code = main(["fidelity", "--json", "--quick", "--out", str(tmp_path)])
    data = json.loads(capsys.readouterr().out)
    assert code == (0 if result.summary.counts["fail"] == 0 else 1)
    assert [r["id"] for r in data["rows"]] == [t.id for t in load_targets()]
    assert all(
        set(r) >= {"id", "quantity", "report", "simulated", "tolerance", "status", "within_tolerance"}
        for r in data["rows"]
    )
    assert data["summary"]["counts"] == result.summary.counts
    # The table names the code it measured (the model changes under the same ids).
    assert data["provenance"] == provenance()
    # Exactly the outputs --overwrite would replace, less the plots this machine cannot draw.
    drawn = set(FIDELITY_OUTPUTS) - set(result.skipped)
    assert {p.name for p in tmp_path.iterdir()} == drawn | {output_list("fidelity")}
    for name in drawn:
        path = tmp_path / name
        assert path.stat().st_size > 10_000
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert main(["fidelity", "--quick"]) == code
    *_, summary, code_line = capsys.readouterr().out.rstrip().splitlines()
    assert summary == result.summary.line()
    assert code_line == f"Code: {describe(provenance())}"


def test_a_second_run_into_the_same_folder_needs_overwrite_and_replaces_only_its_plots(
    tmp_path, capsys, monkeypatch, result
):
    monkeypatch.setattr(table, "run", lambda quick=False: result)
    out = tmp_path / "fid"
    out.mkdir()
    mine = out / "notes.txt"
    mine.write_text("the user's")
    assert main(["fidelity", "--quick", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "not empty" in err and "notes.txt" in err and "--overwrite" in err
    assert [p.name for p in out.iterdir()] == ["notes.txt"]  # nothing written, nothing changed
    # A file of the user's named like a plot (not listed by a run) is never removed by its name.
    theirs = out / "fig6_4_holding_duty_my_version.png"
    theirs.write_bytes(b"mine")
    main(["fidelity", "--quick", "--overwrite", "--out", str(out)])
    capsys.readouterr()
    # An earlier run's plot that this run does not draw (here: as if the bench's data were
    # gone) must not stay beside the new ones as if it were theirs.
    stale = out / fidelity.BENCH_PLOT
    assert stale.exists() and fidelity.BENCH_PLOT in (out / output_list("fidelity")).read_text()
    monkeypatch.setattr(
        table, "run", lambda quick=False: fidelity.FidelityResult(result.rows, {}, {fidelity.BENCH_PLOT: "why"})
    )
    main(["fidelity", "--quick", "--overwrite", "--out", str(out)])
    assert f"{fidelity.BENCH_PLOT} not drawn: why" in capsys.readouterr().err
    assert not stale.exists() and mine.read_text() == "the user's" and theirs.read_bytes() == b"mine"


def test_the_bench_plot_is_skipped_with_a_reason_without_the_real_runs(monkeypatch):
    import sma_gym.data

    monkeypatch.setattr(sma_gym.data, "real_bench_folder", lambda: None)
    assert set(fidelity.skipped_plots()) == {fidelity.BENCH_PLOT}
    assert "step01.csv" in fidelity.skipped_plots()[fidelity.BENCH_PLOT]
    assert fidelity.BENCH_PLOT not in fidelity.plant_plots(None)


# --------------------------------------------------------------------------------------
# Rows that must be able to fail
# --------------------------------------------------------------------------------------
def test_order_rows_refuses_missing_or_doubled_rows(result):
    with pytest.raises(ValueError, match="missing"):
        fidelity.order_rows(result.rows[1:])
    with pytest.raises(ValueError, match="two rows"):
        fidelity.order_rows([*result.rows, result.rows[0]])


def _efficiency_results(values):
    results = Results()
    for (label, *_), v in zip(CHAPTER_8_CASES, values):
        results.records.append(Record("8", "PID", label, "1 -> 7 mm", "efficiency_percent", v, v, 1))
    return results


def test_voltage_ordering_of_efficiencies_is_strict():
    def row(values, row_id="8h"):
        return next(r for r in table.chapter_8_rows(_efficiency_results(values)) if r.id == row_id)

    assert row([0.12, 0.42, 0.51, 0.60, 0.34, 0.24, 0.18]).status == "pass"
    assert row([0.12, 0.42, 0.61, 0.60, 0.34, 0.24, 0.18]).status == "fail"  # 10 V above 15 V
    assert row([0.12, 0.42, 0.51, 0.51, 0.34, 0.24, 0.18]).status == "fail"  # a tie is not a rise
    assert row([0.12, 0.42, 0.51, 0.60, 0.34, 0.24, 0.25], "8i").status == "fail"
    assert row([0.12, 0.42, 0.51, 0.60, 0.34, 0.24, 0.18], "8b").status == "pass"
    assert row([0.12, 0.60, 0.51, 0.60, 0.34, 0.24, 0.18], "8b").status == "fail"  # +43 %


def test_holding_slope_needs_the_line_through_the_origin():
    duty = np.round(np.arange(0.0025, 0.08001, 0.0025), 6)
    report_like = {"duty": duty, "x_heating": duty / 12.0, "x_cooling": duty / 12.0}
    # today's kind of curve: nothing moves below 0.05, then 2 mm per 0.001 of duty
    onset = np.clip((duty - 0.05) * 2.0, 0.0, 9.5e-3)
    flat = {"duty": duty, "x_heating": onset, "x_cooling": onset}
    assert fidelity.holding_slope_per_m(report_like) == pytest.approx(12.0)
    good, bad = (next(r for r in fidelity.holding_rows(c) if r.id == "A27") for c in (report_like, flat))
    assert good.within_tolerance and not bad.within_tolerance
    assert fidelity.holding_slope_per_m(flat) > 6.0  # the slope alone would have let it through
    assert good.status == bad.status == "disputed"


def test_a_wrong_model_fails_its_rows():
    """A 5 V step faster than the 10 V one, and a wire that never moves, fail A21/A22/A1."""
    data = fidelity.voltage_steps()
    cooling = fidelity.cooling_runs(after_s=5.0)
    swapped = {
        k: (v[:, ::-1] if isinstance(v, np.ndarray) and v.ndim == 2 and v.shape[1] == 3 else v) for k, v in data.items()
    }
    frozen = {**data, "position_m": np.zeros_like(data["position_m"])}
    by_id = {r.id: r for r in fidelity.voltage_step_rows(swapped, cooling)}
    assert by_id["A21"].status == "fail"
    by_id = {r.id: r for r in fidelity.voltage_step_rows(frozen, cooling)}
    # A1 is a calibration row (the cut is set to the stroke) but still outside when nothing moves.
    assert not by_id["A1"].within_tolerance and by_id["A22"].status == "fail" and not by_id["A28"].within_tolerance


def test_bench_reports_rates_for_both_modes_and_sizes(capsys):
    assert main(["bench", "--json", "--repeats", "1"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data) == {"averaged", "resolved"}
    for mode in data.values():
        assert set(mode) == {"1", "4096"}
        assert all(rate > 1000.0 for rate in mode.values())
