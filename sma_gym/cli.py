"""The ``sma-gym`` command: ``sma-gym <subcommand> --help`` for each."""

from __future__ import annotations

import argparse
import sys
from typing import Sequence


def _fidelity(args: argparse.Namespace) -> int:
    from sma_gym import fidelity

    return fidelity.main(args.out, args.json, quick=args.quick)


def _bench(args: argparse.Namespace) -> int:
    from sma_gym import bench

    return bench.main(as_json=args.json, repeats=args.repeats)


def _evaluate(args: argparse.Namespace) -> int:
    from agents import evaluation

    experiments = [e.strip() for e in args.experiments.split(",") if e.strip()]
    baselines = [b.strip() for b in args.baselines.split(",") if b.strip()] if args.baselines else None
    return evaluation.main(args.out, args.policy or [], args.json, experiments, args.seeds, baselines)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="sma-gym", description="SMA actuator simulator, environments and tools.")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("fidelity", help="compare the simulator with the report's numbers (T1-T5, T8, T9)")
    p.add_argument("--out", help="folder for the PNG plots")
    p.add_argument("--json", action="store_true", help="print the rows as a JSON list instead of a table")
    p.add_argument("--quick", action="store_true", help="shorter resistance experiment (for smoke tests)")
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
