"""The simulator against the report's numbers: every target within its stated tolerance.

Rows the lumped model cannot reproduce are listed, with the reason, in
``sma_gym.fidelity.KNOWN_GAPS``. They are not asserted away: the test checks they are still
failing, so that a model change that fixes one forces the list (and the docs) to be updated.
"""

import json

import pytest

from sma_gym import fidelity
from sma_gym.cli import main


@pytest.fixture(scope="module")
def result():
    return fidelity.run()


def test_every_target_is_met_within_its_tolerance(result):
    failing = [(r.target, r.report, r.simulated, r.tolerance) for r in result.rows if not r.passed and r.target not in fidelity.KNOWN_GAPS]
    assert not failing


def test_known_gaps_are_still_gaps_and_still_reported(result):
    by_target = {r.target: r for r in result.rows}
    for target, reason in fidelity.KNOWN_GAPS.items():
        assert target in by_target, f"known gap {target!r} is no longer a row"
        row = by_target[target]
        assert not row.passed, f"{target!r} now passes: remove it from KNOWN_GAPS and the docs"
        assert reason in row.note


def test_rows_cover_every_target_group(result):
    groups = {r.target.split()[0] for r in result.rows}
    assert groups >= {"T1", "T2", "T3", "T4", "T5", "T8", "T9"}


def test_cli_prints_json_rows_and_writes_the_plots(tmp_path, capsys):
    code = main(["fidelity", "--json", "--quick", "--out", str(tmp_path)])
    rows = json.loads(capsys.readouterr().out)
    assert code == 0
    assert rows and all(set(r) >= {"target", "report", "simulated", "tolerance", "passed"} for r in rows)
    for name in (
        "fig5_2_voltage_steps.png",
        "fig4_9_resistance_loop.png",
        "fig6_4_holding_duty.png",
        "fig9_multiplexed_rise.png",
        "fig8_efficiency.png",
        "bench_0.5mm_ht_vs_measured.png",
    ):
        path = tmp_path / name
        assert path.exists() and path.stat().st_size > 10_000
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bench_reports_rates_for_both_modes_and_sizes(capsys):
    assert main(["bench", "--json", "--repeats", "1"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data) == {"averaged", "resolved"}
    for mode in data.values():
        assert set(mode) == {"1", "4096"}
        assert all(rate > 1000.0 for rate in mode.values())
