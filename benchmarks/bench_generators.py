"""Speed of the two truth generators of the diagnosis benchmark: a 40 s random-duty trace at
1 kHz from the independent generator (``tests/independent_sma.py``, fixed-step RK4 at 50 us
or shorter) against the same trace from ``sma-gym synth``'s (our kernel), measured
alternately in this run (the machines are shared and noisy, so the ratio is the figure).

A grid of ``bench_diagnosis.py`` draws a fitted and a held-out trace per case, so the
independent generator must stay within seconds per trace: the goal is under 10 s on an idle
core, which the ratio tells apart from a loaded machine.

    python benchmarks/bench_generators.py [--repeats 3]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_diagnosis import independent_module

from sma_gym.diagnosis.synth import SynthSpec, generate
from sma_gym.model import ModelConfig
from sma_gym.params import preset

DURATION_S = 40.0
GOAL_S = 10.0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--repeats", type=int, default=3, help="timings per generator (default 3)")
    args = parser.parse_args()
    if args.repeats < 1:
        parser.error(f"--repeats {args.repeats}: expected at least 1")
    ind = independent_module()
    standard = preset("standard")
    ind.simulate(standard, duty=np.zeros(10))  # compiled (or loaded from numba's cache) first
    generate(SynthSpec(ModelConfig(standard), excitation="random", duration_s=1.0, seed=1))
    theirs, ours = [], []
    for _ in range(args.repeats):
        start = time.perf_counter()
        trace, _ = ind.generate(standard, excitation="random", duration_s=DURATION_S, seed=1)
        theirs.append(time.perf_counter() - start)
        start = time.perf_counter()
        generate(SynthSpec(ModelConfig(standard), excitation="random", duration_s=DURATION_S, seed=1))
        ours.append(time.perf_counter() - start)
    t_ind, t_ours = statistics.median(theirs), statistics.median(ours)
    print(
        f"{DURATION_S:.0f} s random trace at 1 kHz ({trace.t.size} rows), median of {args.repeats}: "
        f"independent generator {t_ind:.2f} s (goal < {GOAL_S:.0f} s on an idle core), "
        f"our kernel {t_ours:.2f} s; ratio {t_ind / t_ours:.1f}x"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
