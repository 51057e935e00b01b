"""``python -m sma_gym``: the ``sma-gym`` command, for an environment whose scripts are not on PATH."""

import sys

from sma_gym.cli import main

if __name__ == "__main__":
    sys.exit(main())
