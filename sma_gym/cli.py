"""The ``sma-gym`` command: ``sma-gym <subcommand> --help`` for each.

Every subcommand checks all its arguments (an ``--out`` that cannot be written included)
before it does any work, and exits 2 with a message naming the argument; an output folder
is locked while a command writes to it (:func:`sma_gym._io.locked_folder`).
"""

from __future__ import annotations

import argparse
import sys
from typing import Sequence


def _fidelity(args: argparse.Namespace) -> int:
    from sma_gym import fidelity
    from sma_gym._io import check_output_folder, locked_folder

    if args.out is None:
        return fidelity.main(args.out, args.json, quick=args.quick)
    check_output_folder(args.out)
    with locked_folder(args.out):
        return fidelity.main(args.out, args.json, quick=args.quick)


def _bench(args: argparse.Namespace) -> int:
    from sma_gym import bench

    return bench.main(as_json=args.json, repeats=args.repeats)


def _evaluate(args: argparse.Namespace) -> int:
    from agents import evaluation
    from agents.policies import load_policy
    from sma_gym._io import check_output_folder, locked_folder

    experiments = [e.strip() for e in args.experiments.split(",") if e.strip()]
    baselines = [b.strip() for b in args.baselines.split(",") if b.strip()] if args.baselines else None
    # Everything checked before the (long) evaluation starts.
    for e in experiments:
        if e not in evaluation.EXPERIMENTS:
            raise ValueError(f"--experiments {e!r}: expected a comma-separated subset of {', '.join(evaluation.EXPERIMENTS)}")
    if not experiments:
        raise ValueError(f"--experiments {args.experiments!r}: expected at least one of {', '.join(evaluation.EXPERIMENTS)}")
    if args.seeds < 1:
        raise ValueError(f"--seeds {args.seeds}: expected an integer >= 1")
    for b in baselines or []:
        evaluation.baseline(b)
    for policy in args.policy or []:
        load_policy(policy)  # card, hash and zip checked now, not after the baselines ran
    if args.out is None:
        return evaluation.main(args.out, args.policy or [], args.json, experiments, args.seeds, baselines)
    check_output_folder(args.out)
    with locked_folder(args.out):
        return evaluation.main(args.out, args.policy or [], args.json, experiments, args.seeds, baselines)


def _diagnose(args: argparse.Namespace) -> int:
    import json

    from sma_gym._io import check_output_folder, locked_folder
    from sma_gym.data import MeasuredDataError, load_traces
    from sma_gym.data.measured import DIAGNOSIS_MIN_ROWS
    from sma_gym.diagnosis.workflow import diagnose, require_max_rounds, write_outputs
    from sma_gym.effects import EFFECTS
    from sma_gym.model import load_model

    require_max_rounds("--max-rounds", args.max_rounds)
    if args.cross_validate and (args.heldout or len(args.files) < 2):
        raise ValueError("--cross-validate: expected at least 2 files and no --heldout (each file is held out in turn)")
    out = check_output_folder(args.out)
    try:
        fit = load_traces(args.files, DIAGNOSIS_MIN_ROWS)
        held = load_traces(args.heldout or [], DIAGNOSIS_MIN_ROWS)
    except MeasuredDataError as err:
        print(f"sma-gym diagnose: invalid measured data:\n{err}", file=sys.stderr)
        return 2
    nominal = load_model(args.model)
    effects = [e.strip() for e in args.effects.split(",")] if args.effects else None
    for name in effects or []:
        if name not in EFFECTS:
            raise ValueError(f"--effects {name!r}: expected a comma-separated subset of {', '.join(EFFECTS)}")

    def progress(message: str) -> None:
        print(f"sma-gym diagnose: {message}", file=sys.stderr, flush=True)

    if args.cross_validate:
        from sma_gym._io import write_json, write_text
        from sma_gym.diagnosis.workflow import cross_validate, cross_validation_table

        with locked_folder(out):
            cv = cross_validate(fit, nominal, effects, progress=progress, max_rounds=args.max_rounds)
            table = cross_validation_table(cv)
            write_json(out / "cross_validation.json", cv)
            write_text(out / "cross_validation.md", "# Leave one run out\n\n" + table)
        print(json.dumps(cv) if args.json else table, end="" if not args.json else "\n")
        return 0
    with locked_folder(out):
        result = diagnose(fit, held, nominal, effects, progress=progress, max_rounds=args.max_rounds)
        paths = write_outputs(result, out, fit, held, nominal)
    if args.json:
        from sma_gym.diagnosis.workflow import _json_default

        print(json.dumps(result.as_dict(), default=_json_default))
    else:
        joiner = " + " if result.verdict == "effects" else " or "
        effect = result.effect if isinstance(result.effect, str) or result.effect is None else joiner.join(result.effect)
        print(f"verdict: {result.verdict}" + (f" ({effect})" if effect else ""))
        for data in ("fit", "heldout"):
            for output, before in result.gap_before[data].items():
                print(f"  {data:8s} {output:10s} RMS {before:.4g} -> {result.gap_after[data].get(output, float('nan')):.4g}")
        print(f"report: {paths['report']}\ncorrected model: {paths['model']}")
    return 0


