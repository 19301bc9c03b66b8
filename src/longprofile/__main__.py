"""``python -m longprofile ...``: the same command-line interface as the ``longprofile`` console script."""

import sys

from .cli.app import main

if __name__ == "__main__":
    sys.exit(main())
