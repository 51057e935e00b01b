"""``sma-gym bench``: simulator speed in actuator-steps per second at a 1 kHz control step.

Two call patterns are timed, because they are what the users do:

* n = 1: one :meth:`Simulator.step` call per control step, as a single env does. This
  includes the Python call overhead, which is what decides whether an env step can cost
  as little as a Gymnasium classic-control step.
* n = 4096: one :meth:`Simulator.step_unchecked` per control step for all actuators, as
  the vector env does.

Actuators are driven by a repeating duty pattern that heats, transforms, holds and cools
them, so the timing includes the transformation solver and not only the idle path. Each
rate is the best of ``repeats`` timings (the machine is shared and noisy; the best run is
the least disturbed one).
"""

from __future__ import annotations

import json
import time

import numpy as np

from sma_gym.simulator import Simulator

SIZES = (1, 4096)
MODES = ("averaged", "resolved")


def duty_pattern(steps: int, n: int, seed: int = 0) -> np.ndarray:
    """A heating / holding / cooling duty pattern with per-actuator phase offsets."""
    rng = np.random.default_rng(seed)
    t = np.arange(steps)[:, None] * 1e-3 + rng.uniform(0.0, 4.0, size=(1, n))
    phase = np.mod(t, 4.0)
    duty = np.where(phase < 0.6, 1.0, np.where(phase < 2.0, 0.07, 0.0))
    return np.ascontiguousarray(duty)


MAX_REPEATS = 100
"""Most timings ``sma-gym bench --repeats`` takes (each is a few seconds per size and mode)."""


def measure(n: int, pwm_mode: str, seconds: float = 0.6, repeats: int = 3, model: object = "standard") -> float:
    """Best-of-``repeats`` actuator-steps/s for n actuators stepped one control step at a time."""
    sim = Simulator(model, n=n, pwm_mode=pwm_mode)
    steps = max(50, int(seconds * 1000 * (1 if n == 1 else 0.25)))
    duty = duty_pattern(steps, n)
    # Warm-up: compile (or load the cache) and get the wires into their working range.
    sim.run(duty[: min(steps, 300)], record=())
    best = 0.0
    for _ in range(repeats):
        sim.reset()
        rows = [duty[k : k + 1] for k in range(steps)]
        start = time.perf_counter()
        if n == 1:
            for k in range(steps):
                sim.step(rows[k][0, 0])
        else:
            for k in range(steps):
                sim.step_unchecked(rows[k])
        elapsed = time.perf_counter() - start
        best = max(best, steps * n / elapsed)
    return best


def run(repeats: int = 3) -> dict[str, dict[str, float]]:
    return {mode: {str(n): measure(n, mode, repeats=repeats) for n in SIZES} for mode in MODES}


def main(as_json: bool = False, repeats: int = 3) -> int:
    if not 1 <= repeats <= MAX_REPEATS:
        raise ValueError(f"--repeats {repeats!r}: expected an integer in [1, {MAX_REPEATS}]")
    result = run(repeats)
    if as_json:
        print(json.dumps(result))
    else:
        print(f"simulator actuator-steps/s at a 1 kHz control step (best of {repeats})")
        for mode, rates in result.items():
            for n, rate in rates.items():
                print(f"  {mode:9s} n = {n:>5s}: {rate:14,.0f}")
    return 0
