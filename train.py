"""Train a stable-baselines3 agent on an sma-gym env and compare it with the report's controllers.

``python train.py --help`` for the options; the code is :mod:`sma_gym_agents.training`.
"""

import sys

from sma_gym_agents.training import main

if __name__ == "__main__":
    sys.exit(main())
