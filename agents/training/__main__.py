"""``python -m sma_gym_agents.training``: the same as ``python train.py``."""

import sys

from sma_gym_agents.training.cli import main

sys.exit(main())