def _synth(args: argparse.Namespace) -> int:
    from sma_gym.diagnosis import synth

    return synth.main(args)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="sma-gym", description="SMA actuator simulator, environments and tools.")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("fidelity", help="compare the simulator with every result of the report (125 rows of REPORT_TARGETS, Table 6.1 and chapters 7-9 included)")
    p.add_argument("--out", help="folder for the PNG plots")
    p.add_argument("--json", action="store_true", help='print {"rows": [...], "summary": {...}} as JSON instead of a table')
    p.add_argument("--quick", action="store_true", help="one seed, shorter sines and sweeps (about 1.5 minutes, for smoke tests)")
    p.set_defaults(func=_fidelity)

    p = sub.add_parser("bench", help="simulator speed in actuator-steps/s (1 kHz control step)")
    p.add_argument("--json", action="store_true", help='print {"averaged": {"1": rate, "4096": rate}, "resolved": {...}}')
    p.add_argument("--repeats", type=int, default=3, help="best of this many timings (default 3)")
    p.set_defaults(func=_bench)

    p = sub.add_parser("evaluate", help="score the report's controllers (and trained agents) on the report's experiments")
    p.add_argument("--out", help="folder for the markdown report, the JSON results and the PNG plots")
    p.add_argument("--policy", action="append", help="a stable-baselines3 model (.zip) written by train.py; repeatable")
    p.add_argument("--json", action="store_true", help="print every metric as one JSON document")
    p.add_argument(
        "--experiments",
        default="6.1,7,8,9,self-sensing",
        help="comma-separated subset of 6.1, 7, 8, 9, self-sensing (default: all)",
    )
    p.add_argument("--seeds", type=int, default=3, help="seeds per run (sensor noise differs); default 3")
    p.add_argument(
        "--baselines",
        help="comma-separated controllers to include, e.g. 'PID,VSC3 + FF' (default: all ten of Table 6.1)",
    )
    p.set_defaults(func=_evaluate)

    p = sub.add_parser(
        "diagnose",
        help="find the effect the model is missing from measured traces, add it, show the gap shrink",
        description="sma-gym diagnose FIT.csv [FIT2.csv ...] [--heldout HELD.csv ...] --out DIR",
    )
    p.add_argument("files", nargs="+", help="measured traces to fit (CSV, see README: measured data)")
    p.add_argument("--heldout", nargs="+", help="measured traces never used for fitting")
    p.add_argument("--out", required=True, help="folder for the report, plots, JSON and corrected_model.json")
    p.add_argument("--model", default="standard", help="nominal model: a preset name or a model JSON file (default standard)")
    p.add_argument("--effects", help="comma-separated subset of effects to consider (default: all)")
    p.add_argument(
        "--max-rounds",
        type=int,
        default=3,
        help="add at most this many effects, one per round, re-fitting everything found so far (default 3; 1 = one round)",
    )
    p.add_argument(
        "--cross-validate",
        action="store_true",
        help="leave one run out: diagnose on all files but one and predict that one, for every file; "
        "writes cross_validation.md/.json",
    )
    p.add_argument("--json", action="store_true", help="print the result as one JSON object")
    p.set_defaults(func=_diagnose)

    p = sub.add_parser("synth", help="write a synthetic measured trace with a hidden effect (labels in a separate file)")
    p.add_argument("--out", required=True, help="CSV file to write (with <out>.json sidecar and <stem>.labels.json)")
    p.add_argument("--effect", default="none", help="none, or NAME or NAME:param=value,... (default none)")
    p.add_argument("--form", default="default", help="form of the effect (default, or an alternative such as uniform)")
    p.add_argument("--excitation", default="steps", choices=("steps", "ramps", "sine", "chirp", "random"))
    p.add_argument("--duration", type=float, default=60.0, help="seconds (default 60)")
    p.add_argument("--model", default="standard", help="nominal model: preset name or model JSON file")
    p.add_argument("--perturb", type=float, default=0.05, help="relative perturbation of the nominal parameters (default 0.05)")
    p.add_argument("--position-noise", type=float, default=5e-6, help="m (default 5e-6)")
    p.add_argument("--position-resolution", type=float, default=1e-6, help="m (default 1e-6)")
    p.add_argument("--resistance-noise", type=float, default=2e-3, help="ohm (default 2e-3)")
    p.add_argument("--sample-period", type=float, default=1e-3, help="s (default 1e-3: 1 kHz)")
    p.add_argument("--no-electrical", action="store_true", help="record position only (no R, I, V)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--overwrite", action="store_true", help="replace an existing file")
    p.set_defaults(func=_synth)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except ValueError as err:
        print(f"sma-gym {args.command}: error: {err}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
