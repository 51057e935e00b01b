"""Train a stable-baselines3 agent on the default tracking env and compare it with the
report's controllers.

Not implemented yet: the environments, the baselines and the evaluation harness this
script needs are still being built. Until then it says so and exits with status 2 rather
than pretending to train.
"""

import sys

if __name__ == "__main__":
    print(
        "train.py: training is not implemented yet (it needs the environments and the "
        "evaluation harness). Try `sma-gym fidelity --out fidelity/` to see the simulator.",
        file=sys.stderr,
    )
    sys.exit(2)
