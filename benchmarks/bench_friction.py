"""Stribeck friction: does the trajectory follow the parameters, and the physics, rather than
the sub-step grid? (docs/model.md section 8, "Stribeck friction".)

The ``coulomb_friction`` effect in its ``stribeck`` form makes the sleigh stick and slip in
jumps of tens to hundreds of micrometres. For each friction force and random sequence of duty
holds (30 s, holds of 0.3-3 s, off or at a duty of 0.05-0.6) this prints, for the default
sub-steps:

- the position RMS from a 1 us reference, up to the first time the reference comes within
  0.3 mm of the end-of-travel cut and over the whole sequence (after the cut, whether a
  sleigh stuck a micrometre below x_eot latches the cut is a discontinuity that no step
  removes, so the whole-sequence figure does not measure the integrator), and that of a
  3 us reference from the 1 us one (is the reference converged?);
- the position RMS that 1 ppm more moving mass causes (a smooth model: about 0);
- the simulation time as a ratio to the Coulomb form of the same force and sequence,
  measured in the same run.

Run: python benchmarks/bench_friction.py [--forces 0.2,0.6,1.5] [--seeds 2]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sma_gym import ModelConfig, Simulator

DURATION_MS = 30_000
CUT_MARGIN_M = 0.3e-3


def duty_sequence(seed: int) -> np.ndarray:
    """Holds of 0.3-3 s, each off or at a random duty of 0.05-0.6, at 1 ms steps."""
    rng = np.random.default_rng(seed)
    duty = np.empty(DURATION_MS)
    k = 0
    while k < DURATION_MS:
        length = int(rng.uniform(300, 3000))
        duty[k : k + length] = rng.choice([0.0, rng.uniform(0.05, 0.6)])
        k += length
    return duty


def _run(model: ModelConfig, duty: np.ndarray, **kwargs) -> tuple[np.ndarray, float]:
    sim = Simulator(model, control_period_s=1e-3, **kwargs)
    start = time.perf_counter()
    x = sim.run(duty[:, None], record=("position_m",))["position_m"][:, 0]
    return x, time.perf_counter() - start


def _rms_um(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2))) * 1e6 if len(a) else float("nan")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--forces", default="0.2,0.6,1.5", help="comma-separated kinetic friction forces [N]")
    parser.add_argument("--seeds", type=int, default=2, help="random duty sequences per force")
    args = parser.parse_args()
    nominal = ModelConfig()
    mass_kg = nominal.actuator.mechanism.moving_mass_kg
    eot_m = nominal.actuator.driver.end_of_travel_m
    print(
        "| force [N] | seed | before the cut [s] | default - 1 us, before the cut [um] | whole [um] "
        "| 3 us - 1 us [um] | 1 ppm mass [um] | time / Coulomb form |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for force in (float(f) for f in args.forces.split(",")):
        for seed in range(args.seeds):
            duty = duty_sequence(seed)
            model = nominal.with_effect("coulomb_friction", {"force_n": force}, form="stribeck")
            coulomb = nominal.with_effect("coulomb_friction", {"force_n": force})
            heavier = model.with_actuator(**{"mechanism.moving_mass_kg": mass_kg * (1.0 + 1e-6)})
            _run(model, duty)  # compile and warm up before timing
            x, seconds = _run(model, duty)
            _, seconds_coulomb = _run(coulomb, duty)
            x_heavier, _ = _run(heavier, duty)
            ref3, _ = _run(model, duty, max_substep_s=3e-6)
            ref1, _ = _run(model, duty, max_substep_s=1e-6)
            near = np.flatnonzero(ref1 >= eot_m - CUT_MARGIN_M)
            k = int(near[0]) if near.size else len(ref1)
            print(
                f"| {force:g} | {seed} | {k / 1000:.1f} | {_rms_um(x[:k], ref1[:k]):.2f} | {_rms_um(x, ref1):.1f} "
                f"| {_rms_um(ref3, ref1):.2f} | {_rms_um(x_heavier, x):.3f} | {seconds / seconds_coulomb:.1f}x |",
                flush=True,
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
