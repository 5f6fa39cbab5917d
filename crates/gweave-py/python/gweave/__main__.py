"""``python -m gweave``: the ``gweave`` command installed with this package."""

import os
import sys

from . import _command


def main() -> None:
    if os.name == "posix":
        # The command takes this process's place: its exit status, its signals and its pipes are
        # the caller's own, with no interpreter in between.
        os.execv(_command.executable(), ["gweave", *sys.argv[1:]])
    sys.exit(_command.run(sys.argv[1:]))


if __name__ == "__main__":
    main()
