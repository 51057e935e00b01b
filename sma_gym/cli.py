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
