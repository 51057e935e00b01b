"""``python -m agents.training``: the same as ``python train.py``."""

import sys

from agents.training.cli import main

sys.exit(main())
