"""``python -m gweave`` and the ``gweave`` console script: the Rust command line."""

import sys

from . import main as _main


def main() -> None:
    sys.exit(_main())


if __name__ == "__main__":
    main()
