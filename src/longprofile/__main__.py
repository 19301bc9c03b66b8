"""``python -m longprofile ...``: the same command-line interface as the ``longprofile`` console script."""

from .cli.app import run

if __name__ == "__main__":
    run()
