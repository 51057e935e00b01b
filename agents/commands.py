"""``sma-gym fidelity`` and ``sma-gym evaluate``: the subcommands that run the report's controllers.

They are declared in ``pyproject.toml`` under the ``sma_gym.commands`` entry-point group,
where :mod:`sma_gym.cli` finds them; ``sma_gym`` itself never imports ``sma_gym_agents``.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import sys
from collections.abc import Sequence
from pathlib import Path

from sma_gym import fidelity
from sma_gym._io import check_output_folder, locked_folder, staged_outputs
from sma_gym.cli import Command
from sma_gym.data import find_real_data_dir
from sma_gym.extras import MissingExtraError, extra_error, install_hint, missing
from sma_gym_agents.controllers import ALL_SPECS

try:
    from sma_gym_agents import evaluation, report_targets
    from sma_gym_agents.report import table_6_1_markdown, write_report
    from sma_gym_agents.trained import load_policy, zip_path
except ModuleNotFoundError as err:
    # Listed by `sma-gym --help` as unavailable, naming the extra that makes both work, and
    # the one extra that makes evaluate work too (else it took two installs to find out).
    error = extra_error(err, "sma-gym evaluate and sma-gym fidelity", modules=("matplotlib", "scipy"))
    if isinstance(error, MissingExtraError) and missing("stable_baselines3"):
        error = MissingExtraError(
            f"{error}; sma-gym evaluate needs stable-baselines3 as well, and "
            f"{install_hint(['stable_baselines3'])} installs all of them",
            error.name or "",
            error.hint,
        )
    raise error from err


# --------------------------------------------------------------------------------------
# sma-gym fidelity
# --------------------------------------------------------------------------------------
def _fidelity_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", help="folder for the PNG plots; must be new or empty unless --overwrite")
    p.add_argument(
        "--overwrite", action="store_true", help="replace the plots of an earlier run in --out (nothing else there)"
    )
    p.add_argument(
        "--json", action="store_true", help='print {"rows": [...], "summary": {...}} as JSON instead of a table'
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help="one seed, shorter sines and sweeps (about 1.5 minutes, for smoke tests: its counts differ from a "
        "full run's by a row or two)",
    )


FIDELITY_OUTPUTS = (
    "fig4_9_resistance_loop.png",
    "fig5_2_voltage_steps.png",
    "fig6_4_holding_duty.png",
    "fig8_efficiency.png",
    "fig9_multiplexed_rise.png",
    fidelity.BENCH_PLOT,
)
"""What ``sma-gym fidelity --out`` writes (besides the list of its files, ``_io.output_list``)."""


def _fidelity(args: argparse.Namespace) -> int:
    find_real_data_dir()  # a $SMA_GYM_REAL_DATA that is no folder is refused before minutes of work
    if args.out is None:
        return report_targets.main(args.out, args.json, quick=args.quick)
    check_output_folder(args.out, must_be_empty=not args.overwrite)
    # Written into a staging folder and moved in at the end: an interrupt leaves the earlier
    # plots (or none), and --overwrite removes only what the earlier run listed.
    with locked_folder(args.out), staged_outputs(args.out, "fidelity") as staging:
        return report_targets.main(str(staging), args.json, quick=args.quick, shown_out=args.out)


FIDELITY = Command(
    "fidelity",
    "compare the simulator with every result of the report (125 rows of REPORT_TARGETS, Table 6.1 and chapters 7-9 included)",
    _fidelity_arguments,
    _fidelity,
    description="Prints the table of every row of the report (pass, fail, calibration, disputed) and "
    "its summary; --out writes the plots. Exit code 0 when no row fails, 1 when some do (the "
    "model's known misses: docs/model.md), 2 for a bad argument.",
    needs=("scipy", "matplotlib"),
    extra="train",
)


# --------------------------------------------------------------------------------------
# sma-gym evaluate
# --------------------------------------------------------------------------------------
MAX_EVALUATION_SEEDS = 100
"""Most seeds ``sma-gym evaluate`` runs: every seed reruns every experiment (the full
evaluation takes minutes per seed), so a typo such as 1000000 would run for weeks."""


def _evaluate_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--out",
        help="folder for the markdown report, the JSON results and the PNG plots; must be new or empty unless "
        "--overwrite",
    )
    p.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the report, results and plots of an earlier evaluation in --out (nothing else there)",
    )
    p.add_argument("--policy", action="append", help="a stable-baselines3 model (.zip) written by train.py; repeatable")
    p.add_argument("--json", action="store_true", help="print every metric as one JSON document")
    p.add_argument(
        "--experiments",
        default=None,
        help="comma-separated subset of 6.1, 7, 8, 9, self-sensing (default: all; 6.1 with --model)",
    )
    p.add_argument(
        "--model",
        default=None,
        help="the actuator Table 6.1 (and self-sensing) run on instead of the report's wire: a preset or twin "
        "name or a model JSON file, e.g. the corrected_model.json of sma-gym diagnose; chapters 7-9 are the "
        "report's conditions of its own wire and are refused with it",
    )
    p.add_argument("--seeds", type=int, default=3, help="seeds per run (sensor noise differs); default 3")
    p.add_argument(
        "--baselines",
        help="comma-separated controllers to include, e.g. 'PID,VSC3 + FF' (default: all ten of Table 6.1)",
    )


def _evaluate(args: argparse.Namespace) -> int:
    if args.experiments is None:
        args.experiments = ",".join(evaluation.MODEL_EXPERIMENTS[:1] if args.model else evaluation.EXPERIMENTS)
    experiments = [e.strip() for e in args.experiments.split(",") if e.strip()]
    baselines = None if args.baselines is None else [b.strip() for b in args.baselines.split(",") if b.strip()]
    if baselines == []:
        # ("" used to run all ten, "," none at all: an empty report that looked like success)
        raise ValueError(
            f"--baselines {args.baselines!r}: expected a comma-separated list of controllers, e.g. 'PID,VSC3 + FF' "
            "(leave the option out for all ten)"
        )
    # Everything checked before the (long) evaluation starts.
    for e in experiments:
        if e not in evaluation.EXPERIMENTS:
            raise ValueError(
                f"--experiments {e!r}: expected a comma-separated subset of {', '.join(evaluation.EXPERIMENTS)}"
            )
    if not experiments:
        raise ValueError(
            f"--experiments {args.experiments!r}: expected at least one of {', '.join(evaluation.EXPERIMENTS)}"
        )
    if not 1 <= args.seeds <= MAX_EVALUATION_SEEDS:
        raise ValueError(
            f"--seeds {args.seeds}: expected an integer in [1, {MAX_EVALUATION_SEEDS}] (each seed reruns every "
            "experiment; the report's figures take 3)"
        )
    labels = [evaluation.baseline(b).name for b in baselines or []]
    for k, label in enumerate(labels):
        if label in labels[:k]:
            # One row per controller: a second would run it again and overwrite its row.
            raise ValueError(f"--baselines {baselines[k]!r}: {label!r} given twice; expected each controller once")
    evaluation.require_model_experiments(args.model, experiments, name="--model")
    for policy in args.policy or []:
        agent = load_policy(policy)  # card, hash and zip checked now, not after the baselines ran
        _require_scored(policy, agent.env_id, experiments)
    if args.out is None:
        return evaluate(args.out, args.policy or [], args.json, experiments, args.seeds, baselines, model=args.model)
    check_output_folder(args.out, must_be_empty=not args.overwrite)
    # Written into a staging folder and moved in at the end: an interrupt leaves the earlier
    # report whole (or nothing), and the earlier report's figures of other experiments or
    # policies, which would sit beside this one as its own, are removed then (those it listed).
    with locked_folder(args.out), staged_outputs(args.out, "evaluate") as staging:
        return evaluate(
            str(staging), args.policy or [], args.json, experiments, args.seeds, baselines, args.out, args.model
        )


EVALUATE_OUTPUTS = (
    "evaluation.md",
    "evaluation.json",
    "fig6_[2356]_*.png",
    "table6_1_*.png",
    "self_sensing_*.png",
    "chapter7_*.png",
    "fig9_multiplexed.png",
)
"""What ``sma-gym evaluate --out`` writes (besides the list of its files, ``_io.output_list``)."""


def _require_scored(policy: str, env_id: str, experiments: Sequence[str]) -> None:
    """Refuse a ``--policy`` that none of the chosen experiments would run: it would be
    left out of the report without a word."""
    runs = evaluation.AGENT_EXPERIMENTS.get(env_id, ())
    if any(e in runs for e in experiments):
        return
    if not runs:
        raise ValueError(
            f"--policy {policy!r}: trained on {env_id}, which no experiment of sma-gym evaluate scores "
            "(train.py's results.md scores it over the chapter-7 conditions)"
        )
    raise ValueError(
        f"--policy {policy!r}: trained on {env_id}, which only the experiment(s) {', '.join(runs)} score; "
        f"--experiments {','.join(experiments)} would leave it out: add {runs[0]} to --experiments"
    )


def agent_names(policies: Sequence[str], names: Sequence[str]) -> list[str]:
    """The models' ``names`` (their cards'), each one that another shares (every model of a
    sweep is "SAC agent") followed by the part of its path that tells them apart, e.g.
    "SAC agent (seed-1/best_model)". The report has one row per name: without this every
    model of a sweep but the first was lost."""
    # The files load_policy reads (m.v1 and m.v2 are two models, m.v1 and m.v1.zip one).
    resolved = [zip_path(p).resolve() for p in policies]
    for k, p in enumerate(resolved):
        if p in resolved[:k]:
            raise ValueError(f"--policy {policies[k]!r}: given twice; expected each model once")
    # A table cell holds no '|' and no line break (a card's name broke the markdown table).
    names = [" ".join(n.replace("|", "/").split()) or "agent" for n in names]
    out = list(names)
    for name in set(names):
        same = [k for k, n in enumerate(names) if n == name]
        if len(same) > 1:
            common = Path(os.path.commonpath([resolved[k].parent for k in same]))
            for k in same:
                out[k] = f"{name} ({resolved[k].relative_to(common).with_suffix('').as_posix()})"
    # A name a baseline has ("PID", "PID (self-sensing)", "PID (fixed slots)") shared its row:
    # the report showed one of the two.
    labels = [spec.label for spec in ALL_SPECS]
    return [f"{n} [agent]" if any(n == lab or n.startswith(f"{lab} (") for lab in labels) else n for n in out]


def evaluate(
    out: str | None,
    policies: Sequence[str],
    as_json: bool,
    experiments: Sequence[str],
    n_seeds: int,
    baselines: Sequence[str] | None = None,
    shown_out: str | None = None,
    model: str | None = None,
) -> int:
    """Score the baselines and the saved ``policies``; print the table (or JSON), write the report into ``out``
    (``shown_out``: the folder named in the message, where a staging ``out`` is moved to). ``model``: the
    actuator of Table 6.1 and self-sensing (None: the report's)."""
    if n_seeds < 1:
        raise ValueError(f"seeds = {n_seeds!r}: expected an integer >= 1")
    agents = [load_policy(p) for p in policies]
    names = agent_names(policies, [a.name for a in agents])
    agents = [dataclasses.replace(a, name=name) for a, name in zip(agents, names)]
    chosen = None if baselines is None else [evaluation.baseline(b) for b in baselines]
    results = evaluation.evaluate(agents, experiments, seeds=tuple(range(n_seeds)), baselines=chosen, model=model)
    if out:
        paths = write_report(results, Path(out))
    if as_json:
        print(results.to_json())
        # stdout stays one JSON document; what the notes say (an agent left out of an
        # experiment, and why) was lost in this mode.
        for note in results.notes:
            print(f"note: {note}", file=sys.stderr)
    else:
        tables = [table_6_1_markdown(results, c) for c in results.distinct("6.1", "condition")]
        print("\n\n".join(tables) if tables else f"{len(results.records)} metrics")
        for note in results.notes:
            print(f"\nnote: {note}")
        if out:
            shown = Path(shown_out or out).resolve()
            print(f"\nreport written to {shown / 'evaluation.md'} ({len(paths)} files)")
    return 0


EVALUATE = Command(
    "evaluate",
    "score the report's controllers (and trained agents) on the report's experiments, or on a model of yours "
    "(--model: Table 6.1 on it)",
    _evaluate_arguments,
    _evaluate,
    needs=("scipy", "matplotlib", "stable_baselines3"),
    extra="train",
)
