"""Train a stable-baselines3 agent on an sma-gym env and compare it with the report's controllers.

``python train.py --help`` for the options; the code is :mod:`agents.training`.
"""

import sys

from agents.training import main

if __name__ == "__main__":
    sys.exit(main())
