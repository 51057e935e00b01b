"""Diagnosis accuracy (confusion matrix) and speed on synthetic data with hidden effects.

For every effect of the library and for "none", for several seeds: a 60 s trace to fit
(``steps`` excitation) and a 40 s held-out trace (``sine``) are synthesised at 1 kHz with the
effect in its *alternative* form where it has one (the candidate is always fitted in its
default form), the nominal parameters perturbed by 5 %, 5 um position noise, 1 um
quantisation and 2 mOhm resistance noise; ``diagnose`` then names what it finds.

Prints the confusion matrix (rows: truth, columns: verdict), the accuracy (an answer counts
as correct when it names exactly the hidden effect, or "none" for clean data), the false
"effect" verdicts on clean data, and the median time to diagnose one 60 s trace at 1 kHz
(goal: under 2 minutes on 2 cores). Goals: accuracy >= 90 %, no false effect on clean data.

    python benchmarks/bench_diagnosis.py [--seeds 3] [--json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import time

from sma_gym.diagnosis.synth import SynthSpec, generate
from sma_gym.diagnosis.workflow import diagnose
from sma_gym.effects import EFFECTS
from sma_gym.model import ModelConfig


def case(effect: str | None, seed: int) -> tuple[str, float]:
    form = "default"
    if effect is not None:
        forms = EFFECTS[effect].forms
        form = forms[1] if len(forms) > 1 else "default"
    model = ModelConfig()
    fit, _ = generate(SynthSpec(model, effect=effect, form=form, excitation="steps", duration_s=60.0, perturb=0.05, seed=seed))
    held, _ = generate(SynthSpec(model, effect=effect, form=form, excitation="sine", duration_s=40.0, perturb=0.05, seed=seed))
    start = time.perf_counter()
    result = diagnose([fit], [held], model)
    elapsed = time.perf_counter() - start
    if result.verdict == "effect":
        answer = str(result.effect)
    elif result.verdict == "ambiguous":
        answer = "ambiguous(" + "|".join(result.effect) + ")"
    elif result.verdict == "effects":
        answer = "effects(" + "+".join(result.effect) + ")"  # a hidden effect plus spurious ones
    else:
        answer = result.verdict
    return answer, elapsed


def run(seeds: int) -> dict:
    truths = ["none", *EFFECTS]
    rows: dict[str, list[str]] = {t: [] for t in truths}
    times = []
    for seed in range(seeds):
        for truth in truths:
            answer, elapsed = case(None if truth == "none" else truth, 100 + seed)
            rows[truth].append(answer)
            times.append(elapsed)
            print(f"seed {seed} truth {truth:22s} -> {answer}  ({elapsed:.0f} s)", flush=True)
    correct = sum(a == t for t, answers in rows.items() for a in answers)
    total = sum(len(a) for a in rows.values())
    false_effects = sum(a not in ("none", "unexplained") for a in rows["none"])
    return {
        "rows": rows,
        "accuracy": correct / total,
        "false_effects_on_clean_data": false_effects,
        "median_seconds_per_60s_trace": statistics.median(times),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    result = run(args.seeds)
    if args.json:
        print(json.dumps(result, indent=2))
        return 0
    labels = sorted({a for answers in result["rows"].values() for a in answers})
    width = max(len(x) for x in labels + list(result["rows"]))
    print("\nconfusion (rows: hidden truth, columns: verdict)")
    print(" " * (width + 2) + "  ".join(f"{c[:12]:>12s}" for c in labels))
    for truth, answers in result["rows"].items():
        print(f"{truth:{width}s}  " + "  ".join(f"{answers.count(c):>12d}" for c in labels))
    print(f"\naccuracy {result['accuracy'] * 100:.1f} % (goal >= 90 %)")
    print(f"false 'effect' on clean data: {result['false_effects_on_clean_data']} (goal 0)")
    print(f"median time per diagnosis of a 60 s, 1 kHz trace (+ 40 s held out): {result['median_seconds_per_60s_trace']:.0f} s (goal < 120 s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
