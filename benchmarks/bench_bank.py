"""The shared budget against fixed slots on one bank step (issue 16, goal 1).

16 actuators at 10 V on one driver at 2 kHz: 15 go to random positions in 1-6 mm and hold
them; once they have settled (40 s), actuator 0 steps 0 -> 8 mm. The report's PID runs per
actuator, on fixed 1/16 slots (Table 9.1's scheme), and on a shared budget under the
budget allocator and under the priority allocator (:mod:`sma_gym_agents.bank`). Prints, per
seed and bank, the stepping
actuator's rise time (to 90 % of 8 mm; ``inf`` if not within 300 s), its time to 50 %, the
highest position it reached, and the holders' errors (settled before the step, largest
during the rise); then the ratio of the rise times.

Goal (issue 16): rise time on the shared budget (under the budget allocator, the issue's
rule) <= 1/4 of the fixed-slot bank's. The priority allocator's ratio is printed beside it.

    python benchmarks/bench_bank.py [--seeds 3] [--json]
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

from sma_gym_agents.evaluation import bank_entry, bank_step

BANKS = {
    "fixed_slots": ("fixed_slots", "proportional"),
    "shared_budget": ("shared_budget", "proportional"),
    "shared_priority": ("shared_budget", "priority"),
}
"""Name -> (scheme, allocation) of each bank run."""
GOAL_RATIO = 0.25


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3, help="seeds (holders' levels, sensor noise); default 3")
    parser.add_argument("--controller", default="PID", help="the report's controller per actuator (default PID)")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    args = parser.parse_args(argv)
    runs = {
        name: [bank_step(bank_entry(args.controller, *bank), seed=seed) for seed in range(args.seeds)]
        for name, bank in BANKS.items()
    }
    rise = {name: np.array([r["rise_time_s"] for r in runs[name]]) for name in BANKS}
    half = {name: np.array([r["half_rise_time_s"] for r in runs[name]]) for name in BANKS}
    ratio = float(np.max(rise["shared_budget"] / rise["fixed_slots"]))  # worst seed; x / inf = 0
    half_ratio = float(np.max(half["shared_budget"] / half["fixed_slots"]))
    out = {
        "runs": runs,
        "rise_ratio_worst_seed": ratio,
        "half_rise_ratio_worst_seed": half_ratio,
        "priority_rise_ratio_worst_seed": float(np.max(rise["shared_priority"] / rise["fixed_slots"])),
        "priority_half_rise_ratio_worst_seed": float(np.max(half["shared_priority"] / half["fixed_slots"])),
        "goal_met": ratio <= GOAL_RATIO,
    }
    if args.json:
        print(json.dumps(out, indent=1, default=lambda v: None if math.isnan(v) else str(v)))
        return out
    print(
        f"{'bank':<16} {'seed':>4} {'rise 90% [s]':>12} {'to 50% [s]':>10} {'highest [mm]':>12} "
        f"{'holders settled [mm]':>20} {'holders worst [mm]':>18}"
    )
    for name in BANKS:
        for seed, r in enumerate(runs[name]):
            print(
                f"{name:<16} {seed:>4} {r['rise_time_s']:>12.3f} {r['half_rise_time_s']:>10.3f} "
                f"{r['highest_position_m'] * 1e3:>12.2f} {r['holders_settled_error_m'] * 1e3:>20.3f} "
                f"{r['holders_max_error_m'] * 1e3:>18.3f}"
            )
    print(
        f"rise-time ratio shared / fixed (worst seed): {ratio:.3g} (goal <= {GOAL_RATIO}: "
        f"{'met' if out['goal_met'] else 'missed'}); to 50 %: {half_ratio:.3g}"
    )
    print(
        f"priority allocator / fixed (worst seed): {out['priority_rise_ratio_worst_seed']:.3g}; "
        f"to 50 %: {out['priority_half_rise_ratio_worst_seed']:.3g}"
    )
    return out


if __name__ == "__main__":
    main()
