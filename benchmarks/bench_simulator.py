"""Simulator speed: actuator-steps/s at a 1 kHz control step, n = 1 and n = 4096, both PWM
modes. The same measurement as `sma-gym bench`; run: python benchmarks/bench_simulator.py"""

from sma_gym.bench import main

if __name__ == "__main__":
    raise SystemExit(main(as_json=False, repeats=5))
