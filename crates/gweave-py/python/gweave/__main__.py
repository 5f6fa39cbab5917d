"""``python -m gweave`` and the ``gweave`` console script: the Rust command line."""

import signal
import sys

from . import main as _main


def main() -> None:
    # A CLI process: die quietly on a closed pipe (`gweave stats big.gcode | head`) like any
    # Unix tool, instead of Python's default of ignoring SIGPIPE.
    if hasattr(signal, "SIGPIPE"):
        signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    sys.exit(_main())


if __name__ == "__main__":
    main()
