"""The ``gweave`` command: the native executable installed with this package.

The wheel carries the command line as its own executable (``gweave``, in the wheel's
``scripts``, which pip installs next to the environment's ``python``), built from the same
checkout as the extension module (``build_backend/gweave_build.py``); the extension itself links
no command-line code. ``gweave.main`` and ``python -m gweave`` run that executable.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sysconfig
from pathlib import Path
from typing import List, Optional, Sequence

NAMES = ("gweave", "gweave.exe")


def executable() -> str:
    """The path of the installed ``gweave`` executable.

    The installed files of the distribution name it wherever pip put the scripts (a virtual
    environment's ``bin/``, ``--user``'s ``~/.local/bin``, a ``--prefix``); the scheme's scripts
    folder is the fallback for an installer that kept no record.
    """
    found: Optional[Path] = None
    try:
        from importlib.metadata import PackageNotFoundError, distribution

        files = distribution("gweave").files or []
        for f in files:
            if f.name in NAMES:
                found = Path(str(f.locate())).resolve()
                break
    except PackageNotFoundError:
        pass
    if found is None or not found.is_file():
        scripts = Path(sysconfig.get_path("scripts"))
        found = next((scripts / n for n in NAMES if (scripts / n).is_file()), None)
    if found is None:
        raise FileNotFoundError(
            "the gweave command is not installed with this package: install it with "
            "`pip install ./crates/gweave-py` (or `make python`), which build both"
        )
    return str(found)


def run(argv: Sequence[str]) -> int:
    """Runs the command with these arguments (without the program name); returns its exit code,
    128 + the signal's number if a signal ended it, as a shell reports it.

    A Ctrl-C reaches the command (a terminal sends it to the whole process group; one sent to this
    process alone is passed on), which removes its scratch files and ends; then ``SystemExit(130)``
    is raised with the ``KeyboardInterrupt`` as its ``__cause__``, as a command-line tool ends.
    """
    args: List[str] = ["gweave", *argv]
    child = subprocess.Popen(args, executable=executable())
    try:
        code = child.wait()
    except KeyboardInterrupt as raised:
        if os.name == "posix":
            child.send_signal(signal.SIGINT)
        else:
            child.terminate()
        child.wait()
        raise SystemExit(130) from raised
    return 128 - code if code < 0 else code
