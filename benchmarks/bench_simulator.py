"""Simulator speed: actuator-steps/s at a 1 kHz control step, n = 1 and n = 4096, both PWM
modes (the same measurement as `sma-gym bench`), and the cost of the nominal hysteresis law:
the nominal wire (7 hysterons, spread in centre and width) against the same wire with
sma-gym 0.1's single play operator, measured alternately in this run (the machines are
shared and noisy, so only the ratio is meaningful). Run: python benchmarks/bench_simulator.py
"""

from sma_gym.bench import main, measure
from sma_gym.model import ModelConfig
from sma_gym.params import preset

PLAY = ModelConfig(
    preset("standard").with_changes(
        **{"wire.minor_loop_law": "play", "wire.transformation_spread_k": 0.0, "wire.hysteron_width_spread": 0.0}
    )
)


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


if __name__ == "__main__":
    main(as_json=False, repeats=5)
    print("nominal hysteresis law against the 0.1 play law (alternating, best of 5):")
    law_cost()
