"""Simulator speed: actuator-steps/s at a 1 kHz control step, n = 1 and n = 4096, both PWM
modes (the same measurement as `sma-gym bench`), and the cost of the nominal hysteresis law:
the nominal wire (7 hysterons, spread in centre and width) against the same wire with
sma-gym 0.1's single play operator, measured alternately in this run (the machines are
shared and noisy, so only the ratio is meaningful).

``--against REV`` measures the simulator of another commit instead, alternately with this
one, each in its own process: issue 11's goal ("within 20 % of the speed before the nominal
wire changed") is that ratio against ``b6ff60b``, the last commit before issue 11 changed
the kernel. The other commit's ``sma_gym`` is taken with ``git archive`` into a temporary
folder (the work tree is not touched) and run with this environment's packages.

    python benchmarks/bench_simulator.py
    python benchmarks/bench_simulator.py --against b6ff60b [--repeats 5]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tarfile
import tempfile
from io import BytesIO
from pathlib import Path

from sma_gym.bench import main, measure
from sma_gym.model import ModelConfig
from sma_gym.params import preset

ROOT = Path(__file__).resolve().parents[1]
ISSUE_11_BASE = "b6ff60b"
"""The last commit before issue 11 changed the kernel (the play law, no spread, no latent heat)."""

PLAY = ModelConfig(
    preset("standard").with_changes(
        **{"wire.minor_loop_law": "play", "wire.transformation_spread_k": 0.0, "wire.hysteron_width_spread": 0.0}
    )
)

# One timing of `sma_gym.bench.measure` (present with this signature since the first commit)
# in a fresh process whose sma_gym is the one on sys.path[0].
_ONE_TIMING = "import sys; sys.path.insert(0, sys.argv[1]); from sma_gym.bench import measure; print(measure(int(sys.argv[2]), sys.argv[3], repeats=1))"


def law_cost(repeats: int = 5) -> None:
    for mode in ("averaged", "resolved"):
        best = {"nominal": 0.0, "play": 0.0}
        for _ in range(repeats):
            best["nominal"] = max(best["nominal"], measure(4096, mode, repeats=1))
            best["play"] = max(best["play"], measure(4096, mode, repeats=1, model=PLAY))
        print(
            f"  {mode:9s} n = 4096: nominal {best['nominal']:12,.0f}  play law {best['play']:12,.0f}"
            f"  ratio nominal / play {best['nominal'] / best['play']:.2f}"
        )


def export_package(rev: str, into: Path) -> Path:
    """``sma_gym`` as committed at ``rev``, unpacked under ``into``; ``ValueError`` naming
    ``rev`` if git does not know it."""
    proc = subprocess.run(["git", "archive", "--format=tar", rev, "sma_gym"], cwd=ROOT, capture_output=True)
    if proc.returncode != 0:
        raise ValueError(
            f"--against {rev!r}: git archive failed ({proc.stderr.decode().strip()}); expected a commit of {ROOT}"
        )
    with tarfile.open(fileobj=BytesIO(proc.stdout)) as tar:
        # The extraction filter exists from Python 3.12 (and late 3.10/3.11 patch releases);
        # the archive is our own repository's, so older Pythons extract without it.
        if hasattr(tarfile, "data_filter"):
            tar.extractall(into, filter="data")
        else:
            tar.extractall(into)
    return into


def timing(package_root: Path, n: int, mode: str, cache_dir: Path) -> float:
    """One best-of-1 timing in a fresh process with ``package_root``'s ``sma_gym`` first on the path
    and numba's cache in ``cache_dir``."""
    proc = subprocess.run(
        [sys.executable, "-c", _ONE_TIMING, str(package_root), str(n), mode],
        capture_output=True,
        text=True,
        env={**os.environ, "NUMBA_CACHE_DIR": str(cache_dir)},
    )
    if proc.returncode != 0:
        raise RuntimeError(f"timing of {package_root} failed:\n{proc.stderr[-2000:]}")
    return float(proc.stdout.strip().splitlines()[-1])


def against(rev: str, repeats: int) -> None:
    with tempfile.TemporaryDirectory(prefix="sma-gym-bench-") as tmp:
        other = export_package(rev, Path(tmp) / "other")
        # Each side gets an empty numba cache of its own, so both compile in their first
        # process and load the cache in the others. The same kernel runs up to 8 % faster
        # as compiled in the process than as loaded from the cache, so a side that found a
        # cache from earlier runs while the other compiled fresh was measured slower
        # (0.84 against 0.89 of b6ff60b for one commit, 2026-11-29).
        caches = {"this": Path(tmp) / "cache-this", rev: Path(tmp) / "cache-other"}
        print(f"this code against {rev} (n = 4096, alternating processes, best of {repeats}):")
        for mode in ("averaged", "resolved"):
            best = {"this": 0.0, rev: 0.0}
            for _ in range(repeats):
                best["this"] = max(best["this"], timing(ROOT, 4096, mode, caches["this"]))
                best[rev] = max(best[rev], timing(other, 4096, mode, caches[rev]))
            print(
                f"  {mode:9s} this {best['this']:12,.0f}  {rev} {best[rev]:12,.0f}"
                f"  ratio this / {rev} {best['this'] / best[rev]:.2f}"
            )


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--against", metavar="REV", help=f"another commit to compare with (issue 11: {ISSUE_11_BASE})")
    parser.add_argument("--repeats", type=int, default=5, help="timings per side (default 5)")
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error(f"--repeats {args.repeats}: expected an integer >= 1")
    if args.against:
        try:
            against(args.against, args.repeats)
        except ValueError as err:
            parser.error(str(err))
    else:
        main(as_json=False, repeats=args.repeats)
        print(f"nominal hysteresis law against the 0.1 play law (alternating, best of {args.repeats}):")
        law_cost(args.repeats)
